// SPDX-License-Identifier: Apache-2.0
// Fit feedback: strain and ease per vertex, region summaries, size verdict.
#include "vfit/engine/fit/fit_feedback.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <sstream>

#include "vfit/geometry/body/cross_section.h"
#include "vfit/geometry/body/measurements.h"
#include "vfit/geometry/garment/surface_graph.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/pseudo_normals.h"

namespace vfit {
namespace {

constexpr double NOT_A_NUMBER = std::numeric_limits<double>::quiet_NaN();

bool is_bottom(GarmentType t) {
  return t == GarmentType::TROUSERS || t == GarmentType::SHORTS || t == GarmentType::SKIRT;
}

Eigen::Vector3d joint(const Body& body, Joint j) { return body.joints.row(idx(j)).transpose(); }

// Landmark heights: measure_body()'s on an upright rest-like body, else read off the joints
// (the same places on the SMPL skeleton: chest at spine3, waist between spine1 and spine2, hip
// a fifth of the way from the hip joints to the pelvis, thigh 30 % of the way down the femur).
BodyLandmarks landmarks(const Body& body) {
  try {
    return measure_body(body.mesh, body.joints).landmarks;
  } catch (const Error&) {
    BodyLandmarks lm;
    const double hips = 0.5 * (joint(body, Joint::LEFT_HIP).y() + joint(body, Joint::RIGHT_HIP).y());
    const double knees = 0.5 * (joint(body, Joint::LEFT_KNEE).y() + joint(body, Joint::RIGHT_KNEE).y());
    lm.chest = joint(body, Joint::SPINE3).y();
    lm.waist = 0.5 * (joint(body, Joint::SPINE1).y() + joint(body, Joint::SPINE2).y());
    lm.hip = hips + 0.2 * (joint(body, Joint::PELVIS).y() - hips);
    lm.thigh = hips - 0.3 * (hips - knees);
    return lm;
  }
}

// The trunk's axis (x, z) at height y: the spine chain's joints, interpolated.
Eigen::Vector2d torso_axis(const Body& body, double y) {
  const Joint chain[] = {Joint::PELVIS, Joint::SPINE1, Joint::SPINE2, Joint::SPINE3, Joint::NECK};
  Eigen::Vector3d prev = joint(body, chain[0]);
  if (y <= prev.y()) return {prev.x(), prev.z()};
  for (Joint j : chain) {
    const Eigen::Vector3d next = joint(body, j);
    if (y <= next.y() && next.y() > prev.y()) {
      const double t = (y - prev.y()) / (next.y() - prev.y());
      const Eigen::Vector3d p = prev + t * (next - prev);
      return {p.x(), p.z()};
    }
    prev = next;
  }
  return {prev.x(), prev.z()};
}

// A leg's axis (x, z) at height y, along hip → knee.
Eigen::Vector2d leg_axis(const Body& body, bool left, double y) {
  const Eigen::Vector3d hip = joint(body, left ? Joint::LEFT_HIP : Joint::RIGHT_HIP);
  const Eigen::Vector3d knee = joint(body, left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE);
  const double t = std::clamp((y - hip.y()) / (knee.y() - hip.y()), 0.0, 1.0);
  const Eigen::Vector3d p = hip + t * (knee - hip);
  return {p.x(), p.z()};
}

// Garment girth minus body girth around (x, z) at height y; NOT_A_NUMBER when either has no closed
// section around the point there.
double girth_ease(const Mesh& garment, const Mesh& body, double y, const Eigen::Vector2d& at) {
  const double g = girth_around(garment, y, at.x(), at.y()), b = girth_around(body, y, at.x(), at.y());
  return g > 0 && b > 0 ? g - b : NOT_A_NUMBER;
}

// Convex-hull perimeter of the section loop of `mesh` at height y around `at` that does not
// also hold `other` (the other leg); 0 when there is none.
double single_leg_girth(const Mesh& mesh, double y, const Eigen::Vector2d& at, const Eigen::Vector2d& other) {
  double best = 0;
  for (const SectionLoop& loop : horizontal_section(mesh, y))
    if (loop.size() >= 3 && loop_contains(loop, at.x(), at.y()) && !loop_contains(loop, other.x(), other.y()))
      best = std::max(best, convex_hull_perimeter(loop));
  return best;
}

// Thigh ease of one leg: garment minus body girth at the thigh landmark, or, where the garment's
// legs are still joined there (its crotch hangs lower than the body's), at the first height
// below, in 1 cm steps down to `reach`, where the garment's leg is a section of its own. NOT_A_NUMBER
// when there is none.
double thigh_ease(const Mesh& garment, const Body& body, bool left, double y, double reach) {
  for (double d = 0; d <= reach + 1e-9; d += 0.01) {
    const double h = y - d;
    const Eigen::Vector2d at = leg_axis(body, left, h), other = leg_axis(body, !left, h);
    const double g = single_leg_girth(garment, h, at, other), b = single_leg_girth(body.mesh, h, at, other);
    if (g > 0 && b > 0) return g - b;
  }
  return NOT_A_NUMBER;
}

} // namespace

std::string size_verdict_name(SizeVerdict verdict) {
  switch (verdict) {
  case SizeVerdict::FALLS_OFF: return "falls off";
  case SizeVerdict::TIGHT: return "tight";
  case SizeVerdict::LOOSE: return "loose";
  case SizeVerdict::GOOD: return "good";
  }
  return "good";
}

FitFeedback fit_feedback(const Mesh& rest, const Mesh& fitted, std::span<const GarmentPart> parts, GarmentType type,
                         const Body& body, std::span<const float> before_simulation,
                         const FitFeedbackOptions& options) {
  const ProximityIndex index(body.mesh.positions, body.mesh.triangles);
  return fit_feedback(rest, fitted, parts, type, body, index, before_simulation, options);
}

FitFeedback fit_feedback(const Mesh& rest, const Mesh& fitted, std::span<const GarmentPart> parts, GarmentType type,
                         const Body& body, const ProximityIndex& index, std::span<const float> before_simulation,
                         const FitFeedbackOptions& options) {
  const std::size_t n = fitted.vertex_count();
  if (rest.vertex_count() != n || rest.triangles != fitted.triangles)
    throw Error("fit feedback", 0, "the rest and fitted garments differ in vertices or faces");
  if (parts.size() != n)
    throw Error("fit feedback", 0,
                std::to_string(parts.size()) + " part labels for " + std::to_string(n) + " vertices");
  if (!before_simulation.empty() && before_simulation.size() != 3 * n)
    throw Error("fit feedback", 0,
                "the pre-simulation positions hold " + std::to_string(before_simulation.size() / 3) +
                    " vertices, the garment " + std::to_string(n));
  FitFeedback out;

  // Strain over the edge graph (rest lengths from the garment as modelled).
  const SurfaceGraph rest_graph = build_surface_graph(rest);
  out.strain.assign(n, 0.0f);
  for (std::size_t v = 0; v < n; ++v) {
    double sum = 0;
    int count = 0;
    for (std::int32_t k = rest_graph.offsets[v]; k < rest_graph.offsets[v + 1]; ++k) {
      const double rest_length = rest_graph.lengths[std::size_t(k)];
      if (rest_length <= 0) continue;
      const std::size_t u = std::size_t(rest_graph.neighbours[std::size_t(k)]);
      const Eigen::Vector3d a(fitted.positions[3 * v], fitted.positions[3 * v + 1], fitted.positions[3 * v + 2]);
      const Eigen::Vector3d b(fitted.positions[3 * u], fitted.positions[3 * u + 1], fitted.positions[3 * u + 2]);
      sum += (a - b).norm() / rest_length - 1;
      ++count;
    }
    out.strain[v] = count ? static_cast<float>(sum / count) : 0.0f;
  }

  // Ease: signed distance to the body.
  ClosestHits hits;
  index.closest_points(fitted.positions, std::numeric_limits<float>::infinity(), hits);
  out.ease = hits.signed_distances;

  // Regions. Girth ease is the garment's size against the body's, so it is measured where the
  // garment was placed (before the simulation, when there was one): a garment settling under
  // gravity brings its narrower waist down to the hips, which says where it rests, not what size
  // it is. Strain and distance come from the final shape.
  Mesh placed_storage;
  if (!before_simulation.empty()) {
    placed_storage.triangles = fitted.triangles;
    placed_storage.positions.assign(before_simulation.begin(), before_simulation.end());
  }
  const Mesh& placed = before_simulation.empty() ? fitted : placed_storage;
  const BodyLandmarks lm = landmarks(body);
  const double height_scale =
      std::max(0.5, joint(body, Joint::HEAD).y() -
                        std::min(joint(body, Joint::LEFT_ANKLE).y(), joint(body, Joint::RIGHT_ANKLE).y()));
  const double band = 0.03 * height_scale; // ±3 % of the ankle–head span: a hand's width
  const bool top = !is_bottom(type), legs = type == GarmentType::TROUSERS || type == GarmentType::SHORTS;
  auto summarise = [&](const char* name, auto&& in_region) {
    RegionFeedback r;
    r.name = name;
    double strain = 0, ease = 0;
    r.max_strain = -INFINITY;
    r.min_ease_mm = INFINITY;
    for (std::size_t v = 0; v < n; ++v) {
      if (!in_region(v)) continue;
      ++r.vertices;
      strain += out.strain[v];
      ease += out.ease[v];
      r.max_strain = std::max(r.max_strain, double(out.strain[v]));
      r.min_ease_mm = std::min(r.min_ease_mm, 1000.0 * out.ease[v]);
    }
    if (r.vertices == 0) return r;
    r.mean_strain = strain / double(r.vertices);
    r.mean_ease_mm = 1000.0 * ease / double(r.vertices);
    return r;
  };
  auto near_height = [&](std::size_t v, double y) { return std::abs(fitted.positions[3 * v + 1] - y) < band; };
  auto judge = [&](RegionFeedback& r, double min_ease) {
    r.verdict = SizeVerdict::GOOD;
    if (r.vertices == 0) return;
    if (r.mean_strain > options.tight_strain) r.verdict = SizeVerdict::TIGHT;
    if (min_ease > 0 && !std::isfinite(r.girth_ease)) {
      // No closed section around the landmark (e.g. a loose top whose sleeves hang open across
      // the chest's plane): the band's mean distance to the body stands in, as the girth of a
      // round section that far out (2π·distance; within 0.3 cm of the sections' ease on the
      // catalogue's tees).
      r.girth_ease = 2 * std::numbers::pi * r.mean_ease_mm / 1000.0;
      r.girth_ease_estimated = true;
    }
    if (min_ease > 0 && std::isfinite(r.girth_ease)) {
      if (r.girth_ease < min_ease)
        r.verdict = SizeVerdict::TIGHT;
      else if (r.verdict == SizeVerdict::GOOD && r.girth_ease > options.loose_factor * min_ease)
        r.verdict = SizeVerdict::LOOSE;
    }
  };
  auto torso_region = [&](const char* name, double y, double min_ease) {
    RegionFeedback r = summarise(name, [&](std::size_t v) {
      return (parts[v] == GarmentPart::TORSO || parts[v] == GarmentPart::SKIRT) && near_height(v, y);
    });
    r.girth_ease = r.vertices ? girth_ease(placed, body.mesh, y, torso_axis(body, y)) : NOT_A_NUMBER;
    judge(r, min_ease);
    out.regions.push_back(r);
  };
  if (top) torso_region("chest", lm.chest, options.min_ease_chest);
  // Tops are judged at the chest; their waist is as the cut makes it (a straight tee is loose
  // there by design). Bottoms and dresses are judged at the waist and hip.
  if (type != GarmentType::TEE && type != GarmentType::LONG_SLEEVE) {
    torso_region("waist", lm.waist, options.min_ease_waist);
    if (is_bottom(type)) torso_region("hip", lm.hip, options.min_ease_hip);
  } else {
    RegionFeedback r =
        summarise("waist", [&](std::size_t v) { return parts[v] == GarmentPart::TORSO && near_height(v, lm.waist); });
    r.girth_ease = r.vertices ? girth_ease(placed, body.mesh, lm.waist, torso_axis(body, lm.waist)) : NOT_A_NUMBER;
    judge(r, 0.0);
    out.regions.push_back(r);
  }
  if (legs) {
    RegionFeedback r = summarise("thigh", [&](std::size_t v) {
      return (parts[v] == GarmentPart::LEFT_LEG || parts[v] == GarmentPart::RIGHT_LEG) && near_height(v, lm.thigh);
    });
    double sum = 0;
    int count = 0;
    for (bool left : {true, false}) {
      const double e = thigh_ease(placed, body, left, lm.thigh, band);
      if (std::isfinite(e)) {
        sum += e;
        ++count;
      }
    }
    r.girth_ease = count ? sum / count : NOT_A_NUMBER;
    judge(r, options.min_ease_thigh);
    out.regions.push_back(r);
  }
  if (top) {
    RegionFeedback r = summarise("sleeves", [&](std::size_t v) {
      return parts[v] == GarmentPart::LEFT_SLEEVE || parts[v] == GarmentPart::RIGHT_SLEEVE;
    });
    r.girth_ease = NOT_A_NUMBER;
    judge(r, 0.0);
    if (r.vertices) out.regions.push_back(r);
  }

  // The hem: the lowest opening's band, and for bottoms the waistband (the highest opening).
  const SurfaceGraph fitted_graph = build_surface_graph(fitted);
  const BoundaryLoop* lowest = nullptr;
  const BoundaryLoop* highest = nullptr;
  for (const BoundaryLoop& loop : fitted_graph.loops) {
    if (!lowest || loop.centroid.y() < lowest->centroid.y()) lowest = &loop;
    if (!highest || loop.centroid.y() > highest->centroid.y()) highest = &loop;
  }
  if (lowest && !legs) {
    const double hem_top = lowest->max_y + band;
    RegionFeedback r = summarise("hem", [&](std::size_t v) {
      return parts[v] != GarmentPart::LEFT_SLEEVE && parts[v] != GarmentPart::RIGHT_SLEEVE &&
             fitted.positions[3 * v + 1] < hem_top;
    });
    r.girth_ease = NOT_A_NUMBER;
    judge(r, 0.0);
    out.regions.push_back(r);
  }

  // Verdict.
  std::ostringstream reason;
  reason.setf(std::ios::fixed);
  reason.precision(1);
  if (is_bottom(type) && highest) {
    // The waistband's own length, as sewn: the same opening's perimeter in the rest garment.
    double girth = 0, drop = 0;
    const std::int32_t first = highest->vertices.front();
    for (const BoundaryLoop& loop : rest_graph.loops)
      if (std::find(loop.vertices.begin(), loop.vertices.end(), first) != loop.vertices.end()) girth = loop.perimeter;
    out.waistband_girth = girth;
    if (!before_simulation.empty()) {
      double before = 0, after = 0;
      for (std::int32_t v : highest->vertices) {
        before += before_simulation[3 * std::size_t(v) + 1];
        after += fitted.positions[3 * std::size_t(v) + 1];
      }
      drop = (before - after) / double(highest->vertices.size());
    }
    out.waistband_drop = drop;
    const double hip_girth =
        girth_around(body.mesh, lm.hip, torso_axis(body, lm.hip).x(), torso_axis(body, lm.hip).y());
    if (hip_girth > 0 && girth >= hip_girth) {
      out.verdict = SizeVerdict::FALLS_OFF;
      reason << "the waistband (" << 100 * girth << " cm) passes over the hips (" << 100 * hip_girth
             << " cm): nothing holds it up";
      out.reason = reason.str();
      return out;
    }
    const double band_height = highest->centroid.y();
    if (!before_simulation.empty() && (drop > options.slide_limit || band_height < lm.hip)) {
      out.verdict = SizeVerdict::FALLS_OFF;
      reason << "the waistband slid " << 100 * drop << " cm down the body during the simulation"
             << (band_height < lm.hip ? ", past the hips" : "");
      out.reason = reason.str();
      return out;
    }
  }
  const RegionFeedback* tight = nullptr;
  const RegionFeedback* loose = nullptr;
  for (const RegionFeedback& r : out.regions) {
    if (r.verdict == SizeVerdict::TIGHT && !tight) tight = &r;
    if (r.verdict == SizeVerdict::LOOSE && !loose) loose = &r;
  }
  auto describe = [&](const RegionFeedback& r) {
    reason << r.name << ": ";
    if (std::isfinite(r.girth_ease))
      reason << "girth ease " << 100 * r.girth_ease << " cm" << (r.girth_ease_estimated ? " (from its distance)" : "")
             << ", ";
    reason << "mean strain " << 100 * r.mean_strain << " %";
  };
  if (tight) {
    out.verdict = SizeVerdict::TIGHT;
    describe(*tight);
  } else if (loose) {
    out.verdict = SizeVerdict::LOOSE;
    describe(*loose);
  } else {
    out.verdict = SizeVerdict::GOOD;
    reason << "every region within the wearing-ease range";
  }
  out.reason = reason.str();
  return out;
}

// The elongation (m) past which an edge stretched to twice its length is torn (see the header).
constexpr double TORN_ELONGATION = 0.02;

TornCloth torn_cloth(const Mesh& fitted, std::span<const float> modelled) {
  const MeshEdges edges = build_mesh_edges(fitted.triangles, fitted.vertex_count());
  std::vector<char> seen(edges.edge_count(), 0);
  std::size_t torn = 0;
  double worst = 0;
  auto length = [](std::span<const float> p, std::int32_t a, std::int32_t b) {
    double d2 = 0;
    for (std::size_t c = 0; c < 3; ++c) {
      const double d = double(p[3 * std::size_t(a) + c]) - p[3 * std::size_t(b) + c];
      d2 += d * d;
    }
    return std::sqrt(d2);
  };
  for (std::size_t f = 0; f < fitted.face_count(); ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const auto e = std::size_t(edges.triangle_edges[3 * f + k]);
      if (seen[e]) continue;
      seen[e] = 1;
      const std::int32_t a = fitted.triangles[3 * f + k], b = fitted.triangles[3 * f + (k + 1) % 3];
      const double rest = length(modelled, a, b), now = length(fitted.positions, a, b);
      if (now > 2 * rest && now - rest > TORN_ELONGATION) {
        ++torn;
        worst = std::max(worst, now - rest);
      }
    }
  return {torn, worst};
}

std::string torn_cloth_warning(const Mesh& fitted, std::span<const float> modelled) {
  const auto [torn, worst] = torn_cloth(fitted, modelled);
  if (torn == 0) return "";
  char line[260];
  std::snprintf(line, sizeof line,
                "%zu edges stretched to over twice their modelled length, by up to %.0f mm: the cloth was pulled "
                "through or around something (a limb lying on it?); check the fit before trusting it",
                torn, 1000 * worst);
  return line;
}

} // namespace vfit
