// SPDX-License-Identifier: Apache-2.0
// Points embedded in a carrier mesh (kernels/surface_embedding.h), against exact oracles: a
// rigid motion of the carrier moves every point by the same motion; points in a flat carrier's
// plane stay in it however the carrier is stretched in its plane; a fine cylinder carried by a
// coarse one through a bend lands within the interpolation bound of the bent fine cylinder.
#include "vfit/kernels/surface_embedding.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// A wavy sheet: a grid in XZ with heights, so its normals vary from triangle to triangle.
Mesh wavy_sheet(int n, float size) {
  Mesh m = make_grid(n, n, size, size);
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    m.positions[3 * v + 1] = 0.05f * std::sin(7 * m.positions[3 * v]) * std::cos(5 * m.positions[3 * v + 2]);
  return m;
}

// Points scattered near the sheet: inside its triangles' prisms, off its boundary, above and below.
std::vector<float> points_near(float size, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> across(-0.6f * size, 0.6f * size), off(-0.02f, 0.02f);
  std::vector<float> p;
  for (int k = 0; k < count; ++k) {
    const float x = across(rng), z = across(rng);
    p.insert(p.end(), {x, 0.05f * std::sin(7 * x) * std::cos(5 * z) + off(rng), z});
  }
  return p;
}

TEST(SurfaceEmbedding, ARigidMotionOfTheCarrierMovesThePointsRigidly) {
  const Mesh sheet = wavy_sheet(12, 1.0f);
  const std::vector<float> points = points_near(1.0f, 2000, 7);
  SurfaceEmbedding e;
  embed_points(points, sheet.positions, sheet.triangles, {}, e);
  ASSERT_EQ(e.size(), 2000u);
  for (std::int32_t t : e.triangles)
    ASSERT_GE(t, 0);

  // At rest the points come back where they were.
  std::vector<float> rest(points.size(), 0.0f);
  carry_embedded_points(e, sheet.positions, sheet.triangles, rest);
  for (std::size_t i = 0; i < points.size(); ++i)
    EXPECT_NEAR(rest[i], points[i], 2e-6) << i;

  const Eigen::Matrix3d r = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.8, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.4, -1.3, 2.2);
  auto move = [&](std::span<const float> in) {
    std::vector<float> out(in.size());
    for (std::size_t v = 0; v < in.size() / 3; ++v) {
      const Eigen::Vector3d x = r * Eigen::Vector3d(in[3 * v], in[3 * v + 1], in[3 * v + 2]) + t;
      for (int c = 0; c < 3; ++c)
        out[3 * v + std::size_t(c)] = float(x[c]);
    }
    return out;
  };
  const std::vector<float> moved_sheet = move(sheet.positions), expected = move(points);
  std::vector<float> carried(points.size(), 0.0f);
  carry_embedded_points(e, moved_sheet, sheet.triangles, carried);
  // Float rounding only: positions of ~2 m carry ~1e-7 relative error through the moved carrier
  // (its vertices rounded to float) and the offsets (float, up to 0.6 m beyond the boundary).
  for (std::size_t i = 0; i < points.size(); ++i)
    EXPECT_NEAR(carried[i], expected[i], 2e-6) << i;
}

TEST(SurfaceEmbedding, PointsInAFlatCarriersPlaneStayInItWhenItStretchesInThePlane) {
  // A flat sheet tilted into the plane through o spanned by a and b, with points in that plane.
  const Eigen::Vector3d o(0.2, 1.0, -0.3), a = Eigen::Vector3d(1, 0.5, 0).normalized(),
                                           b = a.cross(Eigen::Vector3d(0.2, 0.1, 1)).normalized();
  const Eigen::Vector3d normal = a.cross(b);
  const Mesh grid = make_grid(9, 9, 1.0f, 1.0f);
  auto place = [&](double s, double u) { return o + s * a + u * b; };
  std::vector<float> carrier, stretched, points;
  for (std::size_t v = 0; v < grid.vertex_count(); ++v) {
    const double s = grid.positions[3 * v], u = grid.positions[3 * v + 2];
    const Eigen::Vector3d x = place(s, u), y = place(1.5 * s + 0.3 * u * u, 0.8 * u + 0.2 * s * s);
    carrier.insert(carrier.end(), {float(x.x()), float(x.y()), float(x.z())});
    stretched.insert(stretched.end(), {float(y.x()), float(y.y()), float(y.z())});
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> across(-0.7, 0.7);
  for (int k = 0; k < 1000; ++k) {
    const Eigen::Vector3d x = place(across(rng), across(rng));
    points.insert(points.end(), {float(x.x()), float(x.y()), float(x.z())});
  }
  SurfaceEmbedding e;
  embed_points(points, carrier, grid.triangles, {}, e);
  std::vector<float> carried(points.size());
  carry_embedded_points(e, stretched, grid.triangles, carried);
  for (std::size_t p = 0; p < carried.size() / 3; ++p) {
    const Eigen::Vector3d x(carried[3 * p], carried[3 * p + 1], carried[3 * p + 2]);
    // Float rounding of coordinates ~1.5 m (and of the stretched carrier's vertices).
    EXPECT_NEAR((x - o).dot(normal), 0.0, 2e-6) << p;
  }
}

TEST(SurfaceEmbedding, AFineCylinderFollowsACoarseOneThroughABendWithinTheInterpolationBound) {
  // Along +Y: length 0.6 m; the carrier of radius r, 13 × 12; the fine tube 121 × 96, a layer
  // δ = 1 cm outside it (a loose garment over its proxy; on the carrier, δ would be 0).
  constexpr float RADIUS = 0.1f, LENGTH = 0.6f, LAYER = 0.01f;
  const Mesh fine = make_tube(121, 96, RADIUS + LAYER, LENGTH), coarse = make_tube(13, 12, RADIUS, LENGTH);
  // Bend the axis into an arc of radius R in the XY plane: (x, y, z) → ((R + x)·cos θ − R,
  // (R + x)·sin θ, z), θ = y / R, which stretches the side away from the centre by (R + x)/R.
  constexpr double BEND = 0.4;
  auto bend = [&](std::span<const float> in) {
    std::vector<float> out(in.size());
    for (std::size_t v = 0; v < in.size() / 3; ++v) {
      const double x = in[3 * v], theta = in[3 * v + 1] / BEND;
      out[3 * v] = float((BEND + x) * std::cos(theta) - BEND);
      out[3 * v + 1] = float((BEND + x) * std::sin(theta));
      out[3 * v + 2] = in[3 * v + 2];
    }
    return out;
  };
  SurfaceEmbedding e;
  embed_points(fine.positions, coarse.positions, coarse.triangles, {}, e);
  std::vector<float> carried(fine.positions.size());
  carry_embedded_points(e, bend(coarse.positions), coarse.triangles, carried);
  const std::vector<float> expected = bend(fine.positions);
  double worst = 0, sum = 0, worst_translated = 0;
  for (std::size_t v = 0; v < fine.vertex_count(); ++v) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c)
      d2 += std::pow(carried[3 * v + std::size_t(c)] - expected[3 * v + std::size_t(c)], 2);
    worst = std::max(worst, std::sqrt(d2));
    sum += std::sqrt(d2);
  }
  // Bound: a triangle's linear interpolation of the bend misses it by at most h²/8 · |φ''| with
  // h the carrier's longest edge and |φ''| ≤ (1 + r/R)/R (the outer side's curvature); the
  // offset (at most δ plus the sagitta s = r·(1 − cos(π/12)) off the chord) is carried rigidly
  // while the bend stretches along the axis by up to r/R: (s + δ)·r/R more. Doubled for the
  // triangles' diagonal edges.
  const double h = std::hypot(LENGTH / 12.0, 2 * RADIUS * std::sin(std::numbers::pi / 12));
  const double sagitta = RADIUS * (1 - std::cos(std::numbers::pi / 12));
  const double bound = 2 * (h * h / 8 * (1 + RADIUS / BEND) / BEND + (sagitta + LAYER) * RADIUS / BEND);
  EXPECT_LT(worst, bound);
  // Without the frames (each point moved by its closest point only, its offset unturned), the
  // far end's rotation by θ = 1.5 rad swings its offsets (δ and more) off by 2·δ·sin(θ/2) ≈ 14 mm
  // or more: past the bound that the frames keep.
  SurfaceEmbedding closest = e;
  std::fill(closest.offsets.begin(), closest.offsets.end(), 0.0f);
  std::vector<float> q(fine.positions.size()), q_bent(fine.positions.size());
  carry_embedded_points(closest, coarse.positions, coarse.triangles, q);
  carry_embedded_points(closest, bend(coarse.positions), coarse.triangles, q_bent);
  for (std::size_t v = 0; v < fine.vertex_count(); ++v) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * v + std::size_t(c);
      d2 += std::pow(q_bent[i] + (fine.positions[i] - q[i]) - expected[i], 2);
    }
    worst_translated = std::max(worst_translated, std::sqrt(d2));
  }
  EXPECT_GT(worst_translated, bound);
  EXPECT_LT(sum / double(fine.vertex_count()), 0.5 * bound);
}

TEST(SurfaceEmbedding, MaskedPointsAreLeftWhereTheyAre) {
  const Mesh sheet = wavy_sheet(5, 1.0f);
  const std::vector<float> points = points_near(1.0f, 10, 1);
  std::vector<std::uint8_t> mask(10, 1);
  mask[3] = 0;
  SurfaceEmbedding e;
  embed_points(points, sheet.positions, sheet.triangles, mask, e);
  EXPECT_EQ(e.triangles[3], -1);
  std::vector<float> carried(points.size(), 42.0f);
  std::vector<float> moved = sheet.positions;
  for (std::size_t v = 0; v < moved.size(); v += 3)
    moved[v] += 1.0f;
  carry_embedded_points(e, moved, sheet.triangles, carried);
  EXPECT_EQ(carried[9], 42.0f);
  EXPECT_NEAR(carried[0], points[0] + 1.0f, 1e-5);
  EXPECT_THROW(embed_points(points, sheet.positions, sheet.triangles, std::vector<std::uint8_t>(3, 1), e), Error);
}

} // namespace
} // namespace vfit
