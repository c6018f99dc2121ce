// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Rigging a bare body scan (seed 001 §5): the 24 canonical joints estimated from the mesh's
/// geometry alone (horizontal sections for legs, torso, neck and head; sections along each
/// arm; anatomical proportions between the landmarks they give), then skin weights from the
/// joints. Conventions: metres, Y up, the body facing +Z, +X = the body's left.

#include <array>
#include <string>
#include <vector>

#include "body.h"

namespace vfit {

/// The joints estimated for a body scan, how sure the estimator is of each, and the rest pose.
struct JointEstimate {
  JointPositions joints = JointPositions::Zero(); ///< canonical joints (m), SMPL order
  /// Per joint, in (0, 1]: 0.9 for a joint placed on a clear geometric feature (the wrist's
  /// narrowing, the shoulder on the upper arm's axis, the ankle on the shank's), 0.7–0.8 for a
  /// section's centroid at a height set by proportion (knees, elbows, hips, neck, head), 0.5–0.6
  /// where rigs disagree on the convention (spine, collars) or the estimator fell back to a
  /// default (no narrowing found before the hand).
  std::array<double, JOINT_COUNT> confidence{};
  RestPose pose = RestPose::OTHER;   ///< TPOSE (upper arms within 25° of horizontal) or APOSE
  std::vector<std::string> warnings; ///< things worth showing the user (holes, asymmetry, ...)
};

/// Estimates the canonical joints of an upright body scan: a closed or nearly closed triangle
/// mesh (holes at the soles, neck or eyes are tolerated) in metres, Y up, facing +Z, standing
/// with the legs apart and the arms away from the torso (T-pose: upper arms within 25° of
/// horizontal; A-pose: 25°–70° below it). No skeleton is needed.
///
/// Landmarks: the crotch (where the torso's section splits into two legs), the armpits (where
/// the arms join the torso's section), the top of the shoulders and the neck's narrowest
/// section, the toes and fingertips. Joints follow from them: section centroids give x and z;
/// heights come from the landmarks and proportions calibrated on the MakeHuman hm08 rig and on
/// our mannequins. The spine joints follow SMPL's convention (spine1, spine2, spine3 at 20 %,
/// 42 % and 63 % of the way from the pelvis to the neck).
///
/// Throws vfit::Error, saying why, when the mesh is not an upright human in A- or T-pose: too
/// few vertices, not metre-sized, lying down (not taller than twice its depth and three
/// quarters of its width), no crotch with two legs reaching the floor, no neck, feet not
/// pointing to +Z, arms touching the torso, hanging down or raised above the head.
JointEstimate estimate_joints(const Mesh& body_in_metres);

/// Skin weights of `body` (a mesh in metres) for `joints` (canonical, m). Each joint owns the
/// bones from it to its children (the end joints, head, feet and hands, a bone continuing
/// their parent's); a vertex's weight for a bone falls off as 1/d⁶ with its distance d and is
/// zero for bones more than twice as far as the nearest (so a hand near a thigh never shares
/// it); the weights are then averaged over the mesh's edges for about 2 cm (1.2 % of the
/// skeleton's height) and the 4 largest kept and renormalised (SkinWeights::from_dense). Each
/// row sums to 1; neighbouring vertices' weights differ little. Throws vfit::Error for an
/// empty mesh.
SkinWeights estimate_skin_weights(const Mesh& body, const JointPositions& joints);

/// A bare body rigged: estimate_joints(), then estimate_skin_weights(). The returned Body owns
/// the mesh, its joints, weights and detected rest pose; `source` names where it came from (a
/// file path). Throws like estimate_joints(), the message naming `source`.
Body rig_bare_body(Mesh body, std::string source);

} // namespace vfit
