// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/proximity.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/pseudo_normals.h"

namespace vfit {
namespace {

// The BVH and the brute-force paths evaluate the same float expression per triangle, so they
// can differ only when Embree's float box test leaves out a triangle tied with the winner to
// within rounding: a few ulps of the coordinates (ulp(2 m) = 2.4e-7 m). Against a double
// recomputation, a float distance also carries a few ulps of itself (3 × 1.2e-7 relative):
// ~2e-6 m for the far queries, 20 m out.
constexpr float DISTANCE_TOLERANCE = 1e-6f;
double distance_tolerance(double distance) { return DISTANCE_TOLERANCE + 4e-7 * distance; }
// Below this distance the side is not compared: at ~2 m coordinates the closest point carries
// ~1e-7 m of rounding, which at 1e-5 m tilts query − point by under 1°, far inside the margin
// of the pseudo-normal test; nearer than that the input floats do not decide the side.
constexpr float SIGN_THRESHOLD = 1e-5f;

using Vec3 = std::array<double, 3>;

Vec3 position(const Mesh& m, std::int32_t v) {
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}
Vec3 row3(std::span<const float> a, std::size_t i) { return {a[3 * i], a[3 * i + 1], a[3 * i + 2]}; }
Vec3 sub(Vec3 a, Vec3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(Vec3 a, Vec3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(Vec3 a, Vec3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
double norm(Vec3 a) { return std::sqrt(dot(a, a)); }

// Generalized winding number (Jacobson, Kavan & Sorkine-Hornung 2013): Σ solid angles / 4π,
// each by Van Oosterom & Strackee's formula, in double. 1 inside a closed outward mesh, 0 out.
double winding_number(const Mesh& m, Vec3 q) {
  double sum = 0.0;
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    const Vec3 a = sub(position(m, m.triangles[3 * f]), q), b = sub(position(m, m.triangles[3 * f + 1]), q),
               c = sub(position(m, m.triangles[3 * f + 2]), q);
    const double la = norm(a), lb = norm(b), lc = norm(c);
    sum += 2.0 * std::atan2(dot(a, cross(b, c)), la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb);
  }
  return sum / (4.0 * std::numbers::pi);
}

// Query points of every kind the engine meets, from a fixed seed: anywhere in and around the
// bounding box, far away, exactly on vertices and edges, near the surface on both sides, and
// within 1e-4 m of edges and vertices (where a plain face normal gives the wrong side).
std::vector<float> make_queries(const Mesh& m, std::size_t per_kind, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss;
  Vec3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(m.positions[3 * v + k]));
      hi[k] = std::max(hi[k], double(m.positions[3 * v + k]));
    }
  auto in_box = [&](double grow) {
    Vec3 p;
    for (int k = 0; k < 3; ++k) {
      const double mid = 0.5 * (lo[k] + hi[k]), half = 0.5 * (hi[k] - lo[k]) * grow;
      p[k] = mid + (2.0 * unit(rng) - 1.0) * half;
    }
    return p;
  };
  auto direction = [&] {
    Vec3 d{gauss(rng), gauss(rng), gauss(rng)};
    const double l = norm(d);
    return Vec3{d[0] / l, d[1] / l, d[2] / l};
  };
  auto corner = [&](std::size_t f, int k) { return position(m, m.triangles[3 * f + k % 3]); };
  auto random_face = [&] { return std::size_t(unit(rng) * double(m.face_count())) % m.face_count(); };
  auto log_uniform = [&](double a, double b) { return a * std::pow(b / a, unit(rng)); };
  std::vector<float> q;
  auto push = [&](Vec3 p, Vec3 d, double r) {
    for (int k = 0; k < 3; ++k)
      q.push_back(float(p[k] + r * d[k]));
  };
  for (std::size_t i = 0; i < per_kind; ++i) {
    push(in_box(1.4), {}, 0.0);
    push(in_box(10.0), {}, 0.0);
    const std::size_t f = random_face();
    const int k = int(unit(rng) * 3.0) % 3;
    push(corner(f, k), {}, 0.0);
    const double t = unit(rng), s = unit(rng) * (1.0 - t);
    const Vec3 a = corner(f, k), b = corner(f, k + 1), c = corner(f, k + 2);
    const Vec3 on_edge{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
    push(on_edge, {}, 0.0);
    const Vec3 inner{a[0] + t * (b[0] - a[0]) + s * (c[0] - a[0]), a[1] + t * (b[1] - a[1]) + s * (c[1] - a[1]),
                     a[2] + t * (b[2] - a[2]) + s * (c[2] - a[2])};
    push(inner, direction(), log_uniform(1e-4, 1e-2));
    push(on_edge, direction(), log_uniform(2e-5, 1e-4));
    push(a, direction(), log_uniform(2e-5, 1e-4));
  }
  return q;
}

struct MeshCase {
  std::string name;
  std::function<const Mesh&()> mesh;
};

const Mesh& sphere_mesh() {
  static const Mesh m = make_uv_sphere(24, 48, 1.0f);
  return m;
}

// A regular tetrahedron: its dihedral angle (70.5°) puts adjacent face normals 109.5° apart,
// so near an edge or a vertex the face normal of the reported triangle often has the wrong sign.
const Mesh& tetrahedron_mesh() {
  static const Mesh m = [] {
    Mesh t;
    t.positions = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
    t.triangles = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
    return t;
  }();
  return m;
}

const Mesh& mannequin_mesh() {
  static const Mesh m = make_mannequin(MannequinOptions{}).mesh;
  return m;
}

class ProximityMesh : public ::testing::TestWithParam<MeshCase> {};

// Asserts that `got` answers every query as `ref` does (see DISTANCE_TOLERANCE); returns how
// many queries the two attribute to different (equally close) triangles.
std::size_t expect_same_hits(std::span<const float> queries, const ClosestHits& got, const ClosestHits& ref) {
  EXPECT_EQ(got.size(), ref.size());
  std::size_t ties = 0;
  for (std::size_t i = 0; i < std::min(got.size(), ref.size()); ++i) {
    SCOPED_TRACE("query " + std::to_string(i));
    EXPECT_EQ(got.triangles[i] < 0, ref.triangles[i] < 0);
    if (got.triangles[i] < 0 || ref.triangles[i] < 0) continue;
    const float dg = got.signed_distances[i], dr = ref.signed_distances[i];
    EXPECT_NEAR(std::abs(dg), std::abs(dr), DISTANCE_TOLERANCE);
    EXPECT_NEAR(norm(sub(row3(got.points, i), row3(queries, i))), std::abs(dg), distance_tolerance(std::abs(dg)));
    if (std::abs(dr) > SIGN_THRESHOLD) {
      EXPECT_EQ(dg < 0, dr < 0);
    }
    if (got.triangles[i] == ref.triangles[i]) {
      // Same triangle, same float expression: the same bits.
      EXPECT_EQ(got.features[i], ref.features[i]);
      EXPECT_EQ(got.barycentrics[2 * i], ref.barycentrics[2 * i]);
      EXPECT_EQ(got.barycentrics[2 * i + 1], ref.barycentrics[2 * i + 1]);
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(got.points[3 * i + k], ref.points[3 * i + k]);
    } else {
      // Random queries tie between triangles only at a shared edge or vertex: the same point.
      ++ties;
      EXPECT_LT(norm(sub(row3(got.points, i), row3(ref.points, i))), 10 * DISTANCE_TOLERANCE);
    }
  }
  return ties;
}

TEST_P(ProximityMesh, ClosestPointsEqualBruteForce) {
  const Mesh& m = GetParam().mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 150, 11u);
  ClosestHits bvh, brute;
  index.closest_points(q, std::numeric_limits<float>::infinity(), bvh);
  index.closest_points_brute_force(q, std::numeric_limits<float>::infinity(), brute);
  const std::size_t ties = expect_same_hits(q, bvh, brute);
  EXPECT_LT(ties, bvh.size() / 20) << "ties should be rare: only where several triangles share the point";
  for (std::int32_t t : bvh.triangles)
    ASSERT_GE(t, 0) << "an unlimited query always hits";
}

TEST_P(ProximityMesh, TbbEqualsSerialBitForBit) {
  const Mesh& m = GetParam().mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 400, 12u);
  ClosestHits par, ser;
  index.closest_points(q, 0.5f, par);
  index.closest_points_serial(q, 0.5f, ser);
  EXPECT_EQ(par.triangles, ser.triangles);
  EXPECT_EQ(par.points, ser.points);
  EXPECT_EQ(par.barycentrics, ser.barycentrics);
  EXPECT_EQ(par.signed_distances, ser.signed_distances);
  EXPECT_EQ(par.features, ser.features);
}

TEST_P(ProximityMesh, BarycentricsAndFeatureDescribeThePoint) {
  const Mesh& m = GetParam().mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 100, 13u);
  ClosestHits h;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  for (std::size_t i = 0; i < h.size(); ++i) {
    const std::int32_t* t = &m.triangles[3 * std::size_t(h.triangles[i])];
    const double u = h.barycentrics[2 * i], v = h.barycentrics[2 * i + 1], w = 1.0 - u - v;
    Vec3 p;
    for (int k = 0; k < 3; ++k)
      p[k] = w * position(m, t[0])[k] + u * position(m, t[1])[k] + v * position(m, t[2])[k];
    // A few ulps of metre-scale coordinates, as for the distances.
    EXPECT_LT(norm(sub(p, row3(h.points, i))), DISTANCE_TOLERANCE) << "query " << i;
    const auto feature = TriangleFeature(h.features[i]);
    // A query on an edge may be classified FACE with w rounded to 0: the closure is in float.
    const bool bary_ok = feature == TriangleFeature::FACE       ? u >= 0 && v >= 0 && w >= -1e-6
                         : feature == TriangleFeature::EDGE_0   ? v == 0 && u > 0 && u < 1
                         : feature == TriangleFeature::EDGE_1   ? u > 0 && v > 0
                         : feature == TriangleFeature::EDGE_2   ? u == 0 && v > 0 && v < 1
                         : feature == TriangleFeature::VERTEX_0 ? u == 0 && v == 0
                         : feature == TriangleFeature::VERTEX_1 ? u == 1 && v == 0
                                                                : u == 0 && v == 1;
    EXPECT_TRUE(bary_ok) << "query " << i << " feature " << int(h.features[i]) << " (u, v) = " << u << ", " << v;
  }
}

TEST_P(ProximityMesh, SideAgreesWithWindingNumber) {
  const Mesh& m = GetParam().mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 60, 14u);
  ClosestHits h;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  std::size_t compared = 0, naive_wrong = 0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    if (std::abs(h.signed_distances[i]) <= SIGN_THRESHOLD) continue;
    const double w = winding_number(m, row3(q, i));
    // A closed mesh: w is 0 or 1 up to rounding, so 1e-6 is a loose check of closedness.
    ASSERT_NEAR(w, std::round(w), 1e-6) << "query " << i << ": mesh not closed?";
    const bool inside = w > 0.5;
    ++compared;
    EXPECT_EQ(h.signed_distances[i] < 0, inside) << "query " << i << " feature " << int(h.features[i]);
    const std::int32_t* t = &m.triangles[3 * std::size_t(h.triangles[i])];
    const Vec3 n = cross(sub(position(m, t[1]), position(m, t[0])), sub(position(m, t[2]), position(m, t[0])));
    naive_wrong += (dot(sub(row3(q, i), row3(h.points, i)), n) < 0) != inside;
  }
  EXPECT_GT(compared, q.size() / 3 / 2) << "too few queries off the surface to test the side";
  if (GetParam().name == "tetrahedron") {
    EXPECT_GT(naive_wrong, 0u) << "the queries must probe where face normals fail";
  }
}

INSTANTIATE_TEST_SUITE_P(Proximity, ProximityMesh,
                         ::testing::Values(MeshCase{"sphere", sphere_mesh}, MeshCase{"tetrahedron", tetrahedron_mesh},
                                           MeshCase{"mannequin", mannequin_mesh}),
                         [](const ::testing::TestParamInfo<MeshCase>& p) { return p.param.name; });

// A smooth, non-uniform deformation of the sphere (still closed and embedded): a different
// closest triangle for most queries, so a stale BVH or stale pseudo-normals would show.
std::vector<float> deformed_sphere_positions() {
  std::vector<float> p = sphere_mesh().positions;
  for (std::size_t v = 0; v < p.size() / 3; ++v) {
    float& x = p[3 * v];
    float& y = p[3 * v + 1];
    float& z = p[3 * v + 2];
    const float bump = 1.0f + 0.2f * std::sin(3.0f * x) * std::cos(2.0f * y);
    x = 1.5f * x * bump + 0.3f;
    y = 0.7f * y * bump - 0.2f;
    z = z * bump + 0.1f;
  }
  return p;
}

TEST(ProximityRefit, RefitAnswersAsAFreshIndex) {
  const Mesh& m = sphere_mesh();
  ProximityIndex refitted(m.position_view(), m.triangle_view());
  Mesh moved = m;
  moved.positions = deformed_sphere_positions();
  const std::vector<float> q = make_queries(moved, 150, 21u);
  ClosestHits before;
  refitted.closest_points(q, std::numeric_limits<float>::infinity(), before);
  refitted.refit(moved.positions);
  const ProximityIndex fresh(moved.position_view(), moved.triangle_view());
  ClosestHits after, expected, brute;
  refitted.closest_points(q, std::numeric_limits<float>::infinity(), after);
  fresh.closest_points(q, std::numeric_limits<float>::infinity(), expected);
  fresh.closest_points_brute_force(q, std::numeric_limits<float>::infinity(), brute);
  expect_same_hits(q, after, expected);
  expect_same_hits(q, after, brute);
  std::size_t changed = 0;
  for (std::size_t i = 0; i < q.size() / 3; ++i)
    changed += before.signed_distances[i] != after.signed_distances[i];
  EXPECT_GT(changed, q.size() / 3 / 2) << "the deformation must change the answers for the test to mean anything";
  // Pseudo-normals follow the vertices: the side still agrees with the winding number.
  for (std::size_t i = 0; i < after.size(); ++i) {
    if (std::abs(after.signed_distances[i]) <= SIGN_THRESHOLD) continue;
    EXPECT_EQ(after.signed_distances[i]<0, winding_number(moved, row3(q, i))> 0.5) << "query " << i;
  }
}

TEST(ProximityRadius, NoHitBeyondMaxDistance) {
  const Mesh& m = sphere_mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  // On the unit sphere's inscribed polyhedron, a point at radius r is between r − 1 and
  // r − cos(7.5°) ≈ r − 0.991 from the mesh: 1.2 hits within 0.25, 1.5 and 3 do not.
  std::vector<float> q;
  std::mt19937 rng(5u);
  std::normal_distribution<float> gauss;
  for (int i = 0; i < 300; ++i) {
    float d[3] = {gauss(rng), gauss(rng), gauss(rng)};
    const float l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const float r = i % 3 == 0 ? 1.2f : i % 3 == 1 ? 1.5f : 3.0f;
    for (float c : d)
      q.push_back(c / l * r);
  }
  ClosestHits h, brute;
  index.closest_points(q, 0.25f, h);
  index.closest_points_brute_force(q, 0.25f, brute);
  expect_same_hits(q, h, brute);
  for (std::size_t i = 0; i < h.size(); ++i) {
    SCOPED_TRACE("query " + std::to_string(i));
    if (i % 3 == 0) {
      EXPECT_GE(h.triangles[i], 0);
      EXPECT_LE(h.signed_distances[i], 0.25f);
      EXPECT_GT(h.signed_distances[i], 0.0f);
      continue;
    }
    EXPECT_EQ(h.triangles[i], -1);
    EXPECT_EQ(h.features[i], std::int8_t(TriangleFeature::NONE));
    EXPECT_EQ(h.signed_distances[i], std::numeric_limits<float>::infinity());
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(h.points[3 * i + k], q[3 * i + k]);
  }
}

// The per-query radius overload: equal radii answer as the scalar form, bit for bit; a radius
// below a query's distance hides the mesh from that query only; bad radii are refused.
TEST(ProximityRadius, PerQueryRadiiActAsTheScalarRadius) {
  const Mesh& m = sphere_mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 100, 15u);
  const std::size_t n = q.size() / 3;
  ClosestHits scalar, each;
  index.closest_points(q, 0.5f, scalar);
  index.closest_points(q, std::vector<float>(n, 0.5f), each);
  EXPECT_EQ(each.triangles, scalar.triangles);
  EXPECT_EQ(each.points, scalar.points);
  EXPECT_EQ(each.signed_distances, scalar.signed_distances);
  EXPECT_EQ(each.features, scalar.features);
  // Query i gets a radius just above its distance when i is even, half of it when odd.
  std::vector<float> radii(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float d = scalar.triangles[i] >= 0 ? std::abs(scalar.signed_distances[i]) : 1.0f;
    radii[i] = i % 2 == 0 ? d * 1.001f + 1e-6f : 0.5f * d;
  }
  index.closest_points(q, radii, each);
  std::size_t hidden = 0;
  for (std::size_t i = 0; i < n; ++i) {
    SCOPED_TRACE("query " + std::to_string(i));
    if (i % 2 == 0 && scalar.triangles[i] >= 0) {
      EXPECT_GE(each.triangles[i], 0);
      EXPECT_NEAR(each.signed_distances[i], scalar.signed_distances[i], DISTANCE_TOLERANCE);
    }
    if (i % 2 == 1 && std::abs(scalar.signed_distances[i]) > SIGN_THRESHOLD) {
      EXPECT_EQ(each.triangles[i], -1);
      ++hidden;
    }
  }
  EXPECT_GT(hidden, n / 4);
  EXPECT_THROW(index.closest_points(q, std::vector<float>(n - 1, 0.5f), each), Error);
  radii.assign(n, 0.5f);
  radii[3] = -1.0f;
  EXPECT_THROW(index.closest_points(q, radii, each), Error);
  radii[3] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(index.closest_points(q, radii, each), Error);
}

// The warm re-query: points moved by up to 5 cm from where `hits` answered them get the same
// closest distances as a fresh unlimited query (to DISTANCE_TOLERANCE: ties may go to another
// triangle at the same distance); a row without a previous hit searches the whole mesh; a
// hits table of another size is refused.
TEST(ProximityRequery, AnswersAsAFreshQueryAfterASmallMove) {
  const Mesh& m = sphere_mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 200, 21u);
  const std::size_t n = q.size() / 3;
  ClosestHits warm, fresh;
  index.closest_points(q, 0.05f, warm); // far queries have no hit: they search without a limit
  std::mt19937 rng(22u);
  std::uniform_real_distribution<float> shift(-0.05f, 0.05f);
  std::vector<float> moved = q;
  for (float& x : moved)
    x += shift(rng);
  index.requery_closest_points(moved, INFINITY, warm);
  index.closest_points(moved, INFINITY, fresh);
  for (std::size_t i = 0; i < n; ++i) {
    SCOPED_TRACE("query " + std::to_string(i));
    ASSERT_GE(warm.triangles[i], 0);
    EXPECT_NEAR(warm.signed_distances[i], fresh.signed_distances[i],
                distance_tolerance(std::abs(fresh.signed_distances[i])));
  }
  ClosestHits other;
  index.closest_points(std::span<const float>(q).first(3 * (n - 1)), INFINITY, other);
  EXPECT_THROW(index.requery_closest_points(moved, INFINITY, other), Error);
}

TEST(ProximityEdgeCases, EmptyQuerySpanGivesEmptyHits) {
  const Mesh& m = sphere_mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  ClosestHits h;
  h.resize(7); // stale contents from an earlier call must go
  index.closest_points({}, 1.0f, h);
  EXPECT_EQ(h.size(), 0u);
  EXPECT_TRUE(h.points.empty() && h.barycentrics.empty() && h.signed_distances.empty() && h.features.empty());
  index.closest_points_serial({}, 1.0f, h);
  EXPECT_EQ(h.size(), 0u);
}

TEST(ProximityEdgeCases, EmptyMeshNeverHits) {
  const ProximityIndex index(std::span<const float>{}, std::span<const std::int32_t>{});
  const std::vector<float> q = {0, 0, 0, 1, 2, 3};
  ClosestHits h;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h.triangles[0], -1);
  EXPECT_EQ(h.triangles[1], -1);
}

TEST(ProximityEdgeCases, OneCallWrapperAnswersAsTheIndex) {
  const Mesh m = test::octahedron();
  const std::vector<float> q = make_queries(m, 20, 51u);
  ClosestHits once, indexed;
  closest_points(m.position_view(), m.triangle_view(), q, 0.3f, once);
  ProximityIndex(m.position_view(), m.triangle_view()).closest_points(q, 0.3f, indexed);
  EXPECT_EQ(once.triangles, indexed.triangles);
  EXPECT_EQ(once.signed_distances, indexed.signed_distances);
  EXPECT_NE(std::count(once.triangles.begin(), once.triangles.end(), -1), 0) << "far queries miss at 0.3 m";
}

TEST(ProximityEdgeCases, DegenerateTrianglesDoNotCrash) {
  Mesh m = test::octahedron();
  const std::int32_t base = std::int32_t(m.vertex_count());
  // A collinear triangle (a segment in the air), one with two coincident corners, and a point.
  m.positions.insert(m.positions.end(), {2, 0, 0, 3, 0, 0, 4, 0, 0, 0, 2, 0, 0, 3, 0, 0, 0, 3});
  m.triangles.insert(m.triangles.end(),
                     {base, base + 2, base + 1, base + 3, base + 4, base + 4, base + 5, base + 5, base + 5, 0, 0, 2});
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 100, 31u);
  ClosestHits h, brute;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  index.closest_points_brute_force(q, std::numeric_limits<float>::infinity(), brute);
  expect_same_hits(q, h, brute);
  for (std::size_t i = 0; i < h.size(); ++i) {
    EXPECT_TRUE(std::isfinite(h.signed_distances[i])) << "query " << i;
    EXPECT_TRUE(std::isfinite(h.barycentrics[2 * i]) && std::isfinite(h.barycentrics[2 * i + 1])) << "query " << i;
  }
  // The segment's middle is its own closest point, at distance 0, on an edge of its triangle.
  const std::vector<float> on_segment = {2.5f, 0.0f, 0.0f};
  index.closest_points(on_segment, 1.0f, h);
  EXPECT_EQ(h.triangles[0], std::int32_t(test::octahedron().face_count()));
  EXPECT_EQ(h.signed_distances[0], 0.0f);
}

TEST(ProximityCorpus, MakeHumanBodyAgreesWithBruteForceAndWindingNumber) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "corpus folder absent (set VFIT_CORPUS): no MakeHuman body to test";
  const auto path = *corpus / "makehuman" / "derived" / "hm08_body.obj";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " absent";
  Mesh m = read_mesh(path).mesh;
  scale_positions(m.positions, metres_per_unit(Units::DM)); // the corpus body is in decimetres
  const ProximityIndex index(m.position_view(), m.triangle_view());
  const std::vector<float> q = make_queries(m, 60, 41u);
  ClosestHits h, brute;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  index.closest_points_brute_force(q, std::numeric_limits<float>::infinity(), brute);
  expect_same_hits(q, h, brute);
  for (std::size_t i = 0; i < h.size(); ++i) {
    if (std::abs(h.signed_distances[i]) <= SIGN_THRESHOLD) continue;
    EXPECT_EQ(h.signed_distances[i]<0, winding_number(m, row3(q, i))> 0.5) << "query " << i;
  }
}

// A unit sphere with holes cut out, like a scan open at the neck, soles and eyes: three holes
// of angular radius 30° around ±axes 90° apart, and one of 10° (an "eye"). A triangle is
// removed when its centroid lies within a hole's cone.
struct Hole {
  Vec3 axis;    // unit
  double angle; // rad
};
const std::vector<Hole>& sphere_holes() {
  static const std::vector<Hole> holes = [] {
    const double s = 1.0 / std::sqrt(3.0), deg = std::numbers::pi / 180.0;
    return std::vector<Hole>{
        {{1, 0, 0}, 30 * deg}, {{0, 1, 0}, 30 * deg}, {{0, 0, -1}, 30 * deg}, {{-s, -s, s}, 10 * deg}};
  }();
  return holes;
}
const Mesh& holed_sphere_mesh() {
  static const Mesh holed = [] {
    Mesh m = sphere_mesh();
    std::vector<std::int32_t> kept;
    for (std::size_t f = 0; f < m.face_count(); ++f) {
      Vec3 c{0, 0, 0};
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j)
          c[j] += position(m, m.triangles[3 * f + k])[j] / 3.0;
      bool cut = false;
      for (const Hole& h : sphere_holes())
        cut |= dot(c, h.axis) / norm(c) > std::cos(h.angle);
      if (!cut) kept.insert(kept.end(), m.triangles.begin() + 3 * f, m.triangles.begin() + 3 * f + 3);
    }
    m.triangles = kept;
    m.uv_triangles.clear();
    m.uvs.clear();
    return m;
  }();
  return holed;
}

// Distance from q to the rim circle of a hole on the unit sphere.
double distance_to_rim(Vec3 q, const Hole& h) {
  const double height = dot(q, h.axis) - std::cos(h.angle);
  Vec3 radial = sub(q, {h.axis[0] * dot(q, h.axis), h.axis[1] * dot(q, h.axis), h.axis[2] * dot(q, h.axis)});
  return std::hypot(height, norm(radial) - std::sin(h.angle));
}

TEST(ProximityOpenMesh, ClosedMeshHasNoHolesAndNoWarning) {
  const ProximityIndex index(sphere_mesh().position_view(), sphere_mesh().triangle_view());
  EXPECT_EQ(index.hole_count(), 0u);
  EXPECT_TRUE(index.warning().empty());
}

TEST(ProximityOpenMesh, HolesAreFoundAndWarnedAbout) {
  const Mesh& m = holed_sphere_mesh();
  ASSERT_LT(m.face_count(), sphere_mesh().face_count());
  const ProximityIndex index(m.position_view(), m.triangle_view());
  EXPECT_EQ(index.hole_count(), sphere_holes().size());
  EXPECT_EQ(index.warning(), "the body has 4 holes; the side is decided as if they were closed");
  EXPECT_EQ(index.vertex_count(), m.vertex_count()) << "the cap centroids are internal";
  EXPECT_EQ(index.face_count(), m.face_count()) << "the cap triangles are internal";
  // The capped mesh is closed: every edge has two triangles.
  const ProximitySideMesh side = index.side_mesh();
  const MeshEdges edges = build_mesh_edges(side.triangles, side.positions.size() / 3);
  for (std::size_t e = 0; e < edges.edge_count(); ++e)
    EXPECT_EQ(edges.offsets[e + 1] - edges.offsets[e], 2) << e;
}

// Away from the rims (farther than the hole's radius), an open sphere answers inside/outside as
// the closed one does; the closest points never lie on a cap.
TEST(ProximityOpenMesh, SideAgreesWithClosedSphereAwayFromRims) {
  const Mesh& m = holed_sphere_mesh();
  const ProximityIndex open(m.position_view(), m.triangle_view());
  const ProximityIndex closed(sphere_mesh().position_view(), sphere_mesh().triangle_view());
  std::vector<float> q;
  std::mt19937 rng(71u);
  std::uniform_real_distribution<double> unit(-1.6, 1.6);
  while (q.size() < 3 * 3000) {
    const Vec3 p{unit(rng), unit(rng), unit(rng)};
    bool far = true;
    for (const Hole& h : sphere_holes())
      far &= distance_to_rim(p, h) > std::sin(h.angle);
    if (far) q.insert(q.end(), {float(p[0]), float(p[1]), float(p[2])});
  }
  ClosestHits h, expected, brute;
  open.closest_points(q, std::numeric_limits<float>::infinity(), h);
  open.closest_points_brute_force(q, std::numeric_limits<float>::infinity(), brute);
  closed.closest_points(q, std::numeric_limits<float>::infinity(), expected);
  expect_same_hits(q, h, brute);
  std::size_t inside = 0, through_hole = 0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    ASSERT_GE(h.triangles[i], 0);
    ASSERT_LT(std::size_t(h.triangles[i]), m.face_count());
    if (std::abs(expected.signed_distances[i]) <= SIGN_THRESHOLD) continue;
    EXPECT_EQ(h.signed_distances[i] < 0, expected.signed_distances[i] < 0) << "query " << i;
    inside += expected.signed_distances[i] < 0;
    through_hole += std::abs(h.signed_distances[i]) > std::abs(expected.signed_distances[i]) + 1e-4f;
  }
  EXPECT_GT(inside, 150u) << "both sides must be sampled"; // ~230 of 3000 land inside
  EXPECT_GT(through_hole, 30u) << "some queries must see the mesh only past a hole for the test to mean anything";
}

// Near a hole (inside its cone), points clearly inside (below the cap plane) and clearly
// outside (beyond the sphere) are still answered right, although the mesh nearest to them is
// the rim, whose one-sided pseudo-normal alone says "inside" for a point 1.1 out on the axis
// of a 30° hole (1.1·cos 30° < 1).
TEST(ProximityOpenMesh, SideIsRightNearTheHoles) {
  const Mesh& m = holed_sphere_mesh();
  const ProximityIndex index(m.position_view(), m.triangle_view());
  std::mt19937 rng(72u);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<float> q;
  std::vector<char> truly_inside;
  for (const Hole& h : sphere_holes()) {
    // An orthonormal frame around the axis, to sample directions within 0.9 of the cone.
    Vec3 t = std::abs(h.axis[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    t = cross(h.axis, t);
    t = {t[0] / norm(t), t[1] / norm(t), t[2] / norm(t)};
    const Vec3 b = cross(h.axis, t);
    for (int i = 0; i < 200; ++i) {
      const double a = 0.9 * h.angle * std::sqrt(unit(rng)), phi = 2 * std::numbers::pi * unit(rng);
      Vec3 d;
      for (int k = 0; k < 3; ++k)
        d[k] = std::cos(a) * h.axis[k] + std::sin(a) * (std::cos(phi) * t[k] + std::sin(phi) * b[k]);
      // Inside: below the cap plane: the rim is jagged by up to a triangle (7.5°), so 0.85 of cos(hole angle).
      const bool in = i % 2 == 0;
      const double r = in ? (0.2 + 0.75 * unit(rng)) * 0.85 * std::cos(h.angle) / std::cos(a) : 1.05 + unit(rng);
      for (int k = 0; k < 3; ++k)
        q.push_back(float(r * d[k]));
      truly_inside.push_back(in);
    }
  }
  ClosestHits h;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  for (std::size_t i = 0; i < h.size(); ++i)
    EXPECT_EQ(h.signed_distances[i] < 0, bool(truly_inside[i]))
        << "query " << i << " at " << q[3 * i] << ", " << q[3 * i + 1] << ", " << q[3 * i + 2];
}

// A sheet keeps its one-sided pseudo-normals: no caps, no warning, and a point 1.1 out on the
// axis of a 30° hole reads "inside" (its nearest feature is the rim, whose normal tilts away).
TEST(ProximityOpenMesh, OneSidedOptionLeavesTheHolesOpen) {
  const Mesh& m = holed_sphere_mesh();
  const ProximityIndex sheet(m.position_view(), m.triangle_view(), OpenMeshSide::ONE_SIDED);
  const ProximityIndex capped(m.position_view(), m.triangle_view());
  EXPECT_EQ(sheet.hole_count(), sphere_holes().size());
  EXPECT_TRUE(sheet.warning().empty());
  EXPECT_EQ(sheet.side_mesh().triangles.size(), m.triangles.size());
  const std::vector<float> q = {1.1f, 0.0f, 0.0f};
  ClosestHits one_sided, closed;
  sheet.closest_points(q, std::numeric_limits<float>::infinity(), one_sided);
  capped.closest_points(q, std::numeric_limits<float>::infinity(), closed);
  EXPECT_EQ(std::abs(one_sided.signed_distances[0]), std::abs(closed.signed_distances[0])) << "same mesh distance";
  EXPECT_LT(one_sided.signed_distances[0], 0.0f);
  EXPECT_GT(closed.signed_distances[0], 0.0f);
}

TEST(ProximityOpenMesh, RefitMovesTheCaps) {
  Mesh moved = holed_sphere_mesh();
  ProximityIndex refitted(moved.position_view(), moved.triangle_view());
  for (std::size_t i = 0; i < moved.positions.size(); ++i)
    moved.positions[i] = 1.3f * moved.positions[i] + 0.2f;
  refitted.refit(moved.positions);
  const ProximityIndex fresh(moved.position_view(), moved.triangle_view());
  const std::vector<float> q = make_queries(moved, 150, 73u);
  ClosestHits after, expected;
  refitted.closest_points(q, std::numeric_limits<float>::infinity(), after);
  fresh.closest_points(q, std::numeric_limits<float>::infinity(), expected);
  EXPECT_EQ(after.triangles, expected.triangles);
  EXPECT_EQ(after.signed_distances, expected.signed_distances);
}

// Segments against the BVH's ray casts and a brute-force Möller–Trumbore in double: random
// segments around the mesh (1-60 cm long, so some cross it twice, some stop short, some start
// inside) meet the same face at the same t; near a shared edge the two may pick either face
// (Embree's watertight test against an interval test in double), which then meet at the same
// point. t agrees to 1e-5 of the segment (float ray math on coordinates of order 1). A segment
// entering the closed mesh has (b − a)·n < 0, one leaving it (b − a)·n > 0.
void expect_same_segment_hits(const Mesh& m, std::uint32_t seed) {
  const ProximityIndex index(m.position_view(), m.triangle_view());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> box(-1.3f, 1.3f), length(0.01f, 0.6f);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::vector<float> from, to;
  for (int i = 0; i < 3000; ++i) {
    float d[3] = {gauss(rng), gauss(rng), gauss(rng)};
    const float n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), l = length(rng);
    for (int k = 0; k < 3; ++k) {
      const float a = box(rng);
      from.push_back(a);
      to.push_back(a + l * d[k] / n);
    }
  }
  SegmentHits got, ref;
  index.first_hits(from, to, got);
  index.first_hits_brute_force(from, to, ref);
  ASSERT_EQ(got.size(), 3000u);
  int met = 0, entering = 0, leaving = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE("segment " + std::to_string(i));
    ASSERT_EQ(got.triangles[i] == -1, ref.triangles[i] == -1);
    if (got.triangles[i] == -1) {
      EXPECT_EQ(got.t[i], INFINITY);
      continue;
    }
    ++met;
    EXPECT_NEAR(got.t[i], ref.t[i], 1e-5f);
    const float dir[3] = {to[3 * i] - from[3 * i], to[3 * i + 1] - from[3 * i + 1], to[3 * i + 2] - from[3 * i + 2]};
    const float dn = dir[0] * got.normals[3 * i] + dir[1] * got.normals[3 * i + 1] + dir[2] * got.normals[3 * i + 2];
    (dn < 0 ? entering : leaving) += 1;
    if (got.triangles[i] == ref.triangles[i]) {
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(got.normals[3 * i + k], ref.normals[3 * i + k]);
    }
  }
  EXPECT_GT(met, 300);
  EXPECT_GT(entering, 100);
  EXPECT_GT(leaving, 100);
}

TEST(ProximitySegments, FirstHitsEqualBruteForce) {
  expect_same_segment_hits(sphere_mesh(), 11u);
  expect_same_segment_hits(tetrahedron_mesh(), 12u);
}

// Into a closed sphere from outside: the face met is the near one, its normal against the
// segment; from the centre outwards: the normal along it; a segment ending short of the
// surface, or of zero length, meets nothing. Through a hole of an open mesh, the cap is met
// (triangle −2), as the side test sees it.
TEST(ProximitySegments, EntryExitMissAndCaps) {
  const ProximityIndex closed(sphere_mesh().position_view(), sphere_mesh().triangle_view());
  SegmentHits h;
  closed.first_hits(std::vector<float>{0, 2, 0, 0, 0, 0, 0, 0.5f, 0, 0.3f, 0.3f, 0.3f},
                    std::vector<float>{0, 0, 0, 0, 0, 2, 0, 0.9f, 0, 0.3f, 0.3f, 0.3f}, h);
  ASSERT_EQ(h.size(), 4u);
  EXPECT_GE(h.triangles[0], 0);
  EXPECT_NEAR(h.t[0], 0.5f, 1e-3f); // y = 2 → 0 meets the unit sphere at y ≈ 1 (a polygon's pole: exact)
  EXPECT_GT(h.normals[1], 0.99f);   // met from above: the outward normal points up, the segment down
  EXPECT_GE(h.triangles[1], 0);
  EXPECT_NEAR(h.t[1], 0.5f, 0.01f); // the facets sit within 1 % of the unit radius
  EXPECT_GT(h.normals[5], 0.99f);   // leaving along +z
  EXPECT_EQ(h.triangles[2], -1);    // ends at 0.9, inside
  EXPECT_EQ(h.triangles[3], -1);    // zero length
  EXPECT_EQ(h.t[3], INFINITY);
  const Mesh& holed = holed_sphere_mesh();
  const ProximityIndex open(holed.position_view(), holed.triangle_view());
  const auto holes = sphere_holes();
  ASSERT_FALSE(holes.empty());
  const auto& c = holes[0].axis; // a hole's direction from the centre
  SegmentHits through;
  open.first_hits(std::vector<float>{0, 0, 0}, std::vector<float>{float(2 * c[0]), float(2 * c[1]), float(2 * c[2])},
                  through);
  EXPECT_EQ(through.triangles[0], -2) << "the cap of the hole";
  EXPECT_THROW(open.first_hits(std::vector<float>{0, 0, 0}, std::vector<float>{0, 0}, through), Error);
  EXPECT_THROW(open.first_hits(std::vector<float>{0, NAN, 0}, std::vector<float>{0, 0, 0}, through), Error);
}

TEST(ProximityBadInput, NonFiniteQueryIsAnError) {
  const ProximityIndex index(sphere_mesh().position_view(), sphere_mesh().triangle_view());
  ClosestHits h;
  for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    const std::vector<float> q = {0, 0, 0, 1, 2, 3, 0.5f, bad, 0};
    try {
      index.closest_points(q, 1.0f, h);
      ADD_FAILURE() << "no error for a non-finite query";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("query 2 has a non-finite coordinate"), std::string::npos) << e.what();
    }
    EXPECT_THROW(index.closest_points_serial(q, 1.0f, h), Error);
    EXPECT_THROW(index.closest_points_brute_force(q, 1.0f, h), Error);
  }
  const std::vector<float> ragged = {0, 0, 0, 1};
  EXPECT_THROW(index.closest_points(ragged, 1.0f, h), Error);
  const std::vector<float> fine = {0, 0, 0};
  EXPECT_THROW(index.closest_points(fine, std::numeric_limits<float>::quiet_NaN(), h), Error);
  EXPECT_THROW(index.closest_points(fine, -1.0f, h), Error);
}

TEST(ProximityBadInput, BadMeshIsAnError) {
  Mesh m = test::octahedron();
  m.positions[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(ProximityIndex(m.position_view(), m.triangle_view()), Error);
  m = test::octahedron();
  m.triangles[5] = std::int32_t(m.vertex_count());
  try {
    ProximityIndex index(m.position_view(), m.triangle_view());
    ADD_FAILURE() << "no error for an index out of range";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 1"), std::string::npos) << e.what();
  }
  ProximityIndex index(test::octahedron().position_view(), test::octahedron().triangle_view());
  const std::vector<float> short_positions = {0, 0, 0};
  EXPECT_THROW(index.refit(short_positions), Error);
}

} // namespace
} // namespace vfit

namespace vfit {
namespace {

// Points within 2 cm of a body, the band where garment vertices live: a uniform point of a
// random triangle moved by up to 2 cm in a random direction; `shoulder_share` of them are drawn
// from triangles above `shoulder_height` (m), where the arms meet the torso.
std::vector<float> near_surface_queries(const Mesh& m, std::size_t count, double shoulder_share, double shoulder_height,
                                        unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss;
  std::vector<std::size_t> high;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    if (position(m, m.triangles[3 * f])[1] > shoulder_height) high.push_back(f);
  std::vector<float> q;
  for (std::size_t i = 0; i < count; ++i) {
    const bool shoulder = !high.empty() && unit(rng) < shoulder_share;
    const std::size_t f = shoulder ? high[std::size_t(unit(rng) * double(high.size())) % high.size()]
                                   : std::size_t(unit(rng) * double(m.face_count())) % m.face_count();
    double t = unit(rng), s = unit(rng);
    if (t + s > 1.0) t = 1.0 - t, s = 1.0 - s;
    const Vec3 a = position(m, m.triangles[3 * f]), b = position(m, m.triangles[3 * f + 1]),
               c = position(m, m.triangles[3 * f + 2]);
    const Vec3 d{gauss(rng), gauss(rng), gauss(rng)};
    const double r = 0.02 * unit(rng) / norm(d);
    for (int k = 0; k < 3; ++k)
      q.push_back(float(a[k] + t * (b[k] - a[k]) + s * (c[k] - a[k]) + r * d[k]));
  }
  return q;
}

struct SideCheck {
  std::size_t compared = 0, mismatches = 0, explained = 0;
};

// Compares the side of every query farther than SIGN_THRESHOLD from `m` with the winding number.
// A mismatch is `explained` when the mesh overlaps itself there: the winding number 1e-4 m
// behind the closest triangle is not 1 (e.g. 2: the closest surface lies inside another part of
// the body) or 1e-4 m in front of it is not 0 (a fold), where no surface-local side test
// (pseudo-normal or face normal) can know the side.
SideCheck check_side_near_surface(const Mesh& m, std::span<const float> q) {
  const ProximityIndex index(m.position_view(), m.triangle_view());
  ClosestHits h;
  index.closest_points(q, std::numeric_limits<float>::infinity(), h);
  SideCheck r;
  for (std::size_t i = 0; i < h.size(); ++i) {
    if (std::abs(h.signed_distances[i]) <= SIGN_THRESHOLD) continue;
    const double w = winding_number(m, row3(q, i));
    ++r.compared;
    if ((h.signed_distances[i] < 0) == (w > 0.5)) continue;
    ++r.mismatches;
    const std::int32_t* t = &m.triangles[3 * std::size_t(h.triangles[i])];
    const Vec3 n = cross(sub(position(m, t[1]), position(m, t[0])), sub(position(m, t[2]), position(m, t[0])));
    Vec3 behind = row3(h.points, i), front = behind;
    for (int k = 0; k < 3; ++k) {
      behind[k] -= 1e-4 * n[k] / norm(n);
      front[k] += 1e-4 * n[k] / norm(n);
    }
    // Embedded, the mesh has winding number 1 just behind its surface and 0 just in front.
    const bool overlap = std::abs(winding_number(m, behind) - 1.0) > 0.5 || std::abs(winding_number(m, front)) > 0.5;
    r.explained += overlap;
    if (!overlap)
      ADD_FAILURE() << "query " << i << " signed distance " << h.signed_distances[i] << " winding number " << w
                    << " feature " << int(h.features[i]) << " triangle " << h.triangles[i];
  }
  return r;
}

// Regression for "the side flips for points ~5 mm from the surface near the shoulders": on the
// embedded A-pose mannequin the side agrees with the winding number for every query in the
// 2 cm band (hunt: 0 mismatches in 18,000 queries over 7k and 3k
// vertex A-pose and a 5k vertex T-pose mannequin, and in 15,000 more, 90 % at the shoulders, on
// the 7k A-pose one).
TEST(ProximityBody, SideAgreesWithWindingNumberNearTheSurface) {
  const Mesh& m = mannequin_mesh();
  const std::vector<float> q = near_surface_queries(m, 1000, 0.5, 1.2, 21u);
  const SideCheck r = check_side_near_surface(m, q);
  EXPECT_GT(r.compared, q.size() / 3 * 9 / 10);
  EXPECT_EQ(r.mismatches, 0u);
}

// The reported flips are posed bodies that overlap themselves: "demo" (arms down) pushes the
// upper arm into the torso at the shoulder, and a query inside the torso whose closest surface
// is the buried arm skin is outside that skin. Every mismatch must be of that kind.
TEST(ProximityBody, PosedBodyMismatchesAreSelfOverlapOnly) {
  MannequinOptions o;
  o.target_vertices = 4000;
  const Body rest = make_mannequin(o);
  // The named poses share an arm's lowering between collar and shoulder (pose_io.cpp), which
  // keeps the arms out of the torso: no mismatch at all.
  const Mesh demo = pose_body(rest, named_pose("demo", RestPose::APOSE)).mesh;
  const SideCheck named = check_side_near_surface(demo, near_surface_queries(demo, 1000, 0.8, 1.2, 22u));
  EXPECT_EQ(named.mismatches, 0u);
  // Arms lowered to 80° by the shoulders alone: the upper arms sink into the torso.
  Pose down;
  down.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0, 0, -35 * std::numbers::pi / 180;
  down.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) << 0, 0, 35 * std::numbers::pi / 180;
  const Mesh m = pose_body(rest, down).mesh;
  const std::vector<float> q = near_surface_queries(m, 1000, 0.8, 1.2, 22u);
  const SideCheck r = check_side_near_surface(m, q);
  EXPECT_EQ(r.explained, r.mismatches);
  EXPECT_GT(r.explained, 0u) << "this pose should overlap at the shoulders; if it stopped doing so, "
                                "this test no longer probes the overlap";
}

} // namespace
} // namespace vfit
