// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/vertex_normals.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

Mesh jittered_sphere(int rings, int segments, unsigned seed) {
  Mesh m = make_uv_sphere(rings, segments, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.01f, 0.01f);
  for (float& x : m.positions)
    x += jitter(rng);
  return m;
}

TEST(VertexFaceAdjacency, ListsEveryCornerOnceInAscendingFaceOrder) {
  const Mesh m = make_uv_sphere(8, 12, 1.0f);
  const VertexFaceAdjacency adj = build_vertex_face_adjacency(m.triangle_view(), m.vertex_count());
  ASSERT_EQ(adj.offsets.size(), m.vertex_count() + 1);
  EXPECT_EQ(static_cast<std::size_t>(adj.offsets.back()), m.triangles.size());
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    for (std::int32_t k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
      const std::int32_t f = adj.faces[k];
      if (k > adj.offsets[v]) {
        EXPECT_LT(adj.faces[k - 1], f);
      }
      const bool has_v = m.triangles[3 * f] == std::int32_t(v) || m.triangles[3 * f + 1] == std::int32_t(v) ||
                         m.triangles[3 * f + 2] == std::int32_t(v);
      EXPECT_TRUE(has_v) << "vertex " << v << " lists face " << f;
    }
}

TEST(VertexNormals, SphereNormalsPointAlongTheRadius) {
  const Mesh m = make_uv_sphere(64, 128, 2.0f);
  std::vector<float> n;
  vertex_normals_serial(m.position_view(), m.triangle_view(), n);
  ASSERT_EQ(n.size(), m.positions.size());
  double worst = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    double dot = 0, len = 0;
    for (int k = 0; k < 3; ++k) {
      dot += n[3 * v + k] * m.positions[3 * v + k] / 2.0;
      len += double(n[3 * v + k]) * n[3 * v + k];
    }
    EXPECT_NEAR(len, 1.0, 1e-5) << "vertex " << v; // unit length up to float rounding
    worst = std::max(worst, std::acos(std::min(1.0, dot)));
  }
  // On a 64×128 sphere the discrete normal deviates from the radius by far less than 1°
  // (the facets span 2.8°, and the area weighting is symmetric about the radius).
  EXPECT_LT(worst * 180.0 / M_PI, 1.0);
}

TEST(VertexNormals, FlatSquareFacesPlusZ) {
  const Mesh m = test::unit_square();
  std::vector<float> n;
  vertex_normals_serial(m.position_view(), m.triangle_view(), n);
  for (std::size_t v = 0; v < 4; ++v) {
    EXPECT_FLOAT_EQ(n[3 * v + 0], 0.0f);
    EXPECT_FLOAT_EQ(n[3 * v + 1], 0.0f);
    EXPECT_FLOAT_EQ(n[3 * v + 2], 1.0f);
  }
}

TEST(VertexNormals, IsolatedAndDegenerateVerticesGetZero) {
  Mesh m = test::unit_square();
  m.positions.insert(m.positions.end(), {5, 5, 5});          // vertex 4: used by no face
  m.positions.insert(m.positions.end(), {0, 0, 0, 1, 0, 0}); // 5, 6: a zero-area face
  m.positions.insert(m.positions.end(), {2, 0, 0});
  m.triangles.insert(m.triangles.end(), {5, 6, 7}); // collinear: area 0
  std::vector<float> n;
  vertex_normals_serial(m.position_view(), m.triangle_view(), n);
  for (int v : {4, 5, 6, 7})
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(n[3 * v + k], 0.0f) << "vertex " << v;
}

class VertexNormalsParity : public ::testing::TestWithParam<int> {};

TEST_P(VertexNormalsParity, TbbEqualsSerialBitForBit) {
  // The TBB gather visits each vertex's faces in ascending order, as the serial scatter does,
  // with the same expression and no contraction: the results must be identical, not close.
  const Mesh m = jittered_sphere(GetParam(), 2 * GetParam(), 7u + GetParam());
  std::vector<float> serial, parallel;
  vertex_normals_serial(m.position_view(), m.triangle_view(), serial);
  vertex_normals_tbb(m.position_view(), m.triangle_view(), parallel);
  ASSERT_EQ(serial.size(), parallel.size());
  for (std::size_t i = 0; i < serial.size(); ++i)
    ASSERT_EQ(serial[i], parallel[i]) << "component " << i;
}

INSTANTIATE_TEST_SUITE_P(Sizes, VertexNormalsParity, ::testing::Values(3, 16, 100, 300));

TEST(ParallelForRange, CoversEveryIndexExactlyOnce) {
  for (std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{999}, std::size_t{100000}}) {
    std::vector<int> hits(count, 0);
    parallel_for_range(count, 128, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        ++hits[i]; // ranges are disjoint: no race
    });
    for (std::size_t i = 0; i < count; ++i)
      ASSERT_EQ(hits[i], 1) << "index " << i;
  }
}

} // namespace
} // namespace vfit
