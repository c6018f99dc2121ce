// SPDX-License-Identifier: Apache-2.0
#include "measurements.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <tuple>

#include "cross_section.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

Eigen::Vector3d joint_at(const JointPositions& j, Joint which) { return j.row(idx(which)).transpose(); }

// The point at height y on the polyline a → b (clamped to the segment).
Eigen::Vector3d at_height(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double y) {
  const double t = std::clamp((y - a.y()) / (b.y() - a.y()), 0.0, 1.0);
  return a + t * (b - a);
}

// Girth of the section around (x, z) at each of `n` heights in [lo, hi]; returns the best by
// `better` and its height. Golden-section refinement is not worth it: sections are cheap and
// the search ranges are a few centimetres per step.
// When `exclude` is given, sections whose loop also holds exclude(y) are skipped (a thigh
// section that still joins the other leg, e.g. through the buttocks below the crotch).
std::pair<double, double> search_girth(const Mesh& mesh, double lo, double hi, int n, bool largest,
                                       const std::function<Eigen::Vector3d(double)>& axis,
                                       const std::function<Eigen::Vector3d(double)>& exclude = {}) {
  double best = largest ? -1.0 : INFINITY, best_y = lo;
  for (int i = 0; i <= n; ++i) {
    const double y = lo + (hi - lo) * i / n;
    const Eigen::Vector3d c = axis(y);
    double g = 0;
    for (const auto& loop : horizontal_section(mesh, y)) {
      if (loop.size() < 3 || !loop_contains(loop, c.x(), c.z())) continue;
      if (exclude) {
        const Eigen::Vector3d x = exclude(y);
        if (loop_contains(loop, x.x(), x.z())) continue;
      }
      g = std::max(g, convex_hull_perimeter(loop));
    }
    if (g <= 0) continue;
    if (largest ? g > best : g < best) {
      best = g;
      best_y = y;
    }
  }
  return {best, best_y};
}

} // namespace

const std::vector<std::string_view>& BodyMeasurements::names() {
  static const std::vector<std::string_view> n = {
      "height", "crotch_height", "knee_height", "arm_length", "forearm_length", "shoulder_width", "chest",
      "waist",  "hip",           "thigh",       "calf"};
  return n;
}

double& BodyMeasurements::operator[](std::string_view name) {
  double* fields[] = {&height, &crotch_height, &knee_height, &arm_length, &forearm_length, &shoulder_width, &chest,
                      &waist,  &hip,           &thigh,       &calf};
  const auto& n = names();
  for (std::size_t i = 0; i < n.size(); ++i)
    if (n[i] == name) return *fields[i];
  throw Error("measurements", 0, "unknown measurement '" + std::string(name) + "'");
}

double BodyMeasurements::operator[](std::string_view name) const { return const_cast<BodyMeasurements&>(*this)[name]; }

BodyMeasurements body_preset(std::string_view name) {
  BodyMeasurements m;
  if (name == "average") return m;
  if (name == "banana") { // straight: little difference between chest, waist and hip
    m.chest = 0.93, m.waist = 0.86, m.hip = 0.94, m.thigh = 0.54;
  } else if (name == "pear") { // hips and thighs fuller than the chest
    m.chest = 0.90, m.waist = 0.76, m.hip = 1.06, m.thigh = 0.62, m.calf = 0.38;
  } else if (name == "apple") { // full waist
    m.chest = 1.04, m.waist = 1.00, m.hip = 1.02, m.thigh = 0.58, m.calf = 0.38;
  } else if (name == "hourglass") {
    m.chest = 0.98, m.waist = 0.72, m.hip = 1.00, m.thigh = 0.58;
  } else if (name == "tall") {
    m.height = 1.88, m.crotch_height = 0.88, m.knee_height = 0.54, m.arm_length = 0.61, m.forearm_length = 0.28,
    m.shoulder_width = 0.40, m.chest = 1.02, m.waist = 0.86, m.hip = 1.00, m.thigh = 0.58, m.calf = 0.39;
  } else if (name == "petite") {
    m.height = 1.55, m.crotch_height = 0.70, m.knee_height = 0.44, m.arm_length = 0.50, m.forearm_length = 0.225,
    m.shoulder_width = 0.32, m.chest = 0.86, m.waist = 0.70, m.hip = 0.92, m.thigh = 0.52, m.calf = 0.34;
  } else {
    std::string all;
    for (const auto& n : body_preset_names())
      all += (all.empty() ? "" : ", ") + n;
    throw Error("--preset", 0, "unknown body preset '" + std::string(name) + "' (expected one of " + all + ")");
  }
  return m;
}

std::vector<std::string> body_preset_names() {
  return {"average", "banana", "pear", "apple", "hourglass", "tall", "petite"};
}

void check_measurements(const BodyMeasurements& m) {
  auto bad = [](const char* what, double v, const std::string& range) {
    throw Error("measurements", 0,
                std::string(what) + " = " + std::to_string(v) + " m is outside the plausible range " + range);
  };
  const double h = m.height;
  for (std::string_view n : BodyMeasurements::names())
    if (!std::isfinite(m[n]) || m[n] <= 0) bad(std::string(n).c_str(), m[n], "(must be a positive number)");
  if (h < 1.2 || h > 2.3) bad("height", h, "[1.2, 2.3]");
  auto ratio = [&](const char* what, double v, double lo, double hi) {
    if (v < lo * h || v > hi * h)
      bad(what, v, "[" + std::to_string(lo * h) + ", " + std::to_string(hi * h) + "] for this height");
  };
  ratio("crotch_height", m.crotch_height, 0.38, 0.54);
  ratio("knee_height", m.knee_height, 0.22, 0.34);
  ratio("arm_length", m.arm_length, 0.26, 0.40);
  ratio("shoulder_width", m.shoulder_width, 0.15, 0.28);
  ratio("chest", m.chest, 0.40, 0.90);
  ratio("waist", m.waist, 0.30, 0.90);
  ratio("hip", m.hip, 0.42, 0.90);
  ratio("thigh", m.thigh, 0.22, 0.50);
  ratio("calf", m.calf, 0.15, 0.32);
  if (m.forearm_length < 0.35 * m.arm_length || m.forearm_length > 0.6 * m.arm_length)
    bad("forearm_length", m.forearm_length, "[0.35, 0.6] × arm_length");
  if (m.knee_height > 0.8 * m.crotch_height) bad("knee_height", m.knee_height, "(at most 0.8 × crotch_height)");
  if (m.calf > m.thigh) bad("calf", m.calf, "(at most the thigh girth)");
}

MeasuredBody measure_body(const Mesh& mesh, const JointPositions& joints) {
  MeasuredBody out;
  BodyLandmarks& lm = out.landmarks;
  BodyMeasurements& v = out.values;
  if (mesh.vertex_count() == 0) throw Error("body", 0, "cannot measure an empty mesh");
  lm.floor = INFINITY;
  lm.top = -INFINITY;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    lm.floor = std::min(lm.floor, double(mesh.positions[3 * i + 1]));
    lm.top = std::max(lm.top, double(mesh.positions[3 * i + 1]));
  }
  const Eigen::Vector3d pelvis = joint_at(joints, Joint::PELVIS), spine3 = joint_at(joints, Joint::SPINE3);
  const Eigen::Vector3d lhip = joint_at(joints, Joint::LEFT_HIP), rhip = joint_at(joints, Joint::RIGHT_HIP);
  const Eigen::Vector3d lknee = joint_at(joints, Joint::LEFT_KNEE), lankle = joint_at(joints, Joint::LEFT_ANKLE);
  const Eigen::Vector3d hips = 0.5 * (lhip + rhip);

  // Crotch: bisection on "the mid-line point under the pelvis is inside the body".
  auto inside = [&](double y) {
    for (const auto& loop : horizontal_section(mesh, y))
      if (loop.size() >= 3 && loop_contains(loop, pelvis.x(), pelvis.z())) return true;
    return false;
  };
  double lo = lknee.y(), hi = pelvis.y();
  if (inside(lo) || !inside(hi))
    throw Error("body", 0, "cannot find the crotch: the legs are not separate below the pelvis");
  for (int i = 0; i < 30; ++i) {
    const double mid = 0.5 * (lo + hi);
    (inside(mid) ? hi : lo) = mid;
  }
  lm.crotch = hi;

  auto torso_axis = [&](double y) { return at_height(hips, spine3, y); };
  auto leg_axis = [&](double y) { return y > lknee.y() ? at_height(lhip, lknee, y) : at_height(lknee, lankle, y); };
  const Eigen::Vector3d rknee = joint_at(joints, Joint::RIGHT_KNEE);
  auto other_leg_axis = [&](double y) { return at_height(rhip, rknee, y); };
  auto need = [](double g, const char* what) {
    if (g <= 0) throw Error("body", 0, std::string("cannot measure the ") + what + ": no section around the axis");
    return g;
  };

  // Torso landmarks are searched between the hips and the shoulders, so they do not depend on
  // where a rig puts its spine joints. Loops holding an arm's axis (A-pose arms beside the
  // chest) are skipped.
  const Eigen::Vector3d lsh = joint_at(joints, Joint::LEFT_SHOULDER), rsh = joint_at(joints, Joint::RIGHT_SHOULDER);
  const Eigen::Vector3d lel = joint_at(joints, Joint::LEFT_ELBOW), rel = joint_at(joints, Joint::RIGHT_ELBOW);
  const double shoulder_y = 0.5 * (lsh.y() + rsh.y()), span = shoulder_y - hips.y();
  auto arm_at = [&](const Eigen::Vector3d& sh, const Eigen::Vector3d& el, double y) {
    return std::abs(el.y() - sh.y()) < 1e-6 ? Eigen::Vector3d(1e9, y, 1e9) : at_height(sh, el, y);
  };
  auto chest_girth = [&](double y) {
    const Eigen::Vector3d c = torso_axis(y), la = arm_at(lsh, lel, y), ra = arm_at(rsh, rel, y);
    double g = 0;
    for (const auto& loop : horizontal_section(mesh, y)) {
      if (loop.size() < 3 || !loop_contains(loop, c.x(), c.z())) continue;
      if (loop_contains(loop, la.x(), la.z()) || loop_contains(loop, ra.x(), ra.z())) continue;
      g = std::max(g, convex_hull_perimeter(loop));
    }
    return g;
  };
  v.chest = -1;
  for (int i = 0; i <= 40; ++i) {
    const double y = hips.y() + (0.55 + 0.25 * i / 40.0) * span, g = chest_girth(y);
    if (g > v.chest) {
      v.chest = g;
      lm.chest = y;
    }
  }
  need(v.chest, "chest");
  const double wlo = hips.y() + 0.20 * span, whi = hips.y() + 0.60 * span;
  std::tie(v.waist, lm.waist) = search_girth(mesh, wlo, whi, 40, false, torso_axis);
  need(std::isfinite(v.waist) ? v.waist : 0, "waist");
  std::tie(v.hip, lm.hip) = search_girth(mesh, lm.crotch + 0.005, pelvis.y(), 40, true, torso_axis);
  need(v.hip, "hip");
  std::tie(v.thigh, lm.thigh) =
      search_girth(mesh, lm.crotch - 0.08, lm.crotch - 0.005, 30, true, leg_axis, other_leg_axis);
  need(v.thigh, "thigh");
  const double clo = lknee.y() - 0.6 * (lknee.y() - lankle.y()), chi = lknee.y() - 0.15 * (lknee.y() - lankle.y());
  std::tie(v.calf, lm.calf) = search_girth(mesh, clo, chi, 40, true, leg_axis);
  need(v.calf, "calf");

  v.height = lm.top - lm.floor;
  v.crotch_height = lm.crotch - lm.floor;
  v.knee_height = 0.5 * (lknee.y() + joint_at(joints, Joint::RIGHT_KNEE).y()) - lm.floor;
  const Eigen::Vector3d sh = joint_at(joints, Joint::LEFT_SHOULDER), el = joint_at(joints, Joint::LEFT_ELBOW),
                        wr = joint_at(joints, Joint::LEFT_WRIST);
  v.forearm_length = (wr - el).norm();
  v.arm_length = (el - sh).norm() + v.forearm_length;
  v.shoulder_width = (joint_at(joints, Joint::LEFT_SHOULDER) - joint_at(joints, Joint::RIGHT_SHOULDER)).norm();
  return out;
}

double torso_depth(const Mesh& mesh, const JointPositions& joints) {
  const double hip_y = 0.5 * (joints(idx(Joint::LEFT_HIP), 1) + joints(idx(Joint::RIGHT_HIP), 1));
  const double shoulder_y = 0.5 * (joints(idx(Joint::LEFT_SHOULDER), 1) + joints(idx(Joint::RIGHT_SHOULDER), 1));
  const double centre_x = 0.5 * (joints(idx(Joint::LEFT_SHOULDER), 0) + joints(idx(Joint::RIGHT_SHOULDER), 0));
  const double half_span = 0.5 * std::abs(joints(idx(Joint::LEFT_SHOULDER), 0) - joints(idx(Joint::RIGHT_SHOULDER), 0));
  double z_min = INFINITY, z_max = -INFINITY;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float* p = &mesh.positions[3 * v];
    if (p[1] < std::min(hip_y, shoulder_y) || p[1] > std::max(hip_y, shoulder_y) ||
        std::abs(p[0] - centre_x) > half_span)
      continue;
    z_min = std::min(z_min, double(p[2]));
    z_max = std::max(z_max, double(p[2]));
  }
  return z_max >= z_min ? z_max - z_min : 0.0;
}

} // namespace vfit
