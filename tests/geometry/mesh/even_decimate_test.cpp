// SPDX-License-Identifier: Apache-2.0
// decimate_evenly() (geometry/mesh/even_decimate.h): the result is a vertex subset at the
// input's positions, with the input's topology (manifold, consistently oriented, the same
// boundary loops of input boundary vertices, the same Euler characteristic), the target count
// and triangles within the aspect guard.
#include "vfit/geometry/mesh/even_decimate.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit {
namespace {

// Longest edge / height of each triangle (1.15 for an equilateral one).
double worst_aspect(const Mesh& m) {
  double worst = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c)
        p[k][c] = m.positions[3 * std::size_t(m.triangles[3 * f + std::size_t(k)]) + std::size_t(c)];
    double longest = 0, e[2][3];
    for (int k = 0; k < 3; ++k) {
      double l2 = 0;
      for (int c = 0; c < 3; ++c)
        l2 += std::pow(p[(k + 1) % 3][c] - p[k][c], 2);
      longest = std::max(longest, l2);
    }
    for (int c = 0; c < 3; ++c)
      e[0][c] = p[1][c] - p[0][c], e[1][c] = p[2][c] - p[0][c];
    const double cx = e[0][1] * e[1][2] - e[0][2] * e[1][1], cy = e[0][2] * e[1][0] - e[0][0] * e[1][2],
                 cz = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    worst = std::max(worst, longest / std::sqrt(cx * cx + cy * cy + cz * cz));
  }
  return worst;
}

std::set<std::int32_t> boundary_vertices(const Mesh& m) {
  std::multiset<std::pair<std::int32_t, std::int32_t>> directed;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    for (std::size_t k = 0; k < 3; ++k)
      directed.insert({m.triangles[3 * f + k], m.triangles[3 * f + (k + 1) % 3]});
  std::set<std::int32_t> out;
  for (const auto& [a, b] : directed)
    if (directed.count({b, a}) == 0) out.insert(a), out.insert(b);
  return out;
}

class EvenDecimate : public ::testing::TestWithParam<int> {};

Mesh input(int which) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jitter(-0.002f, 0.002f);
  Mesh m = which == 0   ? make_tube(60, 48, 0.1f, 0.6f)
           : which == 1 ? make_grid(70, 50, 1.0f, 0.7f)
                        : make_uv_sphere(40, 60, 0.3f);
  for (float& x : m.positions)
    x += jitter(rng);
  return m;
}

TEST_P(EvenDecimate, KeepsTheTopologyAndTheBoundaryOnAVertexSubset) {
  const Mesh fine = input(GetParam());
  const TopologyReport before = analyse_topology(fine.triangles, fine.vertex_count());
  constexpr std::size_t TARGET = 400;
  std::vector<std::int32_t> sources;
  const Mesh coarse = decimate_evenly(fine, TARGET, sources);
  EXPECT_EQ(coarse.vertex_count(), TARGET);
  ASSERT_EQ(sources.size(), coarse.vertex_count());
  EXPECT_TRUE(std::is_sorted(sources.begin(), sources.end()));
  for (std::size_t v = 0; v < sources.size(); ++v)
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(coarse.positions[3 * v + std::size_t(c)], fine.positions[3 * std::size_t(sources[v]) + std::size_t(c)]);
  const TopologyReport after = analyse_topology(coarse.triangles, coarse.vertex_count());
  EXPECT_TRUE(after.manifold());
  EXPECT_TRUE(after.oriented());
  EXPECT_EQ(after.unreferenced_vertices, 0u);
  EXPECT_EQ(after.components, before.components);
  EXPECT_EQ(after.boundary_loops, before.boundary_loops);
  EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
  // A boundary vertex of the result was one of the input.
  const std::set<std::int32_t> fine_boundary = boundary_vertices(fine);
  for (std::int32_t v : boundary_vertices(coarse))
    EXPECT_TRUE(fine_boundary.count(sources[std::size_t(v)])) << v;
  // The guard: 6, or the input's worst where that is worse (the UV sphere's poles are slivers).
  EXPECT_LE(worst_aspect(coarse), std::max(6.0, worst_aspect(fine)) + 1e-9);
}

std::string mesh_name(const ::testing::TestParamInfo<int>& p) {
  const char* names[] = {"Tube", "Grid", "Sphere"};
  return names[p.param];
}
INSTANTIATE_TEST_SUITE_P(Meshes, EvenDecimate, ::testing::Values(0, 1, 2), mesh_name);

TEST(EvenDecimateSmall, AMeshAtOrBelowTheTargetComesBackWhole) {
  const Mesh m = make_grid(5, 4, 1.0f, 1.0f);
  std::vector<std::int32_t> sources;
  const Mesh out = decimate_evenly(m, 20, sources);
  EXPECT_EQ(out.positions, m.positions);
  EXPECT_EQ(out.triangles, m.triangles);
  ASSERT_EQ(sources.size(), 20u);
  for (std::size_t v = 0; v < 20; ++v)
    EXPECT_EQ(sources[v], std::int32_t(v));
}

} // namespace
} // namespace vfit
