// SPDX-License-Identifier: Apache-2.0
// `vfit body --keypoints`: a photo's 2D keypoints → the posed mannequin, its joints and pose;
// bad keypoint files exit 2 with one line naming the file.
#include <algorithm>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/body/keypoint_fit.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/mesh_io.h"

namespace vfit {
namespace {

// BODY_25 keypoints of the mannequin (average shape) in a relaxed pose, 3 m from a 1000 px camera.
std::string openpose_file() {
  const KeypointBodyModel& model = mannequin_keypoint_model();
  Pose pose;
  pose.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0, 0, -1.2;
  pose.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) << 0, 0, 1.2;
  pose.axis_angle.row(idx(Joint::LEFT_KNEE)) << 0.4, 0, 0;
  pose.translation << 0, -0.1, -3.0;
  const PinholeCamera cam{1200.0, Eigen::Vector2d(500, 500)};
  const auto posed = model.posed_points({}, pose);
  nlohmann::json arr = nlohmann::json::array();
  for (int i = 0; i < 25; ++i) {
    const Eigen::Vector2d px = cam.project(posed.row(keypoint_body_point(KeypointLayout::BODY_25, i)).transpose());
    for (double v : {px.x(), px.y(), 0.9})
      arr.push_back(v);
  }
  return nlohmann::json{{"people", {{{"pose_keypoints_2d", arr}}}}}.dump();
}

TEST(KeypointsCli, FitsWritesTheBodyJointsAndPoseAndPrintsTheStages) {
  test::TempDir tmp;
  const auto kp = tmp / "kp.json", joints = tmp / "joints.json", pose = tmp / "pose.json", mesh = tmp / "body.obj";
  test::write_file(kp, openpose_file());
  const auto r =
      test::run_cli({"body", "--keypoints", kp.string(), "--image-size", "1000", "1000", "--vertices", "1000", "--out",
                     mesh.string(), "--joints", joints.string(), "--pose-out", pose.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("shape+pose"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mean reprojection error"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(test::read_file(joints));
  EXPECT_EQ(j["joints"].size(), 24u);
  // The left knee was bent 0.4 rad; the fit's pose (A-pose rest, camera dropped) bends it too.
  const auto p = nlohmann::json::parse(test::read_file(pose));
  ASSERT_TRUE(p.contains("left_knee")) << p.dump();
  // Its size trades against the thigh's tilt in depth (a 2D ambiguity; measured 0.19 rad), so
  // the test asks for a clear forward bend, not its exact angle.
  EXPECT_GT(p["left_knee"][0].get<double>(), 0.1);
  // The written pose plugs into `vfit body --pose` (and so `vfit fit --pose`).
  const auto again = test::run_cli({"body", "--vertices", "1000", "--pose", pose.string(), "--quiet"});
  EXPECT_EQ(again.exit_code, 0) << again.err;
}

TEST(KeypointsCli, FitTakesTheBodyFromKeypoints) {
  // `vfit fit --keypoints`: the body's measurements and pose come from the photo, and the
  // garment is fitted onto it in one call (no simulation, to stay fast).
  test::TempDir tmp;
  const auto kp = tmp / "kp.json", tee = tmp / "tee.obj", report = tmp / "report.json";
  test::write_file(kp, openpose_file());
  GarmentOptions o;
  o.type = GarmentType::TEE;
  o.target_vertices = 2000;
  write_mesh(tee.string(), make_garment(o).mesh);
  const auto r = test::run_cli({"fit", "--keypoints", kp.string(), "--image-size", "1000x1000", "--vertices", "3000",
                                "--garment", tee.string(), "--no-simulation", "--report", report.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_file(report));
  EXPECT_EQ(j["garments"].size(), 1u);
  EXPECT_EQ(j["penetration"]["after"]["inside_count"].get<std::size_t>(), 0u) << j["penetration"].dump();
  // --keypoints and --pose both set the pose: one line, exit 2.
  const auto both = test::run_cli({"fit", "--keypoints", kp.string(), "--image-size", "1000x1000", "--pose",
                                   "arms_down", "--garment", tee.string(), "--quiet"});
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("--keypoints"), std::string::npos) << both.err;
}

TEST(KeypointsCli, BadKeypointFilesExit2WithOneLine) {
  test::TempDir tmp;
  const std::vector<std::pair<std::string, std::string>> files = {
      {"none.json", R"({"people": []})"},
      {"layout.json", R"({"people": [{"pose_keypoints_2d": [1, 2, 3]}]})"},
      {"few.json", R"({"image_size": [100, 100], "joints": {"left_knee": [1, 2]}})"},
      {"bad.json", R"({"image_size": [100, 100], "joints": {"left_knee": ["a", 2]}})"},
  };
  for (const auto& [name, text] : files) {
    const auto f = tmp / name;
    test::write_file(f, text);
    const auto r = test::run_cli({"body", "--keypoints", f.string(), "--image-size", "640x480"});
    EXPECT_EQ(r.exit_code, 2) << name << ": " << r.err;
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  const auto missing =
      test::run_cli({"body", "--keypoints", (tmp / "missing.json").string(), "--image-size", "640", "480"});
  EXPECT_EQ(missing.exit_code, 2);
}

} // namespace
} // namespace vfit
