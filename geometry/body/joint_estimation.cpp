// SPDX-License-Identifier: Apache-2.0
#include "joint_estimation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "arm_estimation.h"
#include "section_tracks.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// Heights are fractions of the body's height H above the floor unless said otherwise. The
// rules were calibrated on the MakeHuman hm08 rig and on our mannequins (average, pear, tall,
// petite; A- and T-pose); the two values are given where they differ.
constexpr int LEVELS = 500; // horizontal sections: 3.4 mm apart at 1.7 m
constexpr std::size_t MIN_VERTICES = 300;
constexpr double MIN_EXTENT = 0.5, MAX_EXTENT = 3.0;       // m: a largest extent outside is not in metres
constexpr double TORSO_SEED = 0.62;                        // the largest section here is the torso's
constexpr double LEG_AREA = 0.1;                           // a thigh's section: at least this part of the torso's
constexpr double HIP_ABOVE_CROTCH = 0.0535;                // hm08 0.057, mannequins 0.050
constexpr double PELVIS_ABOVE_HIPS = 0.013;                // hm08 0.014, mannequins 0.012
constexpr double KNEE_FRACTION = 0.60;                     // of the crotch's height: hm08 0.58, mannequins 0.61–0.63
constexpr double ANKLE_HEIGHT = 0.044;                     // hm08 0.043, mannequins 0.045
constexpr double SHANK_FIT_LO = 0.07, SHANK_FIT_HI = 0.12; // round shank sections above the foot
constexpr double BALL_HEIGHT = 0.011;                      // hm08 0.004, mannequins 0.018
constexpr double BALL_FRACTION = 0.62;                     // ankle → toe tip: hm08 0.63, mannequins 0.60
constexpr double ARMPIT_JUMP = 0.012;                      // a section this much wider than 2 cm below has met an arm
constexpr double SHOULDER_ABOVE_ARMPIT = 0.585;            // of armpit → top of the shoulders (first guess)
constexpr double TORSO_SIDE_BELOW_ARMPIT = 0.006;          // the torso's side is measured this far under the armpit
constexpr double SHOULDER_OUTSIDE_TORSO = 0.005;           // and the shoulder joint lies this far beyond it
constexpr double NECK_ABOVE_SHOULDERS = 0.002; // above the top of the shoulders: hm08 +0.010, mannequins −0.005
constexpr double HEAD_BELOW_TOP = 0.57;        // of the head and neck's height above the shoulders
constexpr double T_POSE_MAX_DROP = 25;         // degrees below horizontal: T-pose under, A-pose over
// Collar joints: below the top of the shoulders (hm08 0.032, mannequins 0.039), beside the
// mid-plane (hm08 0.016, mannequins 0.026) and in front of the upper back (hm08 0.073,
// mannequins 0.054–0.067). hm08 puts them at the sternal end of the clavicle, SMPL-like rigs
// (our mannequins) further out and deeper; these values lie within 2 cm of both.
constexpr double COLLAR_BELOW_SHOULDERS = 0.0355, COLLAR_X = 0.021, COLLAR_DEPTH = 0.0636;
// SMPL's spine joints, as fractions of pelvis → neck: the SMPL neutral template's joint heights
// (rig_mapping.h); the mannequins use the same fractions.
constexpr double SPINE_FRACTIONS[3] = {0.213, 0.478, 0.581};
// The spine joints' depth as a fraction of the torso's depth from the back (0) to the front (1).
// The vertebral column runs behind the section's centroid: MakeHuman's rig puts it at 0.19–0.31
// (hm08), the mannequins at 0.30.
constexpr double SPINE_DEPTH = 0.33;

void check_shape(const Mesh& mesh, const std::string& source) {
  if (mesh.vertex_count() < MIN_VERTICES || mesh.face_count() < MIN_VERTICES)
    throw Error(source, 0, "too few vertices (" + std::to_string(mesh.vertex_count()) + ") for a body scan");
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    for (int k = 0; k < 3; ++k) {
      const double c = mesh.positions[3 * v + k];
      if (!std::isfinite(c)) throw Error(source, 0, "vertex " + std::to_string(v) + " is not finite");
      lo[k] = std::min(lo[k], c);
      hi[k] = std::max(hi[k], c);
    }
  const Eigen::Vector3d ext = hi - lo;
  std::ostringstream size;
  size.precision(3);
  size << ext.x() << " m wide, " << ext.y() << " m tall and " << ext.z() << " m deep";
  if (ext.maxCoeff() < MIN_EXTENT || ext.maxCoeff() > MAX_EXTENT)
    throw Error(source, 0, "the mesh is " + size.str() + ": not a body in metres (expected 0.5–3 m tall)");
  // Upright: far taller than deep, and as tall as a T-pose's arm span at least.
  // The message says which test failed: a body that stands Y up can still sit or kneel.
  if (ext.y() < 2 * ext.z())
    throw Error(source, 0,
                "the mesh is " + size.str() +
                    ": not an upright body (Y up, facing +Z): deeper than half its height (sitting, "
                    "kneeling or lying, or a floor scanned with it?)");
  if (ext.y() < 0.75 * ext.x())
    throw Error(source, 0,
                "the mesh is " + size.str() +
                    ": not an upright body (Y up, facing +Z): wider than 4/3 of its height (lying on "
                    "its side, or a floor scanned with it?)");
}

const char* side_name(int side) { return side > 0 ? "left" : "right"; }
Joint sided(int side, Joint left, Joint right) { return side > 0 ? left : right; }

// The steps of estimate_joints(), sharing the body's sections and landmarks.
class JointEstimator {
public:
  /// `mesh` has passed check_shape().
  JointEstimator(const Mesh& mesh, std::string source)
      : m_mesh(mesh), m_source(std::move(source)), m_s(mesh, LEVELS), m_h(m_s.height) {}

  JointEstimate run() {
    find_torso();
    find_legs();
    find_shoulder_top();
    for (int side : {1, -1})
      place_arm(side);
    for (int side : {1, -1})
      place_leg(side);
    place_trunk();
    add_warnings();
    return m_est;
  }

private:
  void set(Joint j, const Eigen::Vector3d& p, double confidence) {
    m_est.joints.row(idx(j)) = p.transpose();
    m_est.confidence[std::size_t(idx(j))] = confidence;
  }
  const std::vector<PlaneSection>& loops(int level) const { return m_s.levels[std::size_t(level)]; }
  Eigen::Vector3d torso_centroid(double y) const { return centroid_at(m_s, m_torso, y); }

  // SPINE_DEPTH of the way from the back to the front of the torso's section nearest height y,
  // measured near the mid-sagittal plane (within 3 % of the body's height of it, which keeps
  // arms touching the torso out); the centroid's depth when there is no such section.
  double spine_depth(double y) const {
    const PlaneSection* loop = loop_at(m_s, m_torso, m_s.index(y));
    double back = INFINITY, front = -INFINITY;
    if (loop)
      for (const Eigen::Vector3d& p : loop->points)
        if (std::abs(p.x() - m_mid_x) < 0.03 * m_h) {
          back = std::min(back, p.z());
          front = std::max(front, p.z());
        }
    if (!(front > back)) return torso_centroid(y).z();
    return back + SPINE_DEPTH * (front - back);
  }
  double torso_width(int level) const {
    const PlaneSection& l = *loop_at(m_s, m_torso, level);
    return reach(l, m_mid_x, 1) + reach(l, m_mid_x, -1);
  }

  // The largest loop at `level` on `side` of the mid-plane that is big enough for a thigh
  // (the hands beside the hips are far smaller), or −1.
  int leg_loop(int level, int side) const {
    const auto& l = loops(level);
    int best = -1;
    for (std::size_t j = 0; j < l.size(); ++j)
      if (side * (l[j].centroid.x() - m_mid_x) > 0 && std::abs(l[j].centroid.x() - m_mid_x) < 0.2 * m_h &&
          l[j].area > LEG_AREA * m_seed_area && (best < 0 || l[j].area > l[std::size_t(best)].area))
        best = int(j);
    return best;
  }
  bool legs_apart(int level) const {
    const int left = leg_loop(level, 1), right = leg_loop(level, -1);
    return left >= 0 && right >= 0 && left != right;
  }

  // The torso: the largest section at TORSO_SEED of the height, followed down until the
  // section splits into two legs (the crotch) and up to the top of the head.
  void find_torso() {
    m_seed = m_s.index(m_s.floor + TORSO_SEED * m_h);
    int first = -1;
    for (std::size_t j = 0; j < loops(m_seed).size(); ++j)
      if (first < 0 || loops(m_seed)[j].area > loops(m_seed)[std::size_t(first)].area) first = int(j);
    if (first < 0) throw Error(m_source, 0, "no torso section at " + std::to_string(TORSO_SEED) + " of the height");
    m_mid_x = loops(m_seed)[std::size_t(first)].centroid.x();
    m_seed_area = loops(m_seed)[std::size_t(first)].area;
    m_torso = follow_part(m_s, m_seed, first, -1, 0.05 * m_h, [this](int i) { return legs_apart(i); });
    const SectionTrack up = follow_part(m_s, m_seed, first, +1, 0.05 * m_h);
    for (std::size_t i = 0; i < up.size(); ++i)
      if (up[i] >= 0) m_torso[i] = up[i];
    m_bottom = m_crown = m_seed;
    while (m_bottom > 0 && m_torso[std::size_t(m_bottom - 1)] >= 0)
      --m_bottom;
    while (m_crown + 1 < LEVELS && m_torso[std::size_t(m_crown + 1)] >= 0)
      ++m_crown;
    m_crotch = m_s.y(m_bottom) - m_s.step / 2;
    if (m_bottom == 0 || !legs_apart(m_bottom - 1) || m_crotch < m_s.floor + 0.3 * m_h)
      throw Error(m_source, 0,
                  "no crotch found: the torso does not split into two legs (legs apart, standing upright?)");
    if (m_s.y(m_crown) < m_s.top - 0.03 * m_h)
      throw Error(m_source, 0, "the highest point is not the top of the head (arms raised? expected an A- or T-pose)");
  }

  // The legs: the thigh loops just below the crotch, followed to the floor.
  void find_legs() {
    for (int side : {1, -1}) {
      const int first = leg_loop(m_bottom - 1, side);
      if (first < 0) throw Error(m_source, 0, std::string("no ") + side_name(side) + " leg below the crotch");
      SectionTrack& leg = m_legs[side > 0 ? 0 : 1];
      leg = follow_part(m_s, m_bottom - 1, first, -1, 0.05 * m_h);
      int foot = m_bottom - 1;
      while (foot > 0 && leg[std::size_t(foot - 1)] >= 0)
        --foot;
      if (m_s.y(foot) > m_s.floor + 0.03 * m_h)
        throw Error(m_source, 0, std::string("the ") + side_name(side) + " leg does not reach the floor");
    }
  }

  // The neck: the thinnest section (least area: the chin widens the sections above it) between
  // the shoulders and the head. The top of the shoulders: where the section below the neck
  // widens past twice the neck's width.
  void find_shoulder_top() {
    m_neck_level = -1;
    for (int i = m_s.index(m_s.floor + 0.75 * m_h); i <= std::min(m_crown, m_s.index(m_s.top - 0.10 * m_h)); ++i)
      if (m_torso[std::size_t(i)] >= 0 &&
          (m_neck_level < 0 || loop_at(m_s, m_torso, i)->area < loop_at(m_s, m_torso, m_neck_level)->area))
        m_neck_level = i;
    if (m_neck_level < 0 || torso_width(m_neck_level) > 0.5 * torso_width(m_seed))
      throw Error(m_source, 0,
                  "no neck found: no section above three quarters of the height is narrower than half the torso");
    int level = m_neck_level;
    while (level > m_seed && torso_width(level) <= 2 * torso_width(m_neck_level))
      --level;
    m_shoulder_top = m_s.y(level) + m_s.step / 2;
  }

  // One arm: the armpit is where, going up from the waist, the torso's section widens on that
  // side by more than ARMPIT_JUMP within as much height (a T-pose's arms blend in over a
  // centimetre or two); the shoulder joint is first guessed above it, then the arm is traced
  // (arm_estimation.h). The collar follows the top of the shoulders.
  void place_arm(int side) {
    auto side_width = [&](int i) { return reach(*loop_at(m_s, m_torso, i), m_mid_x, side); };
    const int lag = std::max(1, int(std::ceil(ARMPIT_JUMP * m_h / m_s.step)));
    const int top_level = m_s.index(m_shoulder_top);
    int armpit = -1;
    for (int i = m_seed + lag; i <= top_level && armpit < 0; ++i)
      if (side_width(i) > side_width(i - lag) + ARMPIT_JUMP * m_h) armpit = i;
    if (armpit < 0 || m_s.y(armpit) < m_shoulder_top - 0.15 * m_h)
      throw Error(m_source, 0,
                  std::string("the ") + side_name(side) +
                      " arm does not stand away from the torso below the shoulder (expected an A- or T-pose)");
    const double armpit_y = m_s.y(armpit) - m_s.step / 2;
    const double torso_side = side_width(std::max(m_seed, m_s.index(armpit_y - TORSO_SIDE_BELOW_ARMPIT * m_h)));
    ArmSearch search;
    search.side = side;
    search.floor = m_s.floor;
    search.height = m_h;
    search.mid_x = m_mid_x;
    search.source = m_source;
    const double guess_y = armpit_y + SHOULDER_ABOVE_ARMPIT * (m_shoulder_top - armpit_y);
    search.shoulder_guess = {m_mid_x + side * (torso_side + SHOULDER_OUTSIDE_TORSO * m_h), guess_y,
                             torso_centroid(guess_y).z()};
    const ArmJoints arm = estimate_arm(m_mesh, search);
    set(sided(side, Joint::LEFT_SHOULDER, Joint::RIGHT_SHOULDER), arm.shoulder, 0.9);
    set(sided(side, Joint::LEFT_ELBOW, Joint::RIGHT_ELBOW), arm.elbow, 0.8);
    set(sided(side, Joint::LEFT_WRIST, Joint::RIGHT_WRIST), arm.wrist, arm.wrist_found ? 0.9 : 0.5);
    set(sided(side, Joint::LEFT_HAND, Joint::RIGHT_HAND), arm.hand, arm.wrist_found ? 0.8 : 0.5);
    const RestPose pose = arm.drop_degrees < T_POSE_MAX_DROP ? RestPose::TPOSE : RestPose::APOSE;
    if (side > 0)
      m_est.pose = pose;
    else if (pose != m_est.pose) {
      m_est.pose = RestPose::OTHER;
      m_est.warnings.push_back("the arms are in different poses (one T-pose, one A-pose)");
    }
    // Collar: near the sternal end of the clavicle, at a depth measured from the upper back
    // (bony there: chest fat does not move it) on a strip along the mid-sagittal plane.
    const double y = m_shoulder_top - COLLAR_BELOW_SHOULDERS * m_h;
    const PlaneSection& chest = *loop_at(m_s, m_torso, m_s.index(y));
    double back = INFINITY;
    for (const auto& p : chest.points)
      if (std::abs(p.x() - m_mid_x) < 0.03 * m_h) back = std::min(back, p.z());
    if (!std::isfinite(back)) back = chest.centroid.z() - COLLAR_DEPTH * m_h;
    set(sided(side, Joint::LEFT_COLLAR, Joint::RIGHT_COLLAR),
        {neck_x() + side * COLLAR_X * m_h, y, back + COLLAR_DEPTH * m_h}, 0.6);
  }

  // One leg: hip on the thigh's axis above the crotch, knee and ankle on the leg's centre line,
  // the ball of the foot along the foot from the ankle to the toes.
  // The ankle, the shank's fit and the ball of the foot are measured from the leg's own sole
  // (its lowest point), not the body's: a foot that stands a few cm higher than the other (a
  // raised heel, uneven ground, a leg unposed from a bent knee) keeps its ankle above its own sole.
  void place_leg(int side) {
    const SectionTrack& leg = m_legs[side > 0 ? 0 : 1];
    const double sole = leg_sole(side);
    const double knee_y = m_s.floor + KNEE_FRACTION * (m_crotch - m_s.floor), ankle_y = sole + ANKLE_HEIGHT * m_h;
    const double hip_y = m_crotch + HIP_ABOVE_CROTCH * m_h;
    Eigen::Vector3d hip =
        axis_at(m_s, leg, knee_y + 0.3 * (m_crotch - knee_y), knee_y + 0.8 * (m_crotch - knee_y), hip_y);
    hip.z() = torso_centroid(hip_y).z();
    set(sided(side, Joint::LEFT_HIP, Joint::RIGHT_HIP), hip, 0.8);
    set(sided(side, Joint::LEFT_KNEE, Joint::RIGHT_KNEE), centroid_at(m_s, leg, knee_y), 0.8);
    const Eigen::Vector3d ankle = axis_at(m_s, leg, sole + SHANK_FIT_LO * m_h, sole + SHANK_FIT_HI * m_h, ankle_y);
    set(sided(side, Joint::LEFT_ANKLE, Joint::RIGHT_ANKLE), ankle, 0.9);
    const auto& p = m_mesh.positions;
    auto in_foot = [&](std::size_t v) {
      return p[3 * v + 1] < ankle_y && side * (p[3 * v] - m_mid_x) > 0 && std::abs(p[3 * v] - ankle.x()) < 0.1 * m_h;
    };
    double toe = -INFINITY, heel = INFINITY;
    for (std::size_t v = 0; v < m_mesh.vertex_count(); ++v)
      if (in_foot(v)) {
        toe = std::max(toe, double(p[3 * v + 2]));
        heel = std::min(heel, double(p[3 * v + 2]));
      }
    if (!std::isfinite(toe) || toe - ankle.z() < ankle.z() - heel)
      throw Error(m_source, 0, "the feet do not point to +Z: the body must face +Z");
    const double ball_z = ankle.z() + BALL_FRACTION * (toe - ankle.z());
    double xlo = INFINITY, xhi = -INFINITY;
    for (std::size_t v = 0; v < m_mesh.vertex_count(); ++v)
      if (in_foot(v) && std::abs(p[3 * v + 2] - ball_z) < 0.01 * m_h) {
        xlo = std::min(xlo, double(p[3 * v]));
        xhi = std::max(xhi, double(p[3 * v]));
      }
    const double ball_x = std::isfinite(xlo) ? 0.5 * (xlo + xhi) : ankle.x();
    set(sided(side, Joint::LEFT_FOOT, Joint::RIGHT_FOOT), {ball_x, sole + BALL_HEIGHT * m_h, ball_z}, 0.8);
  }

  // The lowest point of the leg on `side`: the lowest vertex on that side of the mid-plane
  // below the leg's lowest section (find_legs() has checked that it reaches within 3 % of the
  // height of the floor, where no hand reaches).
  double leg_sole(int side) const {
    const SectionTrack& leg = m_legs[side > 0 ? 0 : 1];
    int lowest = m_bottom - 1;
    while (lowest > 0 && leg[std::size_t(lowest - 1)] >= 0)
      --lowest;
    const double below = m_s.y(lowest) + m_s.step;
    double sole = INFINITY;
    const auto& p = m_mesh.positions;
    for (std::size_t v = 0; v < m_mesh.vertex_count(); ++v)
      if (p[3 * v + 1] < below && side * (p[3 * v] - m_mid_x) > 0) sole = std::min(sole, double(p[3 * v + 1]));
    return std::isfinite(sole) ? sole : m_s.floor;
  }

  // Pelvis, spine, neck and head on the mid-sagittal plane, at the torso's centroid depth (the
  // head at the neck's).
  void place_trunk() {
    const double pelvis_y = m_crotch + (HIP_ABOVE_CROTCH + PELVIS_ABOVE_HIPS) * m_h;
    const double neck_y = m_shoulder_top + NECK_ABOVE_SHOULDERS * m_h;
    set(Joint::PELVIS, {m_mid_x, pelvis_y, torso_centroid(pelvis_y).z()}, 0.8);
    const Joint spine[3] = {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3};
    for (int k = 0; k < 3; ++k) {
      const double y = pelvis_y + SPINE_FRACTIONS[k] * (neck_y - pelvis_y);
      set(spine[k], {m_mid_x, y, spine_depth(y)}, 0.5);
    }
    set(Joint::NECK, {neck_x(), neck_y, torso_centroid(neck_y).z()}, 0.8);
    const double head_y = m_s.top - HEAD_BELOW_TOP * (m_s.top - m_shoulder_top);
    set(Joint::HEAD, {neck_x(), head_y, loop_at(m_s, m_torso, m_neck_level)->centroid.z()}, 0.7);
  }

  // The neck's mid-plane: its narrowest section's centroid, not the chest's (m_mid_x): a
  // shoulder girdle or neck tilted sideways (a scan unposed from a twisted torso, a head held to
  // one side) carries the neck, the head and the collars 1-3 cm off the chest's mid-plane.
  double neck_x() const { return loop_at(m_s, m_torso, m_neck_level)->centroid.x(); }

  void add_warnings() {
    const TopologyReport topo = analyse_topology(m_mesh.triangle_view(), m_mesh.vertex_count());
    if (topo.boundary_loops > 0)
      m_est.warnings.push_back("the mesh has " + std::to_string(topo.boundary_loops) +
                               " holes; joints were estimated across them");
    if (topo.components > 1)
      m_est.warnings.push_back("the mesh has " + std::to_string(topo.components) +
                               " separate parts; all were sliced as one body");
    const JointPositions& J = m_est.joints;
    if (std::abs(J(idx(Joint::LEFT_SHOULDER), 1) - J(idx(Joint::RIGHT_SHOULDER), 1)) > 0.03 * m_h)
      m_est.warnings.push_back("the shoulders differ in height by more than 3 % of the height: an asymmetric pose");
    if (m_h < 1.2 || m_h > 2.3) m_est.warnings.push_back("unusual body height " + std::to_string(m_h) + " m");
  }

  const Mesh& m_mesh;
  const std::string m_source;
  const BodySlices m_s;
  const double m_h; // the body's height (m)
  JointEstimate m_est;
  double m_mid_x = 0, m_seed_area = 0, m_crotch = 0, m_shoulder_top = 0;
  int m_seed = 0, m_bottom = 0, m_crown = 0, m_neck_level = 0;
  SectionTrack m_torso, m_legs[2];
};

JointEstimate estimate_joints_named(const Mesh& mesh, const std::string& source) {
  check_shape(mesh, source);
  return JointEstimator(mesh, source).run();
}

} // namespace

JointEstimate estimate_joints(const Mesh& body_in_metres) { return estimate_joints_named(body_in_metres, "body"); }

Body rig_bare_body(Mesh body, std::string source) {
  const JointEstimate est = estimate_joints_named(body, source);
  Body b;
  b.weights = estimate_skin_weights(body, est.joints);
  b.joints = est.joints;
  b.rest_pose = est.pose;
  b.mesh = std::move(body);
  b.source = std::move(source);
  return b;
}

} // namespace vfit
