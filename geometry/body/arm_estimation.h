// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// One arm's joints from sections of the body along the arm (a step of estimate_joints(),
/// joint_estimation.h; seed 001 §5): the arm is followed from the fingertip towards the
/// shoulder through planes normal to the shoulder → fingertip direction; the section
/// centroids give its centreline, the narrowest section before the hand gives the wrist, and
/// the upper arm's centreline meets the shoulder plane at the glenohumeral joint.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Where an arm is looked for: the body's frame and a first guess of the shoulder joint.
struct ArmSearch {
  Eigen::Vector3d shoulder_guess; ///< from the torso's sections (m); its x is kept
  int side = 1;                   ///< +1: the body's left arm (+X), −1: its right arm
  double floor = 0;               ///< lowest y of the body (m)
  double height = 0;              ///< the body's height (m)
  double mid_x = 0;               ///< x of the body's mid-sagittal plane (m)
  std::string source;             ///< names the body in errors
};

/// The joints of one arm (m) and the arm's pose.
struct ArmJoints {
  Eigen::Vector3d shoulder, elbow, wrist, hand;
  double drop_degrees = 0; ///< the upper arm's angle below horizontal (T-pose ≈ 0, A-pose ≈ 45)
  bool wrist_found = true; ///< false: no narrowing before the hand; the wrist is by proportion
};

/// Estimates one arm. Throws vfit::Error naming `search.source` when no arm stands away from
/// the torso on that side, when the arm is too short for the body (it touches the torso or
/// the legs) or when its upper arm is near vertical (arms down or raised: not A- or T-pose).
ArmJoints estimate_arm(const Mesh& mesh, const ArmSearch& search);

} // namespace vfit
