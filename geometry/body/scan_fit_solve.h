// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Internal to fit_scan() (scan_fit.h): the unknowns of seed 001 eq. 4, the correspondences of
/// one ICP round, and the Levenberg–Marquardt solve of the data term with its pose and shape
/// priors (Ceres). Not part of the public API.

#include <array>
#include <vector>

#include <Eigen/Core>

#include "skeleton.h"

namespace vfit::scan_detail {

using Vec3 = Eigen::Vector3d;

/// Axis-angle numbers of the joints below the root (3 per joint).
inline constexpr int BODY_POSE = 3 * (JOINT_COUNT - 1);
/// Shape numbers of the fit: log s, β1 (legs), β2 (arms), β3 (shoulders), then the elbows'
/// shift along the arm (see ELBOW_STEP).
inline constexpr int SHAPE_PARAMS = 5;
/// An elbow shift of 1 moves both elbows this far (m) toward their shoulders along the T-pose's
/// arm, the forearms' skin with them: rigs disagree on where the arm bends (the corpus body's rig
/// at 50 % of shoulder → wrist, our mannequin at 55 %, 3-6 cm apart at the fitted scale), and a
/// template that bends a few cm from where the scan's arm bends fits a bent arm by bending less
/// and turning the upper arm, so that the arm unposed with its weights (stage 5) keeps a residual
/// bend and its elbow is estimated 3-9 cm off (measured on the corpus body in 20 poses: 13 of them
/// had an elbow past 3 cm without the shift, 8 with it). The knees' place was tried the same way
/// and changed nothing measurable (the ankle of a bent leg stayed 3.7 cm off), so it is not fitted.
inline constexpr double ELBOW_STEP = 0.02;
inline constexpr double SHAPE_LIMIT = 3.0;      ///< |β| ≤ 3 σ, as the keypoint fit
inline constexpr double LOG_SCALE_LIMIT = 0.35; ///< s within ×0.70–×1.42 of the average body

/// The template's rest joints move with β through the keypoint model's basis (k = 1, 2, 3).
struct ShapeModel {
  JointPositions mean = JointPositions::Zero();   ///< the template's rest joints (m)
  std::array<JointPositions, 3> basis{};          ///< per σ of β1..β3 (m)
  JointPositions elbows = JointPositions::Zero(); ///< the elbows' shift per unit (ELBOW_STEP)

  /// The rest joints' change for shape numbers `shape` (SHAPE_PARAMS; log s not applied) (m).
  JointPositions displacement(const double* shape) const {
    JointPositions d = shape[4] * elbows;
    for (int k = 0; k < 3; ++k)
      d += shape[k + 1] * basis[static_cast<std::size_t>(k)];
    return d;
  }
};

/// One correspondence: a template point (rest position at the average shape and its ≤ 4 skin
/// influences) and its target in the scan; the residual weighs the offset across the plane of
/// `normal` fully and along it by `tangential` (1: point-to-point).
struct Pair {
  Vec3 rest;
  std::array<int, 4> joint{};
  std::array<double, 4> weight{};
  Vec3 target, normal;
  double sqrt_weight = 1, tangential = 1;
};

/// The unknowns of eq. 4: global rotation, the other joints' axis-angles (T-pose-relative),
/// translation (m) and the shape numbers (SHAPE_PARAMS).
struct State {
  std::array<double, 3> global{};
  std::array<double, BODY_POSE> body{};
  std::array<double, 3> trans{};
  std::array<double, SHAPE_PARAMS> shape{};
};

/// The pose of the unknowns: global rotation, body joints' axis-angles (3·(JOINT_COUNT − 1)) and
/// translation.
Pose pose_of(const double* global, const double* body, const double* trans);
/// The pose of `s`.
Pose pose_of(const State& s);
/// Rest (T-pose) joints of shape numbers `shape` (SHAPE_PARAMS): exp(log s) · (mean + shift) (m).
JointPositions rest_joints_of(const ShapeModel& m, const double* shape);

/// Levenberg–Marquardt over `s` (updated in place) for eq. 4's data term over `pairs` plus the
/// pose prior (a weak pull toward the T-pose, stronger on twists and on the neck's sideways
/// lean; one-sided hinge limits for elbows and knees) and the shape prior, at most `iterations`
/// iterations, the data term's normal equations accumulated on `threads` (1–2) threads (the same bits for either).
/// Returns the iterations taken. Empty `pairs`: only
/// the priors move `s`.
int solve(const ShapeModel& model, const std::vector<Pair>& pairs, State& s, int iterations, int threads);

} // namespace vfit::scan_detail
