// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/cloth/fabric.h"

#include "vfit/kernels/error.h"

namespace vfit {

const std::vector<Fabric>& fabric_presets() {
  static const std::vector<Fabric> presets = {
      {"cotton_jersey", 0.150, 400, 4, 0.05},
      {"denim", 0.400, 3000, 60, 0.05},
      {"silk", 0.070, 800, 1, 0.05},
      {"wool", 0.250, 1200, 20, 0.05},
  };
  return presets;
}

const Fabric& fabric_preset(std::string_view name) {
  std::string known;
  for (const Fabric& f : fabric_presets()) {
    if (f.name == name) return f;
    known += (known.empty() ? "" : ", ") + f.name;
  }
  throw Error("fabric", 0, "unknown fabric '" + std::string(name) + "' (known: " + known + ")");
}

} // namespace vfit
