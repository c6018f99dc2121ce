// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/topology.h"

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/openmesh_adapter.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

TopologyReport analyse(const Mesh& m) { return analyse_topology(m.triangle_view(), m.vertex_count()); }

TEST(Topology, ClosedOctahedronIsWatertightWithEulerTwo) {
  const TopologyReport r = analyse(test::octahedron());
  EXPECT_EQ(r.edges, 12u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_TRUE(r.manifold());
  EXPECT_TRUE(r.oriented());
  EXPECT_TRUE(r.watertight());
  EXPECT_EQ(r.euler_characteristic, 2);
}

TEST(Topology, OpenShapesCountTheirBoundaryLoops) {
  EXPECT_EQ(analyse(test::unit_square()).boundary_loops, 1u);
  const TopologyReport tube = analyse(make_tube(5, 8, 0.1f, 0.5f));
  EXPECT_EQ(tube.boundary_loops, 2u);
  EXPECT_EQ(tube.euler_characteristic, 0); // an annulus
  EXPECT_FALSE(tube.watertight());
  const TopologyReport sphere = analyse(make_uv_sphere(10, 16, 1.0f));
  EXPECT_TRUE(sphere.watertight());
  EXPECT_EQ(sphere.euler_characteristic, 2);
}

// An octahedron, a unit square after it and one unreferenced vertex: three pieces.
Mesh octahedron_square_and_stray() {
  Mesh a = test::octahedron();
  const Mesh b = test::unit_square();
  const auto off = static_cast<std::int32_t>(a.vertex_count());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (std::int32_t v : b.triangles)
    a.triangles.push_back(v + off);
  a.positions.insert(a.positions.end(), {9, 9, 9}); // unreferenced
  return a;
}

TEST(Topology, CountsComponentsAndUnreferencedVertices) {
  const Mesh a = octahedron_square_and_stray();
  const TopologyReport r = analyse(a);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.unreferenced_vertices, 1u);
  EXPECT_EQ(r.boundary_loops, 1u);
}

// The same mesh labelled by pieces: the octahedron's vertices carry 0 (its smallest), the
// square's its own smallest index, the unreferenced vertex itself.
TEST(Topology, LabelsEachVertexByItsPiecesSmallestVertex) {
  const Mesh a = octahedron_square_and_stray();
  const auto off = static_cast<std::int32_t>(test::octahedron().vertex_count());
  const std::size_t square = test::unit_square().vertex_count();
  const std::vector<std::int32_t> label = vertex_piece_labels(a.triangles, a.vertex_count());
  ASSERT_EQ(label.size(), a.vertex_count());
  for (std::int32_t v = 0; v < off; ++v)
    EXPECT_EQ(label[std::size_t(v)], 0) << v;
  for (std::size_t v = 0; v < square; ++v)
    EXPECT_EQ(label[std::size_t(off) + v], off) << v;
  EXPECT_EQ(label.back(), std::int32_t(a.vertex_count() - 1));
}

TEST(Topology, FindsNonManifoldEdgesVerticesAndFlippedFaces) {
  Mesh fin; // three triangles on one edge (0, 1)
  fin.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
  fin.triangles = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  EXPECT_EQ(analyse(fin).non_manifold_edges, 1u);
  EXPECT_FALSE(analyse(fin).manifold());

  Mesh bowtie; // two triangles touching at vertex 0 only
  bowtie.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0};
  bowtie.triangles = {0, 1, 2, 0, 3, 4};
  const TopologyReport r = analyse(bowtie);
  EXPECT_EQ(r.non_manifold_edges, 0u);
  EXPECT_EQ(r.non_manifold_vertices, 1u);
  EXPECT_EQ(r.components, 1u);

  Mesh flipped = test::unit_square();
  std::swap(flipped.triangles[4], flipped.triangles[5]); // second face reversed
  EXPECT_EQ(analyse(flipped).inconsistent_edges, 1u);
  EXPECT_FALSE(analyse(flipped).watertight());
}

class TopologyAgainstOpenMesh : public ::testing::TestWithParam<int> {};

TEST_P(TopologyAgainstOpenMesh, BoundaryLoopsMatchHalfEdgeWalk) {
  // Oracle: OpenMesh's half-edge structure, walked boundary by boundary.
  const int n = GetParam();
  Mesh m = make_grid(n, n + 1, 1.0f, 1.0f);
  // Punch holes: drop both triangles of some interior, non-adjacent quads.
  std::vector<std::int32_t> kept;
  int holes = 0;
  for (std::size_t q = 0; q < m.face_count() / 2; ++q) {
    const int i = int(q) / (n - 1), j = int(q) % (n - 1);
    const bool hole = i % 3 == 1 && j % 3 == 1 && i < n - 1 && j < n - 2;
    if (hole) {
      ++holes;
      continue;
    }
    kept.insert(kept.end(), m.triangles.begin() + 6 * q, m.triangles.begin() + 6 * q + 6);
  }
  m.triangles = kept;
  m.uv_triangles.clear();
  const TopologyReport r = analyse(m);
  auto he = to_half_edge_mesh(m, "grid");
  EXPECT_EQ(r.boundary_loops, half_edge_boundary_loops(*he));
  EXPECT_EQ(r.boundary_loops, std::size_t(1 + holes));
}

INSTANTIATE_TEST_SUITE_P(Grids, TopologyAgainstOpenMesh, ::testing::Values(3, 5, 8, 13));

TEST(OpenMeshAdapter, RejectsNonManifoldInputNamingTheFace) {
  Mesh fin;
  fin.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
  fin.triangles = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  try {
    to_half_edge_mesh(fin, "fin.obj");
    FAIL() << "accepted a non-manifold edge";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fin.obj: face 3"), std::string::npos) << e.what();
  }
  const Mesh back = from_half_edge_mesh(*to_half_edge_mesh(test::octahedron(), "o"));
  EXPECT_EQ(back.triangles.size(), test::octahedron().triangles.size());
}

} // namespace
} // namespace vfit
