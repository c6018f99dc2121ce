#include "engine/penetration.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "geometry/mesh/mesh_io.h"
#include "geometry/mesh/primitives.h"
#include "geometry/mesh/units.h"
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
  for (const char* name : {"female_casualsuit01__tshirt", "female_casualsuit01__jeans", "female_sportsuit01__crop_top",
                           "female_sportsuit01__leggings", "female_elegantsuit01__skirt", "female_casualsuit02__tshirt"}) {
    SCOPED_TRACE(name);
    ParsedMesh g = read_mesh(dir / "parts_on_hm08" / (std::string(name) + ".obj"));
    scale_positions(g.mesh.positions, 0.1);
    const Mesh before = g.mesh;
    const PenetrationReport r = remove_penetration(g.mesh, index);
    EXPECT_GT(r.before.inside_count, 0u);
    EXPECT_LE(r.after.max_depth, 0.0005); // the bar: nothing inside by more than 0.5 mm
    EXPECT_LT(test::mean_edge_length_change(before, g.mesh), 0.02);
    std::printf("%-32s inside %4zu -> %zu, max depth %.2f -> %.2f mm, %d rounds, %.1f ms\n", name, r.before.inside_count,
                r.after.inside_count, 1e3 * r.before.max_depth, 1e3 * r.after.max_depth, r.iterations, r.milliseconds);
  }
}

} // namespace
} // namespace vfit
