// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/layering.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

constexpr float PI = std::numbers::pi_v<float>;

// A closed cylinder along Y (radius r, from y0 to y0 + length), capped by two fans; outward.
Mesh closed_cylinder(float r, float y0, float length, int rings, int segments) {
  Mesh m = make_tube(rings, segments, r, length);
  m.uvs.clear();
  m.uv_triangles.clear();
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    m.positions[3 * v + 1] += y0;
  const auto bottom = std::int32_t(m.vertex_count()), top = bottom + 1;
  m.positions.insert(m.positions.end(), {0, y0, 0, 0, y0 + length, 0});
  const std::int32_t last = (rings - 1) * segments;
  for (std::int32_t j = 0; j < segments; ++j) {
    const std::int32_t k = (j + 1) % segments;
    m.triangles.insert(m.triangles.end(), {bottom, k, j});            // seen from below: −Y
    m.triangles.insert(m.triangles.end(), {top, last + j, last + k}); // seen from above: +Y
  }
  return m;
}

// A tube along Y with its axis at (x, z), from y0 to y0 + length.
Mesh tube_at(float r, float x, float y0, float length, int rings, int segments) {
  Mesh m = make_tube(rings, segments, r, length);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    m.positions[3 * v] += x;
    m.positions[3 * v + 1] += y0;
  }
  return m;
}

float radial(const Mesh& m, std::size_t v, float axis_x) {
  return std::hypot(m.positions[3 * v] - axis_x, m.positions[3 * v + 2]);
}

// Body: a cylinder of radius 10 cm. Inner garment: a tube of radius 11.5 cm around it (1.5 cm
// clear of the body). Outer garment: a tube of radius 12 cm whose axis is 1.2 cm off, so its
// −x side (10.8 cm from the body's axis) is 7 mm inside the inner tube, yet 8 mm outside the
// body: only layering can see that penetration.
constexpr float BODY_R = 0.10f, INNER_R = 0.115f, OUTER_R = 0.12f, OUTER_X = 0.012f;
constexpr int INNER_SEGMENTS = 48, OUTER_SEGMENTS = 40;

struct Scene {
  Mesh body = closed_cylinder(BODY_R, -0.2f, 1.0f, 21, 64);
  Mesh inner = tube_at(INNER_R, 0.0f, 0.0f, 0.6f, 25, INNER_SEGMENTS);
  Mesh outer = tube_at(OUTER_R, OUTER_X, 0.05f, 0.5f, 21, OUTER_SEGMENTS);
  ProximityIndex index{body.positions, body.triangles};
  EdgeCrossingIndex crossings{body.positions, body.triangles};
};

// A polygonal tube's surface is nowhere nearer its axis than r·cos(π / segments).
float inscribed(float r, int segments) { return r * std::cos(PI / float(segments)); }

TEST(Layering, OuterTubePushedIntoAnInnerTubeEndsOutsideBothInnerFirst) {
  Scene s;
  const Mesh inner_start = s.inner, outer_start = s.outer;
  Mesh* garments[] = {&s.inner, &s.outer};
  const auto reports = resolve_layers(garments, s.index, s.crossings);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].before.inside_count, 0u);
  EXPECT_EQ(reports[0].before.near_count, 0u);
  EXPECT_EQ(s.inner.positions, inner_start.positions) << "the inner garment had nothing to resolve";
  EXPECT_GT(reports[1].before.layer_inside_count, 20u);
  EXPECT_GT(reports[1].before.layer_max_depth, 0.005);
  EXPECT_EQ(reports[1].before.inside_count, 0u) << "the body alone sees nothing wrong";
  EXPECT_EQ(reports[1].after.layer_inside_count, 0u);
  EXPECT_EQ(reports[1].after.inside_count, 0u);
  EXPECT_EQ(reports[1].after.crossing_edges, 0u);
  // Oracle independent of the proximity index: every outer vertex is outside the inner tube's
  // polygon and the body (radial distance from the common axis).
  for (std::size_t v = 0; v < s.outer.vertex_count(); ++v) {
    EXPECT_GE(radial(s.outer, v, 0.0f), inscribed(INNER_R, INNER_SEGMENTS)) << v;
    EXPECT_GE(radial(s.outer, v, 0.0f), BODY_R) << v;
  }
  // The far (+x) side, 1.7 cm clear of the inner tube, moved by less than 2 mm.
  for (std::size_t v = 0; v < s.outer.vertex_count(); ++v) {
    if (outer_start.positions[3 * v] > OUTER_X + 0.5f * OUTER_R) {
      EXPECT_NEAR(s.outer.positions[3 * v], outer_start.positions[3 * v], 0.002f) << v;
    }
  }
  const double stretch = test::mean_edge_length_change(outer_start, s.outer);
  EXPECT_LT(stretch, 0.05); // a 7 mm dent on a 12 cm tube: a few per cent at most
  std::printf("outer in inner: %zu vertices inside, max %.1f mm -> %zu; %d rounds, edge change %.2f %%\n",
              reports[1].before.layer_inside_count, 1e3 * reports[1].before.layer_max_depth,
              reports[1].after.layer_inside_count, reports[1].iterations, 100 * stretch);
}

TEST(Layering, OrderMattersTheLaterGarmentEndsOutside) {
  Scene s;
  const Mesh outer_start = s.outer;
  Mesh* garments[] = {&s.outer, &s.inner}; // the wrong way round: the small tube goes on top
  const auto reports = resolve_layers(garments, s.index, s.crossings);
  EXPECT_EQ(s.outer.positions, outer_start.positions) << "listed first, it is resolved against the body only";
  EXPECT_GT(reports[1].before.layer_inside_count, 20u);
  EXPECT_EQ(reports[1].after.layer_inside_count, 0u);
  // Now the small tube bulges out around the off-centre big one on its +x side.
  float max_r = 0;
  for (std::size_t v = 0; v < s.inner.vertex_count(); ++v) {
    const float y = s.inner.positions[3 * v + 1];
    if (y > 0.07f && y < 0.53f) { // away from the big tube's rims, where its boundary rule applies
      EXPECT_GE(radial(s.inner, v, OUTER_X), inscribed(OUTER_R, OUTER_SEGMENTS)) << v;
    }
    max_r = std::max(max_r, radial(s.inner, v, 0.0f));
  }
  EXPECT_GT(max_r, INNER_R + 0.01f);
}

// A garment whose vertices are all outside the inner layer can still have the layer poking out
// through one of its triangles (trousers' waistband through a settled tee): one inner-tube
// vertex pushed out through the middle of a coarse outer tube's triangle.
TEST(Layering, AnInnerVertexPokingThroughAnOuterTriangleIsFoundAndPushedOut) {
  Scene s;
  constexpr float COARSE_R = 0.125f; // faces at least 12.26 cm from the axis, 7.6 mm off the inner tube
  Mesh outer = tube_at(COARSE_R, 0.0f, 0.05f, 0.5f, 7, 16);
  // The outer triangle nearest mid-height, and the inner vertex nearest its centroid's direction.
  float best = INFINITY;
  Eigen::Vector3f centroid;
  for (std::size_t f = 0; f < outer.face_count(); ++f) {
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (int k = 0; k < 3; ++k)
      c += Eigen::Vector3f::Map(&outer.positions[3 * std::size_t(outer.triangles[3 * f + std::size_t(k)])]) / 3.0f;
    if (std::fabs(c.y() - 0.3f) < best) {
      best = std::fabs(c.y() - 0.3f);
      centroid = c;
    }
  }
  std::size_t bump = 0;
  float nearest = INFINITY;
  for (std::size_t v = 0; v < s.inner.vertex_count(); ++v) {
    const Eigen::Vector3f p = Eigen::Vector3f::Map(&s.inner.positions[3 * v]);
    const float d = (p.normalized() - centroid.normalized()).norm() + std::fabs(p.y() - centroid.y());
    if (d < nearest) {
      nearest = d;
      bump = v;
    }
  }
  // Out to 13.2 cm, past the outer face (about 12.3 cm there) by some 9 mm.
  const float scale = 0.132f / radial(s.inner, bump, 0.0f);
  s.inner.positions[3 * bump] *= scale;
  s.inner.positions[3 * bump + 2] *= scale;
  const InnerLayer layer(s.inner, s.index, 0.003, 0.05);
  const LayerObstacle layers[] = {layer.obstacle()};
  const std::vector<std::int32_t> inner_edges = mesh_edge_endpoints(s.inner.triangles, s.inner.vertex_count());
  auto brute_force_crossings = [&](const Mesh& m) { // oracle: every inner edge against every outer triangle
    const EdgeCrossingIndex outer_index(m.positions, m.triangles);
    SegmentCrossings c;
    outer_index.first_crossings_brute_force(s.inner.positions, inner_edges, c);
    return c.crossing_count();
  };
  const std::size_t crossing_before = brute_force_crossings(outer);
  ASSERT_GE(crossing_before, 3u) << "the bumped vertex's edges cross the outer face";

  const PenetrationStats before = measure_penetration(outer, s.index, s.crossings, layers, 0.003);
  EXPECT_EQ(before.layer_inside_count, 0u) << "no outer vertex is inside the inner tube";
  EXPECT_EQ(before.layer_crossing_edges, crossing_before);

  const Mesh start = outer;
  const PenetrationReport r = remove_penetration(outer, s.index, s.crossings, layers);
  EXPECT_EQ(r.before.layer_crossing_edges, crossing_before);
  EXPECT_EQ(r.after.layer_crossing_edges, 0u);
  EXPECT_EQ(r.after.layer_inside_count, 0u);
  EXPECT_EQ(r.after.inside_count, 0u);
  EXPECT_EQ(brute_force_crossings(outer), 0u);
  // Only the pierced spot moved: the tube's other side kept its place.
  for (std::size_t v = 0; v < outer.vertex_count(); ++v)
    if (Eigen::Vector3f::Map(&start.positions[3 * v]).dot(centroid) < 0) {
      EXPECT_EQ(outer.positions[3 * v], start.positions[3 * v]) << v;
    }
  std::printf("inner vertex through an outer triangle: %zu crossing edges -> %zu in %d rounds, edge change %.2f %%\n",
              r.before.layer_crossing_edges, r.after.layer_crossing_edges, r.iterations,
              100 * test::mean_edge_length_change(start, outer));
}

TEST(Layering, InnerLayerOrientsAwayFromTheBodyAndSkipsItsOpenings) {
  Scene s;
  Mesh reversed = s.inner;
  for (std::size_t f = 0; f < reversed.face_count(); ++f)
    std::swap(reversed.triangles[3 * f + 1], reversed.triangles[3 * f + 2]);
  const InnerLayer as_is(s.inner, s.index, 0.003, 0.05);
  const InnerLayer flipped(reversed, s.index, 0.003, 0.05);
  EXPECT_FALSE(as_is.flipped());
  EXPECT_TRUE(flipped.flipped());
  EXPECT_EQ(as_is.boundary_edge_count(), 2u * INNER_SEGMENTS); // two rims

  // A small triangle between body and inner tube (r = 10.9 cm) is inside the layer at mid
  // height; the same triangle just above the tube's top rim is beyond the opening.
  auto patch = [](float y) {
    Mesh m;
    m.positions = {0.109f, y, -0.002f, 0.109f, y, 0.002f, 0.109f, y + 0.003f, 0.0f};
    m.triangles = {0, 1, 2};
    return m;
  };
  for (const InnerLayer* layer : {&as_is, &flipped}) {
    const LayerObstacle o[] = {layer->obstacle()};
    EXPECT_EQ(measure_penetration(patch(0.3f), s.index, s.crossings, o, 0.003).layer_inside_count, 3u);
    EXPECT_EQ(measure_penetration(patch(0.605f), s.index, s.crossings, o, 0.003).layer_inside_count, 0u);
  }
}

} // namespace
} // namespace vfit
