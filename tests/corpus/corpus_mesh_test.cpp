// SPDX-License-Identifier: Apache-2.0
// Every mesh in the shared corpus loads, validates and matches what corpus/MANIFEST.md says of
// it (vertex count, faces, components, boundary loops, watertightness, units); `vfit info`
// prints a sane summary for each. Skipped, saying why, when the corpus is absent.
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit {
namespace {

struct ManifestRow {
  std::size_t vertices = 0, quads = 0, components = 0, loops = 0;
  bool watertight = false;
  std::string units;
};

// Rows of the per-file table: | `path` | kind | V | F (quad:n) | watertight | manifold | comps / loops | ... | units |
std::map<std::string, ManifestRow> manifest_rows(const std::filesystem::path& corpus) {
  std::map<std::string, ManifestRow> rows;
  std::ifstream f(corpus / "MANIFEST.md");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("| `makehuman/", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, '|'))
      cells.push_back(cell);
    if (cells.size() < 12) continue;
    auto trim = [](std::string s) {
      s.erase(0, s.find_first_not_of(" `"));
      s.erase(s.find_last_not_of(" `") + 1);
      return s;
    };
    const std::string path = trim(cells[1]);
    std::smatch m;
    const std::string v = trim(cells[3]), fcell = trim(cells[4]), comps = trim(cells[7]);
    if (!std::regex_match(v, std::regex("[0-9]+"))) continue;
    ManifestRow r;
    r.vertices = std::stoul(v);
    if (std::regex_search(fcell, m, std::regex("quad:([0-9]+)"))) r.quads = std::stoul(m[1]);
    if (std::regex_search(comps, m, std::regex("([0-9]+) / ([0-9]+)"))) {
      r.components = std::stoul(m[1]);
      r.loops = std::stoul(m[2]);
    }
    r.watertight = trim(cells[5]) == "yes";
    r.units = trim(cells[10]);
    rows[path] = r;
  }
  return rows;
}

TEST(CorpusMeshes, EveryMeshLoadsValidatesAndMatchesTheManifest) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  const auto rows = manifest_rows(*corpus);
  ASSERT_GT(rows.size(), 30u) << "could not read the per-file table of MANIFEST.md";
  const auto files = test::files_with_extensions(*corpus, {".obj", ".ply", ".off", ".stl", ".glb", ".gltf"});
  ASSERT_FALSE(files.empty());
  std::size_t checked = 0;
  for (const auto& file : files) {
    SCOPED_TRACE(file.string());
    const ParsedMesh p = read_mesh(file);
    const TopologyReport t = analyse_topology(p.mesh.triangle_view(), p.mesh.vertex_count());
    const MeshStats s = mesh_stats(p.mesh);
    EXPECT_GT(p.mesh.face_count(), 0u);
    const std::string rel = std::filesystem::relative(file, *corpus).string();
    const std::optional<Units> units = detect_mesh_units(s.largest_extent, s.max_abs_coordinate);
    ASSERT_TRUE(units.has_value());
    auto it = rows.find(rel);
    if (it == rows.end()) {
      // Files outside the per-file table (the rigged glTF body) are in metres.
      EXPECT_EQ(units_name(*units), "m");
      continue;
    }
    const ManifestRow& row = it->second;
    EXPECT_EQ(p.mesh.vertex_count(), row.vertices);
    if (row.quads) {
      EXPECT_EQ(p.mesh.face_count(), 2 * row.quads); // each quad becomes two triangles
    }
    EXPECT_EQ(t.components, row.components);
    EXPECT_EQ(t.boundary_loops, row.loops);
    EXPECT_EQ(t.watertight(), row.watertight);
    EXPECT_EQ(units_name(*units), row.units);
    ++checked;
  }
  EXPECT_GT(checked, 30u);
}

TEST(CorpusMeshes, InfoPrintsASaneSummaryOfTheBody) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  const auto body = *corpus / "makehuman" / "derived" / "hm08_body.obj";
  const auto r = test::run_cli({"info", body.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["vertices"], 13380);
  EXPECT_EQ(j["units"], "dm");
  EXPECT_EQ(j["watertight"], true);
  EXPECT_EQ(j["euler_characteristic"], 2);
  EXPECT_NEAR(j["largest_extent_m"].get<double>(), 1.6659, 1e-3);
  const auto glb =
      test::run_cli({"info", (*corpus / "makehuman" / "derived" / "hm08_body_rigged.glb").string(), "--json"});
  ASSERT_EQ(glb.exit_code, 0) << glb.err;
  const auto g = nlohmann::json::parse(glb.out);
  EXPECT_EQ(g["units"], "m");
  EXPECT_EQ(g["faces"], 26756);
  EXPECT_EQ(g["watertight"], true);
}

} // namespace
} // namespace vfit
