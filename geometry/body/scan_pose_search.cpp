// SPDX-License-Identifier: Apache-2.0
#include "scan_pose_search.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <optional>

#include <Eigen/Geometry>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/task_arena.h>

#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

using Vec3 = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;
constexpr double DEG = std::numbers::pi / 180.0;

// Nearest-point distances, capped, over a point set binned in a uniform grid of cells as large
// as the cap: a query looks at its own cell and the 26 around it, which hold every point within
// the cap. The search scores a few hundred poses, so this replaces a triangle BVH (rebuilt per
// pose) with a counting sort.
class PointGrid {
public:
  explicit PointGrid(float cell) : m_cell(cell) {}

  void build(std::span<const float> xyz, std::span<const std::size_t> subset,
             std::span<const Eigen::Vector3d> normals = {}) {
    const std::size_t n = subset.empty() ? xyz.size() / 3 : subset.size();
    auto point = [&](std::size_t i) {
      const std::size_t v = subset.empty() ? i : subset[i];
      return Vec3f(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]);
    };
    m_lo = Vec3f::Constant(INFINITY);
    Vec3f hi = Vec3f::Constant(-INFINITY);
    for (std::size_t i = 0; i < n; ++i) {
      m_lo = m_lo.cwiseMin(point(i));
      hi = hi.cwiseMax(point(i));
    }
    for (int a = 0; a < 3; ++a)
      m_dims[a] = n == 0 ? 0 : static_cast<int>((hi[a] - m_lo[a]) / m_cell) + 1;
    const auto cells =
        static_cast<std::size_t>(m_dims[0]) * static_cast<std::size_t>(m_dims[1]) * static_cast<std::size_t>(m_dims[2]);
    m_start.assign(cells + 1, 0);
    m_cell_of.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      m_cell_of[i] = cell_index(point(i));
      ++m_start[m_cell_of[i] + 1];
    }
    for (std::size_t c = 0; c < cells; ++c)
      m_start[c + 1] += m_start[c];
    m_points.resize(n);
    m_normals.resize(normals.empty() ? 0 : n);
    std::vector<std::size_t> fill(m_start.begin(), m_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = fill[m_cell_of[i]]++;
      m_points[k] = point(i);
      if (!normals.empty()) m_normals[k] = normals[subset.empty() ? i : subset[i]].cast<float>();
    }
  }

  // capped_distance(), with a point behind the nearest point's surface (built with normals)
  // counted `inside_factor` times as far beyond `inside_slack` deep, within the cap.
  float capped_distance_outside(const Vec3f& q, float inside_slack, float inside_factor) const {
    if (m_normals.empty()) return capped_distance(q);
    std::size_t arg = m_points.size();
    const float d = std::sqrt(nearest_squared(q, arg));
    if (arg == m_points.size()) return d;
    const float depth = -(q - m_points[arg]).dot(m_normals[arg]);
    return depth > inside_slack ? std::min(m_cell, d + inside_factor * (depth - inside_slack)) : d;
  }

  // min(distance to the nearest point, cell size).
  float capped_distance(const Vec3f& q) const {
    std::size_t arg = m_points.size();
    return std::sqrt(nearest_squared(q, arg));
  }

private:
  // min(squared distance to the nearest point in the 27 cells around q, cell size²); `arg`
  // is set to that point's index, left as it was when none is nearer than the cap (or q lies
  // outside the grid, where the cap is returned).
  float nearest_squared(const Vec3f& q, std::size_t& arg) const {
    float best = m_cell * m_cell;
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) {
      c[a] = static_cast<int>(std::floor((q[a] - m_lo[a]) / m_cell));
      if (c[a] < -1 || c[a] > m_dims[a]) return best;
    }
    for (int x = std::max(c[0] - 1, 0); x <= std::min(c[0] + 1, m_dims[0] - 1); ++x)
      for (int y = std::max(c[1] - 1, 0); y <= std::min(c[1] + 1, m_dims[1] - 1); ++y)
        for (int z = std::max(c[2] - 1, 0); z <= std::min(c[2] + 1, m_dims[2] - 1); ++z) {
          const std::size_t cell = flat(x, y, z);
          for (std::size_t k = m_start[cell]; k < m_start[cell + 1]; ++k) {
            const float d2 = (m_points[k] - q).squaredNorm();
            if (d2 < best) best = d2, arg = k;
          }
        }
    return best;
  }

  std::size_t flat(int x, int y, int z) const {
    return (static_cast<std::size_t>(x) * static_cast<std::size_t>(m_dims[1]) + static_cast<std::size_t>(y)) *
               static_cast<std::size_t>(m_dims[2]) +
           static_cast<std::size_t>(z);
  }
  std::size_t cell_index(const Vec3f& p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(static_cast<int>((p[a] - m_lo[a]) / m_cell), 0, m_dims[a] - 1);
    return flat(c[0], c[1], c[2]);
  }

  float m_cell;
  Vec3f m_lo = Vec3f::Zero();
  std::array<int, 3> m_dims{};
  std::vector<std::size_t> m_start, m_cell_of;
  std::vector<Vec3f> m_points;
  std::vector<Vec3f> m_normals; // per point, when built with normals
};

// The rotation (axis-angle) taking `from` to `to` about their common normal, the shortest one.
Vec3 swing(const Vec3& from, const Vec3& to) {
  const Eigen::AngleAxisd aa(Eigen::Quaterniond::FromTwoVectors(from, to));
  return aa.angle() * aa.axis();
}
Vec3 compose(const Vec3& a, const Vec3& b) { // rotation a after b
  return matrix_to_axis_angle(axis_angle_to_matrix(a) * axis_angle_to_matrix(b));
}

class Scorer {
public:
  Scorer(const Body& tmpl, std::span<const float> scan, std::span<const Eigen::Vector3d> normals,
         const ScanPoseSearchOptions& o)
      : m_tmpl(tmpl), m_grid(static_cast<float>(o.cap)), m_still_grid(static_cast<float>(o.cap)),
        m_cap(static_cast<float>(o.cap)), m_inside_slack(static_cast<float>(o.inside_slack)),
        m_inside_factor(static_cast<float>(o.inside_factor)), m_serial(m_cap), m_scratch(Scratch(m_cap)) {
    for (std::size_t v : spread_indices(scan.size() / 3, o.scan_samples))
      m_scan_samples.emplace_back(scan[3 * v], scan[3 * v + 1], scan[3 * v + 2]);
    const auto grid_points = spread_indices(scan.size() / 3, o.scan_grid_points);
    m_grid.build(scan, grid_points, normals.size() == scan.size() / 3 ? normals : std::span<const Eigen::Vector3d>{});
    m_floor = INFINITY;
    for (std::size_t v = 0; v < scan.size() / 3; ++v)
      m_floor = std::min(m_floor, scan[3 * v + 1]);
    m_tmpl_samples = spread_indices(tmpl.mesh.vertex_count(), o.template_samples);
  }

  // Scores `pose` at scale exp(log_scale); with `level`, first moves it vertically so that its
  // lowest vertex is level with the scan's (the translation is updated).
  double score(Pose& pose, double log_scale, bool level = false) {
    ++m_evaluations;
    return full_score(m_serial, pose, log_scale, level);
  }
  int evaluations() const { return m_evaluations; }

  // score() of each pose at its scale (not levelled), or with `part` score_part() of each pose
  // (log_scales unused), the poses scored side by side (TBB, SCORE_GRAIN). Every score is a
  // function of its pose alone (and of begin_part()'s base), so the thread count changes no bit.
  std::vector<double> score_all(const std::vector<Pose>& poses, const std::vector<double>& log_scales, bool part) {
    std::vector<double> out(poses.size());
    parallel_for_range(poses.size(), SCORE_GRAIN, [&](std::size_t begin, std::size_t end) {
      // Isolated: a thread waiting on the skinning's nested loop must not start another range
      // here, which would share its scratch.
      tbb::this_task_arena::isolate([&] {
        Scratch& s = m_scratch.local();
        for (std::size_t i = begin; i < end; ++i) {
          Pose p = poses[i];
          out[i] = part ? part_score(s, p) : full_score(s, p, log_scales[i], false);
        }
      });
    });
    m_evaluations += static_cast<int>(poses.size());
    return out;
  }

  // The scan samples at least `distance` from every template vertex that begin_part()'s part
  // does not move: the points that part has to explain.
  std::vector<Vec3> unexplained(double distance) const {
    std::vector<Vec3> out;
    for (std::size_t i = 0; i < m_scan_samples.size(); ++i)
      if (m_still_distance[i] >= distance) out.push_back(m_scan_samples[i].cast<double>());
    return out;
  }

  // Prepares scoring of poses that differ from `base` only in the joints of `subtrees` (and
  // their descendants): the template's vertices they move are re-posed per candidate, the
  // others' distances are kept from `base`.
  void begin_part(Pose& base, double log_scale, const std::vector<int>& subtrees) {
    std::array<bool, JOINT_COUNT> moving{};
    for (int j = 0; j < JOINT_COUNT; ++j)
      for (int a = j; a >= 0 && !moving[static_cast<std::size_t>(j)]; a = joint_parent(a))
        moving[static_cast<std::size_t>(j)] = std::find(subtrees.begin(), subtrees.end(), a) != subtrees.end();
    score(base, log_scale); // m_serial's posed and shaped at this pose and scale
    m_part_shaped = m_serial.shaped;
    const std::vector<float>& posed = m_serial.posed;
    m_part_log_scale = log_scale;
    m_moving.clear();
    std::vector<std::size_t> still;
    const SkinWeights& w = m_tmpl.weights;
    for (std::size_t v = 0; v < w.vertex_count(); ++v) {
      bool moves = false;
      for (int k = 0; k < 4; ++k)
        moves = moves || (w.weights[4 * v + k] > 0 && moving[static_cast<std::size_t>(w.joints[4 * v + k])]);
      (moves ? m_moving : still).push_back(v);
    }
    m_still_grid.build(posed, still);
    m_still_distance.resize(m_scan_samples.size());
    for (std::size_t i = 0; i < m_scan_samples.size(); ++i)
      m_still_distance[i] = still.empty() ? m_cap : m_still_grid.capped_distance(m_scan_samples[i]);
    m_still_sum = 0;
    m_moving_samples.clear();
    std::vector<std::size_t> moving_index(w.vertex_count(), SIZE_MAX);
    for (std::size_t i = 0; i < m_moving.size(); ++i)
      moving_index[m_moving[i]] = i;
    for (std::size_t v : m_tmpl_samples) {
      if (moving_index[v] != SIZE_MAX)
        m_moving_samples.push_back(moving_index[v]);
      else
        m_still_sum += m_grid.capped_distance_outside(Vec3f(posed[3 * v], posed[3 * v + 1], posed[3 * v + 2]),
                                                      m_inside_slack, m_inside_factor);
    }
  }

  // The score of `pose` (equal to score() up to rounding) for a pose that differs from
  // begin_part()'s base only in that part; the translation is kept.
  double score_part(const Pose& pose) {
    ++m_evaluations;
    return part_score(m_serial, pose);
  }

private:
  // Candidates per TBB task in score_all() (a score is ~20-80 µs).
  static constexpr std::size_t SCORE_GRAIN = 4;

  // One thread's working memory.
  struct Scratch {
    explicit Scratch(float cap) : tmpl_grid(cap), part_grid(cap) {}
    std::vector<float> shaped, posed, part_points;
    double shaped_log_scale = 0;
    PointGrid tmpl_grid, part_grid;
  };

  double full_score(Scratch& s, Pose& pose, double log_scale, bool level) const {
    if (log_scale != s.shaped_log_scale || s.shaped.empty()) {
      const auto k = static_cast<float>(std::exp(log_scale));
      s.shaped.resize(m_tmpl.mesh.positions.size());
      for (std::size_t i = 0; i < s.shaped.size(); ++i)
        s.shaped[i] = k * m_tmpl.mesh.positions[i];
      s.shaped_log_scale = log_scale;
    }
    const JointPositions J = std::exp(log_scale) * m_tmpl.joints;
    std::vector<float>& posed = s.posed;
    linear_blend_skinning(s.shaped, m_tmpl.weights, skinning_transforms(J, pose), posed);
    float lowest = INFINITY;
    for (std::size_t v = 0; v < posed.size() / 3; ++v)
      lowest = std::min(lowest, posed[3 * v + 1]);
    const float dy = level ? m_floor - lowest : 0.f;
    for (std::size_t v = 0; v < posed.size() / 3; ++v)
      posed[3 * v + 1] += dy;
    pose.translation.y() += dy;
    s.tmpl_grid.build(posed, {});
    double a = 0, b = 0;
    for (const Vec3f& q : m_scan_samples)
      a += s.tmpl_grid.capped_distance(q);
    for (std::size_t v : m_tmpl_samples)
      b += m_grid.capped_distance_outside(Vec3f(posed[3 * v], posed[3 * v + 1], posed[3 * v + 2]), m_inside_slack,
                                          m_inside_factor);
    return a / static_cast<double>(std::max<std::size_t>(m_scan_samples.size(), 1)) +
           b / static_cast<double>(std::max<std::size_t>(m_tmpl_samples.size(), 1));
  }

  double part_score(Scratch& s, const Pose& pose) const {
    const JointPositions J = std::exp(m_part_log_scale) * m_tmpl.joints;
    const auto A = skinning_transforms(J, pose);
    const SkinWeights& w = m_tmpl.weights;
    std::vector<float>& points = s.part_points;
    points.resize(3 * m_moving.size());
    for (std::size_t i = 0; i < m_moving.size(); ++i) {
      const std::size_t v = m_moving[i];
      const Eigen::Vector3d x(m_part_shaped[3 * v], m_part_shaped[3 * v + 1], m_part_shaped[3 * v + 2]);
      Eigen::Vector3d y = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k)
        if (w.weights[4 * v + k] > 0)
          y += static_cast<double>(w.weights[4 * v + k]) * (A[static_cast<std::size_t>(w.joints[4 * v + k])] * x);
      for (int a = 0; a < 3; ++a)
        points[3 * i + a] = static_cast<float>(y[a]);
    }
    s.part_grid.build(points, {});
    double a = 0, b = m_still_sum;
    for (std::size_t i = 0; i < m_scan_samples.size(); ++i)
      a += std::min(m_still_distance[i], s.part_grid.capped_distance(m_scan_samples[i]));
    for (std::size_t i : m_moving_samples)
      b += m_grid.capped_distance_outside(Vec3f(points[3 * i], points[3 * i + 1], points[3 * i + 2]), m_inside_slack,
                                          m_inside_factor);
    return a / static_cast<double>(std::max<std::size_t>(m_scan_samples.size(), 1)) +
           b / static_cast<double>(std::max<std::size_t>(m_tmpl_samples.size(), 1));
  }

  const Body& m_tmpl;
  PointGrid m_grid, m_still_grid;
  float m_cap, m_inside_slack, m_inside_factor;
  float m_floor = 0;
  std::vector<Vec3f> m_scan_samples;
  std::vector<std::size_t> m_tmpl_samples;
  int m_evaluations = 0;
  Scratch m_serial;                                   // score() and score_part()
  tbb::enumerable_thread_specific<Scratch> m_scratch; // score_all()
  // begin_part(), read by score_part() and score_all():
  std::vector<float> m_part_shaped;
  double m_part_log_scale = 0, m_still_sum = 0;
  std::vector<std::size_t> m_moving;         // the vertices the part moves
  std::vector<std::size_t> m_moving_samples; // the template samples among them, as indices into m_moving
  std::vector<float> m_still_distance;
};

// One candidate: a change to the current pose and scale.
using Candidate = std::function<void(Pose&, double&)>;

void set_joint(Pose& p, int joint, const Vec3& r) { p.axis_angle.row(joint) = r.transpose(); }

std::vector<Candidate> placement_candidates() {
  std::vector<Candidate> c;
  for (double dx : {-0.08, -0.04, 0.04, 0.08}) {
    c.push_back([dx](Pose& p, double&) { p.translation.x() += dx; });
    c.push_back([dx](Pose& p, double&) { p.translation.z() += dx; });
  }
  for (double dy : {-0.12, -0.06, -0.03, 0.03})
    c.push_back([dy](Pose& p, double&) { p.translation.y() += dy; });
  for (double yaw : {-30.0, -15.0, 15.0, 30.0})
    c.push_back([yaw](Pose& p, double&) {
      p.axis_angle.row(0) = compose(Vec3(0, yaw * DEG, 0), p.axis_angle.row(0).transpose()).transpose();
    });
  for (double ds : {-0.15, -0.10, -0.05, 0.05, 0.10, 0.15})
    c.push_back([ds](Pose&, double& log_scale) { log_scale += ds; });
  return c;
}

std::vector<Candidate> torso_candidates() {
  std::vector<Candidate> c;
  for (double bend : {-15.0, 0.0, 15.0, 30.0})
    for (double twist : {-24.0, 0.0, 24.0})
      c.push_back([bend, twist](Pose& p, double&) {
        // Spread over the three spine joints, as a spine bends.
        const Vec3 r = compose(Vec3(0, twist * DEG / 3, 0), Vec3(bend * DEG / 3, 0, 0));
        for (Joint j : {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3})
          set_joint(p, idx(j), r);
      });
  return c;
}

// A frame (columns) from a direction and a second, orthogonalised against it.
Eigen::Matrix3d frame(const Vec3& d, const Vec3& n) {
  Eigen::Matrix3d F;
  F.col(0) = d.normalized();
  F.col(1) = (n - n.dot(F.col(0)) * F.col(0)).normalized();
  F.col(2) = F.col(0).cross(F.col(1));
  return F;
}

// Directions spread over the sphere: the 6 axes, 12 edge and 8 corner directions of a cube.
std::vector<Vec3> sphere_directions() {
  std::vector<Vec3> out;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x != 0 || y != 0 || z != 0) out.push_back(Vec3(x, y, z).normalized());
  return out;
}

// A two-bone limb (thigh and shank, or upper arm and forearm) set to point its first bone
// along `upper` and its second along `lower` (directions in the parent's frame): the root
// joint takes the rotation that maps the rest's bone direction to `upper` and the rest's hinge
// axis to the one that bends `upper` into `lower`; the hinge joint takes the bend about it.
// Straight (`lower` = `upper`): the shortest rotation, no twist.
struct Limb {
  Joint root, hinge;
  Vec3 rest_direction; ///< the first bone's direction in the rest pose
  Vec3 rest_axis;      ///< the hinge axis in the rest pose: a positive bend about it is anatomical
  double max_bend;     ///< rad
};

Candidate limb_candidate(const Limb& limb, const Vec3& upper, const Vec3& lower) {
  const double bend = std::acos(std::clamp(upper.dot(lower), -1.0, 1.0));
  Vec3 root = swing(limb.rest_direction, upper);
  if (bend > 1e-3) {
    const Vec3 axis = upper.cross(lower).normalized();
    const Eigen::Matrix3d R = frame(upper, axis) * frame(limb.rest_direction, limb.rest_axis).transpose();
    root = matrix_to_axis_angle(R);
  }
  const Vec3 hinge = bend * limb.rest_axis;
  return [limb, root, hinge](Pose& p, double&) {
    set_joint(p, idx(limb.root), root);
    set_joint(p, idx(limb.hinge), hinge);
  };
}

// First bones over `uppers`, second bones over the sphere's directions (and straight) that
// bend by 20° to max_bend.
std::vector<Candidate> limb_candidates(const Limb& limb, const std::vector<Vec3>& uppers) {
  std::vector<Candidate> c;
  const auto lowers = sphere_directions();
  for (const Vec3& u : uppers) {
    c.push_back(limb_candidate(limb, u, u));
    for (const Vec3& l : lowers) {
      const double bend = std::acos(std::clamp(u.dot(l), -1.0, 1.0));
      if (bend >= 20 * DEG && bend <= limb.max_bend) c.push_back(limb_candidate(limb, u, l));
    }
  }
  return c;
}

// Thighs: flexion f forward (+Z) and abduction b outward from the rest's straight down.
std::vector<Candidate> leg_candidates(double side) {
  const Limb limb{side > 0 ? Joint::LEFT_HIP : Joint::RIGHT_HIP, side > 0 ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE,
                  Vec3(0, -1, 0), Vec3(1, 0, 0), 120 * DEG};
  std::vector<Vec3> uppers;
  for (double f : {-30.0, 0.0, 25.0, 50.0, 80.0})
    for (double b : {-10.0, 0.0, 12.0, 24.0, 36.0, 48.0})
      uppers.emplace_back(side * std::sin(b * DEG), -std::cos(b * DEG) * std::cos(f * DEG),
                          std::cos(b * DEG) * std::sin(f * DEG));
  // The knee bends only backwards: keep shanks behind the thigh's plane of flexion.
  std::vector<Candidate> c;
  const auto lowers = sphere_directions();
  for (const Vec3& u : uppers) {
    c.push_back(limb_candidate(limb, u, u));
    const Vec3 back = Vec3(1, 0, 0).cross(u).normalized(); // where the shank goes when the knee bends
    for (const Vec3& l : lowers) {
      const double bend = std::acos(std::clamp(u.dot(l), -1.0, 1.0));
      if (bend >= 20 * DEG && bend <= limb.max_bend && l.dot(back) > 0.3) c.push_back(limb_candidate(limb, u, l));
    }
  }
  return c;
}

Limb arm_limb(double side) {
  return {side > 0 ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER, side > 0 ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW,
          Vec3(side, 0, 0), Vec3(0, -side, 0), 140 * DEG};
}

// Upper arms: elevation e above horizontal and azimuth a forward (+Z) from the rest's straight
// out to the side, and straight up and down. Lowered arms also swung 60 and 90° back: an arm
// hanging 70° down and swung 20° back about the shoulder's side axis points ~45° behind the
// side, past -30°, and the nearest candidate put its elbow ~10 cm off (seed 11's random 2 left
// it to the refinement's luck).
std::vector<Vec3> arm_upper_directions(double side) {
  std::vector<Vec3> uppers = {Vec3(0, 1, 0), Vec3(0, -1, 0)};
  for (double e : {-70.0, -45.0, -20.0, 0.0, 25.0, 50.0, 75.0})
    for (double a : {-30.0, 0.0, 35.0, 70.0})
      uppers.emplace_back(side * std::cos(e * DEG) * std::cos(a * DEG), std::sin(e * DEG),
                          std::cos(e * DEG) * std::sin(a * DEG));
  for (double e : {-70.0, -45.0, -20.0})
    for (double a : {-60.0, -90.0})
      uppers.emplace_back(side * std::cos(e * DEG) * std::cos(a * DEG), std::sin(e * DEG),
                          std::cos(e * DEG) * std::sin(a * DEG));
  return uppers;
}

std::vector<Candidate> arm_candidates(double side) {
  return limb_candidates(arm_limb(side), arm_upper_directions(side));
}

// Forearms aimed at the scan: for each of arm_candidates()' upper arms, its elbow placed in
// `base`, the forearm pointed at the scan points the rest of the body leaves unexplained
// (`targets`) that lie a forearm to a forearm and hand away: the few directions most of them
// share (greedily, each with the most targets within AIM_SPREAD, those then dropped). The
// sphere's 26 forearm directions lie up to ~35° apart, which puts a 25 cm forearm's wrist up to
// 15 cm off, past the score's cap: an arm hanging against the torso with its forearm held out
// then scored no candidate near it, and a wrong arm covering part of the forearm won.
std::vector<Candidate> aimed_arm_candidates(double side, const Body& tmpl, double log_scale, const Pose& base,
                                            const std::vector<Vec3>& targets) {
  constexpr double AIM_SPREAD = 15 * DEG; // the directions one candidate stands for
  constexpr int AIMS_PER_UPPER = 3;
  constexpr double REACH_LO = 0.5, REACH_HI = 1.6; // target distances from the elbow, in forearms
  const Limb limb = arm_limb(side);
  const int root = idx(limb.root), hinge = idx(limb.hinge),
            end = idx(side > 0 ? Joint::LEFT_WRIST : Joint::RIGHT_WRIST);
  const JointPositions J = std::exp(log_scale) * tmpl.joints;
  const double upper_length = (J.row(hinge) - J.row(root)).norm(), fore_length = (J.row(end) - J.row(hinge)).norm();
  const auto G = joint_world_transforms(J, base);
  const Eigen::Matrix3d parent = G[static_cast<std::size_t>(joint_parent(root))].linear();
  const Vec3 shoulder = G[static_cast<std::size_t>(root)].translation();
  std::vector<Candidate> out;
  std::vector<Vec3> aims;
  std::vector<int> support;
  std::vector<bool> taken;
  for (const Vec3& u : arm_upper_directions(side)) {
    const Vec3 elbow = shoulder + upper_length * (parent * u);
    aims.clear();
    for (const Vec3& q : targets) {
      const Vec3 d = q - elbow;
      const double r = d.norm();
      if (r < REACH_LO * fore_length || r > REACH_HI * fore_length) continue;
      const Vec3 l = parent.transpose() * (d / r);
      if (std::acos(std::clamp(u.dot(l), -1.0, 1.0)) <= limb.max_bend) aims.push_back(l);
    }
    taken.assign(aims.size(), false);
    const double near = std::cos(AIM_SPREAD);
    for (int k = 0; k < AIMS_PER_UPPER; ++k) {
      support.assign(aims.size(), 0);
      int best = -1;
      for (std::size_t a = 0; a < aims.size(); ++a) {
        if (taken[a]) continue;
        for (std::size_t b = 0; b < aims.size(); ++b)
          if (!taken[b] && aims[a].dot(aims[b]) >= near) ++support[a];
        if (best < 0 || support[a] > support[static_cast<std::size_t>(best)]) best = static_cast<int>(a);
      }
      if (best < 0) break;
      const Vec3 l = aims[static_cast<std::size_t>(best)];
      for (std::size_t b = 0; b < aims.size(); ++b)
        if (aims[b].dot(l) >= near) taken[b] = true;
      out.push_back(limb_candidate(limb, u, l));
    }
  }
  return out;
}

} // namespace

ScanPoseSearch search_scan_pose(const Body& tmpl, std::span<const float> scan, const Pose& start, double log_scale,
                                const ScanPoseSearchOptions& options, std::span<const Eigen::Vector3d> scan_normals) {
  Scorer scorer(tmpl, scan, scan_normals, options);
  ScanPoseSearch out;
  out.pose = start;
  out.log_scale = log_scale;
  out.score = out.start_score = scorer.score(out.pose, out.log_scale, true);
  struct Part {
    std::vector<Candidate> candidates;
    std::vector<int> subtrees; // empty: the whole body moves (scored in full)
    // An arm's root, hinge and end joints: its best distinct candidates are refined before one
    // is kept (ScanPoseSearchOptions::limb_alternatives). Arms only: an upper arm hanging
    // against the torso earns its candidate no credit for the scan points it covers (the torso
    // lies as near), so a wrong arm can outscore a right one until both are refined. On the
    // legs as well it helped none of the corpus test's 20 poses (without it there: the worst
    // joint lower in 6, higher in none; the re-posing lower in 7, higher in 3 by at most
    // 0.3 mm) for 576 more evaluations.
    std::optional<std::array<Joint, 3>> arm;
  };
  const std::vector<Part> parts = {
      {placement_candidates(), {}, {}},
      {torso_candidates(), {}, {}},
      {leg_candidates(1), {idx(Joint::LEFT_HIP)}, {}},
      {leg_candidates(-1), {idx(Joint::RIGHT_HIP)}, {}},
      {arm_candidates(1),
       {idx(Joint::LEFT_SHOULDER)},
       std::array{Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW, Joint::LEFT_WRIST}},
      {arm_candidates(-1),
       {idx(Joint::RIGHT_SHOULDER)},
       std::array{Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW, Joint::RIGHT_WRIST}},
  };
  struct Scored {
    double score;
    Pose pose;
  };
  std::vector<Scored> scored;
  // The limb's best candidates that place it differently, each turned joint by joint (root and
  // hinge about the parent's three axes, halving steps) to its nearest best; the best refined
  // one replaces the current pose when it scores better. scored[0] is the part's base pose.
  auto refine_alternatives = [&](const std::array<Joint, 3>& limb, std::vector<Scored>& candidates) {
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Scored& a, const Scored& b) { return a.score < b.score; });
    const JointPositions J = std::exp(out.log_scale) * tmpl.joints;
    std::vector<std::array<Vec3, 2>> kept_places;
    for (const Scored& c : candidates) {
      if (kept_places.size() >= options.limb_alternatives) break;
      const JointPositions P = posed_joints(J, c.pose);
      const std::array<Vec3, 2> place = {P.row(idx(limb[1])).transpose(), P.row(idx(limb[2])).transpose()};
      bool distinct = true;
      for (const auto& k : kept_places)
        distinct =
            distinct && std::max((k[0] - place[0]).norm(), (k[1] - place[1]).norm()) > options.alternative_separation;
      if (!distinct) continue;
      kept_places.push_back(place);
      Scored best = c;
      for (double step : options.alternative_steps_deg)
        for (Joint joint : {limb[0], limb[1]})
          for (int axis = 0; axis < 3; ++axis)
            for (double sign : {-1.0, 1.0}) {
              Pose p = best.pose;
              const int j = idx(joint);
              set_joint(p, j, compose(sign * step * DEG * Vec3::Unit(axis), p.axis_angle.row(j).transpose()));
              const double sc = scorer.score_part(p);
              if (sc < best.score) best = {sc, p};
            }
      if (best.score < out.score) {
        out.score = best.score;
        out.pose = best.pose;
      }
    }
  };
  for (int pass = 0; pass < std::max(1, options.passes); ++pass)
    for (const Part& part : parts) {
      // Every candidate of a part is tried from the same current pose; the best one is kept.
      Pose base = out.pose;
      const double base_scale = out.log_scale;
      const bool limb = !part.subtrees.empty();
      if (limb) scorer.begin_part(base, base_scale, part.subtrees);
      scored.assign(1, {out.score, base});
      std::vector<Candidate> aimed;
      // Aimed forearms in the last sweep only: before it the torso and the other limbs are still
      // coarse, so the points they leave unexplained are not the arm's (aimed in every sweep, a
      // forearm went to the torso the first sweep misplaced: seed 11's random 2, both elbows 32
      // and 49 cm off).
      if (part.arm && options.aimed_forearms && pass == std::max(1, options.passes) - 1)
        aimed = aimed_arm_candidates(part.arm->at(0) == Joint::LEFT_SHOULDER ? 1.0 : -1.0, tmpl, base_scale, base,
                                     scorer.unexplained(0.5 * options.cap));
      std::vector<const Candidate*> all;
      for (const Candidate& c : part.candidates)
        all.push_back(&c);
      for (const Candidate& c : aimed)
        all.push_back(&c);
      std::vector<Pose> poses(all.size(), base);
      std::vector<double> scales(all.size(), base_scale);
      for (std::size_t i = 0; i < poses.size(); ++i)
        (*all[i])(poses[i], scales[i]);
      const std::vector<double> scores = scorer.score_all(poses, scales, limb);
      for (std::size_t i = 0; i < poses.size(); ++i) {
        const double s = scores[i];
        if (part.arm) scored.push_back({s, poses[i]});
        if (s < out.score) {
          out.score = s;
          out.pose = poses[i];
          out.log_scale = scales[i];
        }
      }
      if (part.arm && options.limb_alternatives > 1) refine_alternatives(*part.arm, scored);
    }
  // Local refinement: each limb joint turned about the parent frame's three axes by a step that
  // halves, keeping improvements. The candidate grids above are 20-45° apart; this brings each
  // bone within a few degrees of the best score, so that ICP (whose robust weights discount
  // pairs a few cm apart) starts nearer its basin.
  const std::array<Joint, 8> refined = {Joint::LEFT_SHOULDER, Joint::RIGHT_SHOULDER, Joint::LEFT_ELBOW,
                                        Joint::RIGHT_ELBOW,   Joint::LEFT_HIP,       Joint::RIGHT_HIP,
                                        Joint::LEFT_KNEE,     Joint::RIGHT_KNEE};
  // Before the limbs at each step, the spine bent sideways by the step (a third at each of its
  // three joints, as the torso candidates spread theirs): the torso candidates try forward bends
  // and twists only, and a sideways lean left to ICP ended in the neck (see the pose prior,
  // scan_fit_solve.cpp).
  auto keep_if_better = [&](const Pose& p) {
    const double s = scorer.score_part(p);
    if (s < out.score) {
      out.score = s;
      out.pose = p;
    }
  };
  for (double step : options.refine_steps_deg) {
    {
      Pose base = out.pose;
      scorer.begin_part(base, out.log_scale, {idx(Joint::SPINE1)});
      for (double sign : {-1.0, 1.0}) {
        Pose p = out.pose;
        for (Joint j : {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3})
          set_joint(p, idx(j), compose(Vec3(0, 0, sign * step / 3 * DEG), p.axis_angle.row(idx(j)).transpose()));
        keep_if_better(p);
      }
    }
    for (Joint joint : refined) {
      const int j = idx(joint);
      Pose base = out.pose;
      scorer.begin_part(base, out.log_scale, {j});
      for (int axis = 0; axis < 3; ++axis)
        for (double sign : {-1.0, 1.0}) {
          Pose p = out.pose;
          set_joint(p, j, compose(sign * step * DEG * Vec3::Unit(axis), p.axis_angle.row(j).transpose()));
          keep_if_better(p);
        }
    }
  }
  out.evaluations = scorer.evaluations();
  return out;
}

std::vector<std::size_t> spread_indices(std::size_t n, std::size_t count) {
  std::vector<std::size_t> out;
  const std::size_t m = std::min(n, std::max<std::size_t>(count, 1));
  for (std::size_t i = 0; i < m; ++i)
    out.push_back(i * n / m);
  return out;
}

} // namespace vfit
