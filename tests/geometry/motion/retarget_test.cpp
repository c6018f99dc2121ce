// SPDX-License-Identifier: Apache-2.0
// Retargeting BVH onto the canonical skeleton: our poses written as BVH come back within 1e-6;
// a rig in another rest pose and other axes gives the same posed bones; the mapping's detection,
// mapping files and their errors; resampling.
#include "vfit/geometry/motion/retarget.h"

#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

const JointPositions& rest_joints(RestPose pose) {
  static const JointPositions t = MannequinShape(BodyMeasurements{}, RestPose::TPOSE).joints();
  static const JointPositions a = MannequinShape(BodyMeasurements{}, RestPose::APOSE).joints();
  return pose == RestPose::TPOSE ? t : a;
}

// A rest frame, then the built-in poses with a small turn and a lift: no ankle below its rest
// height (the floor comes from the lowest ankle).
std::vector<Pose> test_poses() {
  std::vector<Pose> out(1);
  double lift = 0.0;
  for (const std::string name : {"walking", "elbows_bent", "arms_raised", "knee_bent", "contrapposto"}) {
    Pose p = named_pose(name, RestPose::TPOSE);
    p.axis_angle.row(0) << 0, 0.3 + lift, 0;
    p.translation = Eigen::Vector3d(0.1 * lift, 0.05 + lift, -0.2 * lift);
    lift += 0.1;
    out.push_back(p);
  }
  return out;
}

double max_joint_distance(const JointPositions& a, const JointPositions& b) {
  return (a - b).rowwise().norm().maxCoeff();
}

TEST(Retarget, OurPosesThroughBvhComeBack) {
  const JointPositions& rest = rest_joints(RestPose::TPOSE);
  const std::vector<Pose> poses = test_poses();
  const BvhMotion bvh = parse_bvh(bvh_text(poses_to_bvh(rest, poses, 30)), "ours.bvh");
  EXPECT_EQ(bvh.unit, "cm");
  EXPECT_EQ(bvh.up, UpAxis::POS_Y);
  const MotionMapping mapping = detect_motion_mapping(bvh);
  EXPECT_EQ(mapping.name, "smpl");
  const RetargetedMotion back = retarget_bvh(bvh, rest, mapping);
  EXPECT_TRUE(back.unmapped.empty());
  EXPECT_NEAR(back.leg_ratio, 1.0, 1e-12);
  EXPECT_NEAR(back.fps, 30.0, 1e-9);
  ASSERT_EQ(back.frames.size(), poses.size());
  for (std::size_t f = 0; f < poses.size(); ++f) {
    EXPECT_LT(max_joint_distance(posed_joints(rest, back.frames[f]), posed_joints(rest, poses[f])), 1e-6) << f;
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const Eigen::Matrix3d a = axis_angle_to_matrix(back.frames[f].axis_angle.row(j).transpose());
      const Eigen::Matrix3d b = axis_angle_to_matrix(poses[f].axis_angle.row(j).transpose());
      EXPECT_LT((a - b).norm(), 1e-6) << "frame " << f << " joint " << joint_name(j);
    }
  }
}

// The same motion on a rig standing in an A-pose, Z up, in metres, facing −X, with other joint
// names: retargeted onto the T-pose skeleton, every bone points the same way as the original's.
TEST(Retarget, AnotherRestPoseAndOtherAxesGiveTheSameBones) {
  const JointPositions& t_rest = rest_joints(RestPose::TPOSE);
  const JointPositions& a_rest = rest_joints(RestPose::APOSE);
  // The motion expressed on the A-pose rig: posed with the A-pose skeleton so that its world
  // bones match the T-pose skeleton's posed bones (A's rest arms turned up into T first).
  const std::vector<Pose> poses = test_poses();
  const BvhMotion t_bvh = poses_to_bvh(t_rest, poses, 30);
  // Re-express: the A rig's local rotations that give the same world bone directions.
  const MotionMapping smpl = builtin_motion_mapping("smpl");
  const RetargetedMotion on_a = retarget_bvh(t_bvh, a_rest, smpl);
  BvhMotion a_bvh = poses_to_bvh(a_rest, on_a.frames, 30);
  // Other names (MakeHuman's old rig), Z up (x, y, z) → (−z? no: a turn about X), metres.
  const MotionMapping old = builtin_motion_mapping("makehuman_old");
  for (BvhJoint& j : a_bvh.joints)
    if (!j.end_site)
      if (const auto c = joint_from_name(j.name))
        j.name = old.joint[std::size_t(*c)].empty() ? j.name + "_x" : old.joint[std::size_t(*c)];
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()) *
                                Eigen::AngleAxisd(-std::numbers::pi / 2, Eigen::Vector3d::UnitY()))
                                   .toRotationMatrix(); // Y up → Z up, facing +Z → facing −X
  for (BvhJoint& j : a_bvh.joints)
    j.offset = 0.01 * (turn * j.offset);
  for (std::size_t f = 0; f < a_bvh.frame_count(); ++f) {
    double* row = a_bvh.values.data() + f * a_bvh.columns;
    const Eigen::Vector3d p = 0.01 * (turn * Eigen::Vector3d(row[0], row[1], row[2]));
    // The root's rotation is expressed in the turned axes: R' = T R Tᵀ (Z, Y, X Euler angles).
    const Eigen::Matrix3d R =
        (Eigen::AngleAxisd(row[3] * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(row[4] * std::numbers::pi / 180, Eigen::Vector3d::UnitY())) *
        Eigen::AngleAxisd(row[5] * std::numbers::pi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Vector3d zyx = (turn * R * turn.transpose()).eulerAngles(2, 1, 0) * (180 / std::numbers::pi);
    for (int k = 0; k < 3; ++k) {
      row[k] = p[k];
      row[3 + k] = zyx[k];
    }
    // Joints below the root rotate in their parent's (turned) frame: R' = T R Tᵀ for each.
    for (std::size_t j = 1; j < a_bvh.joints.size(); ++j) {
      if (a_bvh.joints[j].end_site) continue;
      double* r = row + a_bvh.joints[j].first_column;
      const Eigen::Matrix3d Rj =
          (Eigen::AngleAxisd(r[0] * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(r[1] * std::numbers::pi / 180, Eigen::Vector3d::UnitY())) *
          Eigen::AngleAxisd(r[2] * std::numbers::pi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
      const Eigen::Vector3d e = (turn * Rj * turn.transpose()).eulerAngles(2, 1, 0) * (180 / std::numbers::pi);
      for (int k = 0; k < 3; ++k)
        r[k] = e[k];
    }
  }
  const BvhMotion rig = parse_bvh(bvh_text(a_bvh), "rig.bvh");
  EXPECT_EQ(rig.up, UpAxis::POS_Z);
  EXPECT_EQ(rig.unit, "m");
  const MotionMapping detected = detect_motion_mapping(rig);
  EXPECT_EQ(detected.name, "makehuman_old");
  const RetargetedMotion back = retarget_bvh(rig, t_rest, detected);
  ASSERT_EQ(back.frames.size(), poses.size());
  for (std::size_t f = 0; f < poses.size(); ++f) {
    const JointPositions want = posed_joints(t_rest, poses[f]);
    const JointPositions got = posed_joints(t_rest, back.frames[f]);
    for (int j = 1; j < JOINT_COUNT; ++j) {
      const int p = joint_parent(j);
      const Eigen::Vector3d a = (want.row(j) - want.row(p)).transpose(), b = (got.row(j) - got.row(p)).transpose();
      EXPECT_GT(a.normalized().dot(b.normalized()), std::cos(1e-4)) << "frame " << f << " bone to " << joint_name(j);
    }
    // The root's motion: the same rig proportions, so the pelvis lands where it was.
    EXPECT_LT((got.row(0) - want.row(0)).norm(), 1e-6) << f;
  }
}

TEST(Retarget, ResamplesByTimeWithSlerp) {
  std::vector<Pose> two(2);
  two[1].axis_angle.row(idx(Joint::LEFT_KNEE)) << 1.2, 0, 0;
  two[1].translation << 0.3, 0, 0;
  const std::vector<Pose> out = resample_poses(two, 10, 40); // 0.1 s at 40 fps: 5 frames
  ASSERT_EQ(out.size(), 5u);
  EXPECT_NEAR(out[2].axis_angle(idx(Joint::LEFT_KNEE), 0), 0.6, 1e-12);
  EXPECT_NEAR(out[1].translation.x(), 0.075, 1e-12);
  EXPECT_NEAR(out[4].axis_angle(idx(Joint::LEFT_KNEE), 0), 1.2, 1e-12);
  EXPECT_EQ(resample_poses(two, 10, 5).size(), 1u); // 0.1 s at 5 fps: the first frame only
  EXPECT_THROW(resample_poses(two, 0, 30), Error);
}

TEST(Retarget, MappingFilesAndTheirErrors) {
  std::string ok = "{";
  const MotionMapping mixamo = builtin_motion_mapping("mixamo");
  for (int j = 0; j < JOINT_COUNT; ++j)
    ok +=
        std::string(j ? "," : "") + "\"" + std::string(joint_name(j)) + "\": \"" + mixamo.joint[std::size_t(j)] + "\"";
  ok += "}";
  EXPECT_EQ(parse_motion_mapping(ok, "m.json").joint[std::size_t(idx(Joint::LEFT_KNEE))], "LeftLeg");
  auto error = [](const std::string& text) {
    try {
      (void)parse_motion_mapping(text, "m.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error("{").find("m.json: invalid JSON"), std::string::npos);
  EXPECT_NE(error("[]").find("expected a JSON object"), std::string::npos);
  EXPECT_NE(error("{\"elbow\": \"x\"}").find("'elbow' is not a canonical joint name"), std::string::npos);
  EXPECT_NE(error("{\"pelvis\": 3}").find("'pelvis': expected the name"), std::string::npos);
  EXPECT_NE(error("{\"pelvis\": \"Hips\", \"neck\": \"Hips\"}").find("'Hips' is already mapped to"), std::string::npos);
  EXPECT_NE(error("{\"pelvis\": \"Hips\"}").find("misses left_hip, right_hip"), std::string::npos);
  EXPECT_THROW(builtin_motion_mapping("unreal"), Error);
}

TEST(Retarget, UnknownRigIsRefusedNamingTheClosestConvention) {
  BvhMotion bvh = poses_to_bvh(rest_joints(RestPose::TPOSE), test_poses(), 30);
  for (BvhJoint& j : bvh.joints)
    if (j.name == "left_knee") j.name = "knee_l";
  try {
    (void)detect_motion_mapping(bvh);
    FAIL() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'smpl', finds 23 of 24 joints and misses left_knee"), std::string::npos) << what;
    EXPECT_NE(what.find("mapping file"), std::string::npos) << what;
  }
  // Prefixed names ("mixamorig:") are found.
  BvhMotion prefixed = poses_to_bvh(rest_joints(RestPose::TPOSE), test_poses(), 30);
  const MotionMapping mixamo = builtin_motion_mapping("mixamo");
  for (BvhJoint& j : prefixed.joints)
    if (const auto c = joint_from_name(j.name)) j.name = "mixamorig:" + mixamo.joint[std::size_t(*c)];
  const MotionMapping found = detect_motion_mapping(prefixed);
  EXPECT_EQ(found.name, "mixamo");
  EXPECT_EQ(found.joint[std::size_t(idx(Joint::LEFT_HIP))], "mixamorig:LeftUpLeg");
}

} // namespace
} // namespace vfit
