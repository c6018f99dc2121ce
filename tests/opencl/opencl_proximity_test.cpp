// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/opencl_proximity.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

bool have_device() { return !list_opencl_devices().empty(); }

#define REQUIRE_OPENCL_DEVICE()                                                                                        \
  if (!have_device()) GTEST_SKIP() << "no OpenCL device installed (apt-get install pocl-opencl-icd)"

// The device evaluates the same point–triangle expression (closest_point_math.h, FP_CONTRACT
// off), but its sqrt and division may round differently by an ulp: two triangles equally close
// to within that may swap, so a different triangle must give the same distance within 1e-6 m
// (a few ulps of the ~1 m coordinates). Same triangle: same point within a few ulps too.
constexpr float TIE_TOLERANCE = 1e-6f;
// Below this the side is not compared (see proximity_test.cpp): the input floats do not decide it.
constexpr float SIGN_THRESHOLD = 1e-5f;

// Queries near and far: surface points moved by N(0, σ), σ from 1 mm to 20 cm, and points in a
// box twice the mesh's size; fixed seed.
std::vector<float> make_queries(const Mesh& m, std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::vector<float> q;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t f = std::size_t(unit(rng) * float(m.face_count())) % m.face_count();
    float u = unit(rng), v = unit(rng);
    if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
    const float sigma = i % 4 == 0 ? 1e-3f : i % 4 == 1 ? 2e-2f : i % 4 == 2 ? 0.2f : 1.0f;
    for (int k = 0; k < 3; ++k) {
      const float a = m.positions[3 * m.triangles[3 * f] + k], b = m.positions[3 * m.triangles[3 * f + 1] + k],
                  c = m.positions[3 * m.triangles[3 * f + 2] + k];
      q.push_back((1 - u - v) * a + u * b + v * c + sigma * gauss(rng));
    }
  }
  return q;
}

void expect_agree(const std::vector<float>& q, const ClosestHits& gpu, const ClosestHits& cpu) {
  ASSERT_EQ(gpu.size(), cpu.size());
  std::size_t same_triangle = 0, hit = 0;
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    SCOPED_TRACE("query " + std::to_string(i) + " at " + std::to_string(q[3 * i]) + ", " +
                 std::to_string(q[3 * i + 1]) + ", " + std::to_string(q[3 * i + 2]));
    ASSERT_EQ(gpu.triangles[i] < 0, cpu.triangles[i] < 0);
    if (cpu.triangles[i] < 0) continue;
    ++hit;
    const float dg = std::abs(gpu.signed_distances[i]), dc = std::abs(cpu.signed_distances[i]);
    // Plus a few ulps of the distance itself for the far queries (as in proximity_test.cpp).
    EXPECT_NEAR(dg, dc, TIE_TOLERANCE + 4e-7f * dc);
    if (gpu.triangles[i] == cpu.triangles[i]) {
      ++same_triangle;
      EXPECT_EQ(gpu.features[i], cpu.features[i]);
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(gpu.points[3 * i + k], cpu.points[3 * i + k], TIE_TOLERANCE);
      for (int k = 0; k < 2; ++k)
        EXPECT_NEAR(gpu.barycentrics[2 * i + k], cpu.barycentrics[2 * i + k], 1e-5f);
    }
    if (dc > SIGN_THRESHOLD) {
      EXPECT_EQ(gpu.signed_distances[i] < 0, cpu.signed_distances[i] < 0);
    }
  }
  // Ties are rare (vertex and edge queries): almost all must be the very same triangle.
  EXPECT_GT(same_triangle, hit * 95 / 100);
}

struct ProximityCase {
  std::string name;
  Mesh (*make)();
};

Mesh sphere() { return make_uv_sphere(24, 48, 1.0f); }
Mesh mannequin() {
  MannequinOptions o;
  o.target_vertices = 2000;
  return make_mannequin(o).mesh;
}
// The sphere with a hole of 30° around +x: the side comes from the hole cap near it.
Mesh holed_sphere() {
  Mesh m = sphere();
  std::vector<std::int32_t> kept;
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    float c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        c[j] += m.positions[3 * m.triangles[3 * f + k] + j];
    if (c[0] / std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) > std::cos(0.5236f)) continue;
    kept.insert(kept.end(), m.triangles.begin() + 3 * f, m.triangles.begin() + 3 * f + 3);
  }
  m.triangles = kept;
  m.uv_triangles.clear();
  m.uvs.clear();
  return m;
}

class OpenClProximityParity : public ::testing::TestWithParam<ProximityCase> {};

TEST_P(OpenClProximityParity, AgreesWithCpuPath) {
  REQUIRE_OPENCL_DEVICE();
  const Mesh m = GetParam().make();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  OpenClContext ctx;
  OpenClProximity gpu(ctx, index);
  EXPECT_GT(gpu.node_count(), m.face_count() / OPENCL_PROXIMITY_LEAF_SIZE);
  const std::vector<float> q = make_queries(m, 4000, 91u);
  ClosestHits on_device, on_cpu;
  gpu.closest_points(q, std::numeric_limits<float>::infinity(), on_device);
  index.closest_points(q, std::numeric_limits<float>::infinity(), on_cpu);
  expect_agree(q, on_device, on_cpu);
  // A search radius: misses agree too.
  gpu.closest_points(q, 0.05f, on_device);
  index.closest_points(q, 0.05f, on_cpu);
  expect_agree(q, on_device, on_cpu);
  EXPECT_GT(std::count(on_cpu.triangles.begin(), on_cpu.triangles.end(), -1), 100) << "some queries must miss";
}

INSTANTIATE_TEST_SUITE_P(OpenClProximity, OpenClProximityParity,
                         ::testing::Values(ProximityCase{"sphere", sphere}, ProximityCase{"mannequin", mannequin},
                                           ProximityCase{"holed_sphere", holed_sphere}),
                         [](const ::testing::TestParamInfo<ProximityCase>& p) { return p.param.name; });

TEST(OpenClProximity, EmptyInputsAndBadQueries) {
  REQUIRE_OPENCL_DEVICE();
  OpenClContext ctx;
  const Mesh m = sphere();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  OpenClProximity gpu(ctx, index);
  ClosestHits h;
  gpu.closest_points({}, 1.0f, h);
  EXPECT_EQ(h.size(), 0u);
  const std::vector<float> bad = {0, 0, std::numeric_limits<float>::quiet_NaN()};
  EXPECT_THROW(gpu.closest_points(bad, 1.0f, h), Error);
  const ProximityIndex empty(std::span<const float>{}, std::span<const std::int32_t>{});
  OpenClProximity none(ctx, empty);
  EXPECT_EQ(none.node_count(), 0u);
  const std::vector<float> q = {0, 0, 0, 1, 2, 3};
  none.closest_points(q, std::numeric_limits<float>::infinity(), h);
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h.triangles[0], -1);
  EXPECT_EQ(h.triangles[1], -1);
}

} // namespace
} // namespace vfit
