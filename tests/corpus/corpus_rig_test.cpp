// SPDX-License-Identifier: Apache-2.0
// The MakeHuman hm08 body rigged with the game_engine skeleton (corpus/MANIFEST.md, "the rigged
// body as glTF 2.0") loads as a Body whose joints and weights agree with the skeleton's JSON
// description, an oracle written independently of the .glb. Skipped when the corpus is absent.
#include <fstream>
#include <iostream>
#include <map>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/body/gltf_body.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit {
namespace {

struct CorpusRig : ::testing::Test {
  static void SetUpTestSuite() {
    const auto corpus = test::corpus_dir();
    if (!corpus) return;
    const auto derived = *corpus / "makehuman" / "derived";
    s_body = read_gltf_body((derived / "hm08_body_rigged.glb").string(), std::nullopt, &s_warnings);
    std::ifstream in(derived / "hm08_skeleton_game_engine.json");
    s_skeleton = nlohmann::json::parse(in);
  }
  static void TearDownTestSuite() { s_body.reset(); }
  void SetUp() override {
    if (!s_body) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  }

  static inline std::optional<Body> s_body;
  static inline std::vector<std::string> s_warnings;
  static inline nlohmann::json s_skeleton;
};

TEST_F(CorpusRig, MeshIsTheWatertightHm08BodyInMetres) {
  const Mesh& mesh = s_body->mesh;
  EXPECT_EQ(mesh.vertex_count(), 13380u);
  EXPECT_TRUE(analyse_topology(mesh.triangles, mesh.vertex_count()).watertight());
  float lo = 1e9f, hi = -1e9f;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    lo = std::min(lo, mesh.positions[3 * v + 1]);
    hi = std::max(hi, mesh.positions[3 * v + 1]);
  }
  EXPECT_NEAR(hi - lo, 1.666, 1e-3) << "MANIFEST: hm08 is 16.66 dm tall";
  for (const std::string& w : s_warnings)
    EXPECT_EQ(w.find("scaled to metres"), std::string::npos) << "the .glb is already in metres: " << w;
}

TEST_F(CorpusRig, JointsAreTheGameEngineBoneHeadsWithTheSpineAtSmplHeights) {
  const RigMapping rig = builtin_rig_mapping("makehuman_game_engine");
  std::map<std::string, Eigen::Vector3d> head;
  for (const auto& bone : s_skeleton["bones"])
    head[bone["name"]] = 0.1 * Eigen::Vector3d(bone["head"][0], bone["head"][1], bone["head"][2]); // dm → m
  std::cout << "hm08 canonical joints (m):\n";
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const Eigen::Vector3d got = s_body->joints.row(j).transpose();
    ASSERT_TRUE(head.contains(rig.bone_for_joint[j])) << rig.bone_for_joint[j];
    Eigen::Vector3d expected = head[rig.bone_for_joint[j]];
    if (const JointAnchor& anchor = rig.anchors[std::size_t(j)]; !anchor.toward.empty()) {
      ASSERT_TRUE(head.contains(anchor.toward)) << anchor.toward;
      expected += anchor.fraction * (head[anchor.toward] - expected); // SMPL's spine heights
    }
    // 1 mm: the .glb stores float32 inverse bind matrices of heads rounded to 1e-6 m.
    EXPECT_LT((got - expected).norm(), 1e-3) << joint_name(j);
    std::cout << "  " << joint_name(j) << " " << got.transpose() << "\n";
  }
  EXPECT_EQ(s_body->rest_pose, RestPose::APOSE);
}

// Expected canonical weights from the JSON's per-bone weights: each bone's weight moves to its
// nearest ancestor-or-self among the mapped bones (the Root, above the pelvis, to the pelvis).
TEST_F(CorpusRig, WeightsAreTheJsonWeightsGatheredOntoMappedAncestors) {
  const RigMapping rig = builtin_rig_mapping("makehuman_game_engine");
  const auto& bones = s_skeleton["bones"];
  std::vector<int> target(bones.size(), 0);
  for (std::size_t b = 0; b < bones.size(); ++b)
    for (int a = static_cast<int>(b); a >= 0; a = bones[a]["parent_index"].get<int>()) {
      const auto it = std::find(rig.bone_for_joint.begin(), rig.bone_for_joint.end(), bones[a]["name"]);
      if (it != rig.bone_for_joint.end()) {
        target[b] = static_cast<int>(it - rig.bone_for_joint.begin());
        break;
      }
    }
  const auto& vertex_weights = s_skeleton["vertex_weights"];
  ASSERT_EQ(vertex_weights.size(), s_body->weights.vertex_count());
  double worst = 0.0;
  for (std::size_t v = 0; v < vertex_weights.size(); ++v) {
    std::array<double, JOINT_COUNT> expected{}, got{};
    for (const auto& pair : vertex_weights[v])
      expected[target[pair[0].get<int>()]] += pair[1].get<double>();
    double sum = 0.0;
    for (int k = 0; k < 4; ++k) {
      got[s_body->weights.joints[4 * v + k]] += s_body->weights.weights[4 * v + k];
      sum += s_body->weights.weights[4 * v + k];
    }
    EXPECT_NEAR(sum, 1.0, 1e-5) << "vertex " << v;
    for (int j = 0; j < JOINT_COUNT; ++j)
      worst = std::max(worst, std::abs(got[j] - expected[j]));
  }
  // The .glb holds the JSON's weights as float32 in the same vertex order; the JSON's 5-decimal
  // weights sum to 1 only within 1e-5, and the loader renormalises.
  EXPECT_LT(worst, 3e-5);
}

} // namespace
} // namespace vfit
