// SPDX-License-Identifier: Apache-2.0
// `vfit body`, `vfit garment` and `vfit measure` end to end, and their bad inputs.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/body/gltf_body.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/topology.h"

namespace vfit {
namespace {

TEST(BodyCli, WritesMeshJointsAndRiggedGltfThatMeasuresBack) {
  test::TempDir tmp;
  const auto mesh = tmp / "body.obj", joints = tmp / "joints.json", rigged = tmp / "body.glb";
  auto r = test::run_cli({"body", "--preset", "pear", "--vertices", "2000", "--out", mesh.string(), "--joints",
                          joints.string(), "--rigged", rigged.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ParsedMesh m = read_mesh(mesh);
  EXPECT_EQ(m.mesh.vertex_count(), 2000u);
  EXPECT_TRUE(analyse_topology(m.mesh.triangle_view(), m.mesh.vertex_count()).watertight());
  const auto j = nlohmann::json::parse(test::read_file(joints));
  EXPECT_EQ(j["joints"].size(), 24u);
  // The rigged glTF loads back as a body with the same joints.
  const Body b = read_gltf_body(rigged.string());
  EXPECT_EQ(b.mesh.vertex_count(), 2000u);
  for (int k = 0; k < JOINT_COUNT; ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(b.joints(k, c), j["joints"][std::string(joint_name(k))][c].get<double>(), 1e-5);
  r = test::run_cli({"measure", rigged.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto got = nlohmann::json::parse(r.out);
  EXPECT_EQ(got["kind"], "gltf-rig");
  EXPECT_NEAR(got["measurements_m"]["hip"].get<double>(), 1.06, 0.01); // the pear preset's hip
  EXPECT_NEAR(got["measurements_m"]["waist"].get<double>(), 0.76, 0.008);
}

TEST(BodyCli, PosesByNameAndByJsonFile) {
  test::TempDir tmp;
  const auto pose = tmp / "pose.json";
  test::write_file(pose, R"({"left_elbow": [0, -1.2, 0], "translation": [0, 0, 0.5]})");
  const auto joints = tmp / "j.json";
  auto r =
      test::run_cli({"body", "--vertices", "1000", "--pose", pose.string(), "--joints", joints.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_file(joints));
  EXPECT_NEAR(j["joints"]["pelvis"][2].get<double>(), 0.5 - 0.005, 1e-3); // translated by 0.5 m in z
  r = test::run_cli({"body", "--vertices", "1000", "--pose", "walking", "--quiet"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

// Mean distance (m) between the joints of two `--joints` JSON files (all 24 named); +∞ when
// the fitted file does not hold 24 joints.
double mean_joint_distance(const std::filesystem::path& truth, const std::filesystem::path& fitted) {
  const auto want = nlohmann::json::parse(test::read_file(truth))["joints"];
  const auto got = nlohmann::json::parse(test::read_file(fitted))["joints"];
  if (got.size() != std::size_t(JOINT_COUNT)) return INFINITY;
  double sum = 0;
  for (int k = 0; k < JOINT_COUNT; ++k) {
    const std::string name(joint_name(k));
    Eigen::Vector3d d;
    for (int c = 0; c < 3; ++c)
      d[c] = got[name][c].get<double>() - want[name][c].get<double>();
    sum += d.norm();
  }
  return sum / JOINT_COUNT;
}

// `vfit body --scan`: the mannequin posed by `vfit body --pose apose`, saved as OBJ with its
// joints, is read back as a bare scan; the fit recovers its joints (measured 10 mm mean) and
// writes the rigged scan, with every scan vertex weighted. (A walking pose is covered by the
// point-cloud test below.)
TEST(BodyCli, ScanOfAPosedMannequinGivesItsJointsAndARiggedScan) {
  test::TempDir tmp;
  const auto scan = tmp / "scan.obj", truth = tmp / "truth.json", fitted = tmp / "fit.json", rigged = tmp / "scan.glb";
  auto r = test::run_cli(
      {"body", "--vertices", "3000", "--pose", "apose", "--out", scan.string(), "--joints", truth.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli(
      {"body", "--scan", scan.string(), "--joints", fitted.string(), "--rigged", rigged.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LE(mean_joint_distance(truth, fitted), 0.03) << "mean joint distance (m); the bar for scans is 3 cm";
  // The rigged scan keeps the scan's own vertices and faces, with skin weights for each.
  const Body b = read_gltf_body(rigged.string());
  const ParsedMesh m = read_mesh(scan);
  EXPECT_EQ(b.mesh.vertex_count(), m.mesh.vertex_count());
  EXPECT_EQ(b.mesh.face_count(), m.mesh.face_count());
  EXPECT_EQ(b.weights.vertex_count(), m.mesh.vertex_count());
}

// `vfit body --scan` on a point cloud: a walking mannequin's vertices written as a PLY with no
// faces (read only because the scan path opts in), fitted from the pose search since joint
// estimation needs a surface in A- or T-pose.
TEST(BodyCli, ScanOfAWalkingPointCloudGivesItsJoints) {
  test::TempDir tmp;
  const auto mesh = tmp / "walk.obj", cloud = tmp / "walk.ply", truth = tmp / "truth.json", fitted = tmp / "fit.json";
  auto r = test::run_cli({"body", "--vertices", "3000", "--pose", "walking", "--out", mesh.string(), "--joints",
                          truth.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ParsedMesh m = read_mesh(mesh);
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.mesh.vertex_count()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  for (std::size_t v = 0; v < m.mesh.vertex_count(); ++v)
    ply += std::to_string(m.mesh.positions[3 * v]) + " " + std::to_string(m.mesh.positions[3 * v + 1]) + " " +
           std::to_string(m.mesh.positions[3 * v + 2]) + "\n";
  test::write_file(cloud, ply);
  r = test::run_cli({"body", "--scan", cloud.string(), "--joints", fitted.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("0 faces"), std::string::npos) << r.out;
  EXPECT_LE(mean_joint_distance(truth, fitted), 0.03) << "mean joint distance (m); the bar for scans is 3 cm";
}

// Before, `vfit body --from b.obj --out b.obj` replaced the body file it read (exit 0).
TEST(BodyCli, AnOutputOverTheInputOrInAMissingFolderExits2) {
  test::TempDir tmp;
  const auto body = tmp / "b.obj";
  auto r = test::run_cli({"body", "--vertices", "2000", "--out", body.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string before = test::read_file(body);
  for (const char* mode : {"--from", "--scan"}) {
    r = test::run_cli({"body", mode, body.string(), "--out", body.string(), "--quiet"});
    EXPECT_EQ(r.exit_code, 2) << mode << ": " << r.err;
    EXPECT_NE(r.err.find("overwrite an input"), std::string::npos) << r.err;
    EXPECT_TRUE(test::read_file(body) == before) << mode << ": the body file was overwritten";
  }
  r = test::run_cli({"body", "--vertices", "2000", "--out", (tmp / "no" / "b.obj").string(), "--quiet"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
}

TEST(GarmentCli, WritesTheGarmentAndItsLabels) {
  test::TempDir tmp;
  const auto out = tmp / "pants.ply";
  const auto r = test::run_cli(
      {"garment", "trousers", "--size", "P3", "--vertices", "1500", "--pose", "apose", "--out", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_mesh(out).mesh.vertex_count(), 1500u);
  const auto labels = nlohmann::json::parse(test::read_file(tmp / "pants.labels.json"));
  EXPECT_EQ(labels["vertex_parts"].size(), 1500u);
  EXPECT_EQ(labels["size"], "P3");
  EXPECT_EQ(labels["part_names"][3], "left_leg");
}

struct BadCall {
  const char* name;
  std::vector<std::string> args;
  const char* expect;
};
void PrintTo(const BadCall& b, std::ostream* os) { *os << b.name; }

class BodyCliBadInput : public ::testing::TestWithParam<BadCall> {};

TEST_P(BodyCliBadInput, ExitsTwoNamingTheProblem) {
  const auto r = test::run_cli(GetParam().args);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(GetParam().expect), std::string::npos) << r.err;
}

INSTANTIATE_TEST_SUITE_P(
    Calls, BodyCliBadInput,
    ::testing::Values(BadCall{"height", {"body", "--height", "5"}, "height"},
                      BadCall{"not_a_number", {"body", "--chest", "big"}, "--chest"},
                      BadCall{"preset", {"body", "--preset", "giraffe"}, "unknown body preset"},
                      BadCall{"pose", {"body", "--pose", "cartwheel"}, "unknown pose"},
                      BadCall{"vertices", {"body", "--vertices", "12"}, "--vertices"},
                      BadCall{"rigged_not_glb", {"body", "--rigged", "x.obj"}, "--rigged writes a .glb"},
                      BadCall{"garment_type", {"garment", "cape", "--out", "x.obj"}, "unknown garment type"},
                      BadCall{"garment_size", {"garment", "tee", "--size", "XXXL", "--out", "x.obj"}, "unknown size"},
                      BadCall{"garment_no_out", {"garment", "tee"}, "--out"},
                      BadCall{"measure_missing", {"measure", "no/such/body.obj"}, "cannot open"},
                      BadCall{"measure_betas", {"measure", "x.npz", "--betas", "1,,2"}, "--betas"}),
    [](const auto& p) { return std::string(p.param.name); });

} // namespace
} // namespace vfit
