// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include "vfit/geometry/body/measurements.h"

namespace vfit {
namespace {

// A body as points: a torso 0.26 m deep between the hips (y 0.9) and shoulders (y 1.4), arms
// beside it (out past the shoulders' span, 0.5 m deep: a hand in front), a head and feet deeper
// than the torso above and below it. Only the torso's points count: its depth exactly.
TEST(TorsoDepth, IsTheTorsosDepthArmsHeadAndFeetLeftOut) {
  JointPositions joints = JointPositions::Zero();
  joints.row(idx(Joint::LEFT_HIP)) << 0.09, 0.9, 0.0;
  joints.row(idx(Joint::RIGHT_HIP)) << -0.09, 0.9, 0.0;
  joints.row(idx(Joint::LEFT_SHOULDER)) << 0.18, 1.4, 0.0;
  joints.row(idx(Joint::RIGHT_SHOULDER)) << -0.18, 1.4, 0.0;
  Mesh body;
  auto add = [&](float x, float y, float z) { body.positions.insert(body.positions.end(), {x, y, z}); };
  for (float y : {0.95f, 1.1f, 1.35f})
    for (float x : {-0.15f, 0.0f, 0.15f}) {
      add(x, y, -0.12f);
      add(x, y, 0.14f);
    }
  for (float y : {0.95f, 1.2f}) {
    add(0.3f, y, -0.25f); // arms and hands beside the torso
    add(-0.3f, y, 0.25f);
  }
  add(0.0f, 1.6f, 0.4f); // head above the shoulders, feet below the hips
  add(0.0f, 0.05f, -0.4f);
  EXPECT_NEAR(torso_depth(body, joints), 0.26, 1e-6); // float coordinates
  // No point in the torso's box (joints that are not this body's): 0.
  joints *= 10.0;
  EXPECT_EQ(torso_depth(body, joints), 0.0);
}

} // namespace
} // namespace vfit
