// SPDX-License-Identifier: Apache-2.0
#include "mannequin_shape.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

#include "cross_section.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr double PI = std::numbers::pi;
constexpr double APOSE_ARM_DROP = 45.0 * PI / 180.0; // arms 45° below horizontal in the A-pose

// Polynomial smooth minimum: equals min(a, b) when |a − b| ≥ k, blends within k (m).
double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}
double smax(double a, double b, double k) { return -smin(-a, -b, k); }

// Distance to a round cone (the convex hull of two spheres).
double round_cone_distance(const Eigen::Vector3d& x, const RoundCone& c) {
  const Eigen::Vector3d ba = c.q - c.p, pa = x - c.p;
  const double l2 = ba.squaredNorm(), rr = c.rp - c.rq, a2 = l2 - rr * rr, il2 = 1.0 / l2;
  const double y = pa.dot(ba), z = y - l2;
  const double x2 = (pa * l2 - ba * y).squaredNorm(), y2 = y * y * l2, z2 = z * z * l2;
  const double k = (rr > 0 ? 1.0 : (rr < 0 ? -1.0 : 0.0)) * rr * rr * x2;
  if ((z > 0 ? 1.0 : -1.0) * a2 * z2 > k) return std::sqrt(x2 + z2) * il2 - c.rq;
  if ((y > 0 ? 1.0 : -1.0) * a2 * y2 < k) return std::sqrt(x2 + y2) * il2 - c.rp;
  return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - c.rp;
}

// First-order distance to an ellipsoid: f/|∇f| with f = |q| − 1, q = local / radii.
double ellipsoid_distance(const Eigen::Vector3d& x, const Ellipsoid& e) {
  const Eigen::Vector3d local = e.axes.transpose() * (x - e.centre);
  const Eigen::Vector3d q = local.cwiseQuotient(e.radii);
  const Eigen::Vector3d q2 = q.cwiseQuotient(e.radii);
  const double k0 = q.norm(), k1 = q2.norm();
  if (k1 < 1e-12) return -e.radii.minCoeff();
  return k0 * (k0 - 1.0) / k1;
}

// Semi-axes (a, b) of an ellipse with perimeter `p` and a/b = `ratio` (Ramanujan's formula).
std::pair<double, double> ellipse_for_perimeter(double p, double ratio) {
  const double unit = PI * (3 * (ratio + 1) - std::sqrt((3 * ratio + 1) * (ratio + 3)));
  const double b = p / unit;
  return {ratio * b, b};
}

// Monotone cubic (Fritsch–Carlson) interpolation of ys over ascending xs, clamped at the ends.
double monotone_cubic(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
  const std::size_t n = xs.size();
  if (x <= xs.front()) return ys.front();
  if (x >= xs.back()) return ys.back();
  std::size_t i = std::upper_bound(xs.begin(), xs.end(), x) - xs.begin() - 1;
  auto slope = [&](std::size_t k) { return (ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k]); };
  auto tangent = [&](std::size_t k) {
    if (k == 0) return slope(0);
    if (k == n - 1) return slope(n - 2);
    const double s0 = slope(k - 1), s1 = slope(k);
    if (s0 * s1 <= 0) return 0.0;
    return 2.0 / (1.0 / s0 + 1.0 / s1); // harmonic mean keeps the curve monotone between keys
  };
  const double h = xs[i + 1] - xs[i], t = (x - xs[i]) / h;
  const double h00 = (1 + 2 * t) * (1 - t) * (1 - t), h10 = t * (1 - t) * (1 - t), h01 = t * t * (3 - 2 * t),
               h11 = t * t * (t - 1);
  return h00 * ys[i] + h10 * h * tangent(i) + h01 * ys[i + 1] + h11 * h * tangent(i + 1);
}

} // namespace

MannequinShape::MannequinShape(const BodyMeasurements& m, RestPose pose) : MannequinShape(m, pose, true) {}

MannequinShape MannequinShape::uncalibrated(const BodyMeasurements& m, RestPose pose) {
  return MannequinShape(m, pose, false);
}

MannequinShape::MannequinShape(const BodyMeasurements& m, RestPose pose, bool calibrated)
    : m_measurements(m), m_pose(pose) {
  check_measurements(m);
  if (pose != RestPose::TPOSE && pose != RestPose::APOSE)
    throw Error("mannequin", 0, "the mannequin is built in T-pose or A-pose");
  place_skeleton();
  build_shapes();
  if (calibrated) calibrate();
}

void MannequinShape::place_skeleton() {
  const BodyMeasurements& m = m_measurements;
  const double H = m.height, s = H / 1.70;
  const double thigh_r = m.thigh / (2 * PI);
  auto set = [&](Joint j, double x, double y, double z) { m_joints.row(idx(j)) << x, y, z; };
  const double hip_y = m.crotch_height + 0.050 * H, hip_x = thigh_r + 0.022 * s; // thighs ~4 cm apart at the crotch
  const double shoulder_y = 0.818 * H;
  set(Joint::PELVIS, 0, hip_y + 0.012 * H, -0.005 * s);
  set(Joint::LEFT_HIP, hip_x, hip_y, 0);
  set(Joint::RIGHT_HIP, -hip_x, hip_y, 0);
  set(Joint::LEFT_KNEE, 0.80 * hip_x, m.knee_height, 0.008 * s);
  set(Joint::RIGHT_KNEE, -0.80 * hip_x, m.knee_height, 0.008 * s);
  const double ankle_y = 0.045 * H;
  set(Joint::LEFT_ANKLE, 0.70 * hip_x, ankle_y, -0.012 * s);
  set(Joint::RIGHT_ANKLE, -0.70 * hip_x, ankle_y, -0.012 * s);
  set(Joint::LEFT_FOOT, 0.72 * hip_x, 0.018 * H, -0.012 * s + 0.075 * H);
  set(Joint::RIGHT_FOOT, -0.72 * hip_x, 0.018 * H, -0.012 * s + 0.075 * H);
  set(Joint::NECK, 0, 0.842 * H, -0.012 * s);
  // Spine joints at SMPL's heights (21 % and 48 % of pelvis → neck; rig_mapping.h), spine3 at the
  // chest line (61 %, SMPL 58 %; the chest girth is placed there), a third of the torso's depth
  // from the back, where the vertebral column runs.
  const double pelvis_y = m_joints(idx(Joint::PELVIS), 1), neck_y = m_joints(idx(Joint::NECK), 1);
  set(Joint::SPINE1, 0, pelvis_y + 0.213 * (neck_y - pelvis_y), -0.040 * s);
  set(Joint::SPINE2, 0, pelvis_y + 0.478 * (neck_y - pelvis_y), -0.040 * s);
  set(Joint::SPINE3, 0, 0.722 * H, -0.035 * s);
  set(Joint::LEFT_COLLAR, 0.045 * s, shoulder_y - 0.010 * H, 0.0);
  set(Joint::RIGHT_COLLAR, -0.045 * s, shoulder_y - 0.010 * H, 0.0);
  set(Joint::HEAD, 0, 0.905 * H, 0.005 * s);
  set(Joint::LEFT_SHOULDER, m.shoulder_width / 2, shoulder_y, -0.010 * s);
  set(Joint::RIGHT_SHOULDER, -m.shoulder_width / 2, shoulder_y, -0.010 * s);
  const double drop = m_pose == RestPose::APOSE ? APOSE_ARM_DROP : 0.0;
  const double upper = m.arm_length - m.forearm_length;
  for (int side : {1, -1}) {
    const Eigen::Vector3d d(side * std::cos(drop), -std::sin(drop), 0.0);
    const int sh = side > 0 ? idx(Joint::LEFT_SHOULDER) : idx(Joint::RIGHT_SHOULDER);
    const Eigen::Vector3d shoulder = m_joints.row(sh).transpose();
    const Eigen::Vector3d elbow = shoulder + upper * d, wrist = elbow + m.forearm_length * d,
                          hand = wrist + 0.050 * H * d;
    m_joints.row(sh + 2) = elbow.transpose(); // elbow = shoulder + 2 in SMPL order
    m_joints.row(sh + 4) = wrist.transpose();
    m_joints.row(sh + 6) = hand.transpose();
  }
}

void MannequinShape::build_shapes() {
  const BodyMeasurements& m = m_measurements;
  const double H = m.height, s = H / 1.70;
  auto J = [&](Joint j) -> Eigen::Vector3d { return m_joints.row(idx(j)).transpose(); };
  const double hip_y = J(Joint::LEFT_HIP).y(), shoulder_y = J(Joint::LEFT_SHOULDER).y();
  const double chest_y = J(Joint::SPINE3).y(), waist_y = 0.620 * H, hipl_y = hip_y - 0.010 * H;

  // Torso keyframes: sizes from the girths (a/b ratios of an average torso), then scaled by the
  // calibration factors.
  const auto [ha, hb] = ellipse_for_perimeter(0.90 * m.hip * m_scale_hip, 1.32);
  const auto [wa, wb] = ellipse_for_perimeter(m.waist * m_scale_waist, 1.38);
  const auto [ca, cb] = ellipse_for_perimeter(0.97 * m.chest * m_scale_chest, 1.36);
  m_torso_bottom = m.crotch_height + 0.012 * H + m_crotch_shift;
  m_torso_top = shoulder_y + 0.022 * H;
  const double under_y = shoulder_y - 0.050 * H;
  m_torso = {
      {m_torso_bottom, 0.88 * ha, 0.90 * hb, -0.012 * s},
      {hipl_y, ha, hb, -0.010 * s},
      {waist_y, wa, wb, -0.004 * s},
      {chest_y, ca, cb, 0.012 * s},
      {under_y, 0.98 * ca, 0.92 * cb, 0.006 * s},
      {shoulder_y, std::max(0.5 * m.shoulder_width - 0.015 * s, 0.8 * ca), 0.70 * cb, -0.008 * s},
      {m_torso_top, 0.55 * m.shoulder_width, 0.55 * cb, -0.010 * s},
  };
  // Keyframes must ascend even for unusual proportions.
  for (std::size_t i = 1; i < m_torso.size(); ++i)
    m_torso[i].y = std::max(m_torso[i].y, m_torso[i - 1].y + 0.005);
  m_key_y.clear();
  m_key_a.clear();
  m_key_b.clear();
  m_key_c.clear();
  for (const auto& k : m_torso) {
    m_key_y.push_back(k.y);
    m_key_a.push_back(k.a);
    m_key_b.push_back(k.b);
    m_key_c.push_back(k.c);
  }

  m_cones.clear();
  m_ellipsoids.clear();
  const double thigh_r = m.thigh / (2 * PI) * m_scale_thigh, calf_r = m.calf / (2 * PI) * m_scale_calf;
  const double knee_r = std::min(0.052 * s, 0.9 * calf_r + 0.004), ankle_r = 0.034 * s;
  for (int side : {1, -1}) {
    const bool left = side > 0;
    const Eigen::Vector3d hip = J(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP),
                          knee = J(left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE),
                          ankle = J(left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE);
    const int jh = idx(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP),
              jk = idx(left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE);
    // The thigh cone reaches its measured radius a little below the crotch.
    m_cones.push_back({hip + Eigen::Vector3d(0, 0.02 * s, 0), knee, thigh_r * 1.04, knee_r, jh});
    const Eigen::Vector3d calf_pt = knee + 0.33 * (ankle - knee) + Eigen::Vector3d(0, 0, -0.012 * s);
    m_cones.push_back({knee, calf_pt, knee_r, calf_r, jk});
    m_cones.push_back({calf_pt, ankle, calf_r, ankle_r, jk});
    // Buttock: behind and beside the hip joint.
    Ellipsoid b;
    b.axes = Eigen::Matrix3d::Identity();
    b.radii = Eigen::Vector3d(0.078, 0.085, 0.068) * (m.hip * m_scale_hip / 0.98);
    // Kept above the crotch, so sections just below it hold two separate legs.
    b.centre = Eigen::Vector3d(side * 0.50 * hip.x(), std::max(hip_y - 0.030 * H, m_torso_bottom + 0.9 * b.radii.y()),
                               -0.55 * hb);
    b.joint = jh;
    m_ellipsoids.push_back(b);
    // Foot: from the heel behind the ankle to the toes, flat on the floor (y = 0).
    Ellipsoid f;
    const Eigen::Vector3d r(0.045 * s, 0.036 * s, 0.128 * s);
    f.centre = Eigen::Vector3d(ankle.x() * 1.02, r.y(), ankle.z() - 0.045 * s + r.z());
    f.axes = Eigen::Matrix3d::Identity();
    f.radii = r;
    f.joint = idx(left ? Joint::LEFT_FOOT : Joint::RIGHT_FOOT);
    m_ellipsoids.push_back(f);

    const Eigen::Vector3d collar = J(left ? Joint::LEFT_COLLAR : Joint::RIGHT_COLLAR),
                          shoulder = J(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER),
                          elbow = J(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW),
                          wrist = J(left ? Joint::LEFT_WRIST : Joint::RIGHT_WRIST);
    const double arm_s = std::sqrt(m.chest / 0.96) * s;
    const int jc = idx(left ? Joint::LEFT_COLLAR : Joint::RIGHT_COLLAR), js = jc + 3, je = js + 2;
    m_cones.push_back({collar, shoulder, 0.050 * arm_s, 0.052 * arm_s, jc});
    m_cones.push_back({shoulder, elbow, 0.047 * arm_s, 0.036 * arm_s, js});
    m_cones.push_back({elbow, wrist, 0.037 * arm_s, 0.026 * arm_s, je});
    // Hand: a mitten along the forearm direction, flat across the palm.
    const Eigen::Vector3d d = (wrist - elbow).normalized();
    const Eigen::Vector3d width = Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d thick = width.cross(d).normalized();
    Ellipsoid h;
    h.centre = wrist + 0.052 * H * d;
    h.axes.col(0) = d;
    h.axes.col(1) = thick;
    h.axes.col(2) = width;
    h.radii = Eigen::Vector3d(0.058 * H, 0.020 * s, 0.044 * s);
    h.joint = idx(left ? Joint::LEFT_WRIST : Joint::RIGHT_WRIST);
    m_ellipsoids.push_back(h);
  }
  // Neck and head.
  const Eigen::Vector3d neck_base(0, shoulder_y - 0.020 * H, -0.015 * s);
  m_cones.push_back({neck_base, J(Joint::HEAD), 0.060 * s, 0.055 * s, idx(Joint::NECK)});
  Ellipsoid head;
  head.radii = Eigen::Vector3d(0.078 * s, 0.115 * s, 0.098 * s);
  head.centre = Eigen::Vector3d(0, H - head.radii.y(), 0.012 * s);
  head.axes = Eigen::Matrix3d::Identity();
  head.joint = idx(Joint::HEAD);
  m_ellipsoids.push_back(head);

  m_cone_bounds.clear();
  for (const RoundCone& c : m_cones)
    m_cone_bounds.push_back({0.5 * (c.p + c.q), 0.5 * (c.q - c.p).norm() + std::max(c.rp, c.rq), 0.0});
  m_ellipsoid_bounds.clear();
  for (const Ellipsoid& e : m_ellipsoids)
    m_ellipsoid_bounds.push_back({e.centre, e.radii.maxCoeff(), e.radii.minCoeff()});

  // Bone segments for skin weights: each joint drives the bone(s) to its child(ren).
  m_bones.clear();
  auto bone = [&](Joint j, const Eigen::Vector3d& a, const Eigen::Vector3d& b) { m_bones.push_back({idx(j), a, b}); };
  // The spine's weight bones run up the torso's centre line (the joints themselves sit back at
  // the vertebral column): weights follow the flesh around them, rotations the column.
  auto centre_line = [&](Joint j, double z) { return Eigen::Vector3d(0, J(j).y(), z * s); };
  const Eigen::Vector3d spine1 = centre_line(Joint::SPINE1, -0.012), spine2 = centre_line(Joint::SPINE2, -0.010),
                        spine3 = centre_line(Joint::SPINE3, -0.005);
  bone(Joint::PELVIS, J(Joint::PELVIS), spine1);
  bone(Joint::PELVIS, J(Joint::PELVIS), 0.5 * (J(Joint::PELVIS) + J(Joint::LEFT_HIP)));
  bone(Joint::PELVIS, J(Joint::PELVIS), 0.5 * (J(Joint::PELVIS) + J(Joint::RIGHT_HIP)));
  bone(Joint::SPINE1, spine1, spine2);
  bone(Joint::SPINE2, spine2, spine3);
  bone(Joint::SPINE3, spine3, J(Joint::NECK));
  bone(Joint::NECK, J(Joint::NECK), J(Joint::HEAD));
  bone(Joint::HEAD, J(Joint::HEAD), Eigen::Vector3d(0, H, 0.01 * s));
  for (int side : {0, 1}) {
    auto L = [&](Joint left_joint) {
      return side == 0 ? left_joint : static_cast<Joint>(mirrored_joint(idx(left_joint)));
    };
    bone(L(Joint::LEFT_HIP), J(L(Joint::LEFT_HIP)), J(L(Joint::LEFT_KNEE)));
    bone(L(Joint::LEFT_KNEE), J(L(Joint::LEFT_KNEE)), J(L(Joint::LEFT_ANKLE)));
    bone(L(Joint::LEFT_ANKLE), J(L(Joint::LEFT_ANKLE)), J(L(Joint::LEFT_FOOT)));
    bone(L(Joint::LEFT_FOOT), J(L(Joint::LEFT_FOOT)), J(L(Joint::LEFT_FOOT)) + Eigen::Vector3d(0, 0, 0.06 * s));
    bone(L(Joint::LEFT_COLLAR), J(L(Joint::LEFT_COLLAR)), J(L(Joint::LEFT_SHOULDER)));
    bone(L(Joint::LEFT_SHOULDER), J(L(Joint::LEFT_SHOULDER)), J(L(Joint::LEFT_ELBOW)));
    bone(L(Joint::LEFT_ELBOW), J(L(Joint::LEFT_ELBOW)), J(L(Joint::LEFT_WRIST)));
    bone(L(Joint::LEFT_WRIST), J(L(Joint::LEFT_WRIST)), J(L(Joint::LEFT_HAND)));
    const Eigen::Vector3d hand = J(L(Joint::LEFT_HAND)), dir = (hand - J(L(Joint::LEFT_WRIST))).normalized();
    bone(L(Joint::LEFT_HAND), hand, hand + 0.045 * H * dir);
  }
}

TorsoSection MannequinShape::torso_at(double y) const {
  return {y, monotone_cubic(m_key_y, m_key_a, y), monotone_cubic(m_key_y, m_key_b, y),
          monotone_cubic(m_key_y, m_key_c, y)};
}

double MannequinShape::torso_centre_z(double y) const { return torso_at(y).c; }

double MannequinShape::torso_distance(double x, double y, double z) const {
  const TorsoSection t = torso_at(std::clamp(y, m_torso_bottom, m_torso_top));
  const double qx = x / t.a, qz = (z - t.c) / t.b, r = std::hypot(qx, qz);
  double side;
  if (r < 1e-9) {
    side = -std::min(t.a, t.b);
  } else {
    const double g = std::hypot(qx / t.a, qz / t.b) / r;
    side = (r - 1.0) / g;
  }
  const double s = m_measurements.height / 1.70;
  const double bottom = smax(side, m_torso_bottom - y, 0.06 * s);
  return smax(bottom, y - m_torso_top, 0.07 * s);
}

double MannequinShape::evaluate_distance(double x, double y, double z, const ShapeInflation* inf, bool bounded) const {
  const double s = m_measurements.height / 1.70;
  const Eigen::Vector3d p(x, y, z);
  const double torso_off = inf && inf->torso_offset ? inf->torso_offset(y) : 0.0;
  const double leg_off = inf && inf->leg_offset ? inf->leg_offset(y) : 0.0;
  const double arm_off = inf ? inf->arm_offset : 0.0, neck_off = inf ? inf->neck_offset : 0.0;
  const bool arms = !inf || inf->with_arms, legs_on = !inf || inf->with_legs, head_on = !inf || inf->with_head,
             hands = !inf || inf->with_hands, feet = !inf || inf->with_feet;
  double d = torso_distance(x, y, z) - torso_off;
  // smin(d, a, k) is exactly d once a - d ≥ k (no blend), so a shape whose distance is
  // provably beyond d + k is skipped; the margin covers rounding (distances are < 10 m), so
  // the result is bit-for-bit that of evaluating every shape. A round cone's distance (exact)
  // is at least the distance to a sphere containing it; an ellipsoid's first-order distance
  // k0 (k0 − 1) / k1 is at least inner (|p − centre| / outer − 1) outside the outer sphere
  // (k0 ≥ |p − centre| / outer ≥ 1 and k0 / k1 ≥ inner).
  constexpr double MARGIN = 1e-9;
  auto cone_beyond = [&](std::size_t i, double current, double k, double offset) {
    if (!bounded) return false;
    const ShapeBound& b = m_cone_bounds[i];
    const double reach = current + k + MARGIN + b.outer + offset; // skip when |p − centre| ≥ reach
    return reach <= 0 || (p - b.centre).squaredNorm() >= reach * reach;
  };
  auto ellipsoid_beyond = [&](std::size_t i, double current, double k, double offset) {
    if (!bounded) return false;
    const ShapeBound& b = m_ellipsoid_bounds[i];
    const double gap = current + k + MARGIN + offset;
    if (!(gap >= 0)) return false;
    const double reach = b.outer * (1.0 + gap / b.inner);
    return (p - b.centre).squaredNorm() >= reach * reach;
  };
  // Legs and buttocks blend into the torso; the two legs never blend with each other.
  double legs[2] = {INFINITY, INFINITY};
  for (std::size_t i = 0; i < m_cones.size(); ++i) {
    const RoundCone& c = m_cones[i];
    const Joint j = static_cast<Joint>(c.joint);
    const bool left_leg = j == Joint::LEFT_HIP || j == Joint::LEFT_KNEE,
               right_leg = j == Joint::RIGHT_HIP || j == Joint::RIGHT_KNEE;
    if (left_leg || right_leg) {
      if (!legs_on) continue;
      double& leg = legs[left_leg ? 0 : 1];
      if (!cone_beyond(i, leg, 0.02 * s, leg_off)) leg = smin(leg, round_cone_distance(p, c) - leg_off, 0.02 * s);
    } else if (j == Joint::NECK) {
      if (head_on && !cone_beyond(i, d, 0.035 * s, neck_off))
        d = smin(d, round_cone_distance(p, c) - neck_off, 0.035 * s);
    } else if (arms && !cone_beyond(i, d, 0.025 * s, arm_off)) {
      d = smin(d, round_cone_distance(p, c) - arm_off, 0.025 * s); // collar, shoulder, elbow pieces
    }
  }
  for (std::size_t i = 0; i < m_ellipsoids.size(); ++i) {
    const Ellipsoid& e = m_ellipsoids[i];
    const Joint j = static_cast<Joint>(e.joint);
    if (j == Joint::LEFT_FOOT || j == Joint::RIGHT_FOOT) {
      double& leg = legs[j == Joint::LEFT_FOOT ? 0 : 1];
      if (feet && legs_on && !ellipsoid_beyond(i, leg, 0.03 * s, 0.0))
        leg = smin(leg, ellipsoid_distance(p, e), 0.03 * s);
    } else if (j == Joint::LEFT_HIP || j == Joint::RIGHT_HIP) {
      if (!ellipsoid_beyond(i, d, 0.04 * s, torso_off)) d = smin(d, ellipsoid_distance(p, e) - torso_off, 0.04 * s);
    } else if (j == Joint::HEAD) {
      if (head_on && !ellipsoid_beyond(i, d, 0.03 * s, 0.0)) d = smin(d, ellipsoid_distance(p, e), 0.03 * s);
    } else if (hands && arms && !ellipsoid_beyond(i, d, 0.015 * s, 0.0)) {
      d = smin(d, ellipsoid_distance(p, e), 0.015 * s);
    }
  }
  if (inf && inf->legs_gap > 0) {
    legs[0] = std::max(legs[0], inf->legs_gap - x); // the left leg lies at +x
    legs[1] = std::max(legs[1], inf->legs_gap + x);
    return smin(d, std::min(legs[0], legs[1]), 0.035 * s);
  }
  d = smin(d, legs[0], 0.035 * s);
  return smin(d, legs[1], 0.035 * s);
}

std::pair<Eigen::Vector3d, Eigen::Vector3d> MannequinShape::bounding_box(double margin) const {
  // The limbs' and head's joints bound the body; the spine's lie inside the torso.
  JointPositions outer = m_joints;
  for (Joint j : {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3})
    outer.row(idx(j)) = m_joints.row(idx(Joint::PELVIS));
  Eigen::Vector3d lo = outer.colwise().minCoeff().transpose(), hi = outer.colwise().maxCoeff().transpose();
  const double s = m_measurements.height / 1.70;
  lo -= Eigen::Vector3d::Constant(0.25 * s);
  hi += Eigen::Vector3d::Constant(0.25 * s);
  lo.y() = -margin;
  hi.y() = m_measurements.height + margin;
  return {lo - Eigen::Vector3d::Constant(margin), hi + Eigen::Vector3d::Constant(margin)};
}

std::array<double, JOINT_COUNT> MannequinShape::skin_affinity(const Eigen::Vector3d& p) const {
  const double s = m_measurements.height / 1.70;
  // Each shape with its distance and the joints that may move it.
  struct Part {
    double d;
    std::vector<int> joints;
  };
  std::vector<Part> parts;
  auto side_joints = [](int j, std::initializer_list<Joint> names) {
    std::vector<int> out;
    const bool right = joint_name(j).rfind("right_", 0) == 0;
    for (Joint n : names)
      out.push_back(right ? mirrored_joint(idx(n)) : idx(n));
    return out;
  };
  parts.push_back({torso_distance(p.x(), p.y(), p.z()),
                   {idx(Joint::PELVIS), idx(Joint::SPINE1), idx(Joint::SPINE2), idx(Joint::SPINE3), idx(Joint::NECK),
                    idx(Joint::LEFT_COLLAR), idx(Joint::RIGHT_COLLAR)}});
  for (const auto& c : m_cones) {
    const Joint j = static_cast<Joint>(c.joint);
    std::vector<int> cand;
    switch (j) {
    case Joint::LEFT_HIP:
    case Joint::RIGHT_HIP:
      cand = side_joints(c.joint, {Joint::LEFT_HIP, Joint::LEFT_KNEE});
      cand.push_back(idx(Joint::PELVIS));
      break;
    case Joint::LEFT_KNEE:
    case Joint::RIGHT_KNEE: cand = side_joints(c.joint, {Joint::LEFT_KNEE, Joint::LEFT_ANKLE, Joint::LEFT_HIP}); break;
    case Joint::LEFT_COLLAR:
    case Joint::RIGHT_COLLAR:
      cand = side_joints(c.joint, {Joint::LEFT_COLLAR, Joint::LEFT_SHOULDER});
      cand.push_back(idx(Joint::SPINE3));
      break;
    case Joint::LEFT_SHOULDER:
    case Joint::RIGHT_SHOULDER:
      cand = side_joints(c.joint, {Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW, Joint::LEFT_COLLAR});
      break;
    case Joint::LEFT_ELBOW:
    case Joint::RIGHT_ELBOW:
      cand = side_joints(c.joint, {Joint::LEFT_ELBOW, Joint::LEFT_WRIST, Joint::LEFT_SHOULDER});
      break;
    case Joint::NECK: cand = {idx(Joint::NECK), idx(Joint::HEAD), idx(Joint::SPINE3)}; break;
    default: cand = {c.joint}; break;
    }
    parts.push_back({round_cone_distance(p, c), cand});
  }
  for (const auto& e : m_ellipsoids) {
    const Joint j = static_cast<Joint>(e.joint);
    std::vector<int> cand;
    switch (j) {
    case Joint::LEFT_HIP:
    case Joint::RIGHT_HIP: cand = {e.joint, idx(Joint::PELVIS)}; break;
    case Joint::LEFT_FOOT:
    case Joint::RIGHT_FOOT: cand = side_joints(e.joint, {Joint::LEFT_FOOT, Joint::LEFT_ANKLE}); break;
    case Joint::LEFT_WRIST:
    case Joint::RIGHT_WRIST: cand = side_joints(e.joint, {Joint::LEFT_WRIST, Joint::LEFT_HAND}); break;
    case Joint::HEAD: cand = {idx(Joint::HEAD), idx(Joint::NECK)}; break;
    default: cand = {e.joint}; break;
    }
    parts.push_back({ellipsoid_distance(p, e), cand});
  }
  double dmin = INFINITY;
  for (const auto& part : parts)
    dmin = std::min(dmin, part.d);
  // Bone distance per joint (nearest of its segments).
  std::array<double, JOINT_COUNT> bone_d;
  bone_d.fill(INFINITY);
  for (const auto& b : m_bones) {
    const Eigen::Vector3d ab = b.b - b.a;
    const double t = std::clamp((p - b.a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
    bone_d[b.joint] = std::min(bone_d[b.joint], (p - (b.a + t * ab)).norm());
  }
  std::array<double, JOINT_COUNT> w{};
  const double tau = 0.008 * s; // shapes within ~1 cm of the nearest one share the point
  for (const auto& part : parts) {
    const double share = std::exp(-(part.d - dmin) / tau);
    if (share < 1e-4) continue;
    double nearest = INFINITY;
    for (int j : part.joints)
      nearest = std::min(nearest, bone_d[j]);
    double total = 0;
    std::array<double, JOINT_COUNT> local{};
    for (int j : part.joints) {
      local[j] = std::pow(nearest / std::max(bone_d[j], 1e-6), 6.0);
      total += local[j];
    }
    for (int j : part.joints)
      w[j] += share * local[j] / total;
  }
  return w;
}

double MannequinShape::section_girth(double y, double x0, double z0) const {
  if (distance(x0, y, z0) >= 0) return 0;
  constexpr int RAYS = 120;
  SectionLoop exits;
  for (int i = 0; i < RAYS; ++i) {
    const double phi = 2 * PI * i / RAYS, dx = std::cos(phi), dz = std::sin(phi);
    // Sphere-trace outward while inside (|d| bounds the distance to the surface), then bisect.
    double t = 0, d = distance(x0, y, z0);
    while (d < 0 && t < 1.0) {
      t += std::max(-d, 0.002);
      d = distance(x0 + t * dx, y, z0 + t * dz);
    }
    double lo = std::max(0.0, t - 0.02), hi = t;
    if (distance(x0 + lo * dx, y, z0 + lo * dz) >= 0) lo = 0;
    for (int k = 0; k < 20; ++k) {
      const double mid = 0.5 * (lo + hi);
      (distance(x0 + mid * dx, y, z0 + mid * dz) < 0 ? lo : hi) = mid;
    }
    exits.push_back({x0 + hi * dx, z0 + hi * dz});
  }
  return convex_hull_perimeter(exits);
}

void MannequinShape::calibrate() {
  const BodyMeasurements& m = m_measurements;
  auto J = [&](Joint j) -> Eigen::Vector3d { return m_joints.row(idx(j)).transpose(); };
  for (int iter = 0; iter < 10; ++iter) {
    // Crotch: the highest mid-line point below the pelvis outside the body.
    const Eigen::Vector3d pelvis = J(Joint::PELVIS);
    double lo = J(Joint::LEFT_KNEE).y(), hi = pelvis.y();
    const double zc = torso_centre_z(pelvis.y());
    for (int k = 0; k < 30; ++k) {
      const double mid = 0.5 * (lo + hi);
      (distance(0, mid, zc) < 0 ? hi : lo) = mid;
    }
    const double crotch = hi;
    const Eigen::Vector3d lhip = J(Joint::LEFT_HIP), lknee = J(Joint::LEFT_KNEE), lankle = J(Joint::LEFT_ANKLE);
    const Eigen::Vector3d hips = 0.5 * (lhip + J(Joint::RIGHT_HIP)), spine3 = J(Joint::SPINE3);
    auto torso_axis_z = [&](double y) { return torso_centre_z(y); };
    auto leg_at = [&](double y) -> Eigen::Vector3d {
      const auto& a = y > lknee.y() ? lhip : lknee;
      const auto& b = y > lknee.y() ? lknee : lankle;
      const double t = std::clamp((y - a.y()) / (b.y() - a.y()), 0.0, 1.0);
      return a + t * (b - a);
    };
    auto extreme = [&](double ylo, double yhi, bool largest, bool leg) {
      double best = largest ? -1.0 : INFINITY;
      for (int i = 0; i <= 12; ++i) {
        const double y = ylo + (yhi - ylo) * i / 12;
        const Eigen::Vector3d c = leg ? leg_at(y) : Eigen::Vector3d(0, y, torso_axis_z(y));
        const double g = section_girth(y, c.x(), c.z());
        if (g > 0) best = largest ? std::max(best, g) : std::min(best, g);
      }
      return best;
    };
    const double chest = section_girth(spine3.y(), 0, torso_axis_z(spine3.y()));
    const double waist =
        extreme(hips.y() + 0.25 * (spine3.y() - hips.y()), hips.y() + 0.85 * (spine3.y() - hips.y()), false, false);
    const double hip = extreme(crotch + 0.005, pelvis.y(), true, false);
    const double thigh = extreme(crotch - 0.08, crotch - 0.005, true, true);
    const double calf =
        extreme(lknee.y() - 0.6 * (lknee.y() - lankle.y()), lknee.y() - 0.15 * (lknee.y() - lankle.y()), true, true);
    const double errors[] = {chest / m.chest - 1, waist / m.waist - 1, hip / m.hip - 1,
                             thigh / m.thigh - 1, calf / m.calf - 1,   (crotch - m.crotch_height) / m.height};
    double worst = 0;
    for (double e : errors)
      worst = std::max(worst, std::abs(e));
    if (std::getenv("VFIT_DEBUG_MANNEQUIN"))
      std::fprintf(stderr, "calib %d: chest %.4f waist %.4f hip %.4f thigh %.4f calf %.4f crotch %.4f\n", iter, chest,
                   waist, hip, thigh, calf, crotch);
    if (worst < 0.002) break;
    m_scale_chest *= m.chest / chest;
    m_scale_waist *= m.waist / waist;
    m_scale_hip *= m.hip / hip;
    m_scale_thigh *= m.thigh / thigh;
    m_scale_calf *= m.calf / calf;
    m_crotch_shift += m.crotch_height - crotch;
    build_shapes();
  }
}

} // namespace vfit
