// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/orient.h"

#include <cmath>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"

namespace vfit {
namespace {

// Turns over each triangle with probability `share` (corners 1 and 2 swapped, UV corners too).
Mesh with_flips(Mesh m, double share, unsigned seed, std::size_t& flipped) {
  std::mt19937 rng(seed);
  flipped = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    if (std::uniform_real_distribution<double>(0, 1)(rng) < share) {
      std::swap(m.triangles[3 * f + 1], m.triangles[3 * f + 2]);
      if (m.has_uvs()) std::swap(m.uv_triangles[3 * f + 1], m.uv_triangles[3 * f + 2]);
      ++flipped;
    }
  return m;
}

TEST(Orient, LeavesAConsistentMeshUntouched) {
  const Mesh sphere = make_uv_sphere(12, 24, 1.0f);
  Mesh m = sphere;
  const OrientReport r = orient_consistently(m);
  EXPECT_FALSE(r.changed());
  EXPECT_EQ(r.conflicts, 0u);
  EXPECT_EQ(m.triangles, sphere.triangles);
  Mesh empty;
  EXPECT_FALSE(orient_consistently(empty).changed());
}

// A closed sphere and an open grid (with UVs) with a third of their triangles turned over: each
// comes back exactly as it was (the majority's winding), UV corners with their triangles.
TEST(Orient, TurnsStrayTrianglesBackToTheirNeighboursWinding) {
  for (const Mesh& original : {make_uv_sphere(12, 24, 1.0f), make_grid(15, 11, 1.0f, 0.7f)}) {
    std::size_t flipped = 0;
    Mesh m = with_flips(original, 0.3, 7, flipped);
    ASSERT_GT(flipped, 0u);
    const OrientReport r = orient_consistently(m);
    EXPECT_EQ(r.flipped, flipped);
    EXPECT_EQ(r.conflicts, 0u);
    EXPECT_EQ(m.triangles, original.triangles);
    EXPECT_EQ(m.uv_triangles, original.uv_triangles);
  }
}

// Pieces are oriented each on its own: a second sphere wound inside out entirely stays so (no
// edge joins it to the first), and a piece mostly one way keeps that way.
TEST(Orient, OrientsEachPieceByItsOwnMajority) {
  const Mesh a = make_uv_sphere(8, 16, 1.0f);
  Mesh both = a;
  const auto offset = static_cast<std::int32_t>(a.vertex_count());
  for (std::size_t i = 0; i < a.positions.size(); ++i)
    both.positions.push_back(a.positions[i] + (i % 3 == 0 ? 5.0f : 0.0f));
  for (std::size_t f = 0; f < a.face_count(); ++f) {
    both.triangles.push_back(a.triangles[3 * f] + offset);
    both.triangles.push_back(a.triangles[3 * f + 2] + offset); // inside out
    both.triangles.push_back(a.triangles[3 * f + 1] + offset);
  }
  const std::vector<std::int32_t> before = both.triangles;
  EXPECT_FALSE(orient_consistently(both).changed());
  EXPECT_EQ(both.triangles, before);
}

// A Möbius strip cannot be oriented: the one edge where its ends meet the wrong way round is
// reported, nothing crashes, and every other edge agrees.
TEST(Orient, ReportsANonOrientableStrip) {
  Mesh m;
  const int n = 24;
  for (int i = 0; i < n; ++i) {
    const double t = 2 * std::numbers::pi * i / n, half = t / 2;
    for (double s : {-0.2, 0.2}) {
      m.positions.push_back(static_cast<float>((1 + s * std::cos(half)) * std::cos(t)));
      m.positions.push_back(static_cast<float>((1 + s * std::cos(half)) * std::sin(t)));
      m.positions.push_back(static_cast<float>(s * std::sin(half)));
    }
  }
  for (int i = 0; i < n; ++i) {
    const int a = 2 * i, b = 2 * i + 1;
    // The last quad joins the strip's ends with a half twist: bottom to top.
    const int c = i + 1 < n ? 2 * (i + 1) : 1, d = i + 1 < n ? 2 * (i + 1) + 1 : 0;
    for (int v : {a, c, b, b, c, d})
      m.triangles.push_back(v);
  }
  const OrientReport r = orient_consistently(m);
  EXPECT_EQ(r.conflicts, 1u);
}

// Three triangles on one edge (non-manifold): the edge joins none of them, each triangle is its
// own piece and keeps its winding.
TEST(Orient, NonManifoldEdgesJoinNothing) {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
  m.triangles = {0, 1, 2, 0, 1, 3, 1, 0, 4};
  const std::vector<std::int32_t> before = m.triangles;
  EXPECT_FALSE(orient_consistently(m).changed());
  EXPECT_EQ(m.triangles, before);
}

// A sphere wound inside out encloses a negative volume and is turned outward, exactly back to the
// original; an outward one is left alone; the volume is a sphere's within its tessellation.
TEST(Orient, TurnsAnInsideOutClosedSurfaceOutward) {
  const Mesh sphere = make_uv_sphere(24, 48, 1.0f);
  EXPECT_NEAR(signed_volume(sphere), 4.0 / 3.0 * std::numbers::pi, 0.05); // 24 × 48 facets: ~1 % short
  Mesh m = sphere;
  EXPECT_FALSE(orient_outward(m));
  for (std::size_t f = 0; f < m.face_count(); ++f)
    std::swap(m.triangles[3 * f + 1], m.triangles[3 * f + 2]);
  EXPECT_LT(signed_volume(m), 0);
  EXPECT_TRUE(orient_outward(m));
  EXPECT_EQ(m.triangles, sphere.triangles);
  Mesh empty;
  EXPECT_FALSE(orient_outward(empty));
}

} // namespace
} // namespace vfit
