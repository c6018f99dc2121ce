// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/body/skeleton.h"

#include <random>

#include <gtest/gtest.h>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

JointPositions sample_joints() {
  JointPositions j;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int k = 0; k < JOINT_COUNT; ++k)
    j.row(k) << u(rng), 1.0 + u(rng), u(rng);
  return j;
}

TEST(Skeleton, NamesParentsAndMirrorsFollowSmpl) {
  EXPECT_EQ(joint_name(0), "pelvis");
  EXPECT_EQ(joint_name(23), "right_hand");
  EXPECT_EQ(joint_from_name("left_elbow"), 18);
  EXPECT_FALSE(joint_from_name("tail").has_value());
  EXPECT_EQ(joint_parent(0), -1);
  for (int j = 1; j < JOINT_COUNT; ++j)
    EXPECT_LT(joint_parent(j), j) << "parents precede children";
  EXPECT_EQ(joint_parent(idx(Joint::LEFT_WRIST)), idx(Joint::LEFT_ELBOW));
  EXPECT_EQ(mirrored_joint(idx(Joint::LEFT_KNEE)), idx(Joint::RIGHT_KNEE));
  EXPECT_EQ(mirrored_joint(idx(Joint::SPINE2)), idx(Joint::SPINE2));
}

TEST(Skeleton, AxisAngleRoundTrip) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int i = 0; i < 100; ++i) {
    Eigen::Vector3d r(u(rng), u(rng), u(rng));
    if (r.norm() > 3.1) continue;
    EXPECT_TRUE(matrix_to_axis_angle(axis_angle_to_matrix(r)).isApprox(r, 1e-9)) << r.transpose();
  }
  EXPECT_TRUE(axis_angle_to_matrix(Eigen::Vector3d::Zero()).isIdentity());
}

TEST(Skeleton, RestPoseLeavesJointsAndMeshUnchanged) {
  const JointPositions rest = sample_joints();
  Pose pose;
  EXPECT_TRUE(posed_joints(rest, pose).isApprox(rest, 1e-12));
  std::vector<float> verts = {0.1f, 1.2f, 0.3f, -0.4f, 0.8f, 0.0f};
  SkinWeights w;
  w.joints = {3, 7, 0, 0, 18, 20, 21, 0};
  w.weights = {0.5f, 0.5f, 0, 0, 0.2f, 0.3f, 0.5f, 0};
  std::vector<float> out;
  linear_blend_skinning(verts, w, skinning_transforms(rest, pose), out);
  for (std::size_t i = 0; i < verts.size(); ++i)
    EXPECT_NEAR(out[i], verts[i], 1e-6);
}

TEST(Skeleton, RotatingOneJointMovesItsDescendantsRigidly) {
  const JointPositions rest = sample_joints();
  Pose pose;
  pose.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0.0, 0.0, -1.2;
  const JointPositions posed = posed_joints(rest, pose);
  const Eigen::Matrix3d R = axis_angle_to_matrix(Eigen::Vector3d(0, 0, -1.2));
  const Eigen::Vector3d s = rest.row(idx(Joint::LEFT_SHOULDER)).transpose();
  for (int j = 0; j < JOINT_COUNT; ++j) {
    bool descendant = false;
    for (int a = j; a >= 0; a = joint_parent(a))
      descendant = descendant || a == idx(Joint::LEFT_SHOULDER);
    const Eigen::Vector3d r = rest.row(j).transpose();
    const Eigen::Vector3d want = descendant ? Eigen::Vector3d(s + R * (r - s)) : r;
    EXPECT_TRUE(posed.row(j).transpose().isApprox(want, 1e-12)) << joint_name(j);
  }
  // Translation moves everything.
  pose.translation << 0.1, -0.2, 0.3;
  EXPECT_TRUE((posed_joints(rest, pose).row(0) - rest.row(0)).isApprox(Eigen::RowVector3d(0.1, -0.2, 0.3), 1e-12));
}

TEST(Skeleton, LbsOfAVertexBoundToOneJointFollowsThatJoint) {
  const JointPositions rest = sample_joints();
  Pose pose;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int j = 0; j < JOINT_COUNT; ++j)
    pose.axis_angle.row(j) << u(rng), u(rng), u(rng);
  const auto g = joint_world_transforms(rest, pose);
  const auto a = skinning_transforms(rest, pose);
  // A point at a joint's rest position, bound only to that joint, lands on the posed joint.
  for (int j = 0; j < JOINT_COUNT; ++j) {
    std::vector<float> v = {float(rest(j, 0)), float(rest(j, 1)), float(rest(j, 2))}, out;
    SkinWeights w;
    w.joints = {j, 0, 0, 0};
    w.weights = {1, 0, 0, 0};
    linear_blend_skinning(v, w, a, out);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(out[k], g[j].translation()[k], 1e-5) << joint_name(j);
  }
}

TEST(SkinWeights, FromDenseKeepsTopFourNormalised) {
  std::vector<double> dense(2 * JOINT_COUNT, 0.0);
  dense[1] = 0.1, dense[2] = 0.4, dense[5] = 0.3, dense[7] = 0.15, dense[9] = 0.05; // five influences
  const SkinWeights w = SkinWeights::from_dense(dense, JOINT_COUNT, 0);
  EXPECT_EQ(w.joints[0], 2);
  EXPECT_EQ(w.joints[1], 5);
  EXPECT_EQ(w.joints[2], 7);
  EXPECT_EQ(w.joints[3], 1);
  EXPECT_NEAR(w.weights[0] + w.weights[1] + w.weights[2] + w.weights[3], 1.0, 1e-6);
  EXPECT_NEAR(w.weights[0], 0.4 / 0.95, 1e-6);
  EXPECT_EQ(w.joints[4], 0); // all-zero row: the fallback joint
  EXPECT_EQ(w.weights[4], 1.0f);
  EXPECT_NO_THROW(validate_skin_weights(w, 2, "w"));
  SkinWeights bad = w;
  bad.weights[0] = 0.9f;
  EXPECT_THROW(validate_skin_weights(bad, 2, "w"), Error);
}

} // namespace
} // namespace vfit
