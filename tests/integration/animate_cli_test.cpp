// SPDX-License-Identifier: Apache-2.0
// `vfit animate`: a catalogue tee on the mannequin played through a short clip written as BVH
// from our own poses (in a Mixamo-named, metre rig) → an animated .glb that the Khronos validator
// accepts, one OBJ per frame, a report per frame with the physics on and every frame clean
// after the clean-up; LBS only with --physics off; bad input → exit 2 and nothing written.
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/engine/view/image.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/motion/retarget.h"

namespace vfit {
namespace {

// A 7-frame clip at 12 fps: rest, walking, elbows bent, walking, rest, ... (Mixamo names).
void write_clip(const std::filesystem::path& path) {
  const JointPositions rest = MannequinShape(BodyMeasurements{}, RestPose::TPOSE).joints();
  std::vector<Pose> poses;
  for (const char* name : {"rest", "walking", "elbows_bent", "walking", "rest", "arms_raised", "rest"})
    poses.push_back(named_pose(name, RestPose::TPOSE));
  BvhMotion bvh = poses_to_bvh(rest, poses, 12);
  const MotionMapping mixamo = builtin_motion_mapping("mixamo");
  for (BvhJoint& j : bvh.joints)
    if (const auto c = joint_from_name(j.name)) j.name = "mixamorig:" + mixamo.joint[std::size_t(*c)];
  test::write_file(path, bvh_text(bvh));
}

TEST(AnimateCli, PlaysAClipOnADressedBody) {
  test::TempDir dir;
  write_clip(dir / "clip.bvh");
  GarmentOptions o;
  o.type = GarmentType::TEE;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2000;
  write_mesh(dir / "tee.obj", make_garment(o).mesh);
  const auto r = test::run_cli({"animate",
                                "--garment",
                                (dir / "tee.obj").string(),
                                "--motion",
                                (dir / "clip.bvh").string(),
                                "--pose-rest",
                                "apose",
                                "--vertices",
                                "3000",
                                "--fps",
                                "24",
                                "--out",
                                (dir / "anim.glb").string(),
                                "--frames-dir",
                                (dir / "frames").string(),
                                "--report",
                                (dir / "anim.json").string(),
                                "--render",
                                (dir / "strip.png").string(),
                                "--render-size",
                                "64",
                                "--no-simulation",
                                "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // 13 frames, every 2nd on the contact sheet: 7 tiles of 64 pixels in one row.
  const Image strip = read_png(dir / "strip.png");
  EXPECT_EQ(strip.width, 7 * 64);
  EXPECT_EQ(strip.height, 64);
  const nlohmann::json report = nlohmann::json::parse(test::read_file(dir / "anim.json"));
  EXPECT_EQ(report["motion"]["mapping"], "mixamo");
  EXPECT_EQ(report["motion"]["unit"], "cm");
  EXPECT_EQ(report["motion"]["frames"], 13); // 0.5 s at 24 fps
  EXPECT_EQ(report["frames"].size(), 13u);
  EXPECT_NEAR(report["motion"]["leg_ratio"].get<double>(), 1.0, 0.02); // the same measurements, T against A
  EXPECT_TRUE(report["physics"]["on"].get<bool>());
  EXPECT_EQ(report["physics"]["diverged"], 0);
  EXPECT_EQ(report["physics"]["restarts"], 1); // the first frame only
  for (const auto& f : report["frames"]) {
    EXPECT_GE(f["lbs_ms"].get<double>(), 0.0);
    EXPECT_GE(f["physics_ms"].get<double>(), 0.0);
    EXPECT_LE(f["inside_1mm"].get<int>(), 0) << f; // after the clean-up, by the fit's measure
    EXPECT_EQ(f["crossing_edges"].get<int>(), 0) << f;
    EXPECT_GT(f["strain"]["mean"].get<double>(), 0.0);
  }
  const double w = report["garments"][0]["physical_weight"].get<double>();
  EXPECT_GE(w, 0.0);
  EXPECT_LE(w, 0.5);
  // At rest (frame 0) the tee fits as it was fitted: hardly anything inside the body.
  EXPECT_LE(report["frames"][0]["inside_1mm"].get<int>(), 5) << report["frames"][0];
  std::size_t frames = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir / "frames"))
    ++frames;
  EXPECT_EQ(frames, 13u);
  EXPECT_TRUE(std::filesystem::exists(dir / "frames" / "frame_00012.obj"));
  // The animated .glb is itself a motion: played back onto the same body, 13 frames at 24 fps.
  const auto again = test::run_cli({"animate", "--garment", (dir / "tee.obj").string(), "--motion",
                                    (dir / "anim.glb").string(), "--pose-rest", "apose", "--vertices", "3000",
                                    "--report", (dir / "again.json").string(), "--no-simulation", "--quiet"});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  const nlohmann::json replay = nlohmann::json::parse(test::read_file(dir / "again.json"));
  EXPECT_EQ(replay["motion"]["mapping"], "smpl");
  EXPECT_EQ(replay["motion"]["fps"], 24);
  EXPECT_EQ(replay["frames"].size(), 13u);
  const std::optional<std::string> validator = test::gltf_validator_report(dir / "anim.glb");
  if (!validator) GTEST_SKIP() << "the Khronos glTF validator is not installed (tools/install_deps.sh style)";
  const nlohmann::json v = nlohmann::json::parse(*validator);
  EXPECT_EQ(v["errors"], 0) << *validator;
  EXPECT_EQ(v["warnings"], 0) << *validator;
}

// Our own poses as a pose-sequence JSON: played without retargeting, at their rate.
TEST(AnimateCli, PlaysAPoseSequence) {
  test::TempDir dir;
  std::string frames;
  for (const char* name : {"rest", "walking", "rest"})
    frames += (frames.empty() ? "" : ", ") + pose_json(named_pose(name, RestPose::APOSE));
  test::write_file(dir / "poses.json", "{\"fps\": 10, \"frames\": [" + frames + "]}");
  GarmentOptions o;
  o.type = GarmentType::TROUSERS;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2000;
  write_mesh(dir / "trousers.obj", make_garment(o).mesh);
  const auto r = test::run_cli({"animate", "--garment", (dir / "trousers.obj").string(), "--motion",
                                (dir / "poses.json").string(), "--pose-rest", "apose", "--vertices", "3000", "--report",
                                (dir / "anim.json").string(), "--no-simulation", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(test::read_file(dir / "anim.json"));
  EXPECT_EQ(report["motion"]["mapping"], "poses");
  EXPECT_EQ(report["motion"]["fps"], 10);
  EXPECT_EQ(report["frames"].size(), 3u);
  EXPECT_EQ(report["garments"][0]["type"], "trousers");
  // LBS only: the physics off, nothing stepped.
  const auto lbs =
      test::run_cli({"animate", "--garment", (dir / "trousers.obj").string(), "--motion", (dir / "poses.json").string(),
                     "--pose-rest", "apose", "--vertices", "3000", "--report", (dir / "lbs.json").string(),
                     "--no-simulation", "--physics", "off", "--threads", "1", "--quiet"});
  ASSERT_EQ(lbs.exit_code, 0) << lbs.err;
  const nlohmann::json off = nlohmann::json::parse(test::read_file(dir / "lbs.json"));
  EXPECT_FALSE(off["physics"]["on"].get<bool>());
  EXPECT_EQ(off["threads"], 1);
  for (const auto& f : off["frames"])
    EXPECT_EQ(f["solver_iterations"], 0);
}

TEST(AnimateCli, BadInputWritesNothing) {
  test::TempDir dir;
  write_clip(dir / "clip.bvh");
  test::write_file(dir / "bad.bvh", "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n");
  test::write_file(dir / "tee.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  struct Case {
    std::vector<std::string> args;
    const char* message;
  };
  const std::string out = (dir / "o.glb").string(), report = (dir / "o.json").string();
  const std::vector<Case> cases = {
      {{"--garment", (dir / "tee.obj").string()}, "--motion FILE.bvh is required"},
      {{"--garment", (dir / "tee.obj").string(), "--motion", (dir / "bad.bvh").string()},
       "bad.bvh:5: unexpected end of file"},
      {{"--garment", (dir / "tee.obj").string(), "--motion", (dir / "clip.bvh").string(), "--pose", "walking"},
       "drop --pose"},
      {{"--garment", (dir / "tee.obj").string(), "--motion", (dir / "clip.bvh").string(), "--out",
        (dir / "o.obj").string()},
       "--out writes an animated .glb"},
      {{"--motion", (dir / "clip.bvh").string()}, "at least one --garment"},
      {{"--garment", (dir / "tee.obj").string(), "--motion", (dir / "clip.bvh").string(), "--physics", "maybe"},
       "--physics: expected on or off"},
      {{"--garment", (dir / "tee.obj").string(), "--motion", (dir / "clip.bvh").string(), "--threads", "0"},
       "--threads"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"animate"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    args.insert(args.end(), {"--report", report, "--quiet"});
    const auto r = test::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << c.message << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(report)) << c.message;
  }
}

} // namespace
} // namespace vfit
