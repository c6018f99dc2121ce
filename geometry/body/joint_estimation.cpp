#include "joint_estimation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "arm_estimation.h"
#include "geometry/mesh/topology.h"
#include "kernels/error.h"
#include "plane_sections.h"

namespace vfit {
namespace {

// Heights are fractions of the body's height H above the floor unless said otherwise. The
// rules were calibrated on the MakeHuman hm08 rig and on our mannequins (average, pear, tall,
// petite; A- and T-pose); the two values are given where they differ.
constexpr int LEVELS = 500;                      // horizontal sections: 3.4 mm apart at 1.7 m
constexpr std::size_t MIN_VERTICES = 300;
constexpr double MIN_EXTENT = 0.5, MAX_EXTENT = 3.0; // m: a largest extent outside is not in metres
constexpr double TORSO_SEED = 0.62;              // the largest section here is the torso's
constexpr double TRACK_AREA_RATIO = 0.3;         // a part's area changes far less from level to level
constexpr double LEG_AREA = 0.1;                 // a thigh's section: at least this part of the torso's
constexpr double HIP_ABOVE_CROTCH = 0.0535;      // hm08 0.057, mannequins 0.050
constexpr double PELVIS_ABOVE_HIPS = 0.013;      // hm08 0.014, mannequins 0.012
constexpr double KNEE_FRACTION = 0.60;           // of the crotch's height: hm08 0.58, mannequins 0.61–0.63
constexpr double ANKLE_HEIGHT = 0.044;           // hm08 0.043, mannequins 0.045
constexpr double SHANK_FIT_LO = 0.07, SHANK_FIT_HI = 0.12; // round shank sections above the foot
constexpr double BALL_HEIGHT = 0.011;            // hm08 0.004, mannequins 0.018
constexpr double BALL_FRACTION = 0.62;           // ankle → toe tip: hm08 0.63, mannequins 0.60
constexpr double ARMPIT_JUMP = 0.012;            // a section this much wider than all below has met an arm
constexpr double SHOULDER_ABOVE_ARMPIT = 0.585;  // of armpit → top of the shoulders (first guess)
constexpr double TORSO_SIDE_BELOW_ARMPIT = 0.006; // the torso's side is measured this far under the armpit
constexpr double SHOULDER_OUTSIDE_TORSO = 0.005; // and the shoulder joint lies this far beyond it
constexpr double NECK_ABOVE_SHOULDERS = 0.002;   // above the top of the shoulders: hm08 +0.010, mannequins −0.005
constexpr double HEAD_BELOW_TOP = 0.57;          // of the head and neck's height above the shoulders
// Collar joints: below the top of the shoulders (hm08 0.032, mannequins 0.039), beside the
// mid-plane (hm08 0.016, mannequins 0.026) and in front of the upper back (hm08 0.073,
// mannequins 0.054–0.067). hm08 puts them at the sternal end of the clavicle, SMPL-like rigs
// (our mannequins) further out and deeper; these values lie within 2 cm of both.
constexpr double COLLAR_BELOW_SHOULDERS = 0.0355, COLLAR_X = 0.021, COLLAR_DEPTH = 0.0636;
// SMPL's spine joints, as fractions of pelvis → neck (the mannequins: 0.20, 0.42, 0.63).
constexpr double SPINE_FRACTIONS[3] = {0.20, 0.42, 0.63};

struct Slices {
  double floor = 0, top = 0, height = 0, step = 0;
  std::vector<std::vector<PlaneSection>> levels; // level i: y = floor + (i + 0.5)·step; uv = (z, x)
  double y(int i) const { return floor + (i + 0.5) * step; }
  int index(double y) const { return std::clamp(int(std::lround((y - floor) / step - 0.5)), 0, int(levels.size()) - 1); }
};

// The largest loop of at least `min_area` (m²) containing q (in the sections' (z, x)
// coordinates), or −1.
int containing(const std::vector<PlaneSection>& loops, const Eigen::Vector2d& q, double min_area = 0) {
  int best = -1;
  for (std::size_t j = 0; j < loops.size(); ++j)
    if (loops[j].area >= min_area && loops[j].contains(q) && (best < 0 || loops[j].area > loops[std::size_t(best)].area))
      best = int(j);
  return best;
}

// Follows a body part from loop `first` of level `start` through the levels in direction `dir`
// (+1 up, −1 down): each level's loop is the one containing the previous centroid or, failing
// that (a notch such as an open mouth), the loop whose centroid lies closest within `nearest`
// (m). Loops of less than TRACK_AREA_RATIO times the previous area (specks from folded or noisy
// triangles) are taken only when nothing larger qualifies. Stops before a level where `stop(level)` holds. Returns the loop
// index per level, −1 outside the part.
template <typename Stop>
std::vector<int> follow(const Slices& s, int start, int first, int dir, double nearest, const Stop& stop) {
  std::vector<int> track(s.levels.size(), -1);
  track[std::size_t(start)] = first;
  const PlaneSection* prev = &s.levels[std::size_t(start)][std::size_t(first)];
  for (int i = start + dir; i >= 0 && i < int(s.levels.size()) && !stop(i); i += dir) {
    const auto& loops = s.levels[std::size_t(i)];
    const Eigen::Vector2d q = prev->centroid_uv;
    const double min_area = TRACK_AREA_RATIO * prev->area;
    int j = containing(loops, q, min_area);
    for (std::size_t k = 0; j < 0 && k < loops.size(); ++k)
      if (loops[k].area >= min_area && (loops[k].centroid_uv - q).norm() < nearest &&
          (j < 0 || (loops[k].centroid_uv - q).norm() < (loops[std::size_t(j)].centroid_uv - q).norm()))
        j = int(k);
    if (j < 0) j = containing(loops, q); // the part really narrows (the neck above shoulders and raised arms)
    if (j < 0) break;
    track[std::size_t(i)] = j;
    prev = &loops[std::size_t(j)];
  }
  return track;
}

const PlaneSection* loop_at(const Slices& s, const std::vector<int>& track, int i) {
  return track[std::size_t(i)] < 0 ? nullptr : &s.levels[std::size_t(i)][std::size_t(track[std::size_t(i)])];
}

// The part's centroid at height y, interpolated between the two nearest levels it occupies.
Eigen::Vector3d centroid_at(const Slices& s, const std::vector<int>& track, double y) {
  const double f = std::clamp((y - s.floor) / s.step - 0.5, 0.0, double(s.levels.size() - 1));
  const int i0 = int(std::floor(f)), i1 = std::min(i0 + 1, int(s.levels.size()) - 1);
  const PlaneSection *a = loop_at(s, track, i0), *b = loop_at(s, track, i1);
  if (a && b) return a->centroid + (f - i0) * (b->centroid - a->centroid);
  if (!a && !b) throw Error("joint estimation: no section of the body part at height " + std::to_string(y));
  return a ? a->centroid : b->centroid;
}

// Least-squares x(y), z(y) through the part's centroids with y in [lo, hi], evaluated at y.
Eigen::Vector3d line_at(const Slices& s, const std::vector<int>& track, double lo, double hi, double y) {
  Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
  Eigen::Matrix<double, 2, 2> atb = Eigen::Matrix2d::Zero(); // columns: x, z
  for (int i = s.index(lo); i <= s.index(hi); ++i)
    if (const PlaneSection* l = loop_at(s, track, i)) {
      const Eigen::Vector2d a(1, l->centroid.y());
      ata += a * a.transpose();
      atb.col(0) += a * l->centroid.x();
      atb.col(1) += a * l->centroid.z();
    }
  if (ata(0, 0) < 2) return centroid_at(s, track, y);
  const Eigen::Matrix2d c = ata.ldlt().solve(atb);
  return {c(0, 0) + c(1, 0) * y, y, c(0, 1) + c(1, 1) * y};
}

double half_width(const PlaneSection& l, double mid_x, int side) {
  double w = 0;
  for (const auto& p : l.points) w = std::max(w, side * (p.x() - mid_x));
  return w;
}

void check_shape(const Mesh& mesh, const std::string& source, Slices& s) {
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
  if (ext.y() < 2 * ext.z() || ext.y() < 0.75 * ext.x())
    throw Error(source, 0, "the mesh is " + size.str() + ": not an upright body (Y up, facing +Z)");
  s.floor = lo.y();
  s.top = hi.y();
  s.height = ext.y();
}

JointEstimate estimate_joints_named(const Mesh& mesh, const std::string& source) {
  Slices s;
  check_shape(mesh, source, s);
  const double H = s.height;
  s.step = H / LEVELS;
  const PlaneSlicer slicer(mesh, Eigen::Vector3d::UnitY());
  s.levels.resize(LEVELS);
  for (int i = 0; i < LEVELS; ++i) s.levels[std::size_t(i)] = slicer.sections(s.y(i));
  JointEstimate est;
  JointPositions& J = est.joints;
  auto set = [&](Joint j, const Eigen::Vector3d& p, double confidence) {
    J.row(idx(j)) = p.transpose();
    est.confidence[std::size_t(idx(j))] = confidence;
  };

  // The torso, followed down to the crotch and up to the top of the head.
  const int seed = s.index(s.floor + TORSO_SEED * H);
  int seed_loop = -1;
  for (std::size_t j = 0; j < s.levels[std::size_t(seed)].size(); ++j)
    if (seed_loop < 0 || s.levels[std::size_t(seed)][j].area > s.levels[std::size_t(seed)][std::size_t(seed_loop)].area) seed_loop = int(j);
  if (seed_loop < 0) throw Error(source, 0, "no torso section at " + std::to_string(TORSO_SEED) + " of the height");
  const double mid_x = s.levels[std::size_t(seed)][std::size_t(seed_loop)].centroid.x();
  // Going down, the crotch is the first level holding a large loop on each side of the
  // mid-plane (two legs); the hands beside the hips are far smaller than a thigh.
  const double seed_area = s.levels[std::size_t(seed)][std::size_t(seed_loop)].area;
  auto leg_loop = [&](int i, int side) {
    const auto& loops = s.levels[std::size_t(i)];
    int best = -1;
    for (std::size_t j = 0; j < loops.size(); ++j)
      if (side * (loops[j].centroid.x() - mid_x) > 0 && std::abs(loops[j].centroid.x() - mid_x) < 0.2 * H &&
          loops[j].area > LEG_AREA * seed_area && (best < 0 || loops[j].area > loops[std::size_t(best)].area))
        best = int(j);
    return best;
  };
  auto legs_apart = [&](int i) { return leg_loop(i, 1) >= 0 && leg_loop(i, -1) >= 0 && leg_loop(i, 1) != leg_loop(i, -1); };
  std::vector<int> torso = follow(s, seed, seed_loop, -1, 0.05 * H, legs_apart);
  const std::vector<int> up = follow(s, seed, seed_loop, +1, 0.05 * H, [](int) { return false; });
  for (std::size_t i = 0; i < up.size(); ++i)
    if (up[i] >= 0) torso[i] = up[i];
  int bottom = seed, crown = seed;
  while (bottom > 0 && torso[std::size_t(bottom - 1)] >= 0) --bottom;
  while (crown + 1 < LEVELS && torso[std::size_t(crown + 1)] >= 0) ++crown;
  const double crotch = s.y(bottom) - s.step / 2;
  if (bottom == 0 || !legs_apart(bottom - 1) || crotch < s.floor + 0.3 * H)
    throw Error(source, 0, "no crotch found: the torso does not split into two legs (legs apart, standing upright?)");
  if (s.y(crown) < s.top - 0.03 * H)
    throw Error(source, 0, "the highest point is not the top of the head (arms raised? expected an A- or T-pose)");
  auto torso_centroid = [&](double y) { return centroid_at(s, torso, y); };

  // Legs: the largest loop on each side just below the crotch, followed to the floor.
  std::vector<int> legs[2];
  for (int side : {1, -1}) {
    const int best = leg_loop(bottom - 1, side);
    const std::string which = side > 0 ? "left" : "right";
    if (best < 0) throw Error(source, 0, "no " + which + " leg below the crotch");
    std::vector<int>& leg = legs[side > 0 ? 0 : 1];
    leg = follow(s, bottom - 1, best, -1, 0.05 * H, [](int) { return false; });
    int foot = bottom - 1;
    while (foot > 0 && leg[std::size_t(foot - 1)] >= 0) --foot;
    if (s.y(foot) > s.floor + 0.03 * H) throw Error(source, 0, "the " + which + " leg does not reach the floor");
  }

  // Neck: the thinnest section (least area: the chin widens the sections above it) between
  // the shoulders and the head; the top of the shoulders is where the section below it widens
  // past twice the neck's width.
  int neck_level = -1;
  auto width = [&](int i) { const PlaneSection& l = *loop_at(s, torso, i); return half_width(l, mid_x, 1) + half_width(l, mid_x, -1); };
  auto area = [&](int i) { return loop_at(s, torso, i)->area; };
  for (int i = s.index(s.floor + 0.75 * H); i <= std::min(crown, s.index(s.top - 0.10 * H)); ++i)
    if (torso[std::size_t(i)] >= 0 && (neck_level < 0 || area(i) < area(neck_level))) neck_level = i;
  if (neck_level < 0 || width(neck_level) > 0.5 * width(seed))
    throw Error(source, 0, "no neck found: no section above three quarters of the height is narrower than half the torso");
  int shoulder_level = neck_level;
  while (shoulder_level > seed && width(shoulder_level) <= 2 * width(neck_level)) --shoulder_level;
  const double shoulder_top = s.y(shoulder_level) + s.step / 2;

  // Armpits: going up from the waist, where the torso's section widens on that side by more
  // than ARMPIT_JUMP within as much height (a T-pose's arms blend in over a centimetre or two).
  const int lag = std::max(1, int(std::ceil(ARMPIT_JUMP * H / s.step)));
  for (int side : {1, -1}) {
    const std::string which = side > 0 ? "left" : "right";
    auto side_width = [&](int i) { return half_width(*loop_at(s, torso, i), mid_x, side); };
    int armpit = -1;
    for (int i = seed + lag; i <= shoulder_level && armpit < 0; ++i)
      if (side_width(i) > side_width(i - lag) + ARMPIT_JUMP * H) armpit = i;
    if (armpit < 0 || s.y(armpit) < shoulder_top - 0.15 * H)
      throw Error(source, 0, "the " + which + " arm does not stand away from the torso below the shoulder (expected an A- or T-pose)");
    const double armpit_y = s.y(armpit) - s.step / 2;
    const double torso_side = side_width(std::max(seed, s.index(armpit_y - TORSO_SIDE_BELOW_ARMPIT * H)));
    ArmSearch search;
    search.side = side;
    search.floor = s.floor;
    search.height = H;
    search.mid_x = mid_x;
    search.source = source;
    const double guess_y = armpit_y + SHOULDER_ABOVE_ARMPIT * (shoulder_top - armpit_y);
    search.shoulder_guess = {mid_x + side * (torso_side + SHOULDER_OUTSIDE_TORSO * H), guess_y, torso_centroid(guess_y).z()};
    const ArmJoints arm = estimate_arm(mesh, search);
    const bool left = side > 0;
    set(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER, arm.shoulder, 0.9);
    set(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW, arm.elbow, 0.8);
    set(left ? Joint::LEFT_WRIST : Joint::RIGHT_WRIST, arm.wrist, arm.wrist_found ? 0.9 : 0.5);
    set(left ? Joint::LEFT_HAND : Joint::RIGHT_HAND, arm.hand, arm.wrist_found ? 0.8 : 0.5);
    const RestPose pose = arm.drop_degrees < 25 ? RestPose::TPOSE : RestPose::APOSE;
    if (left) est.pose = pose;
    else if (pose != est.pose) {
      est.pose = RestPose::OTHER;
      est.warnings.push_back("the arms are in different poses (one T-pose, one A-pose)");
    }
    // Collar: near the sternal end of the clavicle, at a depth measured from the upper back
    // (bony there: chest fat does not move it) on a strip along the mid-sagittal plane.
    const double cy = shoulder_top - COLLAR_BELOW_SHOULDERS * H;
    const PlaneSection& chest = *loop_at(s, torso, s.index(cy));
    double back = INFINITY;
    for (const auto& p : chest.points)
      if (std::abs(p.x() - mid_x) < 0.03 * H) back = std::min(back, p.z());
    if (!std::isfinite(back)) back = chest.centroid.z() - COLLAR_DEPTH * H;
    set(left ? Joint::LEFT_COLLAR : Joint::RIGHT_COLLAR, {mid_x + side * COLLAR_X * H, cy, back + COLLAR_DEPTH * H}, 0.6);
  }

  // Legs' joints.
  const double knee_y = s.floor + KNEE_FRACTION * (crotch - s.floor), ankle_y = s.floor + ANKLE_HEIGHT * H;
  const double hip_y = crotch + HIP_ABOVE_CROTCH * H;
  for (int side : {1, -1}) {
    const bool left = side > 0;
    const std::vector<int>& leg = legs[left ? 0 : 1];
    Eigen::Vector3d hip = line_at(s, leg, knee_y + 0.3 * (crotch - knee_y), knee_y + 0.8 * (crotch - knee_y), hip_y);
    hip.z() = torso_centroid(hip_y).z();
    set(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP, hip, 0.8);
    set(left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE, centroid_at(s, leg, knee_y), 0.8);
    const Eigen::Vector3d ankle = line_at(s, leg, s.floor + SHANK_FIT_LO * H, s.floor + SHANK_FIT_HI * H, ankle_y);
    set(left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE, ankle, 0.9);
    // Ball of the foot: along the foot from the ankle to the toes, at the foot's mid-width.
    double toe = -INFINITY, heel = INFINITY;
    const auto& p = mesh.positions;
    auto in_foot = [&](std::size_t v) {
      return p[3 * v + 1] < ankle_y && side * (p[3 * v] - mid_x) > 0 && std::abs(p[3 * v] - ankle.x()) < 0.1 * H;
    };
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
      if (in_foot(v)) {
        toe = std::max(toe, double(p[3 * v + 2]));
        heel = std::min(heel, double(p[3 * v + 2]));
      }
    if (!std::isfinite(toe) || toe - ankle.z() < ankle.z() - heel)
      throw Error(source, 0, "the feet do not point to +Z: the body must face +Z");
    const double ball_z = ankle.z() + BALL_FRACTION * (toe - ankle.z());
    double xlo = INFINITY, xhi = -INFINITY;
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
      if (in_foot(v) && std::abs(p[3 * v + 2] - ball_z) < 0.01 * H) {
        xlo = std::min(xlo, double(p[3 * v]));
        xhi = std::max(xhi, double(p[3 * v]));
      }
    const double ball_x = std::isfinite(xlo) ? 0.5 * (xlo + xhi) : ankle.x();
    set(left ? Joint::LEFT_FOOT : Joint::RIGHT_FOOT, {ball_x, s.floor + BALL_HEIGHT * H, ball_z}, 0.8);
  }

  // Pelvis, spine, neck and head on the mid-sagittal plane.
  const double pelvis_y = hip_y + PELVIS_ABOVE_HIPS * H, neck_y = shoulder_top + NECK_ABOVE_SHOULDERS * H;
  set(Joint::PELVIS, {mid_x, pelvis_y, torso_centroid(pelvis_y).z()}, 0.8);
  const Joint spine[3] = {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3};
  for (int k = 0; k < 3; ++k) {
    const double y = pelvis_y + SPINE_FRACTIONS[k] * (neck_y - pelvis_y);
    set(spine[k], {mid_x, y, torso_centroid(y).z()}, 0.5);
  }
  set(Joint::NECK, {mid_x, neck_y, torso_centroid(neck_y).z()}, 0.8);
  const double head_y = s.top - HEAD_BELOW_TOP * (s.top - shoulder_top);
  set(Joint::HEAD, {mid_x, head_y, loop_at(s, torso, neck_level)->centroid.z()}, 0.7);

  const TopologyReport topo = analyse_topology(mesh.triangle_view(), mesh.vertex_count());
  if (topo.boundary_loops > 0)
    est.warnings.push_back("the mesh has " + std::to_string(topo.boundary_loops) + " holes; joints were estimated across them");
  if (topo.components > 1)
    est.warnings.push_back("the mesh has " + std::to_string(topo.components) + " separate parts; all were sliced as one body");
  if (std::abs(J(idx(Joint::LEFT_SHOULDER), 1) - J(idx(Joint::RIGHT_SHOULDER), 1)) > 0.03 * H)
    est.warnings.push_back("the shoulders differ in height by more than 3 % of the height: an asymmetric pose");
  if (H < 1.2 || H > 2.3) est.warnings.push_back("unusual body height " + std::to_string(H) + " m");
  return est;
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
