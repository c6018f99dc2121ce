// SPDX-License-Identifier: Apache-2.0
// Sleeve refinement of seed 000 §4.2 (eq. 1–2), generalised from vertical planes to slanted
// and bent arms.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "geodesic.h"
#include "segment.h"
#include "segment_parts.h"

namespace vfit::segment_detail {
namespace {

// Both in units of the armpit's depth below the sleeve's axis (about the sleeve's radius).
// JOINT_INBOARD is calibrated on the catalogue's mannequin (sizes S–M, T- and A-pose), whose
// armpit lies 0.1–0.4 depths outside the shoulder joint, more for looser garments.
constexpr double UNDERSIDE_MARGIN = 0.25;
constexpr double JOINT_INBOARD = 0.3;
// A sleeve longer than this many cuff radii is long enough to bend at the elbow.
constexpr double LONG_SLEEVE_RADII = 4;

struct Axis {
  Eigen::Vector3d origin, direction; // direction points out through the cuff
};

// Centroid of the vertices whose distance d lies within width/2 of level; count: how many.
Eigen::Vector3d ring_centroid(const SurfaceGraph& g, const std::vector<double>& d, double level, double width,
                              int& count) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  count = 0;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (std::abs(d[v] - level) <= 0.5 * width) {
      sum += g.points[v];
      ++count;
    }
  return count ? Eigen::Vector3d(sum / count) : sum;
}

// The upper arm's axis. A short sleeve is a straight tube: the cuff's area vector. A long one
// may bend at the elbow, so its axis joins centroids of rings of equal distance from the cuff
// at 50 % and 85 % of the way to the armpit.
Axis sleeve_axis(const GarmentFrame& fr, const Arm& arm) {
  const SurfaceGraph& g = *fr.graph;
  const BoundaryLoop& cuff = g.loops[arm.loop];
  const Eigen::Vector3d armpit = g.points[arm.armpit];
  Axis axis{cuff.centroid, cuff.normal};
  // Point away from the mid-plane (or, for an arm pointing down or forwards, the armpit).
  const double lateral =
      std::abs(axis.direction.x()) > 0.2 ? axis.direction.x() * arm.side : axis.direction.dot(cuff.centroid - armpit);
  if (lateral < 0) axis.direction = -axis.direction;
  const double cuff_radius = cuff.perimeter / (2 * std::numbers::pi);
  if (arm.length < LONG_SLEEVE_RADII * cuff_radius) return axis;
  const double width = std::max(2.0 * g.mean_edge, 0.05 * arm.length);
  int n_elbow = 0, n_shoulder = 0;
  const Eigen::Vector3d elbow = ring_centroid(g, arm.from_cuff, 0.5 * arm.length, width, n_elbow);
  const Eigen::Vector3d shoulder = ring_centroid(g, arm.from_cuff, 0.85 * arm.length, width, n_shoulder);
  if (n_elbow < 3 || n_shoulder < 3 || (elbow - shoulder).norm() < 1e-9) return axis;
  return {shoulder, (elbow - shoulder).normalized()};
}

struct SleeveBoundary {
  BoundaryPlane plane;
  std::optional<BoundaryPlane> underside; // unset for an arm hanging straight down
};

SleeveBoundary sleeve_boundary(const GarmentFrame& fr, const Arm& sleeve, double armpit_reach) {
  const Eigen::Vector3d armpit = fr.graph->points[sleeve.armpit];
  const Axis axis = sleeve_axis(fr, sleeve);
  const Eigen::Vector3d& o = axis.origin;
  const Eigen::Vector3d& d = axis.direction;
  SleeveBoundary out;
  out.plane.normal = d;
  // Eq. 1 takes P1(x) as the innermost x of the coarse sleeve, i.e. the armpit's x, and eq. 2
  // puts S1 at that x normal to a horizontal arm. A slanted arm keeps the plane normal to its
  // axis, where the axis reaches the armpit's x.
  const double armpit_x = fr.mid_x + sleeve.side * armpit_reach;
  out.plane.point = std::abs(d.x()) > 0.3 ? Eigen::Vector3d(o + (armpit_x - o.x()) / d.x() * d) : armpit;
  Eigen::Vector3d up = Eigen::Vector3d::UnitY() - d.y() * d;
  if (up.norm() > 0.3) {
    up.normalize();
    // The armpit is the bottom of the arm's tube; the margin keeps the fold in the sleeve.
    const double depth = std::max(0.0, (out.plane.point - armpit).dot(up));
    out.underside = BoundaryPlane{armpit - UNDERSIDE_MARGIN * depth * up, up};
    // The shoulder joint, which S should pass through, sits inboard of the armpit: the fold
    // lies on the chest wall, the garment's ease outside the joint.
    out.plane.point -= JOINT_INBOARD * depth * d;
  }
  return out;
}

void label_sleeve(const GarmentFrame& fr, const Arm& sleeve, const SleeveBoundary& b, GarmentPart part,
                  std::vector<GarmentPart>& parts) {
  const SurfaceGraph& g = *fr.graph;
  const std::size_t nv = g.vertex_count();
  auto beyond = [&](const BoundaryPlane& p, std::size_t v) { return (g.points[v] - p.point).dot(p.normal) > 0; };
  std::vector<char> allowed(nv, 0);
  for (std::size_t v = 0; v < nv; ++v)
    allowed[v] = fr.main[v] && beyond(b.plane, v) && (!b.underside || beyond(*b.underside, v)) &&
                 (g.points[v].x() - fr.mid_x) * sleeve.side > 0;
  std::vector<std::int32_t> queue;
  for (std::int32_t v : g.loops[sleeve.loop].vertices)
    if (allowed[v]) {
      allowed[v] = 0;
      queue.push_back(v);
    }
  for (std::size_t i = 0; i < queue.size(); ++i) {
    const std::int32_t v = queue[i];
    parts[v] = part;
    for (std::int32_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k)
      if (allowed[g.neighbours[k]]) {
        allowed[g.neighbours[k]] = 0;
        queue.push_back(g.neighbours[k]);
      }
  }
}

} // namespace

std::vector<Arm> find_arms(const GarmentFrame& fr, const std::vector<int>& openings, const std::vector<Limb>& limbs,
                           const std::vector<std::int32_t>& bottom) {
  const SurfaceGraph& g = *fr.graph;
  std::vector<Arm> arms;
  for (int side : {-1, 1}) {
    Arm arm;
    arm.side = side;
    for (int li : openings)
      if (side * (g.loops[li].centroid.x() - fr.mid_x) > 0 &&
          (arm.loop < 0 || g.loops[li].perimeter > g.loops[arm.loop].perimeter))
        arm.loop = li;
    if (arm.loop < 0) continue;
    const BoundaryLoop& cuff = g.loops[arm.loop];
    for (const Limb& l : limbs)
      if (l.loop == arm.loop && l.joins_trunk) {
        arm.armpit = l.saddle;
        arm.branch = true;
      }
    if (arm.armpit < 0) {
      // No branch: a sleeve hanging down, or an armhole. Keep the opening out of the bottom.
      std::vector<char> in_cuff(g.vertex_count(), 0);
      for (std::int32_t v : cuff.vertices)
        in_cuff[v] = 1;
      std::vector<std::int32_t> base;
      for (std::int32_t v : bottom)
        if (!in_cuff[v]) base.push_back(v);
      arm.armpit = height_saddle(fr, cuff.vertices, base);
    }
    if (arm.armpit < 0) continue;
    std::vector<GeodesicSeed> seeds;
    for (std::int32_t v : cuff.vertices)
      seeds.push_back({v, 0.0});
    arm.from_cuff = geodesic_distance(g, seeds, arm.armpit); // exact up to the armpit, enough for the axis
    arm.length = arm.from_cuff[arm.armpit];
    if (std::isfinite(arm.length)) arms.push_back(std::move(arm));
  }
  return arms;
}

void refine_sleeves(const GarmentFrame& fr, const std::vector<Arm>& sleeves, GarmentSegmentation& out) {
  const SurfaceGraph& g = *fr.graph;
  double armpit_reach = 0;
  for (const Arm& l : sleeves)
    armpit_reach += l.side * (g.points[l.armpit].x() - fr.mid_x) / double(sleeves.size());
  double reach = 0;
  for (const Arm& l : sleeves) {
    const SleeveBoundary b = sleeve_boundary(fr, l, armpit_reach);
    (l.side > 0 ? out.key_points.s2 : out.key_points.s1) = b.plane;
    (l.side > 0 ? out.key_points.p2 : out.key_points.p1) = g.points[l.armpit];
    label_sleeve(fr, l, b, l.side > 0 ? GarmentPart::LEFT_SLEEVE : GarmentPart::RIGHT_SLEEVE, out.vertex_parts);
    for (std::int32_t v : g.loops[l.loop].vertices)
      reach = std::max(reach, (g.points[v] - b.plane.point).dot(b.plane.normal));
  }
  double torso_bottom = INFINITY;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (fr.main[v] && out.vertex_parts[v] == GarmentPart::TORSO) torso_bottom = std::min(torso_bottom, g.points[v].y());
  const double torso_height = g.loops[fr.source].max_y - torso_bottom;
  out.type = reach > 0.5 * torso_height ? GarmentType::LONG_SLEEVE : GarmentType::TEE;
}

} // namespace vfit::segment_detail
