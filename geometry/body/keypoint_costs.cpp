// SPDX-License-Identifier: Apache-2.0
#include "keypoint_costs.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <ceres/rotation.h>

namespace vfit::keypoint_detail {
namespace {

constexpr double PI = std::numbers::pi;

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using RowJacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Mat3 rotation(const double* w) {
  Mat3 R;
  ceres::AngleAxisToRotationMatrix(w, R.data()); // column-major, as Eigen
  return R;
}

// Right Jacobian of SO(3): R(θ + δ) ≈ R(θ) exp([J_r(θ) δ]×). Below |θ|² = 1e-4 the series to
// θ⁴ (error ~|θ|⁶/40320), above it the closed form (cancellation ≤ 1e-16 / 5e-5 relative).
Mat3 right_jacobian(const double* w) {
  const Vec3 v(w[0], w[1], w[2]);
  const double t2 = v.squaredNorm();
  double a, b;
  if (t2 < 1e-4) {
    a = 0.5 - t2 / 24 + t2 * t2 / 720;
    b = 1.0 / 6 - t2 / 120 + t2 * t2 / 5040;
  } else {
    const double t = std::sqrt(t2);
    a = (1 - std::cos(t)) / t2;
    b = (t - std::sin(t)) / (t2 * t);
  }
  const Mat3 K = skew(v);
  return Mat3::Identity() - a * K + b * K * K;
}

// ∂(R(θ) v)/∂θ = −R [v]× J_r(θ).
Mat3 rotated_derivative(const double* w, const Mat3& R, const Vec3& v) { return -R * skew(v) * right_jacobian(w); }

Vec3 rotate(const double* w, const Vec3& v) {
  Vec3 out;
  ceres::AngleAxisRotatePoint(w, v.data(), out.data());
  return out;
}

} // namespace

// ---------------------------------------------------------------------------------------------
// Reprojection.

void reprojection(const KeypointBodyModel& model, const Observations& obs, const PinholeCamera& cam,
                  const double* global, const double* body, const double* trans, const double* beta, double* residuals,
                  double* const* jacobians) {
  // Forward kinematics of the rest joints of β, once for all points, on the joints that move
  // them (a limb's keypoints need ~8 of the 24).
  static const std::array<int, JOINT_COUNT> parent = [] {
    std::array<int, JOINT_COUNT> p{};
    for (int j = 0; j < JOINT_COUNT; ++j)
      p[static_cast<std::size_t>(j)] = joint_parent(j);
    return p;
  }();
  std::array<bool, JOINT_COUNT> needed{};
  for (int pt : obs.points)
    for (int j = model.joint[static_cast<std::size_t>(pt)]; j >= 0 && !needed[static_cast<std::size_t>(j)];
         j = parent[static_cast<std::size_t>(j)])
      needed[static_cast<std::size_t>(j)] = true;
  std::array<Vec3, JOINT_COUNT> J, t;
  std::array<Mat3, JOINT_COUNT> R;
  auto rest = [&](int i) {
    Vec3 p = model.mean.row(i).transpose();
    for (int k = 0; k < KEYPOINT_SHAPE_PARAMS; ++k)
      p += model.basis[static_cast<std::size_t>(k)].row(i).transpose() * beta[k];
    return p;
  };
  auto angles = [&](int j) { return j == 0 ? global : body + 3 * (j - 1); };
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    if (!needed[uj]) continue; // a joint's parent comes before it, and is needed when it is
    J[uj] = rest(j);
    const Mat3 local = rotation(angles(j));
    if (j == 0) {
      R[0] = local;
      t[0] = J[0] + Vec3(trans[0], trans[1], trans[2]);
    } else {
      const auto p = static_cast<std::size_t>(parent[uj]);
      R[uj] = R[p] * local;
      t[uj] = R[p] * (J[uj] - J[p]) + t[p];
    }
  }
  double* const jg = jacobians ? jacobians[0] : nullptr;
  double* const jb = jacobians ? jacobians[1] : nullptr;
  double* const jt = jacobians ? jacobians[2] : nullptr;
  double* const js = jacobians ? jacobians[3] : nullptr;
  const auto rows = 2 * obs.points.size();
  if (jg) std::fill(jg, jg + rows * 3, 0.0);
  if (jb) std::fill(jb, jb + rows * BODY_POSE, 0.0);
  if (jt) std::fill(jt, jt + rows * 3, 0.0);
  if (js) std::fill(js, js + rows * KEYPOINT_SHAPE_PARAMS, 0.0);
  // B_k = R_k J_r(θ_k): ∂X/∂θ_k = −[X − t_k]× B_k for every X below joint k.
  std::array<Mat3, JOINT_COUNT> B;
  if (jg || jb)
    for (int j = 0; j < JOINT_COUNT; ++j)
      if (needed[static_cast<std::size_t>(j)])
        B[static_cast<std::size_t>(j)] = R[static_cast<std::size_t>(j)] * right_jacobian(angles(j));
  // ∂t_j/∂β (3 × 4 per joint): t_j = R_p (J_j − J_p) + t_p with the rotations fixed.
  using ShapeJacobian = Eigen::Matrix<double, 3, KEYPOINT_SHAPE_PARAMS>;
  auto rest_basis = [&](int i) {
    ShapeJacobian d;
    for (int k = 0; k < KEYPOINT_SHAPE_PARAMS; ++k)
      d.col(k) = model.basis[static_cast<std::size_t>(k)].row(i).transpose();
    return d;
  };
  std::array<ShapeJacobian, JOINT_COUNT> dt;
  if (js) {
    dt[0] = rest_basis(0);
    for (int j = 1; j < JOINT_COUNT; ++j) {
      const auto uj = static_cast<std::size_t>(j), p = static_cast<std::size_t>(parent[uj]);
      if (!needed[uj]) continue;
      dt[uj] = R[p] * (rest_basis(j) - rest_basis(parent[uj])) + dt[p];
    }
  }

  const double sigma2 = obs.sigma * obs.sigma;
  for (std::size_t i = 0; i < obs.points.size(); ++i) {
    const int pt = obs.points[i];
    const int a = model.joint[static_cast<std::size_t>(pt)];
    const auto ua = static_cast<std::size_t>(a);
    const Vec3 X = pt < JOINT_COUNT ? t[static_cast<std::size_t>(pt)] : Vec3(R[ua] * (rest(pt) - J[ua]) + t[ua]);
    // Points behind or at the camera are held at 5 cm in front of it (the optimiser steps back).
    double depth = -X.z();
    const bool clamped = depth < 0.05;
    if (clamped) depth = 0.05;
    const double u = cam.principal_point.x() + cam.focal * X.x() / depth;
    const double v = cam.principal_point.y() - cam.focal * X.y() / depth;
    const double eu = u - obs.pixels[i].x(), ev = v - obs.pixels[i].y();
    const double q = sigma2 + eu * eu + ev * ev;
    const double s = obs.sqrt_weight[i] * obs.sigma / std::sqrt(q);
    residuals[2 * i] = s * eu;
    residuals[2 * i + 1] = s * ev;
    if (!jg && !jb && !jt && !js) continue;
    // M = ∂r/∂X = ∂r/∂e · ∂e/∂X, with ∂r/∂e = s (I − e eᵀ / q).
    const Eigen::Vector2d e(eu, ev);
    const Eigen::Matrix2d dr_de = s * (Eigen::Matrix2d::Identity() - e * e.transpose() / q);
    Eigen::Matrix<double, 2, 3> de_dX;
    de_dX << cam.focal / depth, 0, clamped ? 0.0 : cam.focal * X.x() / (depth * depth), //
        0, -cam.focal / depth, clamped ? 0.0 : -cam.focal * X.y() / (depth * depth);
    const Eigen::Matrix<double, 2, 3> M = dr_de * de_dX;
    using Rows = Eigen::Map<Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::RowMajor>, 0, Eigen::OuterStride<>>;
    if (jt) Rows(jt + 2 * i * 3, 2, 3, Eigen::OuterStride<>(3)) = M;
    if (jg || jb)
      for (int k = a; k >= 0; k = parent[static_cast<std::size_t>(k)]) {
        if (k == pt) continue; // a joint's own rotation does not move it
        const Eigen::Matrix<double, 2, 3> C =
            -M * skew(X - t[static_cast<std::size_t>(k)]) * B[static_cast<std::size_t>(k)];
        if (k == 0) {
          if (jg) Rows(jg + 2 * i * 3, 2, 3, Eigen::OuterStride<>(3)) = C;
        } else if (jb) {
          Rows(jb + 2 * i * BODY_POSE + 3 * (k - 1), 2, 3, Eigen::OuterStride<>(BODY_POSE)) = C;
        }
      }
    if (js) {
      const ShapeJacobian dX = pt < JOINT_COUNT ? dt[static_cast<std::size_t>(pt)]
                                                : ShapeJacobian(R[ua] * (rest_basis(pt) - rest_basis(a)) + dt[ua]);
      Rows(js + 2 * i * KEYPOINT_SHAPE_PARAMS, 2, KEYPOINT_SHAPE_PARAMS, Eigen::OuterStride<>(KEYPOINT_SHAPE_PARAMS)) =
          M * dX;
    }
  }
}

// ---------------------------------------------------------------------------------------------

namespace {

// Pose prior: anatomical limits and a saturating pull toward a relaxed pose, each arm toward the
// nearest of three rest places (T-pose-relative axis-angle; body faces +Z, +X is its left, so
// e.g. a knee bends about +X and the left elbow about −Y).

struct BoxLimit {
  int joint, axis;
  double lo, hi;
};

const std::vector<BoxLimit>& box_limits() {
  static const std::vector<BoxLimit> limits = [] {
    std::vector<BoxLimit> v;
    auto box = [&](Joint j, double xl, double xh, double yl, double yh, double zl, double zh) {
      v.push_back({idx(j), 0, xl, xh});
      v.push_back({idx(j), 1, yl, yh});
      v.push_back({idx(j), 2, zl, zh});
    };
    for (Joint j : {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3})
      box(j, -0.35, 0.60, -0.45, 0.45, -0.35, 0.35);
    box(Joint::NECK, -0.50, 0.60, -0.70, 0.70, -0.40, 0.40);
    box(Joint::HEAD, -0.45, 0.45, -0.60, 0.60, -0.35, 0.35);
    for (Joint j : {Joint::LEFT_COLLAR, Joint::RIGHT_COLLAR})
      box(j, -0.30, 0.30, -0.30, 0.30, -0.35, 0.35);
    // Knees hinge forward only: flexion about +X up to ~150°, a little twist, no side bend.
    for (Joint j : {Joint::LEFT_KNEE, Joint::RIGHT_KNEE})
      box(j, 0.0, 2.6, -0.30, 0.30, -0.10, 0.10);
    // Elbows hinge forward only (left about −Y, right about +Y); forearm twist is free-ish.
    box(Joint::LEFT_ELBOW, -1.5, 1.5, -2.6, 0.0, -0.10, 0.10);
    box(Joint::RIGHT_ELBOW, -1.5, 1.5, 0.0, 2.6, -0.10, 0.10);
    for (Joint j : {Joint::LEFT_ANKLE, Joint::RIGHT_ANKLE})
      box(j, -0.80, 0.60, -0.40, 0.40, -0.40, 0.40);
    // Ball joints: twist about the bone (x for arms, y for thighs) within a range; direction
    // limits below.
    for (Joint j : {Joint::LEFT_SHOULDER, Joint::RIGHT_SHOULDER})
      v.push_back({idx(j), 0, -1.3, 1.3});
    for (Joint j : {Joint::LEFT_HIP, Joint::RIGHT_HIP})
      v.push_back({idx(j), 1, -0.7, 0.7});
    return v;
  }();
  return limits;
}

constexpr double LIMIT_WEIGHT = 400.0; // px-equivalent per rad (or per unit of direction)
// px-equivalent per unit of an upper arm's hinge axis along the torso's forward axis (humeral
// rotation away from neutral).
constexpr double HINGE_WEIGHT = 20.0;
constexpr double PRIOR_SATURATION = 0.5; // rad: where the pull toward the relaxed pose levels off
constexpr double BEHIND_WEIGHT = 20.0;   // px-equivalent per unit of a limb's backward direction
constexpr double BEHIND_MARGIN = 0.2;    // backward direction component free of cost (~12°)

// Where an upper arm rests besides the relaxed pose's ~60° drop (T-pose-relative axis-angle of the
// shoulder, left arm; the right arm's mirror negates the y and z numbers): reaching forward
// (horizontal, pointing ahead) and raised overhead. Everyday arms work in these three places
// (hanging, handling things in front, reaching up); a single relaxed pose pulls a forward or
// raised arm back down along its depth ambiguity, which the keypoints cannot resist.
constexpr std::array<std::array<double, 3>, 2> ARM_MODES = {{{0.0, -PI / 2, 0.0}, {0.0, 0.0, PI / 2}}};

} // namespace

// Weights strong on what 2D joints barely see.
const PoseMean& pose_mean() {
  static const PoseMean m = [] {
    PoseMean p;
    auto at = [](Joint j, int axis) { return static_cast<std::size_t>(3 * (idx(j) - 1) + axis); };
    p.mean[at(Joint::LEFT_SHOULDER, 2)] = -1.05;
    p.mean[at(Joint::RIGHT_SHOULDER, 2)] = 1.05;
    p.mean[at(Joint::LEFT_ELBOW, 1)] = -0.15;
    p.mean[at(Joint::RIGHT_ELBOW, 1)] = 0.15;
    p.mean[at(Joint::LEFT_KNEE, 0)] = 0.08;
    p.mean[at(Joint::RIGHT_KNEE, 0)] = 0.08;
    p.weight.fill(20.0);
    for (Joint j : {Joint::LEFT_WRIST, Joint::RIGHT_WRIST, Joint::LEFT_HAND, Joint::RIGHT_HAND, Joint::LEFT_FOOT,
                    Joint::RIGHT_FOOT})
      for (int a = 0; a < 3; ++a)
        p.weight[at(j, a)] = 200.0;
    // The torso and neck stay near upright unless the keypoints insist: 2D joints cannot tell a
    // spine bent towards the camera from one bent away.
    for (Joint j : {Joint::LEFT_COLLAR, Joint::RIGHT_COLLAR, Joint::SPINE1, Joint::SPINE2, Joint::SPINE3, Joint::NECK})
      for (int a = 0; a < 3; ++a)
        p.weight[at(j, a)] = 40.0;
    // Twists about the bone: invisible in 2D joints.
    p.weight[at(Joint::LEFT_ELBOW, 0)] = p.weight[at(Joint::RIGHT_ELBOW, 0)] = 60.0;
    p.weight[at(Joint::LEFT_SHOULDER, 0)] = p.weight[at(Joint::RIGHT_SHOULDER, 0)] = 20.0;
    // Elbow and knee flexion: everyday poses use the whole range and the 2D angle between the
    // bones shows it in most views, so the pull is half the default: it settles a foreshortened
    // limb without straightening a bent one that the keypoints show.
    p.weight[at(Joint::LEFT_ELBOW, 1)] = p.weight[at(Joint::RIGHT_ELBOW, 1)] = 10.0;
    p.weight[at(Joint::LEFT_KNEE, 0)] = p.weight[at(Joint::RIGHT_KNEE, 0)] = 10.0;
    p.weight[at(Joint::LEFT_KNEE, 1)] = p.weight[at(Joint::RIGHT_KNEE, 1)] = 60.0;
    return p;
  }();
  return m;
}

const std::vector<PosePriorTerm>& pose_prior_terms() {
  static const std::vector<PosePriorTerm> terms = [] {
    std::vector<PosePriorTerm> v;
    for (int j = 1; j < JOINT_COUNT; ++j) {
      int rows = 3; // the pull
      for (const BoxLimit& b : box_limits())
        rows += b.joint == j;
      if (j == idx(Joint::LEFT_HIP) || j == idx(Joint::RIGHT_HIP)) rows += 3;           // extension, crossing, behind
      if (j == idx(Joint::LEFT_SHOULDER) || j == idx(Joint::RIGHT_SHOULDER)) rows += 3; // far behind, across, rotation
      v.push_back({{j}, rows});
    }
    v.push_back({{idx(Joint::LEFT_COLLAR), idx(Joint::LEFT_SHOULDER), idx(Joint::LEFT_ELBOW)}, 2});
    v.push_back({{idx(Joint::RIGHT_COLLAR), idx(Joint::RIGHT_SHOULDER), idx(Joint::RIGHT_ELBOW)}, 2});
    return v;
  }();
  return terms;
}

int pose_prior_residual_count() {
  static const int count = [] {
    int n = 0;
    for (const PosePriorTerm& t : pose_prior_terms())
      n += t.residuals;
    return n;
  }();
  return count;
}

void pose_prior_term(std::size_t term, const double* body, const std::array<double, BODY_POSE>& relaxed, double* r,
                     double* jacobian) {
  const PosePriorTerm& pt = pose_prior_terms().at(term);
  const auto cols = static_cast<Eigen::Index>(3 * pt.joints.size());
  Eigen::Map<RowJacobian> Jac(jacobian, jacobian ? pt.residuals : 0, jacobian ? cols : 0);
  if (jacobian) Jac.setZero();
  int k = 0;
  auto angles = [&](Joint j) { return body + 3 * (idx(j) - 1); };
  auto column = [&](Joint j) {
    return 3 * static_cast<Eigen::Index>(std::find(pt.joints.begin(), pt.joints.end(), idx(j)) - pt.joints.begin());
  };
  auto excess = [](double x, double lo, double hi) { return x > hi ? x - hi : (x < lo ? x - lo : 0.0); };
  auto slope = [](double x, double lo, double hi) { return x > hi || x < lo ? 1.0 : 0.0; };
  // A residual w · excess(x) of a component x of a rotated direction: its Jacobian row
  // w · slope · ∂x/∂θ over the joints' columns.
  using Row3 = Eigen::Matrix<double, 1, 3>;
  auto put = [&](double w, double x, double lo, double hi, std::initializer_list<std::pair<Joint, Row3>> grads) {
    r[k] = w * excess(x, lo, hi);
    if (jacobian && slope(x, lo, hi) != 0.0)
      for (const auto& [j, g] : grads)
        Jac.block<1, 3>(k, column(j)) += w * g;
    ++k;
  };
  const Vec3 down(0, -1, 0);

  if (term + 1 < static_cast<std::size_t>(JOINT_COUNT)) {
    const int j = pt.joints[0];
    const Joint joint = static_cast<Joint>(j);
    const auto at = static_cast<std::size_t>(3 * (j - 1));
    const PoseMean& m = pose_mean();
    // Saturating (Geman–McClure-like) pull toward the relaxed pose: quadratic for small
    // deviations, so keypoint noise is not explained by bending limbs in depth, but bounded for
    // large ones (r² → (w·PRIOR_SATURATION)²), so a pose the keypoints clearly show is not
    // dragged along its depth ambiguity toward the relaxed pose.
    // Each shoulder is pulled toward the nearest of its three rest places (ARM_MODES and the
    // relaxed pose), nearest by this pull's own cost at the present pose: a mixture prior's
    // minimum, continuous, with a kink where two places are equally near.
    constexpr double S2 = PRIOR_SATURATION * PRIOR_SATURATION;
    auto pull2 = [&](std::size_t i, double target) {
      const double d = body[i] - target, w = m.weight[i];
      return w * w * d * d / (1 + d * d / S2);
    };
    std::array<double, 3> target = {relaxed[at], relaxed[at + 1], relaxed[at + 2]};
    const bool shoulder = joint == Joint::LEFT_SHOULDER || joint == Joint::RIGHT_SHOULDER;
    if (shoulder) {
      const double side = joint == Joint::LEFT_SHOULDER ? 1.0 : -1.0;
      double best = pull2(at, relaxed[at]) + pull2(at + 1, relaxed[at + 1]) + pull2(at + 2, relaxed[at + 2]);
      for (const auto& mode : ARM_MODES) {
        const double c = pull2(at, mode[0]) + pull2(at + 1, side * mode[1]) + pull2(at + 2, side * mode[2]);
        if (c < best) {
          best = c;
          target = {mode[0], side * mode[1], side * mode[2]};
        }
      }
    }
    for (std::size_t a = 0; a < 3; ++a) {
      const double d = body[at + a] - target[a], g = 1 + d * d / S2;
      r[k] = m.weight[at + a] * d / std::sqrt(g);
      if (jacobian)
        Jac(k, static_cast<Eigen::Index>(a)) = m.weight[at + a] / (g * std::sqrt(g)); // d/dd [w d / √(1 + d²/S²)]
      ++k;
    }
    for (const BoxLimit& b : box_limits()) {
      if (b.joint != j) continue;
      const double x = body[3 * (b.joint - 1) + b.axis];
      r[k] = LIMIT_WEIGHT * excess(x, b.lo, b.hi);
      if (jacobian) Jac(k, b.axis) = LIMIT_WEIGHT * slope(x, b.lo, b.hi);
      ++k;
    }
    if (joint == Joint::LEFT_HIP || joint == Joint::RIGHT_HIP) {
      // Thighs: not more than 30° behind the body, not crossing far over the mid-line; and the
      // softer behind-the-body cost below.
      const Vec3 d = rotate(angles(joint), down);
      const Mat3 D = jacobian ? rotated_derivative(angles(joint), rotation(angles(joint)), down) : Mat3::Zero();
      const double side = joint == Joint::LEFT_HIP ? 1.0 : -1.0;
      put(LIMIT_WEIGHT, d.z(), -0.5, 10.0, {{joint, D.row(2)}});
      put(LIMIT_WEIGHT, side * d.x(), -0.35, 10.0, {{joint, side * D.row(0)}});
      put(BEHIND_WEIGHT, d.z(), -BEHIND_MARGIN, 10.0, {{joint, D.row(2)}});
    }
    if (shoulder) {
      // Upper arms: not far behind the body, and not across it except in front of the chest:
      // the shoulder adducts ~25° past the vertical in the frontal plane (sin 25° ≈ 0.4),
      // further only as the arm comes forward (horizontal adduction); an arm pointing through
      // the torso or over and down the other side is out of range.
      const double side = joint == Joint::LEFT_SHOULDER ? 1.0 : -1.0;
      const Vec3 out(side, 0, 0);
      const Vec3 d = rotate(angles(joint), out);
      const Mat3 Rs = jacobian ? rotation(angles(joint)) : Mat3::Identity();
      const Mat3 D = jacobian ? rotated_derivative(angles(joint), Rs, out) : Mat3::Zero();
      put(LIMIT_WEIGHT, d.z(), -0.6, 10.0, {{joint, D.row(2)}});
      const double forward = d.z() > 0 ? d.z() : 0.0;
      put(LIMIT_WEIGHT, -side * d.x() - forward, -10.0, 0.4,
          {{joint, -side * D.row(0) - (d.z() > 0 ? 1.0 : 0.0) * D.row(2)}});
      // Humeral rotation: in neutral rotation the elbow's hinge axis lies square to the torso's
      // forward axis (the forearm flexes in the arm's plane of elevation, towards the front when
      // the arm hangs); rotating the humerus inwards or outwards tilts the axis forward or back.
      // A pull toward neutral, which also tells a forearm bent towards the camera from one bent
      // away (the other needs a humerus turned far round). Silent where the arm points forward
      // (the axis is then square to it whatever the rotation).
      const Vec3 hinge_rest(0, -side, 0);
      const Vec3 hinge = rotate(angles(joint), hinge_rest);
      r[k] = HINGE_WEIGHT * hinge.z();
      if (jacobian) Jac.block<1, 3>(k, 0) = HINGE_WEIGHT * rotated_derivative(angles(joint), Rs, hinge_rest).row(2);
      ++k;
    }
    return;
  }
  // Limbs reach forward further than back (shoulder flexion ~180° against extension ~50°, hip
  // flexion ~120° against extension ~20°): a soft cost on each upper arm, forearm and thigh
  // (above) pointing behind the torso's frontal plane, beyond a margin that lets arms and legs
  // swing. upper = R_c R_s out, fore = R_c R_s R_e out.
  const Joint collar = static_cast<Joint>(pt.joints[0]), sh = static_cast<Joint>(pt.joints[1]),
              elbow = static_cast<Joint>(pt.joints[2]);
  const Vec3 out(sh == Joint::LEFT_SHOULDER ? 1.0 : -1.0, 0, 0);
  const Vec3 a = rotate(angles(sh), out);
  const Vec3 upper = rotate(angles(collar), a);
  const Vec3 ae = rotate(angles(elbow), out);
  const Vec3 b = rotate(angles(sh), ae);
  const Vec3 fore = rotate(angles(collar), b);
  Mat3 Du_c = Mat3::Zero(), Du_s = Mat3::Zero(), Df_c = Mat3::Zero(), Df_s = Mat3::Zero(), Df_e = Mat3::Zero();
  if (jacobian) {
    const Mat3 Rc = rotation(angles(collar)), Rs = rotation(angles(sh)), Re = rotation(angles(elbow));
    Du_c = rotated_derivative(angles(collar), Rc, a);
    Du_s = Rc * rotated_derivative(angles(sh), Rs, out);
    Df_c = rotated_derivative(angles(collar), Rc, b);
    Df_s = Rc * rotated_derivative(angles(sh), Rs, ae);
    Df_e = Rc * Rs * rotated_derivative(angles(elbow), Re, out);
  }
  put(BEHIND_WEIGHT, upper.z(), -BEHIND_MARGIN, 10.0, {{collar, Du_c.row(2)}, {sh, Du_s.row(2)}});
  put(BEHIND_WEIGHT, fore.z(), -BEHIND_MARGIN, 10.0, {{collar, Df_c.row(2)}, {sh, Df_s.row(2)}, {elbow, Df_e.row(2)}});
}

void pose_prior(const double* body, const std::array<double, BODY_POSE>& relaxed, double* r, double* jacobian) {
  const auto& terms = pose_prior_terms();
  Eigen::Map<RowJacobian> Jac(jacobian, jacobian ? pose_prior_residual_count() : 0, BODY_POSE);
  if (jacobian) Jac.setZero();
  RowJacobian part;
  int row = 0;
  for (std::size_t t = 0; t < terms.size(); ++t) {
    const PosePriorTerm& pt = terms[t];
    if (jacobian) part.resize(pt.residuals, static_cast<Eigen::Index>(3 * pt.joints.size()));
    pose_prior_term(t, body, relaxed, r + row, jacobian ? part.data() : nullptr);
    if (jacobian)
      for (std::size_t c = 0; c < pt.joints.size(); ++c)
        Jac.block(row, 3 * (pt.joints[c] - 1), pt.residuals, 3) = part.middleCols(static_cast<Eigen::Index>(3 * c), 3);
    row += pt.residuals;
  }
}

} // namespace vfit::keypoint_detail
