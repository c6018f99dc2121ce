// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Pose and shape of a body from a photo's 2D keypoints (seed 000 §3, which uses SMPLify):
/// SMPLify's objective with our own priors, solved with Ceres (analytic derivatives, keypoint_costs.h):
///   E(θ, β, t) = Σ_i w_i c_i ρ(Π(X_i(θ, β) + t) − x_i) + E_pose(θ) + E_shape(β)
/// with ρ Geman–McClure (σ = the torso's length in px), Π a pinhole camera, X_i the posed body point that
/// keypoint i observes, c_i its confidence and w_i its trust (0.5 for hips, whose annotations
/// sit off the joint centres; keypoints.h). SMPLify's learned pose prior cannot ship, so E_pose
/// is anatomical and ships without learned data: joint limits (elbows and knees hinge one way
/// only, spine, neck and collars within ranges, thighs and upper arms not far behind the body,
/// upper arms across the body only in front of the chest); a pull toward neutral humeral
/// rotation (the elbow's hinge axis square to the torso's forward axis); a soft cost on upper
/// arms, forearms and thighs pointing behind the torso's frontal plane (limbs reach forward
/// further than back); and a saturating pull toward a relaxed pose (arms ~60° down; each upper arm
/// toward the nearest of three rest places: hanging so, reaching forward, raised overhead):
/// quadratic near it, so 3 px of keypoint noise is not explained by bending limbs in depth,
/// levelling off ~0.5 rad away, so a pose the keypoints show is not dragged along its depth
/// ambiguity; weaker on
/// elbow and knee flexion (visible in 2D), stronger on what 2D joints cannot see (twists, hands,
/// feet); an elbow whose wrist keypoint is missing is pulled toward a typical 17° flexion instead
/// of the relaxed pose's 9° (its forearm is seen by nothing but the prior). The fit tries per-limb depth hypotheses
/// (each arm and leg lifted onto its keypoints' camera rays with its elbow or knee and its wrist or ankle nearer or
/// farther, limb_lift.h) and lets the objective, priors included, pick the winner.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "body.h"
#include "keypoint_model.h"
#include "keypoints.h"
#include "measurements.h"

namespace vfit {

/// The mannequin's keypoint model, built on first use and cached; thread-safe. The first use
/// places 9 uncalibrated mannequins (MannequinShape::uncalibrated(), whose skeleton and head
/// and foot shapes are the calibrated ones, without the girth calibration's cost).
const KeypointBodyModel& mannequin_keypoint_model();

/// Settings of fit_keypoints().
struct KeypointFitOptions {
  int max_iterations = 60; ///< per stage and start (Levenberg–Marquardt iterations)
  /// Ceres threads, at most 2. The residual blocks are small (a limb's keypoints, one prior
  /// term), so a second thread costs more than it shares; default 1.
  int threads = 1;
  bool fit_shape = true; ///< stage 3 (shape + pose); false: the average body's shape
  /// A warm start (e.g. the previous video frame's fit, or a known pose in a test): when set,
  /// stage 1 and the multi-start search of stage 2 are skipped and stages 2–3 start from this
  /// pose (T-pose-relative, translation in the camera frame of fit_keypoints()) and
  /// `initial_shape`.
  std::optional<Pose> initial_pose;
  KeypointShape initial_shape{}; ///< shape of the warm start (population σ); unused without initial_pose
};

/// One stage of the fit, as Ceres reported it.
struct KeypointFitStage {
  std::string name;   ///< "camera", "pose", "shape+pose"
  int iterations = 0; ///< Ceres iterations (all starts of the stage together)
  double ms = 0;      ///< wall time
  double cost = 0;    ///< final cost of the kept start
};

/// Result of fit_keypoints(): the body's pose, shape and camera, and how the fit went.
struct KeypointFit {
  /// T-pose-relative pose (SMPL layout; convert with pose_for_rest()); translation places the
  /// body in the camera's frame (m), so joints = posed_joints(rest_joints, pose).
  Pose pose;
  KeypointShape shape{};         ///< in population standard deviations
  BodyMeasurements measurements; ///< of that shape
  PinholeCamera camera;          ///< focal = Keypoints::focal, principal point = image centre (px)
  JointPositions rest_joints = JointPositions::Zero(); ///< T-pose joints of the shape
  JointPositions joints = JointPositions::Zero();      ///< posed joints, camera frame (m)
  std::vector<Eigen::Vector2d> projected;              ///< the fitted body's pixel for each input keypoint
  double mean_reprojection_px = 0;                     ///< mean |projected − keypoint| over the keypoints
  bool facing_away = false;                            ///< the back-facing start won stage 1
  std::vector<KeypointFitStage> stages;                ///< the stages run, in order
  double total_ms = 0;                                 ///< wall time of the whole fit (ms)
};

/// Fits the mannequin's pose, shape and position to `keypoints` in three stages (SMPLify):
/// 1 camera translation and global orientation on the torso keypoints, from the front- and the
/// back-facing start (translation from the torso's pixel length by similar triangles, depth held
/// near it by a prior), keeping the better; 2 pose (shape fixed), from that start and from its
/// mirror turn when the torso is turned (2D torso keypoints cannot tell a turn to the left from
/// one to the right), keeping the better, then per limb (arms, legs) its 4 depth hypotheses
/// (lift_limb(): middle and end joints nearer or farther on their camera rays; a missing middle
/// keypoint is replaced by the joint's present image, a missing end keypoint keeps the hinge),
/// each re-solved and kept when its objective is lower; 3 shape and pose. Robust to a few wrong keypoints
/// (Geman–McClure). Never throws for Keypoints from parse_keypoints(); a hand-built Keypoints
/// with no shoulder or no hip keypoint throws vfit::Error naming keypoints.source ("too few
/// torso keypoints for a fit"). options.threads is clamped to [1, 2].
KeypointFit fit_keypoints(const Keypoints& keypoints, const KeypointFitOptions& options = {});

/// The objective E(θ, β, t) above, with the last stage's weights and Ceres' convention (½ Σ r²,
/// px²-equivalent), of `pose` (T-pose-relative, translation in the camera frame of
/// fit_keypoints()) and `shape` against `keypoints`. A diagnostic: a fit that ends above the
/// objective of the true pose was stuck in a local minimum; one that ends below it lost to the
/// priors' preference (monocular ambiguity). Throws like fit_keypoints() (the same torso
/// check).
double keypoint_fit_objective(const Keypoints& keypoints, const Pose& pose, const KeypointShape& shape);

/// `pose` (relative to the T-pose rest skeleton) re-expressed for a skeleton whose rest pose is
/// `rest`, so that both give the same posed joints: for APOSE the shoulders' rotations lose the
/// A-pose's 45° arm drop and the arm's lower joints (elbow, wrist, hand) are conjugated by it.
/// TPOSE/OTHER: returned unchanged. Never throws.
Pose pose_for_rest(const Pose& pose, RestPose rest);

} // namespace vfit
