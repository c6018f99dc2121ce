// SPDX-License-Identifier: Apache-2.0
// The keypoint fit's objective terms (geometry/body/keypoint_costs.h): their analytic Jacobians
// against central differences of their own residuals, at random poses and shapes.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "vfit/geometry/body/keypoint_costs.h"
#include "vfit/geometry/body/keypoint_fit.h"

namespace vfit {
namespace {

using namespace keypoint_detail;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Central differences of `f` (residuals of a parameter vector x) at x, one column per number.
template <typename F> RowMatrix central_differences(F&& f, std::vector<double> x, int rows) {
  // STEP = 1e-6 on numbers of order 0.1–1 (rad, m, σ): truncation ~STEP² (≪ 1e-9 here), rounding
  // ~1e-16 · |r| / STEP ≈ 1e-7 for residuals of a few hundred px.
  constexpr double STEP = 1e-6;
  RowMatrix J(rows, static_cast<Eigen::Index>(x.size()));
  std::vector<double> plus(static_cast<std::size_t>(rows)), minus(static_cast<std::size_t>(rows));
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double x0 = x[k];
    x[k] = x0 + STEP;
    f(x.data(), plus.data());
    x[k] = x0 - STEP;
    f(x.data(), minus.data());
    x[k] = x0;
    for (int i = 0; i < rows; ++i)
      J(i, static_cast<Eigen::Index>(k)) =
          (plus[static_cast<std::size_t>(i)] - minus[static_cast<std::size_t>(i)]) / (2 * STEP);
  }
  return J;
}

// Analytic and differenced Jacobians agree to 1e-6 of the block's largest entry (hundreds of px
// per rad; rounding of the differences ~1e-7 px), at 6 poses drawn with every joint turned up to
// ±1.2 rad per axis (so that joint limits are active) and every body point observed 30 px off.
TEST(KeypointCosts, ReprojectionJacobiansMatchCentralDifferences) {
  const KeypointBodyModel& model = mannequin_keypoint_model();
  const PinholeCamera cam{1200.0, Eigen::Vector2d(500, 500)};
  std::mt19937 rng(11);
  auto draw = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  for (int trial = 0; trial < 6; ++trial) {
    std::vector<double> global = {draw(-0.5, 0.5), draw(-3, 3), draw(-0.3, 0.3)}, body(BODY_POSE),
                        trans = {draw(-0.3, 0.3), -0.2, -3.2};
    std::vector<double> beta(KEYPOINT_SHAPE_PARAMS);
    for (double& b : body)
      b = draw(-1.2, 1.2);
    for (double& b : beta)
      b = draw(-1.5, 1.5);
    Observations obs;
    obs.sigma = 150;
    Pose pose;
    pose.axis_angle.row(0) << global[0], global[1], global[2];
    for (int j = 1; j < JOINT_COUNT; ++j)
      pose.axis_angle.row(j) << body[3 * (j - 1)], body[3 * (j - 1) + 1], body[3 * (j - 1) + 2];
    pose.translation << trans[0], trans[1], trans[2];
    const KeypointShape shape = {beta[0], beta[1], beta[2], beta[3]};
    const auto posed = model.posed_points(shape, pose);
    for (int p = 0; p < BODY_POINT_COUNT; ++p) {
      obs.points.push_back(p);
      obs.pixels.push_back(cam.project(posed.row(p).transpose()) + Eigen::Vector2d(draw(-30, 30), draw(-30, 30)));
      obs.sqrt_weight.push_back(draw(0.5, 1.0));
    }
    const int rows = 2 * BODY_POINT_COUNT;
    std::vector<double> r(static_cast<std::size_t>(rows));
    std::array<RowMatrix, 4> analytic = {RowMatrix(rows, 3), RowMatrix(rows, BODY_POSE), RowMatrix(rows, 3),
                                         RowMatrix(rows, KEYPOINT_SHAPE_PARAMS)};
    double* jac[4] = {analytic[0].data(), analytic[1].data(), analytic[2].data(), analytic[3].data()};
    reprojection(model, obs, cam, global.data(), body.data(), trans.data(), beta.data(), r.data(), jac);
    // The residuals are the ones posed_points() and project() give.
    for (int p = 0; p < BODY_POINT_COUNT; ++p) {
      const Eigen::Vector2d e = cam.project(posed.row(p).transpose()) - obs.pixels[static_cast<std::size_t>(p)];
      const double s =
          obs.sqrt_weight[static_cast<std::size_t>(p)] * obs.sigma / std::sqrt(obs.sigma * obs.sigma + e.squaredNorm());
      EXPECT_NEAR(r[static_cast<std::size_t>(2 * p)], s * e.x(), 1e-9);
      EXPECT_NEAR(r[static_cast<std::size_t>(2 * p + 1)], s * e.y(), 1e-9);
    }
    std::array<std::vector<double>*, 4> blocks = {&global, &body, &trans, &beta};
    for (std::size_t b = 0; b < 4; ++b) {
      auto f = [&](const double* x, double* out) {
        std::array<const double*, 4> p = {global.data(), body.data(), trans.data(), beta.data()};
        p[b] = x;
        reprojection(model, obs, cam, p[0], p[1], p[2], p[3], out, nullptr);
      };
      const RowMatrix numeric = central_differences(f, *blocks[b], rows);
      const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
      EXPECT_LT((analytic[b] - numeric).cwiseAbs().maxCoeff(), 1e-6 * scale) << "trial " << trial << ", block " << b;
    }
  }
}

// The pose prior's Jacobian against central differences at poses with joint limits active (the
// one-sided limits are differentiable away from their bounds; a draw lands within 1e-6 of a
// bound with probability ~1e-5 per number).
TEST(KeypointCosts, PosePriorJacobianMatchesCentralDifferences) {
  std::mt19937 rng(5);
  auto draw = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  const int rows = pose_prior_residual_count();
  int active_limits = 0;
  for (int trial = 0; trial < 8; ++trial) {
    std::vector<double> body(BODY_POSE);
    for (double& b : body)
      b = draw(-1.4, 1.4);
    std::vector<double> r(static_cast<std::size_t>(rows));
    RowMatrix analytic(rows, BODY_POSE);
    pose_prior(body.data(), pose_mean().mean, r.data(), analytic.data());
    for (int i = BODY_POSE; i < rows; ++i)
      active_limits += r[static_cast<std::size_t>(i)] != 0.0;
    const RowMatrix numeric = central_differences(
        [&](const double* x, double* out) { pose_prior(x, pose_mean().mean, out, nullptr); }, body, rows);
    const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
    EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-6 * scale) << "trial " << trial;
    // Each term reads only its own joints (the fit gives it nothing else): with every other
    // joint zeroed it gives pose_prior()'s rows exactly.
    int row = 0;
    for (std::size_t t = 0; t < pose_prior_terms().size(); ++t) {
      const PosePriorTerm& term = pose_prior_terms()[t];
      std::vector<double> only(BODY_POSE, 0.0), rt(static_cast<std::size_t>(term.residuals));
      for (int j : term.joints)
        for (int a = 0; a < 3; ++a)
          only[static_cast<std::size_t>(3 * (j - 1) + a)] = body[static_cast<std::size_t>(3 * (j - 1) + a)];
      pose_prior_term(t, only.data(), pose_mean().mean, rt.data(), nullptr);
      for (int i = 0; i < term.residuals; ++i)
        EXPECT_EQ(rt[static_cast<std::size_t>(i)], r[static_cast<std::size_t>(row + i)]) << "term " << t;
      row += term.residuals;
    }
    EXPECT_EQ(row, rows);
  }
  EXPECT_GT(active_limits, 8 * 10) << "the draws exercise the limits"; // measured count printed on failure
}

} // namespace
} // namespace vfit
