#include "engine/penetration.h"

#include <cmath>

#include <gtest/gtest.h>

#include "geometry/mesh/mesh_io.h"
#include "geometry/mesh/primitives.h"
#include "geometry/mesh/units.h"
#include "kernels/proximity.h"
#include "test_support.h"

namespace vfit {
namespace {


TEST(Penetration, PushesATubeThatCutsIntoASphereOutAndKeepsItsShape) {
  const Mesh body = make_uv_sphere(40, 80, 0.20f);
  const ProximityIndex index(body.positions, body.triangles);
  // A sleeve-like tube of radius 0.1 whose axis passes 0.17 m from the sphere's centre: its
  // near side is up to 2.9 cm inside.
  Mesh tube = make_tube(40, 48, 0.10f, 0.6f);
  for (std::size_t v = 0; v < tube.vertex_count(); ++v) {
    tube.positions[3 * v] += 0.27f;
    tube.positions[3 * v + 1] -= 0.3f;
  }
  const Mesh before = tube;
  const PenetrationReport r = remove_penetration(tube, index);
  EXPECT_GT(r.before.inside_count, 50u);
  EXPECT_GT(r.before.max_depth, 0.02);
  EXPECT_EQ(r.after.inside_count, 0u) << "max depth after " << r.after.max_depth;
  // The cloth moved only where it had to: the far side of the tube is untouched within 2 mm.
  for (std::size_t v = 0; v < tube.vertex_count(); ++v) {
    if (before.positions[3 * v] > 0.33f) {
      EXPECT_NEAR(tube.positions[3 * v], before.positions[3 * v], 0.002f) << v;
    }
  }
  EXPECT_LT(test::mean_edge_length_change(before, tube), 0.05);
}

TEST(Penetration, NothingToDoLeavesTheGarmentAlone) {
  const Mesh body = make_uv_sphere(20, 40, 0.2f);
  const ProximityIndex index(body.positions, body.triangles);
  Mesh far = make_tube(5, 8, 0.05f, 0.2f);
  for (std::size_t v = 0; v < far.vertex_count(); ++v) far.positions[3 * v] += 1.0f;
  const Mesh before = far;
  const PenetrationReport r = remove_penetration(far, index);
  EXPECT_EQ(r.before.near_count, 0u);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(far.positions, before.positions);
}

} // namespace
} // namespace vfit
