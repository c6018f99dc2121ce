// SPDX-License-Identifier: Apache-2.0
// A dressed body animated in a .glb: the body and a garment share one skeleton (one skin), each
// has its own material, and an animation of the canonical joints plays it. The Khronos glTF
// validator reports no error; bad animations are refused naming what is wrong.
#include <cstdio>
#include <cstring>
#include <numbers>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/garment_skinning.h"
#include "vfit/geometry/mesh/gltf_format.h"
#include "vfit/geometry/motion/gltf_motion.h"
#include "vfit/geometry/motion/retarget.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

nlohmann::json json_chunk(const std::string& glb) { return nlohmann::json::parse(test::glb_json_text(glb)); }

struct Dressed {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  Garment tee;
  MeshSkin body_skin_, tee_skin;
  std::vector<Pose> poses;
  Dressed() {
    GarmentOptions o;
    o.type = GarmentType::TEE;
    o.pose = RestPose::APOSE;
    o.target_vertices = 3000;
    tee = make_garment(o);
    body_skin_ = body_skin(body);
    tee_skin = body_skin_;
    const SkinWeights w = garment_skin_weights(body, tee.mesh, GarmentType::TEE);
    tee_skin.joints = w.joints;
    tee_skin.weights = w.weights;
    for (const char* name : {"rest", "walking", "arms_raised", "elbows_bent", "rest"})
      poses.push_back(named_pose(name, RestPose::APOSE));
    poses[2].translation << 0.1, 0.05, -0.2;
  }
};

TEST(AnimatedGlb, BodyAndGarmentShareOneSkeletonAndPlay) {
  const Dressed d;
  const SkinAnimation animation = poses_to_skin_animation(d.body.joints, d.poses, 2.0, "test");
  const std::vector<NamedMesh> meshes = {{"body", &d.body.mesh, &d.body_skin_, std::array<float, 3>{0.8f, 0.6f, 0.5f}},
                                         {"tee", &d.tee.mesh, &d.tee_skin, std::array<float, 3>{0.2f, 0.3f, 0.8f}}};
  const std::string glb = write_glb(meshes, &animation);
  const nlohmann::json doc = json_chunk(glb);
  ASSERT_EQ(doc["skins"].size(), 1u);
  EXPECT_EQ(doc["nodes"][0]["skin"], 0);
  EXPECT_EQ(doc["nodes"][1]["skin"], 0);
  EXPECT_EQ(doc["materials"].size(), 2u);
  ASSERT_EQ(doc["animations"].size(), 1u);
  EXPECT_EQ(doc["animations"][0]["channels"].size(), std::size_t(JOINT_COUNT + 1));
  EXPECT_EQ(doc["nodes"].size(), 2u + JOINT_COUNT); // two meshes, one skeleton
  // The last key's time is the clip's length: 4 frames at 2 fps.
  const auto& input = doc["accessors"][doc["animations"][0]["samplers"][0]["input"].get<std::size_t>()];
  EXPECT_FLOAT_EQ(input["max"][0].get<float>(), 2.0f);

  test::TempDir tmp;
  const auto path = tmp / "dressed.glb";
  test::write_file(path, glb);
  const std::optional<std::string> report = test::gltf_validator_report(path);
  if (!report) GTEST_SKIP() << "the Khronos glTF validator is not installed (tools/install_deps.sh style)";
  std::printf("validator: %s", report->c_str());
  const nlohmann::json r = nlohmann::json::parse(*report);
  EXPECT_EQ(r["errors"], 0) << *report;
  EXPECT_EQ(r["warnings"], 0) << *report;
}

// The .glb read back as a motion (gltf_motion.h) and retargeted onto the same skeleton gives the
// poses it was written from: joints within 0.1 mm (float32 storage), and the rate of its keys.
TEST(AnimatedGlb, ReadBackGivesTheFrames) {
  const Dressed d;
  const SkinAnimation animation = poses_to_skin_animation(d.body.joints, d.poses, 24.0, "walk");
  const std::vector<NamedMesh> meshes = {{"body", &d.body.mesh, &d.body_skin_}, {"tee", &d.tee.mesh, &d.tee_skin}};
  const BvhMotion motion = parse_gltf_motion(write_glb(meshes, &animation), "dressed.glb");
  EXPECT_NEAR(motion.fps(), 24.0, 1e-3);
  EXPECT_EQ(motion.frame_count(), d.poses.size());
  EXPECT_EQ(motion.up, UpAxis::POS_Y);
  const MotionMapping mapping = detect_motion_mapping(motion);
  EXPECT_EQ(mapping.name, "smpl");
  const RetargetedMotion back = retarget_bvh(motion, d.body.joints, mapping);
  ASSERT_EQ(back.frames.size(), d.poses.size());
  EXPECT_NEAR(back.leg_ratio, 1.0, 1e-6);
  for (std::size_t f = 0; f < d.poses.size(); ++f) {
    // The root's translation is read relative to the clip's first frame and lowest ankle: the
    // bones are compared, the translation up to that reference.
    const JointPositions want = posed_joints(d.body.joints, d.poses[f]);
    const JointPositions got = posed_joints(d.body.joints, back.frames[f]);
    const JointPositions want0 = posed_joints(d.body.joints, d.poses[0]);
    const JointPositions got0 = posed_joints(d.body.joints, back.frames[0]);
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const Eigen::Vector3d a = (want.row(j) - want.row(0)).transpose(), b = (got.row(j) - got.row(0)).transpose();
      EXPECT_LT((a - b).norm(), 1e-4) << "frame " << f << " joint " << joint_name(j);
    }
    const Eigen::Vector3d moved_want = (want.row(0) - want0.row(0)).transpose();
    const Eigen::Vector3d moved_got = (got.row(0) - got0.row(0)).transpose();
    EXPECT_LT((moved_want - moved_got).head<1>().norm() + std::abs(moved_want.z() - moved_got.z()), 1e-4) << f;
  }
}

TEST(AnimatedGlb, AFileWithoutASkinOrAnAnimationIsNoMotion) {
  const Dressed d;
  auto error = [](const std::string& glb) {
    try {
      (void)parse_gltf_motion(glb, "m.glb");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::vector<NamedMesh> bare = {{"body", &d.body.mesh}};
  EXPECT_NE(error(write_glb(bare)).find("m.glb: no skin"), std::string::npos);
  const std::vector<NamedMesh> skinned = {{"body", &d.body.mesh, &d.body_skin_}};
  EXPECT_NE(error(write_glb(skinned)).find("m.glb: no animation"), std::string::npos);
  const SkinAnimation a = poses_to_skin_animation(d.body.joints, d.poses, 24.0, "walk");
  EXPECT_NE(error(write_glb(skinned, &a)).find("accepted"), std::string::npos);
  EXPECT_THROW(parse_gltf_motion(write_glb(skinned, &a), "m.glb", 0, 1), Error); // no second animation
  EXPECT_THROW(parse_gltf_motion(write_glb(skinned, &a), "m.glb", 5000), Error); // rate out of range
}

TEST(AnimatedGlb, RefusesAnimationsThatDoNotFit) {
  const Dressed d;
  SkinAnimation a = poses_to_skin_animation(d.body.joints, d.poses, 30.0, "bad");
  const std::vector<NamedMesh> skinned = {{"body", &d.body.mesh, &d.body_skin_}};
  const std::vector<NamedMesh> bare = {{"body", &d.body.mesh}};
  auto error = [](const std::vector<NamedMesh>& m, const SkinAnimation& an) {
    try {
      (void)write_glb(m, &an);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error(bare, a).find("bad: an animation needs a skinned mesh"), std::string::npos);
  SkinAnimation short_rotations = a;
  short_rotations.rotations.pop_back();
  EXPECT_NE(error(skinned, short_rotations).find("sizes do not match"), std::string::npos);
  SkinAnimation backwards = a;
  std::swap(backwards.times[1], backwards.times[2]);
  EXPECT_NE(error(skinned, backwards).find("time 3"), std::string::npos);
  SkinAnimation nan = a;
  nan.root_positions[4] = NAN;
  EXPECT_NE(error(skinned, nan).find("root position is not finite"), std::string::npos);
  EXPECT_THROW(poses_to_skin_animation(d.body.joints, {}, 30.0, "none"), Error);
}

} // namespace
} // namespace vfit

namespace vfit {
namespace {

// A rig as other exporters write it: joints with rotations at rest (not the identity), Mixamo
// names, under an armature node turned a quarter about X (Z up), keyframes as float32 in a .glb
// built here. Read as a motion and retargeted onto our skeleton, every bone points where the
// original poses put it.
TEST(GltfMotion, ARigWithRestRotationsUnderATurnedArmatureGivesTheSameBones) {
  const JointPositions rest = test::mannequin(RestPose::APOSE, 6000).joints;
  std::vector<Pose> poses;
  for (const char* name : {"rest", "walking", "elbows_bent", "arms_raised"})
    poses.push_back(named_pose(name, RestPose::APOSE));
  poses[2].translation << 0.05, 0.02, 0.1;
  const MotionMapping mixamo = builtin_motion_mapping("mixamo");
  // Rest rotations: arbitrary per joint; world rest rotations B (under the armature).
  std::array<Eigen::Matrix3d, JOINT_COUNT> Q, B;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    Q[std::size_t(j)] =
        Eigen::AngleAxisd(0.2 * (j % 5) - 0.3, Eigen::Vector3d(1, 1, 0.5 * (j % 3)).normalized()).toRotationMatrix();
    const int p = joint_parent(j);
    B[std::size_t(j)] = p < 0 ? Q[std::size_t(j)] : Eigen::Matrix3d(B[std::size_t(p)] * Q[std::size_t(j)]);
  }
  const Eigen::Quaterniond armature(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()));
  nlohmann::json doc;
  doc["asset"] = {{"version", "2.0"}};
  nlohmann::json nodes = nlohmann::json::array();
  nodes.push_back({{"name", "Armature"},
                   {"rotation", {armature.x(), armature.y(), armature.z(), armature.w()}},
                   {"children", {1}}});
  auto quat = [](const Eigen::Matrix3d& m) {
    const Eigen::Quaterniond q(m);
    return nlohmann::json::array({q.x(), q.y(), q.z(), q.w()});
  };
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const int p = joint_parent(j);
    const Eigen::Vector3d t =
        p < 0 ? Eigen::Vector3d(rest.row(j).transpose())
              : Eigen::Vector3d(B[std::size_t(p)].transpose() * (rest.row(j) - rest.row(p)).transpose());
    nlohmann::json node = {{"name", "mixamorig:" + mixamo.joint[std::size_t(j)]},
                           {"translation", {t.x(), t.y(), t.z()}},
                           {"rotation", quat(Q[std::size_t(j)])}};
    for (int c = 0; c < JOINT_COUNT; ++c)
      if (joint_parent(c) == j) node["children"].push_back(1 + c);
    nodes.push_back(std::move(node));
  }
  doc["nodes"] = std::move(nodes);
  doc["scenes"] = {{{"nodes", {0}}}};
  nlohmann::json joints = nlohmann::json::array();
  for (int j = 0; j < JOINT_COUNT; ++j)
    joints.push_back(1 + j);
  doc["skins"] = {{{"joints", joints}}};
  // Keyframes: times, then per joint its local rotations B_pᵀ R_j B_j, then the root's translation.
  std::string bin;
  auto add = [&](const std::vector<float>& data, const char* type) {
    const std::size_t offset = bin.size();
    bin.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(float));
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", data.size() * sizeof(float)}});
    const std::size_t width = std::string(type) == "SCALAR" ? 1 : std::string(type) == "VEC3" ? 3 : 4;
    doc["accessors"].push_back({{"bufferView", doc["bufferViews"].size() - 1},
                                {"componentType", 5126},
                                {"count", data.size() / width},
                                {"type", type}});
    return doc["accessors"].size() - 1;
  };
  std::vector<float> times;
  for (std::size_t k = 0; k < poses.size(); ++k)
    times.push_back(float(k) / 10.0f);
  const std::size_t input = add(times, "SCALAR");
  doc["accessors"][input]["min"] = {times.front()};
  doc["accessors"][input]["max"] = {times.back()};
  nlohmann::json samplers = nlohmann::json::array(), channels = nlohmann::json::array();
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const int p = joint_parent(j);
    std::vector<float> values;
    for (const Pose& pose : poses) {
      const Eigen::Matrix3d R = axis_angle_to_matrix(pose.axis_angle.row(j).transpose());
      const Eigen::Matrix3d local = p < 0 ? Eigen::Matrix3d(R * B[std::size_t(j)])
                                          : Eigen::Matrix3d(B[std::size_t(p)].transpose() * R * B[std::size_t(j)]);
      const Eigen::Quaterniond q(local);
      values.insert(values.end(), {float(q.x()), float(q.y()), float(q.z()), float(q.w())});
    }
    channels.push_back({{"sampler", samplers.size()}, {"target", {{"node", 1 + j}, {"path", "rotation"}}}});
    samplers.push_back({{"input", input}, {"output", add(values, "VEC4")}});
  }
  std::vector<float> root;
  for (const Pose& pose : poses) {
    const Eigen::Vector3d t = rest.row(0).transpose() + pose.translation;
    root.insert(root.end(), {float(t.x()), float(t.y()), float(t.z())});
  }
  channels.push_back({{"sampler", samplers.size()}, {"target", {{"node", 1}, {"path", "translation"}}}});
  samplers.push_back({{"input", input}, {"output", add(root, "VEC3")}});
  doc["animations"] = {{{"channels", channels}, {"samplers", samplers}}};
  doc["buffers"] = {{{"byteLength", bin.size()}}};
  std::string json = doc.dump();
  while (json.size() % 4)
    json += ' ';
  while (bin.size() % 4)
    bin += '\0';
  std::string glb;
  auto u32 = [&](std::uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67);
  u32(2);
  u32(std::uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  u32(std::uint32_t(json.size()));
  u32(0x4E4F534A);
  glb += json;
  u32(std::uint32_t(bin.size()));
  u32(0x004E4942);
  glb += bin;

  const BvhMotion motion = parse_gltf_motion(glb, "rig.glb");
  EXPECT_NEAR(motion.fps(), 10.0, 1e-9);
  EXPECT_EQ(motion.up, UpAxis::POS_Z);
  const MotionMapping mapping = detect_motion_mapping(motion);
  EXPECT_EQ(mapping.name, "mixamo");
  const RetargetedMotion back = retarget_bvh(motion, rest, mapping);
  ASSERT_EQ(back.frames.size(), poses.size());
  for (std::size_t f = 0; f < poses.size(); ++f) {
    const JointPositions want = posed_joints(rest, poses[f]), got = posed_joints(rest, back.frames[f]);
    for (int j = 1; j < JOINT_COUNT; ++j) {
      const int p = joint_parent(j);
      const Eigen::Vector3d a = (want.row(j) - want.row(p)).transpose(), b = (got.row(j) - got.row(p)).transpose();
      EXPECT_GT(a.normalized().dot(b.normalized()), std::cos(1e-3)) << "frame " << f << " bone to " << joint_name(j);
    }
  }
}

} // namespace
} // namespace vfit
