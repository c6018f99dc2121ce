// SPDX-License-Identifier: Apache-2.0
#include <iostream>

#include "commands.h"
#include "mesh_summary.h"

namespace vfit::cli {

int run_info(Args& args) {
  const bool json = args.flag("json");
  ReadOptions options;
  options.repair = args.flag("repair");
  std::optional<Units> units;
  if (auto u = args.value("units")) units = parse_units(*u);
  const auto files = args.positionals(1, 1);
  MeshSummary s = summarise_mesh(files[0], options, units);
  if (json) {
    std::cout << summary_json(s).dump(2) << "\n";
  } else {
    for (const auto& w : s.parsed.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
    std::cout << summary_text(s);
  }
  return 0;
}

} // namespace vfit::cli
