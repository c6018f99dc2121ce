#include "engine/penetration.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "engine/layering.h"
#include "geometry/mesh/mesh_io.h"
#include "geometry/mesh/primitives.h"
#include "geometry/mesh/units.h"
#include "kernels/edge_crossings.h"
#include "kernels/proximity.h"
#include "test_support.h"

namespace vfit {
namespace {


TEST(CorpusPenetration, FemaleOutfitsEndUpOutsideTheBody) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  const auto dir = *corpus / "makehuman" / "derived";
  ParsedMesh body = read_mesh(dir / "hm08_body.obj");
  scale_positions(body.mesh.positions, 0.1); // MakeHuman files are in decimetres
  const ProximityIndex index(body.mesh.positions, body.mesh.triangles);
  const EdgeCrossingIndex crossings(body.mesh.positions, body.mesh.triangles);
  for (const char* name : {"female_casualsuit01__tshirt", "female_casualsuit01__jeans", "female_sportsuit01__crop_top",
                           "female_sportsuit01__leggings", "female_elegantsuit01__skirt", "female_casualsuit02__tshirt"}) {
    SCOPED_TRACE(name);
    ParsedMesh g = read_mesh(dir / "parts_on_hm08" / (std::string(name) + ".obj"));
    scale_positions(g.mesh.positions, 0.1);
    const Mesh before = g.mesh;
    const PenetrationReport r = remove_penetration(g.mesh, index, crossings);
    const double stretch = test::mean_edge_length_change(before, g.mesh);
    EXPECT_GT(r.before.inside_count, 0u);
    EXPECT_LE(r.after.max_depth, 0.0005); // the bar: nothing inside by more than 0.5 mm
    EXPECT_EQ(r.after.crossing_edges, 0u); // the bar: no garment edge crossing the body
    EXPECT_EQ(measure_penetration(g.mesh, index, crossings, 0.002).crossing_edges, 0u);
    EXPECT_LT(stretch, 0.02); // the bar: the garment's shape kept
    std::printf("%-32s inside %4zu -> %zu, max depth %.2f -> %.2f mm, crossing edges %zu -> %zu, edge change %.2f %%, "
                "%d rounds, %.1f ms\n",
                name, r.before.inside_count, r.after.inside_count, 1e3 * r.before.max_depth, 1e3 * r.after.max_depth,
                r.before.crossing_edges, r.after.crossing_edges, 100 * stretch, r.iterations, r.milliseconds);
  }
}

TEST(CorpusPenetration, ATshirtLayeredOverJeansEndsOutsideBoth) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  const auto dir = *corpus / "makehuman" / "derived";
  ParsedMesh body = read_mesh(dir / "hm08_body.obj");
  scale_positions(body.mesh.positions, 0.1); // MakeHuman files are in decimetres
  const ProximityIndex index(body.mesh.positions, body.mesh.triangles);
  const EdgeCrossingIndex crossings(body.mesh.positions, body.mesh.triangles);
  auto load = [&](const char* name) {
    ParsedMesh g = read_mesh(dir / "parts_on_hm08" / (std::string(name) + ".obj"));
    scale_positions(g.mesh.positions, 0.1);
    return g.mesh;
  };
  Mesh jeans = load("female_casualsuit01__jeans"), tshirt = load("female_casualsuit01__tshirt");
  const Mesh tshirt_start = tshirt;
  Mesh* layers[] = {&jeans, &tshirt}; // inner to outer
  const LayeringOptions options;
  const auto reports = resolve_layers(layers, index, crossings, options);
  for (const PenetrationReport& r : reports) {
    EXPECT_LE(r.after.max_depth, 0.0005);
    EXPECT_EQ(r.after.crossing_edges, 0u);
    EXPECT_EQ(r.after.layer_inside_count, 0u);
    EXPECT_EQ(r.after.layer_crossing_edges, 0u);
  }
  // Recomputed from scratch: the T-shirt is outside the jeans as resolved.
  const InnerLayer inner(jeans, index, options.layer_clearance, options.reach);
  const LayerObstacle obstacle[] = {inner.obstacle()};
  const PenetrationStats s = measure_penetration(tshirt, index, crossings, obstacle, options.penetration.clearance);
  EXPECT_EQ(s.layer_inside_count, 0u);
  EXPECT_EQ(s.layer_crossing_edges, 0u) << "the jeans poke out through the T-shirt";
  EXPECT_EQ(s.crossing_edges, 0u);
  const double stretch = test::mean_edge_length_change(tshirt_start, tshirt);
  EXPECT_LT(stretch, 0.02);
  std::printf("t-shirt over jeans: inside the jeans %zu -> %zu (max %.2f mm), jeans edges through it %zu -> %zu, %d "
              "rounds, edge change %.2f %%\n",
              reports[1].before.layer_inside_count, reports[1].after.layer_inside_count,
              1e3 * reports[1].before.layer_max_depth, reports[1].before.layer_crossing_edges,
              reports[1].after.layer_crossing_edges, reports[1].iterations, 100 * stretch);
}

} // namespace
} // namespace vfit
