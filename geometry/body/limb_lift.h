// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Depth hypotheses for the keypoint fit's limbs (keypoint_fit.h): a limb's 2D keypoints fix each
/// bone's depth up to a sign (Taylor, "Reconstruction of articulated objects from point
/// correspondences in a single uncalibrated image", CVIU 2000: the bone's end lies where the
/// camera ray through its pixel meets the sphere of the bone's length about its start, nearer or
/// farther). lift_limb() poses one limb on such a choice by inverse kinematics through its hinge
/// (elbow, knee): the upper joint's swing and twist put the hinge's plane through the three
/// joints, the hinge flexes the anatomical way only, so each of the 4 sign choices is one
/// anatomically bent limb whose joints project onto the keypoints.

#include <array>
#include <optional>

#include "skeleton.h"

namespace vfit {

/// A limb of three joints whose middle one is a hinge: upper (shoulder, hip), middle (elbow, knee)
/// and end (wrist, ankle) joints, and the hinge's flexion axis in the rest (T-pose) frame: a
/// positive rotation about it is flexion (elbow: forearm towards the front, knee: shin towards
/// the back).
struct HingeLimb {
  Joint upper;                  ///< shoulder or hip
  Joint middle;                 ///< elbow or knee: the hinge
  Joint end;                    ///< wrist or ankle
  Eigen::Vector3d flexion_axis; ///< unit, rest frame (left elbow −Y, right elbow +Y, knees +X)
};

/// The four hinge limbs: left arm, right arm, left leg, right leg.
const std::array<HingeLimb, 4>& hinge_limbs();

/// Which side of the sphere a lifted joint takes: NEAR (towards the camera) or FAR.
enum class LiftDepth : int { NEAR = -1, FAR = 1 };

/// Re-poses `limb` in `pose` (T-pose-relative axis-angle, translation in the camera frame; the
/// camera at the origin) on the rest skeleton `rest` (#JOINT_COUNT × 3, m) so that the middle
/// joint lies on the camera ray `middle_ray` (unit, from the origin) at the upper bone's length
/// from the upper joint, on the `middle_depth` side, and — when `end_ray` is given — the end joint
/// likewise on `end_ray` at the lower bone's length from there. Where a ray misses a bone's
/// sphere, the bone points at the ray's point nearest the sphere's centre (both sides agree).
/// Writes the upper and middle joints' rotations only: the middle joint's pure flexion about
/// limb.flexion_axis in [0, π] that opens the rest bones to the lifted angle, and the upper
/// joint's swing and twist that carry both bones onto their lifted directions (the hinge plane
/// through the three joints). Without `end_ray`, or with a straight limb, the hinge keeps its
/// present world axis (made square to the new upper bone) and its flexion. Never throws;
/// degenerate rays or bones leave `pose` as it was.
void lift_limb(const JointPositions& rest, const HingeLimb& limb, const Eigen::Vector3d& middle_ray,
               LiftDepth middle_depth, const std::optional<Eigen::Vector3d>& end_ray, LiftDepth end_depth, Pose& pose);

} // namespace vfit
