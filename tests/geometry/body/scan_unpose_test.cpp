// SPDX-License-Identifier: Apache-2.0
// Unposing a scan about a limb's pivot (scan_unpose.h): a tube skinned from a collar to a
// shoulder and posed by turning the shoulder about its true pivot is the oracle. Unposed with
// the same rotation about a pivot 4 cm off (a template's shoulder), its seam stretches more than
// about the true one; with the pivot moved to the true joint by move_limb_pivot(), unposing is the
// exact inverse of posing.
#include "vfit/geometry/body/scan_unpose.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "vfit/geometry/body/scan_skin_transfer.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using scan_detail::limb_roots;
using scan_detail::move_limb_pivot;
using scan_detail::seam_stretch;
using scan_detail::unpose_scan;

constexpr int RINGS = 31, SEGMENTS = 12;
constexpr double LENGTH = 0.6, RADIUS = 0.05; // m
const int COLLAR = idx(Joint::RIGHT_COLLAR), SHOULDER = idx(Joint::RIGHT_SHOULDER);
const Eigen::Vector3d PIVOT(0.25, 0, 0); // the tube's true shoulder (m)

// A closed-side tube along +X (open ends), collar weights up to x = 0.2 m, the shoulder's from
// x = 0.3 m, blended linearly between (the seam).
struct Tube {
  Mesh mesh;
  SkinWeights weights;
};
Tube tube() {
  Tube t;
  for (int r = 0; r < RINGS; ++r) {
    const double x = LENGTH * r / (RINGS - 1);
    const double s = std::clamp((x - 0.2) / 0.1, 0.0, 1.0); // the shoulder's share
    for (int k = 0; k < SEGMENTS; ++k) {
      const double a = 2 * std::numbers::pi * k / SEGMENTS;
      for (double c : {x, RADIUS * std::cos(a), RADIUS * std::sin(a)})
        t.mesh.positions.push_back(static_cast<float>(c));
      t.weights.joints.insert(t.weights.joints.end(), {COLLAR, SHOULDER, 0, 0});
      t.weights.weights.insert(t.weights.weights.end(), {static_cast<float>(1 - s), static_cast<float>(s), 0.f, 0.f});
    }
  }
  for (int r = 0; r + 1 < RINGS; ++r)
    for (int k = 0; k < SEGMENTS; ++k) {
      const int a = r * SEGMENTS + k, b = r * SEGMENTS + (k + 1) % SEGMENTS;
      t.mesh.triangles.insert(t.mesh.triangles.end(), {a, b, a + SEGMENTS, b, b + SEGMENTS, a + SEGMENTS});
    }
  return t;
}

// Identity transforms but the shoulder's chain (shoulder, elbow, wrist, hand): turned 40° about
// Z around `pivot`.
std::array<Eigen::Isometry3d, JOINT_COUNT> arm_turned_about(const Eigen::Vector3d& pivot) {
  std::array<Eigen::Isometry3d, JOINT_COUNT> A;
  A.fill(Eigen::Isometry3d::Identity());
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.translate(pivot)
      .rotate(Eigen::AngleAxisd(-40 * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()))
      .translate(-pivot);
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (skin_chain_of_joint(j) == skin_chain_of_joint(SHOULDER)) A[static_cast<std::size_t>(j)] = turn;
  return A;
}

double max_distance(const Mesh& a, const Mesh& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.positions.size(); ++i)
    d = std::max(d, std::abs(static_cast<double>(a.positions[i]) - b.positions[i]));
  return d;
}

TEST(ScanUnpose, LimbRootsAreTheShouldersAndHips) {
  EXPECT_EQ(limb_roots(), (std::vector<int>{idx(Joint::LEFT_HIP), idx(Joint::RIGHT_HIP), idx(Joint::LEFT_SHOULDER),
                                            idx(Joint::RIGHT_SHOULDER)}));
}

TEST(ScanUnpose, MovingTheLimbPivotToTheTrueJointMakesUnposingExact) {
  const Tube t = tube();
  Mesh posed = t.mesh;
  linear_blend_skinning(t.mesh.positions, t.weights, arm_turned_about(PIVOT), posed.positions);

  // The template's pivot, 4 cm above: the arm slides against the collar's skin when unposed.
  const Eigen::Vector3d wrong = PIVOT + Eigen::Vector3d(0, 0.04, 0);
  auto A = arm_turned_about(wrong);
  const Mesh off = unpose_scan(posed, t.weights, A);
  EXPECT_GT(max_distance(off, t.mesh), 0.01); // 2·sin(20°)·4 cm = 2.7 cm at the arm
  const int chain = skin_chain_of_joint(SHOULDER);
  const double off_stretch = seam_stretch(posed, t.weights, A, chain);

  move_limb_pivot(A, SHOULDER, PIVOT);
  const auto truth = arm_turned_about(PIVOT);
  for (int j = 0; j < JOINT_COUNT; ++j) // the whole chain moved, every other bone kept
    EXPECT_TRUE(A[static_cast<std::size_t>(j)].isApprox(truth[static_cast<std::size_t>(j)], 1e-12)) << j;
  const Mesh on = unpose_scan(posed, t.weights, A);
  // The exact inverse of the posing: float rounding only (coordinates < 1 m, 1e-6 relative).
  EXPECT_LT(max_distance(on, t.mesh), 1e-5);
  // The seam keeps the blend's own distortion, the rest tube's seam against the posed one's
  // (brute force below, 1e-6 m: float positions); the slide about the wrong pivot adds to it by
  // more than fit_scan()'s 5 % (PIVOT_GAIN).
  const double on_stretch = seam_stretch(posed, t.weights, A, chain);
  double blend = 0;
  for (std::size_t i = 0; i < posed.triangles.size(); ++i) {
    const auto a = static_cast<std::size_t>(posed.triangles[i]);
    const auto b = static_cast<std::size_t>(posed.triangles[i % 3 == 2 ? i - 2 : i + 1]);
    auto in_seam = [&](std::size_t v) { return t.weights.weights[4 * v] > 0 && t.weights.weights[4 * v + 1] > 0; };
    if (!in_seam(a) && !in_seam(b)) continue;
    auto length = [&](const Mesh& m) {
      return (Eigen::Vector3f::Map(&m.positions[3 * a]) - Eigen::Vector3f::Map(&m.positions[3 * b]))
          .cast<double>()
          .norm();
    };
    blend += std::abs(length(t.mesh) - length(posed));
  }
  EXPECT_GT(blend, 0.1); // a 40° turn blended over 10 cm: cm per edge on hundreds of edges
  EXPECT_NEAR(on_stretch, blend, 1e-3);
  EXPECT_LT(on_stretch, 0.95 * off_stretch);
  // The other chains have no seam on this tube.
  EXPECT_EQ(seam_stretch(posed, t.weights, A, skin_chain_of_joint(idx(Joint::LEFT_SHOULDER))), 0.0);
}

TEST(ScanUnpose, ARigidMoveLeavesTheSeamUnstretched) {
  const Tube t = tube();
  Mesh moved = t.mesh;
  const Eigen::Isometry3d m(Eigen::Translation3d(0.3, -0.1, 0.2) *
                            Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  std::array<Eigen::Isometry3d, JOINT_COUNT> A;
  A.fill(m);
  linear_blend_skinning(t.mesh.positions, t.weights, A, moved.positions);
  // Hundreds of seam edges, each off by float rounding (< 1e-7 m on 3 cm edges).
  EXPECT_LT(seam_stretch(moved, t.weights, A, skin_chain_of_joint(SHOULDER)), 1e-4);
}

TEST(ScanUnpose, MoveLimbPivotRejectsAJointThatStartsNoLimb) {
  auto A = arm_turned_about(PIVOT);
  EXPECT_THROW(move_limb_pivot(A, idx(Joint::RIGHT_ELBOW), PIVOT), Error);
  EXPECT_THROW(move_limb_pivot(A, 0, PIVOT), Error);
  EXPECT_THROW(move_limb_pivot(A, JOINT_COUNT, PIVOT), Error);
}

} // namespace
} // namespace vfit
