// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/spatial_hash.h"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

// `count` points scattered around the mesh's vertices, each moved by up to `spread` (m) per
// axis: inside, on and outside the surface, where cloth particles are.
std::vector<float> points_near(const Mesh& mesh, std::size_t count, float spread, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> vertex(0, mesh.vertex_count() - 1);
  std::uniform_real_distribution<float> offset(-spread, spread);
  std::vector<float> q(3 * count);
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t v = vertex(rng);
    for (int k = 0; k < 3; ++k)
      q[3 * i + k] = mesh.positions[3 * v + k] + offset(rng);
  }
  return q;
}

// The hash and the BVH run the same closest-point function (closest_point_math.h) over the
// same float coordinates and keep the minimum, so the closest distance agrees to the bit;
// the side is then the same pseudo-normal test. Only the triangle may differ, where two
// triangles are equally close (a shared edge or vertex): then the point and side still agree.
void expect_same_answers(const ClosestHits& hash, const ClosestHits& bvh, const std::string& what) {
  ASSERT_EQ(hash.size(), bvh.size());
  std::size_t hits = 0, inside = 0;
  for (std::size_t i = 0; i < hash.size(); ++i) {
    ASSERT_EQ(hash.signed_distances[i], bvh.signed_distances[i]) << what << ", query " << i;
    if (hash.triangles[i] != bvh.triangles[i]) {
      ASSERT_GE(hash.triangles[i], 0) << what << ", query " << i;
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(hash.points[3 * i + k], bvh.points[3 * i + k], 1e-6f) << what << ", tie at query " << i;
    }
    hits += bvh.triangles[i] >= 0;
    inside += bvh.signed_distances[i] < 0;
  }
  // The scatter reaches both sides of the surface (else the side test would go unexercised);
  // with the smallest radius (1 cm) about a quarter of the queries still find the surface.
  EXPECT_GT(hits, hash.size() / 5) << what;
  EXPECT_GT(inside, hash.size() / 20) << what;
}

TEST(SpatialHash, AgreesWithTheBvhOnASphere) {
  const Mesh sphere = make_uv_sphere(24, 48, 0.25f);
  const SpatialHash hash(sphere.position_view(), sphere.triangle_view());
  const ProximityIndex bvh(sphere.position_view(), sphere.triangle_view());
  const std::vector<float> q = points_near(sphere, 4000, 0.04f, 3u);
  for (float radius : {0.01f, 0.05f, INFINITY}) {
    ClosestHits a, b;
    hash.closest_points(q, radius, a);
    bvh.closest_points(q, radius, b);
    expect_same_answers(a, b, "radius " + std::to_string(radius));
  }
}

TEST(SpatialHash, AgreesWithTheBvhOnAPosedMannequinAndAfterItMoves) {
  const Mesh& body = test::mannequin(RestPose::APOSE, 5000).mesh;
  SpatialHash hash(body.position_view(), body.triangle_view());
  ProximityIndex bvh(body.position_view(), body.triangle_view());
  // Cell = mean edge length of a 5,000-vertex mannequin: about 2 cm.
  EXPECT_GT(hash.cell_size(), 0.005f);
  EXPECT_LT(hash.cell_size(), 0.05f);
  EXPECT_GE(hash.table_size(), 2 * hash.entry_count());
  const std::vector<float> q = points_near(body, 5000, 0.03f, 5u);
  ClosestHits a, b, serial;
  hash.closest_points(q, 0.05f, a);
  hash.closest_points_serial(q, 0.05f, serial);
  bvh.closest_points(q, 0.05f, b);
  expect_same_answers(a, b, "rest");
  EXPECT_EQ(a.triangles, serial.triangles);
  EXPECT_EQ(a.signed_distances, serial.signed_distances);

  // A moved and squashed body: the updated hash answers as a fresh BVH over the new positions.
  Mesh moved = body;
  for (std::size_t v = 0; v < moved.vertex_count(); ++v) {
    moved.positions[3 * v] = 0.9f * moved.positions[3 * v] + 0.1f;
    moved.positions[3 * v + 1] += 0.2f;
  }
  hash.update(moved.position_view());
  bvh.refit(moved.position_view());
  const std::vector<float> q2 = points_near(moved, 5000, 0.03f, 7u);
  hash.closest_points(q2, INFINITY, a);
  bvh.closest_points(q2, INFINITY, b);
  expect_same_answers(a, b, "moved");
}

// An open tube (two holes): the hash caps the holes as the proximity core does, so queries
// seen through the openings get the same side.
TEST(SpatialHash, DecidesTheSideOfAnOpenMeshLikeTheBvh) {
  const Mesh tube = make_tube(12, 32, 0.1f, 0.4f);
  const SpatialHash hash(tube.position_view(), tube.triangle_view());
  const ProximityIndex bvh(tube.position_view(), tube.triangle_view());
  ASSERT_GT(bvh.hole_count(), 0u);
  const std::vector<float> q = points_near(tube, 3000, 0.05f, 11u);
  ClosestHits a, b;
  hash.closest_points(q, INFINITY, a);
  bvh.closest_points(q, INFINITY, b);
  expect_same_answers(a, b, "tube");
}

TEST(SpatialHash, FarQueriesAndEmptyMeshesReportNoHit) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.25f);
  const SpatialHash hash(sphere.position_view(), sphere.triangle_view());
  const std::vector<float> far = {3.0f, 0.0f, 0.0f, 0.0f, -2.0f, 0.5f};
  ClosestHits hits;
  hash.closest_points(far, 0.5f, hits);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(hits.triangles[i], -1);
    EXPECT_EQ(hits.signed_distances[i], INFINITY);
    EXPECT_EQ(hits.features[i], static_cast<std::int8_t>(TriangleFeature::NONE));
  }
  // Without a radius the far query still finds the sphere (2.75 m away: ~100 shells of cells).
  hash.closest_points(far, INFINITY, hits);
  EXPECT_NEAR(hits.signed_distances[0], 2.75f, 0.01f); // 0.01: the facets sit inside the sphere

  const SpatialHash empty(std::span<const float>{}, std::span<const std::int32_t>{});
  empty.closest_points(far, INFINITY, hits);
  EXPECT_EQ(hits.triangles[0], -1);
}

TEST(SpatialHash, BadInputIsAnError) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.25f);
  std::vector<std::int32_t> tris = sphere.triangles;
  tris[7] = 100000;
  EXPECT_THROW(SpatialHash(sphere.position_view(), tris), Error);
  EXPECT_THROW(SpatialHash(sphere.position_view(), sphere.triangle_view(), -1.0f), Error);
  SpatialHash hash(sphere.position_view(), sphere.triangle_view());
  EXPECT_THROW(hash.update(std::vector<float>(6, 0.0f)), Error);
  ClosestHits hits;
  EXPECT_THROW(hash.closest_points(std::vector<float>{0.0f, NAN, 0.0f}, 1.0f, hits), Error);
}

} // namespace
} // namespace vfit
