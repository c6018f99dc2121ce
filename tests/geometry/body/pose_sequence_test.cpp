// SPDX-License-Identifier: Apache-2.0
// Pose-sequence JSON ({"fps": N, "frames": [pose, ...]}): read back as written by pose_json(),
// and refused naming the file and the frame's key.
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

TEST(PoseSequence, ReadsFramesWrittenByPoseJson) {
  test::TempDir dir;
  const Pose a = named_pose("walking", RestPose::TPOSE), b = named_pose("elbows_bent", RestPose::TPOSE);
  test::write_file(dir / "s.json", "{\"fps\": 24, \"frames\": [" + pose_json(a) + ", " + pose_json(b) + "]}");
  const PoseSequence s = read_pose_sequence_json(dir / "s.json");
  EXPECT_EQ(s.fps, 24);
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_LT((s.frames[0].axis_angle - a.axis_angle).norm(), 1e-12);
  EXPECT_LT((s.frames[1].axis_angle - b.axis_angle).norm(), 1e-12);
}

TEST(PoseSequence, BadFilesNameTheKey) {
  test::TempDir dir;
  const std::pair<const char*, const char*> cases[] = {
      {"[]", "expected {\"fps\": N"},
      {"{\"frames\": [{}]}", "'fps': expected"},
      {"{\"fps\": 0, \"frames\": [{}]}", "'fps': expected"},
      {"{\"fps\": 30, \"frames\": []}", "'frames': expected a non-empty array"},
      {"{\"fps\": 30, \"frames\": [{}, {\"left_elbo\": [0, 0, 1]}]}", "unknown joint 'frames[1].left_elbo'"},
      {"{\"fps\": 30, \"frames\": [{\"left_elbow\": [0, 0]}]}", "'frames[0].left_elbow': expected [x, y, z]"},
      {"{\"fps\": 30, \"frames\": [3]}", "'frames[0]': expected a JSON object"},
      {"{\"fps\": 30, \"frames\": [{}], \"extra\": 1}", "unknown key 'extra'"},
  };
  for (const auto& [text, message] : cases) {
    test::write_file(dir / "s.json", text);
    try {
      (void)read_pose_sequence_json(dir / "s.json");
      ADD_FAILURE() << text << ": accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("s.json"), std::string::npos) << what;
      EXPECT_NE(what.find(message), std::string::npos) << text << ": " << what;
    }
  }
}

} // namespace
} // namespace vfit
