// SPDX-License-Identifier: Apache-2.0
#include "arm_estimation.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "plane_sections.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// Lengths are fractions of the body's height H. The proportions were calibrated on the
// MakeHuman hm08 rig and on our mannequins (average, pear, tall, petite; A- and T-pose).
constexpr double STEP = 0.003;             // slicing step along the arm: 5 mm at 1.7 m
constexpr double CLUSTER_RADIUS = 0.05;    // loops centred this close to the last centroid are the arm's (fingers too)
constexpr double MIN_LATERAL_REACH = 0.10; // the fingertip lies at least this far beyond the shoulder guess
constexpr double MIN_ARM_LENGTH = 0.25;    // shoulder → fingertip along the arm (hm08 0.35, mannequins 0.43)
constexpr double HAND_LENGTH_MAX = 0.15;   // past this distance from the fingertip, a jump in area is the torso
constexpr double WRIST_SEARCH_MIN = 0.065, WRIST_SEARCH_MAX = 0.15; // the wrist's distance from the fingertip
constexpr double NARROW_TOLERANCE = 1.04;    // sections within 4 % of the narrowest make the narrow region
constexpr double NARROWEST_FROM_TIP = 0.106; // if no narrowing shows (hm08 and the mannequins: 0.10–0.11)
// The narrowest forearm section lies just proximal of the wrist joint (the styloid processes
// widen the wrist itself): 1.3 cm on hm08, 1.6 cm on the mannequins.
constexpr double WRIST_PAST_NARROWEST = 0.010;
constexpr double HAND_PAST_WRIST = 0.052;                  // knuckles beyond the wrist (hm08 0.058, mannequins 0.050)
constexpr double ELBOW_FRACTION = 0.52;                    // shoulder → wrist (hm08 0.49, mannequins 0.545)
constexpr double UPPER_FIT_LO = 0.10, UPPER_FIT_HI = 0.40; // part of shoulder → wrist that fits the upper arm's line
constexpr double MAX_DROP_DEGREES = 70, MIN_DROP_DEGREES = -25;

struct ArmSample {
  double s;                 // level along the arm direction (m)
  Eigen::Vector3d centroid; // of the arm's loops at that level
  double area, diameter;
};

// The arm's sections from the fingertip back towards the torso, stopping where the arm's
// loops merge into the torso's (the centroid jumps or the area balloons).
std::vector<ArmSample> trace_arm(const PlaneSlicer& slicer, const Eigen::Vector3d& tip, double s_end, double height) {
  const double step = STEP * height, radius = CLUSTER_RADIUS * height, s_tip = tip.dot(slicer.direction());
  std::vector<ArmSample> samples;
  Eigen::Vector3d q = tip;
  for (double s = s_tip - step / 2; s > s_end; s -= step) {
    double area = 0;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    std::vector<const PlaneSection*> cluster;
    const std::vector<PlaneSection> loops = slicer.sections(s);
    for (const PlaneSection& loop : loops)
      if ((loop.centroid - q).norm() < radius) {
        cluster.push_back(&loop);
        area += loop.area;
        c += loop.area * loop.centroid;
      }
    if (cluster.empty() || area <= 0) break;
    c /= area;
    if (s_tip - s > HAND_LENGTH_MAX * height && !samples.empty() &&
        (area > 2.5 * samples.back().area || (c - q).norm() > 0.5 * radius))
      break;
    double diameter = 0;
    for (int k = 0; k < 16; ++k) {
      const Eigen::Vector2d e(std::cos(M_PI * k / 16), std::sin(M_PI * k / 16));
      double lo = INFINITY, hi = -INFINITY;
      for (const PlaneSection* loop : cluster)
        for (const Eigen::Vector2d& p : loop->uv) {
          lo = std::min(lo, p.dot(e));
          hi = std::max(hi, p.dot(e));
        }
      diameter = std::max(diameter, hi - lo);
    }
    samples.push_back({s, c, area, diameter});
    q = c;
  }
  return samples;
}

// The traced centreline at level s (samples run from the fingertip down in s), interpolated.
Eigen::Vector3d centre_at(const std::vector<ArmSample>& samples, double s) {
  if (s >= samples.front().s) return samples.front().centroid;
  for (std::size_t i = 1; i < samples.size(); ++i)
    if (s >= samples[i].s) {
      const double t = (s - samples[i].s) / (samples[i - 1].s - samples[i].s);
      return samples[i].centroid + t * (samples[i - 1].centroid - samples[i].centroid);
    }
  return samples.back().centroid;
}

// The distance from the fingertip (m) of the wrist's narrowest section, or NaN if none.
double narrowest_before_hand(const std::vector<ArmSample>& samples, double s_tip, double height) {
  std::vector<std::size_t> window;
  for (std::size_t i = 1; i + 1 < samples.size(); ++i) {
    const double t = s_tip - samples[i].s;
    if (t >= WRIST_SEARCH_MIN * height && t <= WRIST_SEARCH_MAX * height) window.push_back(i);
  }
  if (window.size() < 5) return NAN;
  auto smoothed = [&](std::size_t i) {
    return (samples[i - 1].diameter + samples[i].diameter + samples[i + 1].diameter) / 3;
  };
  std::size_t best = window.front();
  for (std::size_t i : window)
    if (smoothed(i) < smoothed(best)) best = i;
  const double limit = NARROW_TOLERANCE * smoothed(best);
  std::size_t lo = best, hi = best;
  while (lo > window.front() && smoothed(lo - 1) <= limit)
    --lo;
  while (hi < window.back() && smoothed(hi + 1) <= limit)
    ++hi;
  return s_tip - 0.5 * (samples[lo].s + samples[hi].s);
}

} // namespace

ArmJoints estimate_arm(const Mesh& mesh, const ArmSearch& search) {
  const double H = search.height;
  const int side = search.side;
  const std::string which = side > 0 ? "left" : "right";
  const auto& p = mesh.positions;
  // The fingertip: the point farthest out on this side, above the knees (the feet of a wide
  // stance never reach as far out as the hands of an A-pose).
  std::size_t tip_v = 0;
  double reach = -INFINITY;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const double lateral = side * (p[3 * v] - search.mid_x);
    if (p[3 * v + 1] > search.floor + 0.3 * H && lateral > reach) {
      reach = lateral;
      tip_v = v;
    }
  }
  const Eigen::Vector3d tip(p[3 * tip_v], p[3 * tip_v + 1], p[3 * tip_v + 2]);
  const double shoulder_reach = side * (search.shoulder_guess.x() - search.mid_x);
  if (reach < shoulder_reach + MIN_LATERAL_REACH * H)
    throw Error(search.source, 0, "no " + which + " arm stands away from the torso (expected an A- or T-pose)");
  const Eigen::Vector3d axis = tip - search.shoulder_guess;
  if (axis.norm() < MIN_ARM_LENGTH * H)
    throw Error(search.source, 0,
                "the " + which + " arm is too short for the body (" + std::to_string(axis.norm()) + " m)");
  const PlaneSlicer slicer(mesh, axis);
  const Eigen::Vector3d& d = slicer.direction();
  const double s_tip = tip.dot(d), s_guess = search.shoulder_guess.dot(d);
  const std::vector<ArmSample> samples = trace_arm(slicer, tip, s_guess, H);
  if (samples.size() < 10 || s_tip - samples.back().s < 0.5 * (s_tip - s_guess))
    throw Error(search.source, 0,
                "the " + which + " arm could not be followed from the hand to the shoulder (it touches the body?)");

  ArmJoints arm;
  double t_narrow = narrowest_before_hand(samples, s_tip, H);
  if (std::isnan(t_narrow)) {
    arm.wrist_found = false;
    t_narrow = NARROWEST_FROM_TIP * H;
  }
  const double s_wrist = s_tip - t_narrow + WRIST_PAST_NARROWEST * H;
  arm.wrist = centre_at(samples, s_wrist);
  arm.hand = centre_at(samples, std::min(s_wrist + HAND_PAST_WRIST * H, s_tip));

  // The upper arm's centreline (a least-squares line through its section centroids), cut by the
  // plane x = shoulder_guess.x: the glenohumeral joint sits above the armpit.
  std::vector<Eigen::Vector3d> upper;
  const double span = s_wrist - s_guess;
  for (const ArmSample& a : samples)
    if (a.s >= s_guess + UPPER_FIT_LO * span && a.s <= s_guess + UPPER_FIT_HI * span) upper.push_back(a.centroid);
  if (upper.size() < 4)
    throw Error(search.source, 0, "the " + which + " upper arm merges with the torso (arms must stand away from it)");
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : upper)
    mean += c;
  mean /= double(upper.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& c : upper)
    cov += (c - mean) * (c - mean).transpose();
  Eigen::Vector3d dir = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(2);
  if (dir.dot(d) < 0) dir = -dir;
  arm.drop_degrees = std::asin(std::clamp(-dir.y(), -1.0, 1.0)) * 180 / M_PI;
  if (arm.drop_degrees > MAX_DROP_DEGREES || arm.drop_degrees < MIN_DROP_DEGREES || std::abs(dir.x()) < 0.3)
    throw Error(search.source, 0,
                "the " + which + " upper arm points " + std::to_string(int(std::lround(arm.drop_degrees))) +
                    "° below horizontal: expected an A-pose (about 45°) or a T-pose (0°)");
  arm.shoulder = mean + (search.shoulder_guess.x() - mean.x()) / dir.x() * dir;
  const double s_shoulder = arm.shoulder.dot(d);
  const double s_elbow = s_shoulder + ELBOW_FRACTION * (s_wrist - s_shoulder);
  arm.elbow = s_elbow >= samples.back().s ? centre_at(samples, s_elbow)
                                          : Eigen::Vector3d(mean + (s_elbow - mean.dot(d)) / dir.dot(d) * dir);
  return arm;
}

} // namespace vfit
