// SPDX-License-Identifier: Apache-2.0
// Rig mappings and glTF skinned bodies. The bodies are written here as .gltf files (JSON with a
// base64 buffer) from a small Mixamo-style rig with a finger bone, a twist bone and an end bone,
// so every expectation has an independent oracle: the rig's own bone heads, weights and a
// hand-rolled skinning of the rig.
#include "vfit/geometry/body/gltf_body.h"

#include <cmath>
#include <functional>
#include <numbers>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using Json = nlohmann::json;

std::string base64(const std::string& bytes) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 3; ++k)
      v = (v << 8) | (k < n ? std::uint8_t(bytes[i + k]) : 0u);
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += n > 1 ? alphabet[(v >> 6) & 63] : '=';
    out += n > 2 ? alphabet[v & 63] : '=';
  }
  return out;
}

struct Bone {
  std::string name;
  int parent;
  Eigen::Vector3d head; // m, bind pose
};

// A 29-bone Mixamo rig in an A-pose (arms 45° down), +X = the body's left.
std::vector<Bone> mixamo_rig(double arm_drop_deg = 45.0) {
  std::vector<Bone> b{{"Hips", -1, {0, 1.0, 0}},          {"Spine", 0, {0, 1.1, 0}}, {"Spine1", 1, {0, 1.22, 0}},
                      {"Spine2", 2, {0, 1.35, 0}},        {"Neck", 3, {0, 1.5, 0}},  {"Head", 4, {0, 1.6, 0.02}},
                      {"HeadTop_End", 5, {0, 1.78, 0.02}}};
  const double a = arm_drop_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d arm(std::cos(a), -std::sin(a), 0);
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "Left" : "Right";
    const Eigen::Vector3d x(side, 1, 1);
    const int base = static_cast<int>(b.size());
    const Eigen::Vector3d shoulder(0.17 * side, 1.43, 0);
    const Eigen::Vector3d elbow = shoulder + 0.28 * arm.cwiseProduct(x), wrist = elbow + 0.25 * arm.cwiseProduct(x);
    b.push_back({s + "Shoulder", 3, {0.03 * side, 1.45, 0}});
    b.push_back({s + "Arm", base, shoulder});
    b.push_back({s + "ForeArm", base + 1, elbow});
    b.push_back({s + "Hand", base + 2, wrist});
    b.push_back({s + "HandMiddle1", base + 3, wrist + 0.09 * arm.cwiseProduct(x)});
    b.push_back({s + "HandIndex1", base + 3, wrist + 0.08 * arm.cwiseProduct(x) + Eigen::Vector3d(0, 0, 0.03)});
    b.push_back({s + "ForeArmTwist", base + 2, 0.5 * (elbow + wrist)});
  }
  for (const double side : {1.0, -1.0}) {
    const std::string s = side > 0 ? "Left" : "Right";
    const int base = static_cast<int>(b.size());
    b.push_back({s + "UpLeg", 0, {0.09 * side, 0.95, 0}});
    b.push_back({s + "Leg", base, {0.09 * side, 0.52, 0.01}});
    b.push_back({s + "Foot", base + 1, {0.09 * side, 0.09, -0.02}});
    b.push_back({s + "ToeBase", base + 2, {0.09 * side, 0.02, 0.1}});
  }
  return b;
}

int bone_index(const std::vector<Bone>& rig, const std::string& name) {
  for (std::size_t i = 0; i < rig.size(); ++i)
    if (rig[i].name == name) return static_cast<int>(i);
  return -1;
}

// A skinned body: one small tetrahedron per bone, its vertices weighted to the bone, its
// parent and the bone after it, in four different mixes.
struct SkinnedFile {
  std::vector<Bone> rig = mixamo_rig();
  std::string prefix = "mixamorig:";
  double scale = 1.0;           // file units per metre
  std::vector<float> positions; // m
  std::vector<std::uint32_t> triangles;
  std::vector<std::array<std::uint16_t, 4>> joints;
  std::vector<std::array<float, 4>> weights;
  bool quantized = false; // JOINTS_0 unsigned byte, WEIGHTS_0 normalized unsigned short

  SkinnedFile() { build_mesh(); }

  void build_mesh() {
    positions.clear(), triangles.clear(), joints.clear(), weights.clear();
    const std::array<Eigen::Vector3d, 4> tet{Eigen::Vector3d(0.02, 0.01, 0.03), Eigen::Vector3d(-0.02, 0.03, -0.01),
                                             Eigen::Vector3d(0.01, -0.02, -0.02), Eigen::Vector3d(-0.01, -0.01, 0.02)};
    const std::array<std::array<float, 4>, 4> mixes{
        {{1, 0, 0, 0}, {0.6f, 0.4f, 0, 0}, {0.5f, 0.25f, 0.25f, 0}, {0.25f, 0.25f, 0.25f, 0.25f}}};
    for (std::size_t b = 0; b < rig.size(); ++b) {
      const std::uint32_t v0 = static_cast<std::uint32_t>(positions.size() / 3);
      for (int k = 0; k < 4; ++k) {
        for (int c = 0; c < 3; ++c)
          positions.push_back(static_cast<float>(rig[b].head[c] + tet[k][c]));
        const auto other = [&](std::size_t i) { return static_cast<std::uint16_t>(i % rig.size()); };
        const std::uint16_t parent = static_cast<std::uint16_t>(rig[b].parent < 0 ? b : rig[b].parent);
        joints.push_back({std::uint16_t(b), parent, other(b + 1), other(b + 7)});
        weights.push_back(mixes[k]);
      }
      for (auto t : {std::array{0u, 2u, 1u}, std::array{0u, 1u, 3u}, std::array{1u, 2u, 3u}, std::array{0u, 3u, 2u}})
        for (std::uint32_t c : t)
          triangles.push_back(v0 + c);
    }
  }

  // The glTF document: scene [Armature (rotated 90° about Y and offset, as exporters do) →
  // Hips → ..., body mesh node (its own transform, which glTF ignores)]. Bones have arbitrary
  // bind rotations; their inverse bind matrices are exact inverses of their world matrices.
  Json document() const {
    std::string bin;
    Json views = Json::array(), accessors = Json::array();
    auto add = [&](const void* data, std::size_t bytes, Json accessor) {
      views.push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}});
      bin.append(static_cast<const char*>(data), bytes);
      bin.resize((bin.size() + 3) / 4 * 4, '\0');
      accessor["bufferView"] = views.size() - 1;
      accessors.push_back(accessor);
      return accessors.size() - 1;
    };
    std::vector<float> scaled(positions);
    for (float& x : scaled)
      x = static_cast<float>(x * scale);
    const std::size_t nv = scaled.size() / 3;
    Json attributes{{"POSITION", add(scaled.data(), 4 * scaled.size(),
                                     {{"componentType", 5126}, {"count", nv}, {"type", "VEC3"}})}};
    if (quantized) {
      std::vector<std::uint8_t> j8;
      std::vector<std::uint16_t> w16;
      for (std::size_t v = 0; v < nv; ++v)
        for (int k = 0; k < 4; ++k) {
          j8.push_back(static_cast<std::uint8_t>(joints[v][k]));
          w16.push_back(static_cast<std::uint16_t>(std::lround(weights[v][k] * 65535.0f)));
        }
      attributes["JOINTS_0"] = add(j8.data(), j8.size(), {{"componentType", 5121}, {"count", nv}, {"type", "VEC4"}});
      attributes["WEIGHTS_0"] = add(w16.data(), 2 * w16.size(),
                                    {{"componentType", 5123}, {"normalized", true}, {"count", nv}, {"type", "VEC4"}});
    } else {
      attributes["JOINTS_0"] = add(joints.data(), 8 * nv, {{"componentType", 5123}, {"count", nv}, {"type", "VEC4"}});
      attributes["WEIGHTS_0"] =
          add(weights.data(), 16 * nv, {{"componentType", 5126}, {"count", nv}, {"type", "VEC4"}});
    }
    const std::size_t indices = add(triangles.data(), 4 * triangles.size(),
                                    {{"componentType", 5125}, {"count", triangles.size()}, {"type", "SCALAR"}});

    const Eigen::Affine3d armature =
        Eigen::Translation3d(0.5, 0, -2) * Eigen::AngleAxisd(0.5 * std::numbers::pi, Eigen::Vector3d::UnitY());
    std::vector<Eigen::Affine3d> world(rig.size());
    std::vector<float> ibm;
    Json nodes = Json::array(), skin_joints = Json::array();
    for (std::size_t b = 0; b < rig.size(); ++b) {
      const Eigen::Vector3d axis = Eigen::Vector3d(1.0 + b, 2.0, 3.0 - b).normalized();
      world[b] = Eigen::Translation3d(rig[b].head * scale) * Eigen::AngleAxisd(0.37 * b, axis);
      const Eigen::Affine3d parent = rig[b].parent < 0 ? armature : world[rig[b].parent];
      const Eigen::Affine3d local = parent.inverse() * world[b];
      const Eigen::Quaterniond q(local.rotation());
      const Eigen::Vector3d t = local.translation();
      nodes.push_back({{"name", prefix + rig[b].name},
                       {"translation", {t.x(), t.y(), t.z()}},
                       {"rotation", {q.x(), q.y(), q.z(), q.w()}},
                       {"children", Json::array()}});
      if (rig[b].parent >= 0) nodes[rig[b].parent]["children"].push_back(b);
      skin_joints.push_back(b);
      const Eigen::Matrix4f m = world[b].inverse().matrix().cast<float>();
      ibm.insert(ibm.end(), m.data(), m.data() + 16);
    }
    const std::size_t ibm_accessor =
        add(ibm.data(), 4 * ibm.size(), {{"componentType", 5126}, {"count", rig.size()}, {"type", "MAT4"}});
    const Eigen::Quaterniond qa(armature.rotation());
    nodes.push_back({{"name", "Armature"},
                     {"children", {0}},
                     {"translation", {0.5, 0, -2}},
                     {"rotation", {qa.x(), qa.y(), qa.z(), qa.w()}}});
    nodes.push_back({{"name", "Body"}, {"mesh", 0}, {"skin", 0}, {"translation", {3, 4, 5}}, {"scale", {2, 2, 2}}});
    Json doc;
    doc["asset"] = {{"version", "2.0"}};
    doc["scene"] = 0;
    doc["scenes"] = Json::array({{{"nodes", {rig.size(), rig.size() + 1}}}});
    doc["nodes"] = nodes;
    Json primitive{{"attributes", attributes}, {"indices", indices}};
    doc["meshes"] = Json::array({{{"name", "body"}, {"primitives", Json::array({primitive})}}});
    doc["skins"] = Json::array({{{"joints", skin_joints}, {"inverseBindMatrices", ibm_accessor}}});
    doc["accessors"] = accessors;
    doc["bufferViews"] = views;
    doc["buffers"] =
        Json::array({{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin)}}});
    return doc;
  }
};

// The canonical joint that each rig bone's weight should reach, from the rig's own names.
int expected_target(const std::vector<Bone>& rig, int b) {
  const RigMapping mixamo = builtin_rig_mapping("mixamo");
  for (int a = b; a >= 0; a = rig[a].parent)
    for (int j = 0; j < JOINT_COUNT; ++j)
      if (mixamo.bone_for_joint[j] == rig[a].name) return j;
  return 0;
}

class GltfBody : public ::testing::Test {
protected:
  Body load(const Json& doc, const std::optional<RigMapping>& mapping = {},
            std::vector<std::string>* warnings = nullptr) {
    const std::string path = (m_dir / "body.gltf").string();
    test::write_file(path, doc.dump());
    return read_gltf_body(path, mapping, warnings);
  }
  test::TempDir m_dir;
};

TEST_F(GltfBody, JointsAreTheMappedBoneHeads) {
  const SkinnedFile file;
  std::vector<std::string> warnings;
  const Body body = load(file.document(), std::nullopt, &warnings);
  const RigMapping mixamo = builtin_rig_mapping("mixamo");
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const Eigen::Vector3d head = file.rig[bone_index(file.rig, mixamo.bone_for_joint[j])].head;
    // float32 inverse bind matrices of bones up to 1.8 m from the origin: ~1e-7 relative.
    EXPECT_LT((body.joints.row(j).transpose() - head).norm(), 1e-6) << joint_name(j);
  }
  EXPECT_EQ(body.mesh.vertex_count(), file.positions.size() / 3) << "skinned node transform ignored, nothing welded";
  for (std::size_t i = 0; i < file.positions.size(); ++i)
    ASSERT_EQ(body.mesh.positions[i], file.positions[i]) << "the skinned node's own transform is ignored";
  EXPECT_EQ(body.rest_pose, RestPose::APOSE);
  EXPECT_EQ(body.source, (m_dir / "body.gltf").string());
  // The nodes' current pose is not the bind pose: joints still come from the inverse bind matrices.
  Json posed = file.document();
  posed["nodes"][bone_index(file.rig, "LeftArm")]["rotation"] = {0.0, 0.0, 0.6, 0.8};
  EXPECT_LT((load(posed).joints - body.joints).norm(), 1e-12);
  EXPECT_NE(warnings.at(0).find("mixamo"), std::string::npos) << warnings.at(0);
}

TEST_F(GltfBody, WeightsGoToTheNearestMappedAncestor) {
  const SkinnedFile file;
  const Body body = load(file.document());
  validate_skin_weights(body.weights, body.mesh.vertex_count(), "body");
  EXPECT_EQ(expected_target(file.rig, bone_index(file.rig, "LeftHandIndex1")), idx(Joint::LEFT_WRIST));
  EXPECT_EQ(expected_target(file.rig, bone_index(file.rig, "RightForeArmTwist")), idx(Joint::RIGHT_ELBOW));
  EXPECT_EQ(expected_target(file.rig, bone_index(file.rig, "HeadTop_End")), idx(Joint::HEAD));
  for (std::size_t v = 0; v < file.joints.size(); ++v) {
    std::array<double, JOINT_COUNT> expected{}, got{};
    for (int k = 0; k < 4; ++k) {
      expected[expected_target(file.rig, file.joints[v][k])] += file.weights[v][k];
      got[body.weights.joints[4 * v + k]] += body.weights.weights[4 * v + k];
    }
    for (int j = 0; j < JOINT_COUNT; ++j)
      ASSERT_NEAR(got[j], expected[j], 1e-6) << "vertex " << v << ", joint " << joint_name(j);
  }
  // The finger tetrahedron's first vertex is all LeftHandIndex1: it follows the wrist.
  const std::size_t v = 4 * static_cast<std::size_t>(bone_index(file.rig, "LeftHandIndex1"));
  EXPECT_EQ(body.weights.joints[4 * v], idx(Joint::LEFT_WRIST));
  EXPECT_FLOAT_EQ(body.weights.weights[4 * v], 1.0f);
}

// Oracle: the source rig posed by rotating each mapped bone's subtree about its head (world
// axes, root first) and skinned with the rig's own per-bone weights.
TEST_F(GltfBody, LbsOfTheBodyMovesVerticesLikeTheSourceRig) {
  const SkinnedFile file;
  const Body body = load(file.document());
  Pose pose;
  pose.axis_angle.row(idx(Joint::PELVIS)) << 0.0, 0.3, 0.0;
  pose.axis_angle.row(idx(Joint::SPINE2)) << 0.2, 0.0, 0.1;
  pose.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0.0, 0.4, 0.7;
  pose.axis_angle.row(idx(Joint::LEFT_ELBOW)) << 0.0, -1.1, 0.0;
  pose.axis_angle.row(idx(Joint::LEFT_WRIST)) << 0.5, 0.0, 0.0;
  pose.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 1.2, 0.0, 0.0;
  pose.axis_angle.row(idx(Joint::NECK)) << 0.0, 0.0, -0.3;
  pose.translation << 0.1, -0.05, 0.2;
  const Body posed = pose_body(body, pose);

  const RigMapping mixamo = builtin_rig_mapping("mixamo");
  std::vector<Eigen::Affine3d> rig_pose(file.rig.size());
  for (std::size_t b = 0; b < file.rig.size(); ++b) {
    Eigen::Affine3d m = Eigen::Affine3d::Identity();
    for (int a = static_cast<int>(b); a >= 0; a = file.rig[a].parent) {
      const auto it = std::find(mixamo.bone_for_joint.begin(), mixamo.bone_for_joint.end(), file.rig[a].name);
      if (it == mixamo.bone_for_joint.end()) continue; // unmapped bones do not rotate
      const Eigen::Vector3d r = pose.axis_angle.row(it - mixamo.bone_for_joint.begin()).transpose();
      const Eigen::Vector3d p = file.rig[a].head;
      m = Eigen::Translation3d(p) * Eigen::Affine3d(axis_angle_to_matrix(r)) * Eigen::Translation3d(-p) * m;
    }
    rig_pose[b] = Eigen::Translation3d(pose.translation) * m;
  }
  for (std::size_t v = 0; v < file.joints.size(); ++v) {
    const Eigen::Vector3d x(file.positions[3 * v], file.positions[3 * v + 1], file.positions[3 * v + 2]);
    Eigen::Vector3d expected = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k)
      expected += file.weights[v][k] * (rig_pose[file.joints[v][k]] * x);
    const Eigen::Vector3d got(posed.mesh.positions[3 * v], posed.mesh.positions[3 * v + 1],
                              posed.mesh.positions[3 * v + 2]);
    // float32 positions and weights, lever arms ≤ 2 m.
    ASSERT_LT((got - expected).norm(), 2e-6) << "vertex " << v;
  }
}

TEST_F(GltfBody, CentimetreFileIsScaledToMetresAndQuantizedWeightsRead) {
  SkinnedFile file;
  file.scale = 100.0;
  file.quantized = true;
  file.prefix = "";
  std::vector<std::string> warnings;
  const Body body = load(file.document(), std::nullopt, &warnings);
  const RigMapping mixamo = builtin_rig_mapping("mixamo");
  for (int j = 0; j < JOINT_COUNT; ++j)
    EXPECT_LT((body.joints.row(j).transpose() - file.rig[bone_index(file.rig, mixamo.bone_for_joint[j])].head).norm(),
              1e-6);
  for (std::size_t i = 0; i < file.positions.size(); ++i)
    ASSERT_NEAR(body.mesh.positions[i], file.positions[i], 1e-6);
  bool said = false;
  for (const std::string& w : warnings)
    said = said || w.find("read as cm") != std::string::npos;
  EXPECT_TRUE(said);
  // Normalized unsigned shorts: weights within 1/65535 of the float ones.
  validate_skin_weights(body.weights, body.mesh.vertex_count(), "body");
  const std::size_t v = 4 * 1 + 1; // Spine's second vertex: 0.6 Spine (spine1), 0.4 Hips (pelvis)
  EXPECT_EQ(body.weights.joints[4 * v], idx(Joint::SPINE1));
  EXPECT_NEAR(body.weights.weights[4 * v], 0.6f, 1e-4);
}

TEST_F(GltfBody, RestPoseFollowsTheUpperArms) {
  SkinnedFile t_pose;
  t_pose.rig = mixamo_rig(5.0);
  t_pose.build_mesh();
  EXPECT_EQ(load(t_pose.document()).rest_pose, RestPose::TPOSE);
  SkinnedFile arms_down;
  arms_down.rig = mixamo_rig(85.0);
  arms_down.build_mesh();
  EXPECT_EQ(load(arms_down.document()).rest_pose, RestPose::OTHER);
  JointPositions j = JointPositions::Zero();
  EXPECT_EQ(classify_rest_pose(j), RestPose::OTHER) << "coincident shoulder and elbow";
}

TEST_F(GltfBody, ExplicitMappingFileMapsAnUnknownRig) {
  SkinnedFile file;
  for (std::size_t b = 0; b < file.rig.size(); ++b)
    file.rig[b].name = "bone" + std::to_string(b);
  file.prefix = "";
  EXPECT_THROW(load(file.document()), Error) << "no built-in mapping knows bone0, bone1, ...";
  const RigMapping mixamo = builtin_rig_mapping("mixamo");
  const SkinnedFile named;
  Json mapping = Json::object();
  for (int j = 0; j < JOINT_COUNT; ++j)
    mapping[std::string(joint_name(j))] = "bone" + std::to_string(bone_index(named.rig, mixamo.bone_for_joint[j]));
  test::write_file(m_dir / "rig.json", mapping.dump());
  const Body body = load(file.document(), load_rig_mapping((m_dir / "rig.json").string()));
  for (int j = 0; j < JOINT_COUNT; ++j)
    EXPECT_LT((body.joints.row(j).transpose() - named.rig[bone_index(named.rig, mixamo.bone_for_joint[j])].head).norm(),
              1e-6);
}

struct BadBody {
  std::string name;
  std::function<void(Json&)> edit;
  std::string word; ///< must appear in the message
};

class GltfBodyBadInput : public GltfBody, public ::testing::WithParamInterface<BadBody> {};

TEST_P(GltfBodyBadInput, ThrowsNamingTheFileAndTheProblem) {
  Json doc = SkinnedFile().document();
  GetParam().edit(doc);
  const std::string path = (m_dir / "body.gltf").string();
  try {
    load(doc);
    FAIL() << "expected vfit::Error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(GetParam().word), std::string::npos) << message;
  }
}

Json& attributes(Json& doc) { return doc["meshes"][0]["primitives"][0]["attributes"]; }

INSTANTIATE_TEST_SUITE_P(
    GltfBodyFiles, GltfBodyBadInput,
    ::testing::Values(
        BadBody{"NoSkin", [](Json& d) { d["nodes"].back().erase("skin"); }, "no skinned mesh"},
        BadBody{"NoJoints0", [](Json& d) { attributes(d).erase("JOINTS_0"); }, "no JOINTS_0"},
        BadBody{"NoWeights0", [](Json& d) { attributes(d).erase("WEIGHTS_0"); }, "no WEIGHTS_0"},
        BadBody{
            "JointIndexOutOfRange",
            [](Json& d) {
              // POSITION's floats read as unsigned shorts: far past the 29 joints.
              d["accessors"].push_back({{"bufferView", 0}, {"componentType", 5123}, {"count", 116}, {"type", "VEC4"}});
              attributes(d)["JOINTS_0"] = d["accessors"].size() - 1;
            },
            "the skin has 29"},
        BadBody{"AllWeightsZero",
                [](Json& d) {
                  attributes(d)["WEIGHTS_0"] = d["accessors"].size(),
                  d["accessors"].push_back({{"componentType", 5126}, {"count", 116}, {"type", "VEC4"}});
                },
                "all its weights zero"},
        BadBody{"JointsCountDiffers",
                [](Json& d) { d["accessors"][attributes(d)["JOINTS_0"].get<int>()]["count"] = 115; }, "count differs"},
        BadBody{"UnmappableRig",
                [](Json& d) { d["nodes"][bone_index(mixamo_rig(), "LeftHandMiddle1")]["name"] = "Thumb"; },
                "left_hand"},
        BadBody{"BadInverseBindMatrices",
                [](Json& d) { d["accessors"][d["skins"][0]["inverseBindMatrices"].get<int>()]["type"] = "VEC4"; },
                "inverseBindMatrices"},
        BadBody{"SingularInverseBindMatrix",
                [](Json& d) {
                  const int a = d["skins"][0]["inverseBindMatrices"].get<int>();
                  d["accessors"].push_back(d["accessors"][a]);
                  d["accessors"].back().erase("bufferView"); // all zeros
                  d["skins"][0]["inverseBindMatrices"] = d["accessors"].size() - 1;
                },
                "singular"},
        BadBody{"SkinWithoutJoints", [](Json& d) { d["skins"][0]["joints"] = Json::array(); }, "has no joints"}),
    [](const auto& param_info) { return param_info.param.name; });

TEST(RigMapping, BuiltinsNameTwentyFourDistinctBones) {
  for (const std::string& name : builtin_rig_mappings()) {
    const RigMapping rig = builtin_rig_mapping(name, "p:");
    std::set<std::string> bones(rig.bone_for_joint.begin(), rig.bone_for_joint.end());
    EXPECT_EQ(bones.size(), 24u) << name;
    for (const std::string& bone : bones)
      EXPECT_TRUE(bone.starts_with("p:")) << bone;
  }
  EXPECT_THROW(builtin_rig_mapping("blender_rigify"), Error);
}

std::vector<std::string> with_extras(const RigMapping& rig, const std::string& prefix) {
  std::vector<std::string> names{prefix + "Root", prefix + "LeftHandIndex1", prefix + "HeadTop_End"};
  names.insert(names.end(), rig.bone_for_joint.begin(), rig.bone_for_joint.end());
  return names;
}

TEST(RigMapping, DetectsEachBuiltinUnderAnyPrefix) {
  for (const std::string& name : builtin_rig_mappings())
    for (const std::string prefix : {"", "mixamorig:", "mixamorig1:", "m_avg_", "Armature|"}) {
      const RigMapping expected = builtin_rig_mapping(name, prefix);
      const RigMapping got = detect_rig_mapping(with_extras(expected, prefix), "rig");
      EXPECT_EQ(got.name, name) << prefix;
      EXPECT_EQ(got.bone_for_joint, expected.bone_for_joint) << name << " " << prefix;
    }
}

TEST(RigMapping, DetectionFailureListsTheMissingJoints) {
  std::vector<std::string> names = with_extras(builtin_rig_mapping("mixamo", "mixamorig:"), "mixamorig:");
  std::erase(names, "mixamorig:LeftHandMiddle1");
  std::erase(names, "mixamorig:RightToeBase");
  try {
    detect_rig_mapping(names, "model.glb");
    FAIL() << "expected vfit::Error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("model.glb: ", 0), 0u) << message;
    for (const char* word : {"mixamo", "left_hand (mixamorig:LeftHandMiddle1)", "right_foot", "mapping file"})
      EXPECT_NE(message.find(word), std::string::npos) << word << " in " << message;
    EXPECT_EQ(message.find("left_wrist"), std::string::npos) << message;
  }
}

TEST(RigMapping, LoadsAnExplicitFile) {
  test::TempDir dir;
  Json j = Json::object();
  for (int k = 0; k < JOINT_COUNT; ++k)
    j[std::string(joint_name(k))] = "b" + std::to_string(k);
  test::write_file(dir / "rig.json", j.dump(2));
  const RigMapping rig = load_rig_mapping((dir / "rig.json").string());
  EXPECT_EQ(rig.bone_for_joint[idx(Joint::LEFT_ELBOW)], "b18");
  EXPECT_EQ(rig.name, (dir / "rig.json").string());
}

TEST(RigMapping, BadFilesNameTheFileAndTheKey) {
  Json full = Json::object();
  for (int k = 0; k < JOINT_COUNT; ++k)
    full[std::string(joint_name(k))] = "b" + std::to_string(k);
  const std::vector<std::pair<std::string, std::string>> cases{{"{", "invalid JSON"},
                                                               {"[]", "JSON object"},
                                                               {[&] {
                                                                  Json j = full;
                                                                  j["tail"] = "t";
                                                                  return j.dump();
                                                                }(),
                                                                "\"tail\""},
                                                               {[&] {
                                                                  Json j = full;
                                                                  j.erase("right_hand");
                                                                  return j.dump();
                                                                }(),
                                                                "missing joints: right_hand"},
                                                               {[&] {
                                                                  Json j = full;
                                                                  j["neck"] = 3;
                                                                  return j.dump();
                                                                }(),
                                                                "\"neck\""},
                                                               {[&] {
                                                                  Json j = full;
                                                                  j["head"] = "b12";
                                                                  return j.dump();
                                                                }(),
                                                                "already mapped to"}};
  for (const auto& [text, word] : cases) {
    try {
      parse_rig_mapping(text, "rig.json");
      ADD_FAILURE() << "accepted " << text;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("rig.json: ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(load_rig_mapping("/nonexistent/rig.json"), Error);
}

} // namespace
} // namespace vfit
