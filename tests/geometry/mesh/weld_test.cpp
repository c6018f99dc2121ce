// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/weld.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit {
namespace {

// A grid cut into two pieces at the middle of its x range, the right piece with its own copy
// of every vertex it uses (`seam` of them shared with the left piece), plus a stray vertex no
// face uses; UVs and labels per face.
Mesh two_pieces(const Mesh& grid, std::size_t& copies, std::size_t& seam) {
  Mesh m = grid;
  const std::size_t nv = grid.vertex_count();
  float lo = 1e30f, hi = -1e30f;
  for (std::size_t v = 0; v < nv; ++v)
    lo = std::min(lo, m.positions[3 * v]), hi = std::max(hi, m.positions[3 * v]);
  const float mid = 0.5f * (lo + hi);
  std::vector<std::int32_t> copy(nv, -1);
  std::vector<char> left(nv, 0);
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    float cx = 0;
    for (int k = 0; k < 3; ++k)
      cx += m.positions[3 * std::size_t(m.triangles[3 * f + std::size_t(k)])];
    if (cx / 3 < mid)
      for (int k = 0; k < 3; ++k)
        left[std::size_t(m.triangles[3 * f + std::size_t(k)])] = 1;
  }
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    float cx = 0;
    for (int k = 0; k < 3; ++k)
      cx += m.positions[3 * std::size_t(m.triangles[3 * f + std::size_t(k)])];
    if (cx / 3 < mid) continue; // the left piece keeps the originals
    for (int k = 0; k < 3; ++k) {
      std::int32_t& v = m.triangles[3 * f + std::size_t(k)];
      if (copy[std::size_t(v)] < 0) {
        copy[std::size_t(v)] = std::int32_t(m.vertex_count());
        for (int c = 0; c < 3; ++c)
          m.positions.push_back(m.positions[3 * std::size_t(v) + std::size_t(c)]);
      }
      v = copy[std::size_t(v)];
    }
  }
  copies = seam = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    copies += copy[v] >= 0;
    seam += copy[v] >= 0 && left[v];
  }
  m.positions.insert(m.positions.end(), {5, 5, 5}); // stray
  m.uvs = {0, 0};
  m.uv_triangles.assign(m.triangles.size(), 0);
  m.face_labels.resize(m.face_count());
  for (std::size_t f = 0; f < m.face_count(); ++f)
    m.face_labels[f] = std::int32_t(f % 2);
  m.label_names = {"a", "b"};
  return m;
}

TEST(Weld, JoinsPiecesThatShareSeamPositionsAndKeepsFaceData) {
  const Mesh grid = make_grid(9, 9, 1.0f, 1.0f);
  std::size_t copies = 0, seam = 0;
  Mesh m = two_pieces(grid, copies, seam);
  ASSERT_GT(seam, 5u);
  ASSERT_GT(copies, seam);
  ASSERT_EQ(analyse_topology(m.triangle_view(), m.vertex_count()).components, 2u);
  const std::vector<std::int32_t> labels = m.face_labels;
  const WeldReport r = weld_coincident_vertices(m);
  EXPECT_TRUE(r.changed());
  EXPECT_EQ(r.unreferenced, copies - seam + 1); // the right piece's originals off the seam, and the stray
  EXPECT_EQ(r.welded, seam);                    // the seam's copies
  EXPECT_EQ(r.collapsed, 0u);
  EXPECT_EQ(m.vertex_count(), grid.vertex_count());
  EXPECT_EQ(m.face_count(), grid.face_count());
  EXPECT_EQ(analyse_topology(m.triangle_view(), m.vertex_count()).components, 1u);
  EXPECT_EQ(m.face_labels, labels);
  EXPECT_EQ(m.uv_triangles.size(), m.triangles.size());
  // Every triangle has the grid's own corners (positions), in the same order.
  for (std::size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(m.positions[3 * std::size_t(m.triangles[3 * f + std::size_t(k)]) + std::size_t(c)],
                  grid.positions[3 * std::size_t(grid.triangles[3 * f + std::size_t(k)]) + std::size_t(c)]);
}

TEST(Weld, LeavesACleanMeshUntouchedAndDropsCollapsedTriangles) {
  Mesh clean = make_grid(4, 4, 1.0f, 1.0f);
  const Mesh before = clean;
  EXPECT_FALSE(weld_coincident_vertices(clean).changed());
  EXPECT_EQ(clean.positions, before.positions);
  EXPECT_EQ(clean.triangles, before.triangles);
  // Two corners of a triangle at one position (−0.0 and 0.0 alike): the triangle goes.
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, -0.0f, 0, 0};
  m.triangles = {0, 1, 2, 3, 1, 2, 3, 0, 2};
  const WeldReport r = weld_coincident_vertices(m);
  EXPECT_EQ(r.welded, 1u);
  EXPECT_EQ(r.collapsed, 1u);
  EXPECT_EQ(m.face_count(), 2u);
  EXPECT_EQ(m.vertex_count(), 3u);
}

// Seam copies an exporter rounded apart: the right piece's copies moved by up to 2e-6 of the
// grid's diagonal (a few µm on a garment) stay apart under the exact weld and are joined by
// weld_seams() into one piece; a second sheet 1 mm off (a lining: 7e-4 of the diagonal) and an
// interior vertex nudged by as little are left alone.
TEST(Weld, SeamsRoundedApartAreJoinedAndLiningsAndInteriorsAreNot) {
  const Mesh grid = make_grid(9, 9, 1.0f, 1.0f); // diagonal ≈ 1.41
  std::size_t copies = 0, seam = 0;
  Mesh m = two_pieces(grid, copies, seam);
  const std::size_t originals = grid.vertex_count();
  for (std::size_t v = originals; v + 1 < m.vertex_count(); ++v) // the copies, not the stray
    for (std::size_t c = 0; c < 3; ++c)
      m.positions[3 * v + c] += 2.5e-6f * float(1 + (v + c) % 3) * (c == 1 ? -1.0f : 1.0f) / 3.0f;
  Mesh exact = m;
  EXPECT_EQ(weld_coincident_vertices(exact).welded, 0u);
  EXPECT_EQ(analyse_topology(exact.triangle_view(), exact.vertex_count()).components, 2u);
  const WeldReport r = weld_seams(m);
  EXPECT_EQ(r.welded, seam);
  EXPECT_EQ(r.collapsed, 0u);
  EXPECT_EQ(m.vertex_count(), grid.vertex_count());
  EXPECT_EQ(analyse_topology(m.triangle_view(), m.vertex_count()).components, 1u);

  // A lining: the grid and a copy of it 1 mm above, two open sheets whose boundaries lie 1 mm
  // apart. And an interior vertex of the grid moved 2e-6 towards its neighbour: no boundary.
  Mesh two = grid;
  const auto n = std::int32_t(grid.vertex_count());
  for (std::size_t v = 0; v < grid.vertex_count(); ++v)
    two.positions.insert(two.positions.end(),
                         {grid.positions[3 * v], grid.positions[3 * v + 1] + 1e-3f, grid.positions[3 * v + 2]});
  for (std::int32_t t : grid.triangles)
    two.triangles.push_back(t + n);
  const std::size_t interior = 4 * 9 + 4; // the middle of the 9 × 9 grid
  two.positions[3 * interior] += 2e-6f;
  const Mesh before = two;
  EXPECT_FALSE(weld_seams(two).changed());
  EXPECT_EQ(two.positions, before.positions);
  EXPECT_EQ(two.triangles, before.triangles);
}

} // namespace
} // namespace vfit
