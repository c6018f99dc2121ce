// SPDX-License-Identifier: Apache-2.0
#pragma once
// What `vfit info` and `vfit demo` say about a mesh file.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit::cli {

struct MeshSummary {
  std::string path;
  std::string format;
  std::uintmax_t bytes = 0;
  ParsedMesh parsed;
  TopologyReport topology;
  MeshStats stats;
  Units units = Units::M;
  bool units_stated = false; ///< from --units rather than detected
  double read_ms = 0;
};

/// Reads, validates and analyses a mesh file. `stated` overrides unit detection; detection
/// failure (extent too large or zero) is an error asking for --units.
MeshSummary summarise_mesh(const std::filesystem::path& path, const ReadOptions& options, std::optional<Units> stated);

nlohmann::json summary_json(const MeshSummary& s);
std::string summary_text(const MeshSummary& s);

} // namespace vfit::cli
