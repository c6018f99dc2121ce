// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/hole_caps.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/pseudo_normals.h"

namespace vfit {
namespace {

// Every edge of mesh + caps has exactly two triangles, used once in each direction.
void expect_capped_mesh_closed(std::span<const std::int32_t> triangles, std::size_t vertex_count,
                               const HoleCaps& caps) {
  std::vector<std::int32_t> all(triangles.begin(), triangles.end());
  all.insert(all.end(), caps.triangles.begin(), caps.triangles.end());
  const MeshEdges edges = build_mesh_edges(all, vertex_count + caps.loop_count());
  for (std::size_t e = 0; e < edges.edge_count(); ++e)
    EXPECT_EQ(edges.offsets[e + 1] - edges.offsets[e], 2) << e;
  std::vector<std::pair<std::int32_t, std::int32_t>> directed;
  for (std::size_t i = 0; i < all.size(); ++i)
    directed.emplace_back(all[i], all[i - i % 3 + (i % 3 + 1) % 3]);
  std::sort(directed.begin(), directed.end());
  EXPECT_EQ(std::adjacent_find(directed.begin(), directed.end()), directed.end()) << "an edge used twice one way";
}

TEST(HoleCaps, ClosedMeshHasNone) {
  const Mesh m = test::octahedron();
  const HoleCaps caps = build_hole_caps(m.triangles, m.vertex_count());
  EXPECT_EQ(caps.loop_count(), 0u);
  EXPECT_TRUE(caps.triangles.empty());
}

TEST(HoleCaps, GridHasOneLoopAroundItsBorder) {
  const Mesh m = make_grid(4, 3, 1.0f, 1.0f);
  const HoleCaps caps = build_hole_caps(m.triangles, m.vertex_count());
  ASSERT_EQ(caps.loop_count(), 1u);
  EXPECT_EQ(caps.loop_vertices.size(), caps.triangles.size() / 3) << "one cap triangle per boundary edge";
  expect_capped_mesh_closed(m.triangles, m.vertex_count(), caps);
  std::vector<float> capped;
  capped_positions(m.positions, caps, capped);
  ASSERT_EQ(capped.size(), m.positions.size() + 3);
  // The border's mean lies at the grid's centre.
  double c[3] = {0, 0, 0};
  for (std::int32_t v : caps.loop_vertices)
    for (int k = 0; k < 3; ++k)
      c[k] += m.positions[3 * std::size_t(v) + std::size_t(k)] / double(caps.loop_vertices.size());
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(capped[m.positions.size() + std::size_t(k)], c[k], 1e-6);
}

// Two triangles touching at one vertex (a bow tie): two loops through the shared vertex.
TEST(HoleCaps, LoopsTouchingAtAVertexAreBothCapped) {
  const std::vector<std::int32_t> triangles = {0, 1, 2, 0, 3, 4};
  const HoleCaps caps = build_hole_caps(triangles, 5);
  EXPECT_EQ(caps.loop_count(), 2u);
  EXPECT_EQ(caps.triangles.size(), 18u);
  expect_capped_mesh_closed(triangles, 5, caps);
}

// The sphere's pole fan removed: one loop, capped with the orientation of the mesh.
TEST(HoleCaps, SphereHoleCapIsOrientedOutward) {
  Mesh m = make_uv_sphere(8, 12, 1.0f);
  std::vector<std::int32_t> kept; // without the north pole's fan (the triangles of vertex 0)
  for (std::size_t f = 0; f < m.face_count(); ++f)
    if (m.triangles[3 * f] != 0 && m.triangles[3 * f + 1] != 0 && m.triangles[3 * f + 2] != 0)
      kept.insert(kept.end(), m.triangles.begin() + 3 * std::ptrdiff_t(f),
                  m.triangles.begin() + 3 * std::ptrdiff_t(f) + 3);
  m.triangles = kept;
  const HoleCaps caps = build_hole_caps(m.triangles, m.vertex_count());
  ASSERT_EQ(caps.loop_count(), 1u);
  EXPECT_EQ(caps.loop_vertices.size(), 12u);
  expect_capped_mesh_closed(m.triangles, m.vertex_count(), caps);
  std::vector<float> p;
  capped_positions(m.positions, caps, p);
  for (std::size_t t = 0; t < caps.triangles.size() / 3; ++t) {
    auto at = [&](int k, int j) { return p[3 * std::size_t(caps.triangles[3 * t + std::size_t(k)]) + std::size_t(j)]; };
    // y of the normal (b − a) × (c − a): the cap faces +y, out of the sphere.
    const float ny = (at(2, 0) - at(0, 0)) * (at(1, 2) - at(0, 2)) - (at(1, 0) - at(0, 0)) * (at(2, 2) - at(0, 2));
    EXPECT_GT(ny, 0.0f) << "cap triangle " << t;
  }
}

} // namespace
} // namespace vfit
