// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/edge_crossings.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"

namespace vfit {
namespace {

// Random segments around a sphere of radius 0.2: some wholly outside, some through, some with
// one end inside.
std::vector<float> random_points(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.35f, 0.35f);
  std::vector<float> p(3 * count);
  for (float& x : p)
    x = u(rng);
  return p;
}

TEST(EdgeCrossings, EmbreeAgreesWithBruteForceSerialAndParallel) {
  const Mesh body = make_uv_sphere(16, 32, 0.2f);
  const EdgeCrossingIndex index(body.positions, body.triangles);
  const std::size_t count = 3000;
  const std::vector<float> points = random_points(2 * count, 7);
  std::vector<std::int32_t> edges(2 * count);
  for (std::size_t i = 0; i < edges.size(); ++i)
    edges[i] = static_cast<std::int32_t>(i);
  SegmentCrossings fast, serial, brute;
  index.first_crossings(points, edges, fast);
  index.first_crossings_serial(points, edges, serial);
  index.first_crossings_brute_force(points, edges, brute);
  EXPECT_EQ(fast.triangles, serial.triangles);
  EXPECT_EQ(fast.parameters, serial.parameters);
  std::size_t crossing = 0;
  for (std::size_t i = 0; i < count; ++i) {
    ASSERT_EQ(fast.triangles[i] >= 0, brute.triangles[i] >= 0) << "segment " << i;
    if (brute.triangles[i] < 0) continue;
    ++crossing;
    // Float (Embree) against double (brute force) on segments ≤ 1.2 m: t agrees to ~1e-6;
    // the triangle may differ only when the hit lies on a shared edge, where t still agrees.
    EXPECT_NEAR(fast.parameters[i], brute.parameters[i], 1e-5f) << "segment " << i;
  }
  // The oracle agreement means something only if both kinds occur.
  EXPECT_GT(crossing, count / 5);
  EXPECT_LT(crossing, count);
}

TEST(EdgeCrossings, FindsAnEdgeThroughAThinRodWithBothEndsOutside) {
  // A rod of radius 5 mm along Z (a squashed sphere), and a 6 cm edge across it.
  Mesh rod = make_uv_sphere(12, 16, 1.0f);
  for (std::size_t v = 0; v < rod.vertex_count(); ++v) {
    rod.positions[3 * v] *= 0.005f;
    rod.positions[3 * v + 1] *= 0.005f;
    rod.positions[3 * v + 2] *= 0.2f;
  }
  const EdgeCrossingIndex index(rod.positions, rod.triangles);
  const std::vector<float> points = {-0.03f, 0.001f, 0.0f, 0.03f, 0.001f, 0.0f, 0.0f, 0.02f, 0.0f};
  const std::vector<std::int32_t> edges = {0, 1, 1, 0, 0, 2};
  SegmentCrossings c;
  index.first_crossings(points, edges, c);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_EQ(c.crossing_count(), 2u);
  // Entering at x ≈ −0.005 from either side: t ≈ (0.03 − 0.005)/0.06 (the rod is a 16-gon, so
  // its surface is up to 2 % inside the circle).
  EXPECT_NEAR(c.parameters[0], 0.25f / 0.6f, 0.01f);
  EXPECT_NEAR(c.parameters[1], 0.25f / 0.6f, 0.01f);
  EXPECT_EQ(c.triangles[2], -1);
  float n[3];
  index.face_normal(c.triangles[0], n);
  EXPECT_LT(n[0], -0.5f) << "the face met first from −x faces −x";
}

TEST(EdgeCrossings, EdgeEndpointsAreTheDistinctEdges) {
  const Mesh tube = make_tube(3, 5, 0.1f, 0.2f);
  const std::vector<std::int32_t> ends = mesh_edge_endpoints(tube.triangles, tube.vertex_count());
  // Euler: a tube (annulus) has V − E + F = 0.
  EXPECT_EQ(tube.vertex_count() + tube.triangles.size() / 3, ends.size() / 2);
  for (std::size_t e = 0; 2 * e < ends.size(); ++e)
    EXPECT_LT(ends[2 * e], ends[2 * e + 1]);
}

TEST(EdgeCrossings, EmptyBodyCrossesNothing) {
  const EdgeCrossingIndex index({}, {});
  const std::vector<float> points = {0, 0, 0, 1, 1, 1};
  const std::vector<std::int32_t> edges = {0, 1};
  SegmentCrossings c;
  index.first_crossings(points, edges, c);
  EXPECT_EQ(c.crossing_count(), 0u);
}

} // namespace
} // namespace vfit
