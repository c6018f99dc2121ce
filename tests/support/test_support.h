// SPDX-License-Identifier: Apache-2.0
#pragma once
// Shared helpers for vfit's test suites: temporary folders, files, running the CLI, the corpus.

#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "vfit/geometry/body/body.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit::test {

/// A fresh, empty temporary folder removed when the object dies.
class TempDir {
public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return m_path; }
  std::filesystem::path operator/(const std::string& name) const { return m_path / name; }

private:
  std::filesystem::path m_path;
};

void write_file(const std::filesystem::path& path, const std::string& bytes);
std::string read_file(const std::filesystem::path& path);

/// The JSON chunk of a glTF binary (`.glb` bytes): its text, to parse.
std::string glb_json_text(const std::string& glb);

/// Result of running the vfit executable.
struct CliResult {
  int exit_code = -1;
  std::string out; ///< standard output
  std::string err; ///< standard error
};

/// Runs the built `vfit` with `args` (no shell involved), capturing both streams.
CliResult run_cli(const std::vector<std::string>& args);

/// The Khronos glTF validator's report on `file` (tools/validate_gltf.cjs: one JSON line with
/// "errors", "warnings" and "messages"), or nullopt when Node.js or the npm package
/// gltf-validator (build/npm/, installed by tools/install_deps.sh style) is absent: tests then
/// GTEST_SKIP, saying why.
std::optional<std::string> gltf_validator_report(const std::filesystem::path& file);

/// The shared corpus folder, or nullopt when it is absent (tests then GTEST_SKIP, saying why).
/// VFIT_CORPUS overrides the path configured at build time.
std::optional<std::filesystem::path> corpus_dir();

/// The garment type a corpus garment's file name promises (parts_on_hm08: "..._tshirt",
/// "..._jeans", ...); nullopt for pieces that are not garments on their own (a detached shirt
/// collar, an inner shirt panel: the pipeline must refuse them) and for names it does not know,
/// in which case `known` (when given) is set false.
std::optional<GarmentType> corpus_garment_type(const std::string& name, bool* known = nullptr);

/// Every file under `dir` whose extension (lower case) is one of `extensions`, sorted.
std::vector<std::filesystem::path> files_with_extensions(const std::filesystem::path& dir,
                                                         const std::vector<std::string>& extensions);

/// Two triangles sharing an edge (a unit square in the XY plane, CCW seen from +Z), with UVs.
/// The default mannequin (average measurements) in `pose` with `vertices` vertices, built once
/// per process and kept: a mannequin takes a second or more.
const Body& mannequin(RestPose pose, std::size_t vertices);

Mesh unit_square();

/// Mean over the triangles' edges of |length after / length before − 1| (same topology): how
/// much a deformation stretched or shrank the cloth.
double mean_edge_length_change(const Mesh& before, const Mesh& after);

/// A fan of `rim` triangles around hub vertex 0 at the origin: rim vertex k at angle 2πk/rim,
/// radius 0.3 + 0.05·u m and height 0.02·u m (u uniform in [−1, 1) from `rng`, radius then
/// height per vertex, in vertex order). Its hub's spring row is longer than a gather block.
Mesh random_fan(int rim, std::mt19937& rng);

/// A closed, outward-oriented octahedron (6 vertices, 8 triangles).
Mesh octahedron();

} // namespace vfit::test
