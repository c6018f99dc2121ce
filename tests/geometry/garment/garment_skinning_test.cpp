// SPDX-License-Identifier: Apache-2.0
// Garment skin weights (seed 001 §7.1): catalogue garments made around the A-pose mannequin lie
// on it as fitted, so their weights come from it directly. Sleeves hang from their own arm,
// no triangle is torn between distant bones, a skirt's hem follows both thighs equally, and a
// posed tee keeps its sleeves on the arms.
#include "vfit/geometry/garment/garment_skinning.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/body/scan_skin_transfer.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

Garment garment_of(GarmentType type) {
  GarmentOptions o;
  o.type = type;
  o.pose = RestPose::APOSE;
  o.target_vertices = 4000;
  return make_garment(o);
}

// The largest difference between two corners' weights over the triangles: half the L1 distance
// of their 24-joint weight vectors (0: the same weights, 1: no joint in common).
double worst_triangle_spread(const Mesh& mesh, const SkinWeights& w) {
  auto dense = [&](std::size_t v) {
    std::array<double, JOINT_COUNT> d{};
    for (std::size_t k = 0; k < 4; ++k)
      d[std::size_t(w.joints[4 * v + k])] += w.weights[4 * v + k];
    return d;
  };
  double worst = 0;
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const auto a = dense(std::size_t(mesh.triangles[3 * f + k])),
                 b = dense(std::size_t(mesh.triangles[3 * f + (k + 1) % 3]));
      double l1 = 0;
      for (int j = 0; j < JOINT_COUNT; ++j)
        l1 += std::abs(a[std::size_t(j)] - b[std::size_t(j)]);
      worst = std::max(worst, 0.5 * l1);
    }
  return worst;
}

double chain_weight(const SkinWeights& w, std::size_t v, int chain) {
  double sum = 0;
  for (std::size_t k = 0; k < 4; ++k)
    if (skin_chain_of_joint(w.joints[4 * v + k]) == chain) sum += w.weights[4 * v + k];
  return sum;
}

TEST(GarmentSkinning, SleevesHangFromTheirArmAndNoTriangleIsTorn) {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  const Garment tee = garment_of(GarmentType::TEE);
  const SkinWeights w = garment_skin_weights(body, tee.mesh, GarmentType::TEE);
  validate_skin_weights(w, tee.mesh.vertex_count(), "tee");
  GarmentSkinningOptions raw;
  raw.smoothing_radius = 0;
  const SkinWeights unsmoothed = garment_skin_weights(body, tee.mesh, GarmentType::TEE, raw);
  const double spread = worst_triangle_spread(tee.mesh, w), before = worst_triangle_spread(tee.mesh, unsmoothed);
  std::printf("tee: worst corner-to-corner weight difference %.3f (%.3f before the diffusion)\n", spread, before);
  EXPECT_LT(spread, 0.5);
  EXPECT_LE(spread, before);
  // Sleeve vertices far out on the arm (past the elbow's height in x) hang from their own arm.
  std::size_t left = 0, right = 0;
  const double reach = 0.5 * (body.joints(idx(Joint::LEFT_SHOULDER), 0) + body.joints(idx(Joint::LEFT_ELBOW), 0));
  for (std::size_t v = 0; v < tee.mesh.vertex_count(); ++v) {
    const double x = tee.mesh.positions[3 * v];
    if (x > reach) {
      ++left;
      EXPECT_GT(chain_weight(w, v, 1), 0.9) << "vertex " << v;
    } else if (x < -reach) {
      ++right;
      EXPECT_GT(chain_weight(w, v, 2), 0.9) << "vertex " << v;
    }
  }
  EXPECT_GT(left, 20u);
  EXPECT_GT(right, 20u);
}

TEST(GarmentSkinning, ASkirtsHemFollowsBothThighsEqually) {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  const Garment skirt = garment_of(GarmentType::SKIRT);
  const SkinWeights w = garment_skin_weights(body, skirt.mesh, GarmentType::SKIRT);
  double lowest = INFINITY;
  for (std::size_t v = 0; v < skirt.mesh.vertex_count(); ++v)
    lowest = std::min(lowest, double(skirt.mesh.positions[3 * v + 1]));
  std::size_t hem = 0;
  for (std::size_t v = 0; v < skirt.mesh.vertex_count(); ++v) {
    if (skirt.mesh.positions[3 * v + 1] > lowest + 0.02) continue;
    ++hem;
    double l = 0, r = 0, other_leg = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      const int j = w.joints[4 * v + k];
      if (j == idx(Joint::LEFT_HIP))
        l += w.weights[4 * v + k];
      else if (j == idx(Joint::RIGHT_HIP))
        r += w.weights[4 * v + k];
      else if (skin_chain_of_joint(j) >= 3)
        other_leg += w.weights[4 * v + k];
    }
    EXPECT_NEAR(l, r, 1e-5) << "hem vertex " << v;
    EXPECT_EQ(other_leg, 0.0) << "hem vertex " << v << ": knees or feet";
  }
  EXPECT_GT(hem, 20u);
}

// Posed with the arms raised, the tee's sleeves stay on the arms: each sleeve vertex keeps its
// distance to the upper arm's bone within 1.5 cm of its rest distance.
TEST(GarmentSkinning, APosedTeeKeepsItsSleevesOnTheArms) {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  const Garment tee = garment_of(GarmentType::TEE);
  const SkinWeights w = garment_skin_weights(body, tee.mesh, GarmentType::TEE);
  const Pose pose = named_pose("arms_raised", RestPose::APOSE);
  std::vector<float> posed;
  linear_blend_skinning(tee.mesh.positions, w, skinning_transforms(body.joints, pose), posed);
  const JointPositions j = posed_joints(body.joints, pose);
  auto bone_distance = [](const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    return (p - (a + t * (b - a))).norm();
  };
  const double reach = 0.5 * (body.joints(idx(Joint::LEFT_SHOULDER), 0) + body.joints(idx(Joint::LEFT_ELBOW), 0));
  double worst = 0;
  for (std::size_t v = 0; v < tee.mesh.vertex_count(); ++v) {
    const double x = tee.mesh.positions[3 * v];
    if (std::abs(x) < reach) continue;
    const Joint s = x > 0 ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER,
                e = x > 0 ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW;
    const Eigen::Vector3d rest(tee.mesh.positions[3 * v], tee.mesh.positions[3 * v + 1], tee.mesh.positions[3 * v + 2]);
    const Eigen::Vector3d now(posed[3 * v], posed[3 * v + 1], posed[3 * v + 2]);
    const double d0 = bone_distance(rest, body.joints.row(idx(s)).transpose(), body.joints.row(idx(e)).transpose());
    const double d1 = bone_distance(now, j.row(idx(s)).transpose(), j.row(idx(e)).transpose());
    worst = std::max(worst, std::abs(d1 - d0));
  }
  std::printf("arms_raised: sleeve vertices' distance to the upper arm changes by at most %.1f mm\n", worst * 1000);
  EXPECT_LT(worst, 0.015);
}

TEST(GarmentSkinning, RefusesAnEmptyGarment) {
  EXPECT_THROW(garment_skin_weights(test::mannequin(RestPose::APOSE, 6000), Mesh{}, GarmentType::TEE), Error);
}

} // namespace
} // namespace vfit
