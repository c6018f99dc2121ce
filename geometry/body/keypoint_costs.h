// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The terms of the keypoint fit's objective (keypoint_fit.h) with analytic derivatives: the
/// robust reprojection error of the body's points and the anatomical pose prior. Each is one
/// function that writes the residuals and, on request, their Jacobians, so that the forward
/// kinematics runs once per evaluation in doubles, on the joints that move the observed points
/// (instead of automatic differentiation with one 79-wide Jet per number). The prior comes in
/// terms on 1–3 joints each (pose_prior_terms()), so that a solver can assemble sparse normal
/// equations. The rotation derivatives are the
/// articulated chain rule: a change δ of joint k's axis-angle θ_k turns everything below k about
/// the posed joint t_k, ∂X/∂θ_k = −[X − t_k]× R_k J_r(θ_k), with R_k the joint's world rotation
/// and J_r the right Jacobian of SO(3) (R(θ + δ) ≈ R(θ) exp([J_r(θ) δ]×)).
/// Internal to the fit; a header so that tests can check the derivatives against differences.

#include <array>
#include <vector>

#include "keypoint_model.h"

namespace vfit::keypoint_detail {

inline constexpr int BODY_POSE = 3 * (JOINT_COUNT - 1); ///< the 69 non-root axis-angle numbers

/// The keypoints one term of the fit sees: body points (keypoints.h numbering), their pixels,
/// √(confidence × trust) each, and the Geman–McClure scale σ (px).
struct Observations {
  std::vector<int> points;             ///< body point of each keypoint
  std::vector<Eigen::Vector2d> pixels; ///< px, v down
  std::vector<double> sqrt_weight;     ///< √(confidence × trust), one per keypoint
  double sigma = 100;                  ///< Geman–McClure scale (px)
};

/// Robust reprojection residuals of every observation i, r_i = √w_i e_i σ / √(σ² + |e_i|²), so
/// |r_i|² = w_i ρ_GM(e_i) exactly, with e_i = Π(X_i) − x_i (px) and X_i the posed point
/// (KeypointBodyModel::posed_points() of shape `beta` and the pose global (3, root axis-angle),
/// body (BODY_POSE, the other joints' axis-angles), trans (3, m)). Points less than 5 cm in
/// front of the camera are projected as if 5 cm in front (no depth derivative there).
/// `residuals`: 2 × #observations (u, v of each in turn). `jacobians`: null, or 4 pointers
/// (global, body, trans, beta), each null or a row-major 2·#observations × (3, BODY_POSE, 3,
/// KEYPOINT_SHAPE_PARAMS) block, overwritten (Ceres' convention).
void reprojection(const KeypointBodyModel& model, const Observations& obs, const PinholeCamera& cam,
                  const double* global, const double* body, const double* trans, const double* beta, double* residuals,
                  double* const* jacobians);

/// The relaxed pose (arms ~60° down, elbows and knees slightly bent; BODY_POSE numbers, rad) and
/// the per-number weights of the prior's saturating pull toward it (px-equivalent per rad near it).
struct PoseMean {
  std::array<double, BODY_POSE> mean{};   ///< rad
  std::array<double, BODY_POSE> weight{}; ///< px-equivalent per rad
};

/// The prior's relaxed pose and weights, built on first use; thread-safe.
const PoseMean& pose_mean();

/// One term of the pose prior: `residuals` consecutive residuals of pose_prior() that depend on
/// the angles of `joints` only (1–3 joints in [1, JOINT_COUNT)), so that a solver sees the
/// prior's sparsity (each term its own residual block on per-joint parameter blocks).
struct PosePriorTerm {
  std::vector<int> joints; ///< joints whose axis-angles the term reads, in its Jacobian's column order
  int residuals = 0;       ///< number of residuals
};

/// The pose prior's terms in the order of pose_prior()'s residuals: per joint 1 … 23 its pull
/// toward the relaxed pose (3), its box limits and, for hips and shoulders, their direction
/// limits; then per arm (left, right) the upper arm's and forearm's behind-the-body costs, on
/// collar, shoulder and elbow. Built on first use; thread-safe.
const std::vector<PosePriorTerm>& pose_prior_terms();

/// Number of residuals of pose_prior(): the terms' residuals together (BODY_POSE pulls, the box
/// limits, 16 direction limits).
int pose_prior_residual_count();

/// Residuals of pose_prior_terms()[term] at the body pose `body` (BODY_POSE numbers) and, when
/// `jacobian` is not null, their derivatives (row-major residuals × 3·joints.size(), three
/// columns per joint of the term, overwritten). Throws std::out_of_range for a term past the
/// last.
void pose_prior_term(std::size_t term, const double* body, const std::array<double, BODY_POSE>& relaxed,
                     double* residuals, double* jacobian);

/// The anatomical pose prior E_pose (keypoint_fit.h) of the body pose `body` (BODY_POSE
/// numbers): a saturating pull toward `relaxed` (each upper arm toward the nearest of its three
/// rest places instead), box limits on joint angles and limits on limb directions, as
/// residuals (`residuals`: pose_prior_residual_count(), E_pose = Σ r²; every term of
/// pose_prior_terms() in turn). `jacobian`: null or row-major pose_prior_residual_count() ×
/// BODY_POSE, overwritten. The limits are one-sided (derivative 0 inside the range); the rest
/// place each arm is pulled toward is held fixed (chosen by the present pose, not
/// differentiated).
void pose_prior(const double* body, const std::array<double, BODY_POSE>& relaxed, double* residuals, double* jacobian);

} // namespace vfit::keypoint_detail
