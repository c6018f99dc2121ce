// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to geometry/body: reading the small JSON inputs users hand us (poses, joints), with
// errors that name the file and the key.

#include <cmath>
#include <filesystem>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit::json_input {

/// The parsed file; throws vfit::Error "<file>: invalid JSON: ..." or "cannot open".
inline nlohmann::json read_file(const std::filesystem::path& path) {
  try {
    return nlohmann::json::parse(read_file_bytes(path));
  } catch (const nlohmann::json::exception& e) {
    throw Error(path.string(), 0, std::string("invalid JSON: ") + e.what());
  }
}

/// [x, y, z] of finite numbers under `key`; throws vfit::Error naming file and key otherwise.
inline Eigen::Vector3d vec3(const nlohmann::json& v, const std::string& file, const std::string& key) {
  if (!v.is_array() || v.size() != 3) throw Error(file, 0, "'" + key + "': expected [x, y, z]");
  Eigen::Vector3d r;
  for (int k = 0; k < 3; ++k) {
    if (!v[k].is_number() || !std::isfinite(v[k].get<double>()))
      throw Error(file, 0, "'" + key + "': not a finite number");
    r[k] = v[k].get<double>();
  }
  return r;
}

} // namespace vfit::json_input
