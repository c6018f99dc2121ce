// SPDX-License-Identifier: Apache-2.0
#include "skeleton_driving.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>
#include <numeric>
#include <optional>
#include <queue>
#include <string>

#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include "coarse_move.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The hip joint's height above the crotch key point, per distance between the two legs' axes
// at the key point's height, measured on the catalogue's mannequin: (0.865 − 0.7734) / 0.1974
// for its trousers (size M). A body's proportion, not the garment's rise: the rule before
// this one, a fraction (0.37) of the way from the crotch key point up to the source opening's
// centre, was exact on the catalogue, whose waistbands sit at the mannequin's waist, but put
// the corpus's low-rise jeans on hm08 31–39 mm low and its shorts 55 mm low, and the worksuit's
// bib overalls, whose source opening is the top of the bib, 74 mm high. With this rule: the
// same garments within 8–20 mm (jeans +8 and −12, shorts −16, overalls −20 mm), the catalogue's
// trousers and shorts in sizes P1–P3 within 21 mm (a loose pair's crotch hangs lower).
constexpr double HIP_RISE_PER_LEG_SPACING = 0.464;
// The legs' wedges (their skeletons' nodes before PartSkeleton::tube_start) count towards the
// axes when their first nodes are mirror images to within this share of the legs' spacing at
// the crotch. Measured, first nodes' mirror distance / spacing: the catalogue's trousers 0.07
// (0.17 in one driving test's pose), the corpus's jeans, shorts and leggings 0.02–0.08, its suit
// trousers 0.28, the worksuit overalls 0.86 (its right leg's label runs up the hip, its left
// leg's chain starts at the crotch). Half the spacing: a wedge that far from its mirror image
// reaches up a different side of the hip.
constexpr double WEDGE_MIRROR_TOLERANCE = 0.5;

Eigen::Vector3d point(std::span<const float> p, std::size_t v) { return {p[3 * v], p[3 * v + 1], p[3 * v + 2]}; }

bool is_limb(GarmentPart p) {
  return p == GarmentPart::LEFT_SLEEVE || p == GarmentPart::RIGHT_SLEEVE || p == GarmentPart::LEFT_LEG ||
         p == GarmentPart::RIGHT_LEG;
}

std::array<Joint, 3> limb_bones(GarmentPart p) {
  switch (p) {
  case GarmentPart::LEFT_SLEEVE: return {Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW, Joint::LEFT_WRIST};
  case GarmentPart::RIGHT_SLEEVE: return {Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW, Joint::RIGHT_WRIST};
  case GarmentPart::LEFT_LEG: return {Joint::LEFT_HIP, Joint::LEFT_KNEE, Joint::LEFT_ANKLE};
  default: return {Joint::RIGHT_HIP, Joint::RIGHT_KNEE, Joint::RIGHT_ANKLE};
  }
}

// Makes the key joints mirror images of each other about the garment's mid-plane (x = their
// mean x): an input garment is left/right symmetric (segment.h), but its boundary planes and
// thigh axes are estimated on each side separately, and differ by a centimetre or more front
// to back or in height (a slanted armhole's plane, a skeleton's wobble), which would turn the
// whole garment by degrees about its vertical or its depth axis.
void symmetrise(GarmentKeyJoints& g) {
  const Eigen::Vector3d mirror(-1, 1, 1);
  const double mid = 0.5 * (g.j1.x() + g.j2.x()), half = 0.5 * std::abs(g.j2.x() - g.j1.x());
  const double y = 0.5 * (g.j1.y() + g.j2.y()), z = 0.5 * (g.j1.z() + g.j2.z());
  g.j1 = {mid - half, y, z};
  g.j2 = {mid + half, y, z};
  Eigen::Vector3d right = g.right_axis + g.left_axis.cwiseProduct(mirror);
  if (right.norm() < 1e-9) right = g.right_axis; // opposite estimates: keep the right side's
  g.right_axis = right.normalized();
  g.left_axis = g.right_axis.cwiseProduct(mirror);
}

// Arc length along the chain from node 0 (eq. 8).
std::vector<double> arc_lengths(std::span<const Eigen::Vector3d> l) {
  std::vector<double> s(l.size(), 0.0);
  for (std::size_t k = 1; k < l.size(); ++k)
    s[k] = s[k - 1] + (l[k] - l[k - 1]).norm();
  return s;
}

const PartSkeleton* find_skeleton(std::span<const PartSkeleton> skeletons, GarmentPart part) {
  for (const PartSkeleton& s : skeletons)
    if (s.part == part && !s.nodes.empty()) return &s;
  return nullptr;
}

// A leg's open end: the centroid and unit normal (pointing away from `inboard`) of the mesh's
// boundary vertices labelled `part`, i.e. of its hem, and the hem's RMS radius about the
// centroid; nullopt for fewer than 3 such vertices.
struct Hem {
  Eigen::Vector3d centre, normal;
  double radius = 0;
};
std::optional<Hem> leg_hem(const Mesh& garment, std::span<const GarmentPart> parts, GarmentPart part,
                           const Eigen::Vector3d& inboard) {
  // A vertex of the leg is on its hem when one of its edges belongs to a single triangle: among
  // the neighbours its faces list (each face names two), one that appears once. Gathered per
  // vertex (counting, then filling), so the cost is linear in the faces.
  const std::size_t nv = garment.vertex_count();
  std::vector<std::int32_t> start(nv + 1, 0);
  for (std::int32_t v : garment.triangles)
    if (parts[static_cast<std::size_t>(v)] == part) start[static_cast<std::size_t>(v) + 1] += 2;
  for (std::size_t v = 0; v < nv; ++v)
    start[v + 1] += start[v];
  std::vector<std::int32_t> around(static_cast<std::size_t>(start[nv]));
  std::vector<std::int32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < garment.face_count(); ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(garment.triangles[3 * f + k]);
      if (parts[v] != part) continue;
      around[static_cast<std::size_t>(fill[v]++)] = garment.triangles[3 * f + (k + 1) % 3];
      around[static_cast<std::size_t>(fill[v]++)] = garment.triangles[3 * f + (k + 2) % 3];
    }
  std::vector<char> on_hem(nv, 0);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto begin = around.begin() + start[v], end = around.begin() + start[v + 1];
    std::sort(begin, end);
    for (auto it = begin; it != end;) {
      const auto next = std::find_if(it, end, [&](std::int32_t w) { return w != *it; });
      if (next - it == 1 && parts[static_cast<std::size_t>(*it)] == part) on_hem[v] = 1;
      it = next;
    }
  }
  std::vector<Eigen::Vector3d> ring;
  for (std::size_t v = 0; v < garment.vertex_count(); ++v)
    if (on_hem[v]) ring.push_back(point(garment.positions, v));
  if (ring.size() < 3) return std::nullopt;
  Hem hem;
  hem.centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : ring)
    hem.centre += p;
  hem.centre /= double(ring.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : ring)
    cov += (p - hem.centre) * (p - hem.centre).transpose();
  hem.radius = std::sqrt(cov.trace() / double(ring.size()));
  hem.normal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0);
  if (hem.normal.dot(hem.centre - inboard) < 0) hem.normal = -hem.normal;
  return hem;
}

// A leg's axis, from the hip towards the hem, and `joint`, the axis's point at `height`. The
// principal direction of its skeleton's nodes through their centroid, from the first node
// towards the last; but when the nodes span less than the hem's diameter (shorts: a tube about
// as long as it is wide, whose skeleton zigzags across it), the hem's normal through its
// centre (`hem`), as the cuff's area vector gives a short sleeve's axis (segment_sleeves.cpp).
void leg_axis(const PartSkeleton& leg, const std::optional<Hem>& hem, double height, std::size_t first,
              Eigen::Vector3d& joint, Eigen::Vector3d& direction) {
  // The nodes from `first` on: garment_key_joints() passes tube_start, or 0 when the two legs'
  // wedges above the crotch agree. (The thigh's half of the nodes alone tilted a short leg's
  // axis to the horizontal: the female jeans of the corpus were extrapolated metres away.)
  const std::span<const Eigen::Vector3d> nodes =
      std::span<const Eigen::Vector3d>(leg.nodes).subspan(std::min(first, leg.nodes.size() - 1));
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : nodes)
    c += p;
  c /= double(nodes.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : nodes)
    cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  direction = eig.eigenvectors().col(2);
  if (direction.dot(nodes.back() - nodes.front()) < 0) direction = -direction;
  double lo = INFINITY, hi = -INFINITY;
  for (const Eigen::Vector3d& p : nodes) {
    lo = std::min(lo, (p - c).dot(direction));
    hi = std::max(hi, (p - c).dot(direction));
  }
  if (hem && hi - lo < 2 * hem->radius) {
    direction = hem->normal;
    c = hem->centre;
  }
  if (nodes.size() < 2 || std::abs(direction.y()) < 1e-6) {
    direction = -Eigen::Vector3d::UnitY();
    joint = {c.x(), height, c.z()};
    return;
  }
  joint = c + (height - c.y()) / direction.y() * direction;
}

// The point at arc length `s` along the polyline `bones` (eq. 11), continued along the last
// bone of non-zero length past its end; `segment` receives that bone's index.
Eigen::Vector3d point_at_arc_length(std::span<const Eigen::Vector3d> bones, double s, int& segment) {
  int last = -1;
  for (std::size_t b = 0; b + 1 < bones.size(); ++b) {
    const double len = (bones[b + 1] - bones[b]).norm();
    if (len <= 1e-12) continue;
    last = static_cast<int>(b);
    if (s <= len) break;
    // Past the last joint the node continues along the last bone, so the part keeps its length.
    bool more = false;
    for (std::size_t c = b + 1; c + 1 < bones.size(); ++c)
      more = more || (bones[c + 1] - bones[c]).norm() > 1e-12;
    if (!more) break;
    s -= len;
  }
  segment = std::max(0, last);
  if (last < 0) return bones[0];
  const Eigen::Vector3d& a = bones[static_cast<std::size_t>(last)];
  const Eigen::Vector3d& b = bones[static_cast<std::size_t>(last) + 1];
  return a + s / (b - a).norm() * (b - a);
}

// Per-vertex adjacency (CSR) of the mesh's edges: each vertex's neighbours gathered from its
// faces by counting (no global sort), then sorted and deduplicated per vertex.
void edge_adjacency(const Mesh& mesh, std::vector<std::int32_t>& offsets, std::vector<std::int32_t>& neighbours) {
  const std::size_t nv = mesh.vertex_count();
  std::vector<std::int32_t> start(nv + 1, 0);
  for (std::int32_t v : mesh.triangles)
    start[static_cast<std::size_t>(v) + 1] += 2;
  for (std::size_t v = 0; v < nv; ++v)
    start[v + 1] += start[v];
  std::vector<std::int32_t> all(static_cast<std::size_t>(start[nv]));
  std::vector<std::int32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::size_t>(mesh.triangles[3 * f + k]);
      all[static_cast<std::size_t>(fill[a]++)] = mesh.triangles[3 * f + (k + 1) % 3];
      all[static_cast<std::size_t>(fill[a]++)] = mesh.triangles[3 * f + (k + 2) % 3];
    }
  offsets.assign(nv + 1, 0);
  neighbours.clear();
  neighbours.reserve(all.size() / 2 + nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto begin = all.begin() + start[v], end = all.begin() + start[v + 1];
    std::sort(begin, end);
    neighbours.insert(neighbours.end(), begin, std::unique(begin, end));
    offsets[v + 1] = static_cast<std::int32_t>(neighbours.size());
  }
}

// Unit principal direction of points through their centroid (sign arbitrary); +Y for fewer than 2.
Eigen::Vector3d principal_direction(std::span<const Eigen::Vector3d> points) {
  if (points.size() < 2) return Eigen::Vector3d::UnitY();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points)
    c += p;
  c /= double(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points)
    cov += (p - c) * (p - c).transpose();
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(2);
}

// The direction of the chain's nodes past `upper_length` along `axis` (principal direction
// through their centroid, pointing along the chain), or `axis` when fewer than two nodes lie
// there or they span less than a tenth of the upper length (a short sleeve, shorts).
Eigen::Vector3d lower_direction(std::span<const Eigen::Vector3d> nodes, std::span<const double> along,
                                double upper_length, const Eigen::Vector3d& axis) {
  std::vector<Eigen::Vector3d> past;
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t k = 0; k < nodes.size(); ++k)
    if (along[k] > upper_length) {
      past.push_back(nodes[k]);
      lo = std::min(lo, along[k]);
      hi = std::max(hi, along[k]);
    }
  if (past.size() < 2 || hi - lo < 0.1 * upper_length) return axis;
  const Eigen::Vector3d d = principal_direction(past);
  return d.dot(past.back() - past.front()) < 0 ? Eigen::Vector3d(-d) : d;
}

// A chain whose nodes spread across their principal line by more than this fraction of their
// spread along it (RMS) is no tube's axis (a jacket's sleeve skeleton wandering over the chest).
constexpr double CROOKED_CHAIN = 0.3;

// The direction of the chain's nodes between root·upper_length and `upper_length` along `axis`
// (principal direction through their centroid, pointing along `axis`), or `axis` when no node
// lies past `upper_length` (a limb that ends above the elbow or knee), fewer than three lie
// within, they span less than half the upper length, or they are crooked (CROOKED_CHAIN).
Eigen::Vector3d upper_direction(std::span<const Eigen::Vector3d> nodes, std::span<const double> along,
                                double upper_length, double root, const Eigen::Vector3d& axis) {
  std::vector<Eigen::Vector3d> within;
  double lo = INFINITY, hi = -INFINITY;
  bool past = false;
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    past = past || along[k] > upper_length;
    if (along[k] < root * upper_length || along[k] > upper_length) continue;
    within.push_back(nodes[k]);
    lo = std::min(lo, along[k]);
    hi = std::max(hi, along[k]);
  }
  if (!past || within.size() < 3 || hi - lo < 0.5 * upper_length) return axis;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : within)
    c += p;
  c /= double(within.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : within)
    cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d spread = eig.eigenvalues().cwiseMax(0.0);
  const double ratio = std::sqrt((spread[0] + spread[1]) / std::max(1e-30, spread[2]));
  if (ratio > CROOKED_CHAIN) return axis;
  const Eigen::Vector3d d = eig.eigenvectors().col(2);
  return d.dot(axis) < 0 ? Eigen::Vector3d(-d) : d;
}

// Samples along the line down the trunk from the hips' midpoint, over one thigh's length.
constexpr int CROTCH_SAMPLES = 256;

// The body's crotch: where the line from `hips` (the hips' midpoint, inside the body) along
// −`up` first leaves the body, within `length` of it (m); nullopt when `hips` is outside the
// body or the line stays inside (no crotch found).
std::optional<Eigen::Vector3d> body_crotch(const ProximityIndex& body, const Eigen::Vector3d& hips,
                                           const Eigen::Vector3d& up, double length) {
  std::vector<float> line(3 * CROTCH_SAMPLES);
  for (int i = 0; i < CROTCH_SAMPLES; ++i) {
    const Eigen::Vector3d p = hips - (length * i / (CROTCH_SAMPLES - 1)) * up;
    for (int c = 0; c < 3; ++c)
      line[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(c)] = static_cast<float>(p[c]);
  }
  ClosestHits hits;
  body.closest_points(line, INFINITY, hits);
  if (hits.triangles[0] < 0 || hits.signed_distances[0] >= 0) return std::nullopt;
  for (std::size_t i = 1; i < CROTCH_SAMPLES; ++i) {
    const double d0 = hits.signed_distances[i - 1], d1 = hits.signed_distances[i];
    if (hits.triangles[i] < 0 || d1 < 0) continue;
    // Between the last sample inside and the first outside, where the signed distance is 0.
    const double s = (double(i) - 1 + (-d0) / (d1 - d0)) * length / (CROTCH_SAMPLES - 1);
    return hips - s * up;
  }
  return std::nullopt;
}

// The pocket search (pocket_offset()): offsets along the trunk within ±POCKET_RANGE (m) of the
// contact placement, every POCKET_STEP (m). The crotch key point lies up to 30 mm from the
// body's crotch on the corpus's bottoms (their cloth's crotch 13–49 mm below the body's), and
// a loose garment needs the range to reach what holds it: catalogue trousers placed 2 cm high
// are brought down 30 mm, which ±30 mm did not reach (their clearance still rising there).
constexpr double POCKET_RANGE = 0.05;
constexpr double POCKET_STEP = 0.002;
// The clearance of a placement: this quantile of the torso's signed distances to the body, the
// closest approach but for a few stray vertices (a crumpled waistband, a belt loop).
constexpr double CLEARANCE_QUANTILE = 0.01;
// Offsets within this clearance (m) of the best count as equally free; the lowest of them is
// taken: the garment slides down until its tight band (waistband, seat) is pressed this much
// more into the body than where it is freest, about the depth the corpus's jeans are modelled
// into their body (2 mm as modelled; with 1 mm the male jeans stayed 10.4 mm high). A pocket
// must be deeper than this on both sides, or the placement stays.
constexpr double POCKET_TOLERANCE = 0.002;

// The clearance (CLEARANCE_QUANTILE of the signed distances to the body) of `points` (#Q × 3,
// m) moved by each of the offsets k·POCKET_STEP·up, k = −steps … steps, in order; empty when a
// point has no closest point on the body (no body). Only the smallest distances decide a
// quantile, so a point is queried at an offset only while it may be among them: the signed
// distance to a closed surface that does not intersect itself changes by at most the distance
// moved (it is 1-Lipschitz), so a point last queried j offsets away is at least its distance
// then minus j·POCKET_STEP from the body: the points whose bound may put them among the closest
// are queried, each only as far as its last closest point (and no farther than the quantile
// when it is surely outside). The quantiles equal those of every point queried at every offset.
std::vector<double> pocket_clearances(std::span<const float> points, const ProximityIndex& body,
                                      const Eigen::Vector3d& up, int steps) {
  const std::size_t n = points.size() / 3;
  const auto q = static_cast<std::size_t>(CLEARANCE_QUANTILE * double(n - 1));
  auto offset = [&](int k) { return Eigen::Vector3f((k * POCKET_STEP * up).cast<float>()); };
  std::vector<float> moved(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      moved[3 * i + std::size_t(c)] = points[3 * i + std::size_t(c)] + offset(-steps)[c];
  ClosestHits hits; // per point, its answer at the offset queried_at[i]
  body.closest_points(moved, INFINITY, hits);
  if (std::any_of(hits.triangles.begin(), hits.triangles.end(), [](std::int32_t t) { return t < 0; })) return {};
  std::vector<int> queried_at(n, -steps);
  std::vector<double> clearance;
  std::vector<float> values(hits.signed_distances.begin(), hits.signed_distances.end());
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(q), values.end());
  clearance.push_back(values[q]);

  std::vector<std::size_t> order(n), batch;
  std::vector<double> bound(n);
  // A point queried within a capped radius and not found there is farther than that radius:
  // far_from[i] (m) at offset far_at[i] (−∞: nothing known beyond its distance).
  std::vector<double> far_from(n, -INFINITY);
  std::vector<int> far_at(n, -steps);
  std::vector<float> queries, radii;
  ClosestHits some;
  std::vector<char> exact(n);
  for (int k = -steps + 1; k <= steps; ++k) {
    const Eigen::Vector3f d = offset(k);
    // 1e-6 m: the float rounding of the positions and distances.
    for (std::size_t i = 0; i < n; ++i)
      bound[i] = std::max(double(hits.signed_distances[i]) - std::abs(k - queried_at[i]) * POCKET_STEP,
                          far_from[i] - std::abs(k - far_at[i]) * POCKET_STEP) -
                 1e-6;
    // Queries `which` at offset k, each within its distance to its last closest point, or within
    // `cap` (m) when that is smaller and the point is surely outside (bound > 0).
    auto query = [&](const std::vector<std::size_t>& which, double cap) {
      queries.clear();
      radii.clear();
      for (const std::size_t i : which) {
        for (std::size_t c = 0; c < 3; ++c)
          queries.push_back(points[3 * i + c] + d[int(c)]);
        const float warm = requery_radius(&queries[queries.size() - 3], &hits.points[3 * i]);
        radii.push_back(bound[i] > 0 ? std::min(warm, float(cap)) : warm);
      }
      body.closest_points(queries, radii, some);
      for (std::size_t j = 0; j < which.size(); ++j) {
        const std::size_t i = which[j];
        if (some.triangles[j] < 0) { // farther than the cap, outside
          far_from[i] = radii[j];
          far_at[i] = k;
          continue;
        }
        hits.copy_row(i, some, j);
        queried_at[i] = k;
        exact[i] = 1;
      }
    };
    auto exact_quantile = [&] {
      values.clear();
      for (std::size_t i = 0; i < n; ++i)
        if (exact[i]) values.push_back(hits.signed_distances[i]);
      std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(q), values.end());
      return values[q];
    };
    // The q + 1 points of least bound, exactly; then every other point whose bound is below
    // their quantile, within that quantile (a point not found there cannot lower it). The
    // quantile of all is then that of the points found (it can only fall).
    std::fill(exact.begin(), exact.end(), char(0));
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::nth_element(order.begin(), order.begin() + std::ptrdiff_t(q), order.end(),
                     [&](std::size_t a, std::size_t b) { return bound[a] < bound[b]; });
    batch.assign(order.begin(), order.begin() + std::ptrdiff_t(q + 1));
    query(batch, INFINITY);
    const float first = exact_quantile();
    batch.clear();
    for (std::size_t i = 0; i < n; ++i)
      if (!exact[i] && bound[i] < double(first)) batch.push_back(i);
    if (!batch.empty()) query(batch, std::max(double(first), 0.0) + 1e-6);
    clearance.push_back(batch.empty() ? first : exact_quantile());
  }
  return clearance;
}

// The offset along `up` (m) moving `points` (#Q × 3, m) to the height of the most clearance
// from the body within ±POCKET_RANGE; 0 when the clearance does not fall by POCKET_TOLERANCE
// both below and above its best (no pocket: a garment loose all round, or held only from one
// side) or there are no points.
double pocket_offset(std::span<const float> points, const ProximityIndex& body, const Eigen::Vector3d& up) {
  const std::size_t n = points.size() / 3;
  if (n == 0) return 0;
  const int steps = static_cast<int>(std::lround(POCKET_RANGE / POCKET_STEP));
  const std::vector<double> clearance = pocket_clearances(points, body, up, steps);
  if (clearance.empty()) return 0;
  const double best = *std::max_element(clearance.begin(), clearance.end());
  if (clearance.front() > best - POCKET_TOLERANCE || clearance.back() > best - POCKET_TOLERANCE) return 0;
  const auto lowest =
      std::find_if(clearance.begin(), clearance.end(), [&](double c) { return c >= best - POCKET_TOLERANCE; });
  return (static_cast<int>(lowest - clearance.begin()) - steps) * POCKET_STEP;
}

Eigen::Matrix3d slerp(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b, double w) {
  return Eigen::Quaterniond(a).slerp(w, Eigen::Quaterniond(b)).toRotationMatrix();
}

} // namespace

Eigen::Matrix3d rotation_between(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const double nf = from.norm(), nt = to.norm();
  if (nf == 0 || nt == 0) return Eigen::Matrix3d::Identity();
  const Eigen::Vector3d a = from / nf, b = to / nt;
  const Eigen::Vector3d axis = a.cross(b);
  const double s = axis.norm(), c = std::clamp(a.dot(b), -1.0, 1.0);
  if (s < 1e-12) {
    if (c > 0) return Eigen::Matrix3d::Identity();
    // Opposite: a half turn about any axis normal to `from`.
    Eigen::Vector3d n = a.cross(Eigen::Vector3d::UnitX());
    if (n.norm() < 1e-6) n = a.cross(Eigen::Vector3d::UnitY());
    return Eigen::AngleAxisd(std::numbers::pi, n.normalized()).toRotationMatrix();
  }
  return Eigen::AngleAxisd(std::atan2(s, c), axis / s).toRotationMatrix();
}

std::vector<Eigen::Vector3d> arc_length_targets(std::span<const Eigen::Vector3d> nodes,
                                                std::span<const Eigen::Vector3d> bones, double offset,
                                                std::vector<int>& segment) {
  if (bones.size() < 2) throw Error("skeleton driving", 0, "a bone polyline needs at least 2 joints");
  const std::vector<double> s = arc_lengths(nodes);
  std::vector<Eigen::Vector3d> out(nodes.size());
  segment.assign(nodes.size(), 0);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    out[k] = point_at_arc_length(bones, offset + s[k], segment[k]);
  return out;
}

GarmentKeyJoints garment_key_joints(const Mesh& garment, const GarmentSegmentation& segmentation,
                                    std::span<const PartSkeleton> skeletons) {
  const SegmentationKeyPoints& kp = segmentation.key_points;
  GarmentKeyJoints out;
  if (kp.s1 && kp.s2) {
    out.j1 = kp.s1->point;
    out.j2 = kp.s2->point;
    out.right_axis = kp.s1->normal.normalized();
    out.left_axis = kp.s2->normal.normalized();
    symmetrise(out);
    return out;
  }
  const PartSkeleton* left = find_skeleton(skeletons, GarmentPart::LEFT_LEG);
  const PartSkeleton* right = find_skeleton(skeletons, GarmentPart::RIGHT_LEG);
  if (kp.crotch && left && right) {
    std::optional<Hem> hems[2];
    if (segmentation.vertex_parts.size() == garment.vertex_count()) {
      hems[0] = leg_hem(garment, segmentation.vertex_parts, GarmentPart::RIGHT_LEG, *kp.crotch);
      hems[1] = leg_hem(garment, segmentation.vertex_parts, GarmentPart::LEFT_LEG, *kp.crotch);
    }
    // The hips' height from the legs' own spacing: their tubes' axes' distance apart at the
    // crotch (the tubes alone: a wedge that differs between the legs would skew it).
    leg_axis(*right, hems[0], kp.crotch->y(), right->tube_start, out.j1, out.right_axis);
    leg_axis(*left, hems[1], kp.crotch->y(), left->tube_start, out.j2, out.left_axis);
    const double spacing = (out.j2 - out.j1).norm();
    const double height = kp.crotch->y() + HIP_RISE_PER_LEG_SPACING * spacing;
    // The wedges above the crotch, when they are mirror images (the label runs equally far up
    // both hips), carry the hips' place: they reach out towards the hip joints, which lie
    // outboard of the tubes' axes (a thigh's tube narrows inwards up to the crotch). The
    // catalogue's trousers' hips from the tubes alone were 11 mm inboard and 15 mm forward of the
    // mannequin's. When the wedges differ (one leg's label runs up its hip, the other's chain
    // starts at the crotch), neither counts: the tubes alone are mirror images.
    std::size_t first[2] = {right->tube_start, left->tube_start};
    if (!right->nodes.empty() && !left->nodes.empty()) {
      const double mid = 0.5 * (out.j1.x() + out.j2.x());
      Eigen::Vector3d mirrored = left->nodes.front();
      mirrored.x() = 2 * mid - mirrored.x();
      if ((mirrored - right->nodes.front()).norm() < WEDGE_MIRROR_TOLERANCE * spacing) first[0] = first[1] = 0;
    }
    leg_axis(*right, hems[0], height, first[0], out.j1, out.right_axis);
    leg_axis(*left, hems[1], height, first[1], out.j2, out.left_axis);
    symmetrise(out);
    out.crotch = *kp.crotch;
    out.legs = true;
    return out;
  }
  throw Error("skeleton driving", 0,
              "the garment has neither sleeve boundary planes (a top) nor a crotch and two leg skeletons (trousers)");
}

struct SkeletonDriver::Band {
  std::once_flag built;
  std::unique_ptr<BandLaplacianDeformer> deformer;
  Eigen::MatrixXd rest_delta; ///< #V × 3: L · rest positions
};

SkeletonDriver::SkeletonDriver(const Mesh& garment, const GarmentSegmentation& segmentation,
                               std::span<const PartSkeleton> skeletons, const SkeletonDrivingOptions& options)
    : m_garment(garment), m_parts(segmentation.vertex_parts), m_options(options) {
  const auto t0 = Clock::now();
  const std::size_t nv = garment.vertex_count();
  if (m_parts.size() != nv)
    throw Error("skeleton driving", 0,
                std::to_string(m_parts.size()) + " part labels for a garment of " + std::to_string(nv) + " vertices");
  for (std::int32_t v : garment.triangles)
    if (v < 0 || static_cast<std::size_t>(v) >= nv)
      throw Error("skeleton driving", 0, "triangle vertex " + std::to_string(v) + " out of range");
  for (const PartSkeleton& s : skeletons)
    if (is_limb(s.part) && !s.nodes.empty()) m_skeletons.push_back(s);
  m_key_joints = garment_key_joints(garment, segmentation, m_skeletons);

  m_vertex_limb.assign(nv, -1);
  m_vertex_node.assign(nv, -1);
  for (std::size_t i = 0; i < m_skeletons.size(); ++i) {
    const PartSkeleton& s = m_skeletons[i];
    if (s.vertices.size() != s.vertex_node.size())
      throw Error("skeleton driving", 0, garment_part_name(s.part) + " skeleton: vertex and node lists differ in size");
    for (std::size_t k = 0; k < s.vertices.size(); ++k) {
      const std::int32_t v = s.vertices[k], node = s.vertex_node[k];
      if (v < 0 || static_cast<std::size_t>(v) >= nv || node < 0 || static_cast<std::size_t>(node) >= s.nodes.size())
        throw Error("skeleton driving", 0,
                    garment_part_name(s.part) + " skeleton: vertex " + std::to_string(v) + " or node " +
                        std::to_string(node) + " out of range");
      m_vertex_limb[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(i);
      m_vertex_node[static_cast<std::size_t>(v)] = node;
    }
  }

  // Distance along edges from the seams (limb vertices with a neighbour outside their limb),
  // up to seam_radius.
  std::vector<std::int32_t> offsets, neighbours;
  edge_adjacency(garment, offsets, neighbours);
  const std::span<const float> x = garment.positions;
  m_seam_distance.assign(nv, std::numeric_limits<double>::infinity());
  m_seam_limb.assign(nv, -1);
  using Item = std::pair<double, std::int32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (std::size_t v = 0; v < nv; ++v) {
    if (m_vertex_limb[v] < 0) continue;
    for (std::int32_t i = offsets[v]; i < offsets[v + 1]; ++i)
      if (m_vertex_limb[static_cast<std::size_t>(neighbours[static_cast<std::size_t>(i)])] != m_vertex_limb[v]) {
        m_seam_distance[v] = 0;
        m_seam_limb[v] = m_vertex_limb[v];
        queue.emplace(0.0, static_cast<std::int32_t>(v));
        break;
      }
  }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > m_seam_distance[static_cast<std::size_t>(v)]) continue;
    for (std::int32_t i = offsets[static_cast<std::size_t>(v)]; i < offsets[static_cast<std::size_t>(v) + 1]; ++i) {
      const auto w = static_cast<std::size_t>(neighbours[static_cast<std::size_t>(i)]);
      const double dw = d + (point(x, w) - point(x, static_cast<std::size_t>(v))).norm();
      // Only distances up to seam_radius are used (blending, handles): the search stops there
      // instead of crossing the whole garment (0.3 s of a 10^6-vertex tee's setup).
      if (dw < m_seam_distance[w] && dw <= options.seam_radius) {
        m_seam_distance[w] = dw;
        m_seam_limb[w] = m_seam_limb[static_cast<std::size_t>(v)];
        queue.emplace(dw, static_cast<std::int32_t>(w));
      }
    }
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (m_seam_distance[v] > options.seam_radius) m_handles.push_back(static_cast<std::int32_t>(v));

  m_band = std::make_unique<Band>();
  m_setup_ms = ms_since(t0);
}

double SkeletonDriver::build_band() const {
  double ms = 0;
  std::call_once(m_band->built, [&] {
    // Isolated: while its pieces are factored in parallel, this thread must not pick up another
    // drive() of the same driver, which would wait on this once_flag.
    tbb::this_task_arena::isolate([&] {
      const auto t0 = Clock::now();
      m_band->deformer = std::make_unique<BandLaplacianDeformer>(m_garment, m_handles, false, m_options.band_solver);
      if (m_band->deformer->ok()) m_band->rest_delta = m_band->deformer->laplacian_coordinates(m_garment.positions);
      ms = ms_since(t0);
    });
  });
  return ms;
}

SkeletonDriver::~SkeletonDriver() = default;
SkeletonDriver::SkeletonDriver(SkeletonDriver&&) noexcept = default;
SkeletonDriver& SkeletonDriver::operator=(SkeletonDriver&&) noexcept = default;

void SkeletonDriver::orient(const JointPositions& body_joints, const ProximityIndex* body_surface, SkeletonDriving& out,
                            Eigen::Matrix3d& R, Eigen::Vector3d& t) const {
  const auto t0 = Clock::now();
  const std::size_t nv = m_garment.vertex_count();
  const std::span<const float> x = m_garment.positions;
  auto joint = [&](Joint j) { return Eigen::Vector3d(body_joints.row(idx(j)).transpose()); };
  // Orientation (eq. 5–7): R_h turns the garment's horizontal (J2 − J1) onto the body's, then
  // R_v, about the body's horizontal, turns the garment's vertical (+Y, an upright garment)
  // onto the body's trunk (pelvis → neck), both made normal to that horizontal. The collar or
  // waistband is too close to J1, J2 to give a vertical within a few degrees.
  const GarmentKeyJoints& g = m_key_joints;
  const Eigen::Vector3d h1 = joint(g.legs ? Joint::RIGHT_HIP : Joint::RIGHT_SHOULDER);
  const Eigen::Vector3d h2 = joint(g.legs ? Joint::LEFT_HIP : Joint::LEFT_SHOULDER);
  const Eigen::Vector3d vh_body = h2 - h1;
  const Eigen::Matrix3d Rh = rotation_between(g.j2 - g.j1, vh_body);
  const Eigen::Vector3d axis = vh_body.normalized();
  auto normal_part = [&](const Eigen::Vector3d& v) { return Eigen::Vector3d(v - v.dot(axis) * axis); };
  const Eigen::Vector3d vv_cloth = normal_part(Rh * Eigen::Vector3d::UnitY());
  const Eigen::Vector3d vv_body = normal_part(joint(Joint::NECK) - joint(Joint::PELVIS));
  R = rotation_between(vv_cloth, vv_body) * Rh;
  // Eq. 16–17: the key joints' midpoints coincide.
  t = 0.5 * (h1 + h2) - R * (0.5 * (g.j1 + g.j2));
  if (body_surface && g.legs) {
    const Eigen::Vector3d up = (joint(Joint::NECK) - joint(Joint::PELVIS)).normalized();
    const double thigh = 0.5 * ((joint(Joint::LEFT_KNEE) - h2).norm() + (joint(Joint::RIGHT_KNEE) - h1).norm());
    if (const auto crotch = body_crotch(*body_surface, 0.5 * (h1 + h2), up, thigh))
      t += up * (*crotch - (R * g.crotch + t)).dot(up);
  }
  if (body_surface) {
    // The key joints are estimates from the garment's cut; its torso says how it sat on its
    // body: its closest approach to the body level all round (contact_translation()). All of
    // the torso counts, the band along the seams included: a pair of trousers has little torso
    // farther than seam_radius from its legs, and the hips and shoulders it rests on lie there.
    std::vector<float> torso;
    for (std::size_t v = 0; v < nv; ++v)
      if (m_vertex_limb[v] < 0) {
        const Eigen::Vector3d p = R * point(x, v) + t;
        torso.insert(torso.end(), {float(p.x()), float(p.y()), float(p.z())});
      }
    out.contact_translation = contact_translation(torso, *body_surface);
    t += out.contact_translation;
    if (g.legs) {
      // Trousers sit in a pocket of the body along the trunk, the hips widening below their
      // waistband and the crotch above their crotch seam: the height with the most clearance
      // is where they were made to sit (contact_translation()'s level envelope is not: the
      // closest approach of MakeHuman jeans is not level along the trunk, and levelling it
      // lifted them 14 mm). Measured from the contact placement, so the trunk's cross-section
      // keeps its horizontal fit.
      const Eigen::Vector3d up = (joint(Joint::NECK) - joint(Joint::PELVIS)).normalized();
      for (std::size_t i = 0; i < torso.size(); i += 3)
        for (int c = 0; c < 3; ++c)
          torso[i + static_cast<std::size_t>(c)] += static_cast<float>(out.contact_translation[c]);
      const double lift = pocket_offset(torso, *body_surface, up);
      out.pocket_offset = lift;
      t += lift * up;
    }
  }
  out.torso_rotation = R;
  out.torso_translation = t;
  out.timings.orientation_ms = ms_since(t0);
}

SkeletonDriving SkeletonDriver::drive(const JointPositions& body_joints, const ProximityIndex* body_surface) const {
  SkeletonDriving out;
  const auto start = Clock::now();
  const std::size_t nv = m_garment.vertex_count();
  const std::span<const float> x = m_garment.positions;
  auto joint = [&](Joint j) { return Eigen::Vector3d(body_joints.row(idx(j)).transpose()); };
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  // The band's factorisation (first call only) beside the orientation, which does not need it.
  tbb::parallel_invoke([&] { out.timings.factorisation_ms = build_band(); },
                       [&] { orient(body_joints, body_surface, out, R, t); });
  if (!m_band->deformer->ok())
    throw Error("skeleton driving", 0,
                "the Laplacian system is singular: a piece of the garment lies entirely within " +
                    std::to_string(m_options.seam_radius) + " m of a seam, so it has no handle");

  const GarmentKeyJoints& g = m_key_joints;

  // Skeleton driving (eq. 8–11) and node rotations (eq. 13–15). With a body surface, limbs are
  // measured from the body's joints; with joints alone, from the garment's own key joints.
  const bool refined = body_surface != nullptr;
  const auto t1 = Clock::now();
  std::vector<std::vector<Eigen::Vector3d>> moved(m_skeletons.size());
  std::vector<std::vector<double>> along_axis;
  std::vector<Eigen::Vector3d> axes;
  std::vector<std::vector<Eigen::Vector3d>> node_feet;
  for (std::size_t i = 0; i < m_skeletons.size(); ++i) {
    const PartSkeleton& s = m_skeletons[i];
    std::vector<Eigen::Vector3d>& l = moved[i];
    for (const Eigen::Vector3d& p : s.nodes)
      l.push_back(R * p + t);
    const std::array<Joint, 3> jb = limb_bones(s.part);
    const std::array<Eigen::Vector3d, 3> bones{joint(jb[0]), joint(jb[1]), joint(jb[2])};
    const bool left = s.part == GarmentPart::LEFT_SLEEVE || s.part == GarmentPart::LEFT_LEG;
    const Eigen::Vector3d axis_g = R * (left ? g.left_axis : g.right_axis);
    const std::array<Eigen::Vector3d, 2> bone_dir{(bones[1] - bones[0]).normalized(),
                                                  (bones[2] - bones[1]).normalized()};
    const double upper_length = (bones[1] - bones[0]).norm();
    // Each node's distance from the body's joint along the limb's axis, the torso placed: the
    // part covers the stretch of the limb it covered on its own body (eq. 9–11, with l_1's
    // offset the first node's projection onto the limb's line; nodes inboard of the joint
    // stay on that line, before the joint). Measured from the garment's own key joint
    // instead, a shoulder or hip estimated a few centimetres off would slide the whole sleeve
    // or leg along the limb by as much.
    std::vector<double> along(l.size());
    for (std::size_t k = 0; k < l.size(); ++k)
      along[k] = (l[k] - bones[0]).dot(axis_g);
    if (!refined) {
      // Joints alone: eq. 8–11 as the paper has it, each node at its distance from the
      // garment's own key joint along the limb's axis, on the bones, turned by the bones.
      const Eigen::Vector3d own = R * (left ? g.j2 : g.j1) + t;
      DrivenLimb limb;
      limb.part = s.part;
      limb.segment.assign(l.size(), 0);
      std::vector<Eigen::Vector3d> feet;
      for (std::size_t k = 0; k < l.size(); ++k) {
        along[k] = std::max(0.0, (l[k] - own).dot(axis_g));
        limb.targets.push_back(point_at_arc_length(bones, along[k], limb.segment[k]));
        feet.push_back(own + along[k] * axis_g);
      }
      const Eigen::Matrix3d upper = rotation_between(axis_g, bones[1] - bones[0]);
      const Eigen::Matrix3d lower = rotation_between(bones[1] - bones[0], bones[2] - bones[1]) * upper;
      for (std::size_t k = 0; k < l.size(); ++k)
        limb.rotations.push_back(limb.segment[k] == 0 ? upper : lower);
      along_axis.push_back(std::move(along));
      axes.push_back(axis_g);
      node_feet.push_back(std::move(feet));
      out.limbs.push_back(std::move(limb));
      continue;
    }
    // A limb reaching past the elbow or knee has its upper part's own axis: the direction of
    // its nodes between the joint and the upper limb's length. The key joints' axis (a long
    // sleeve's boundary plane joins ring centres half way and 85 % of the way from the cuff
    // to the armpit) mixes in the forearm's bend: 20-27 degrees on the MakeHuman long sleeves,
    // which turned the whole sleeve, and the torso's band along its seam, by as much.
    // Sleeves only: a leg's axis is already its skeleton's (garment_key_joints()), and on the
    // catalogue's trousers the thigh's nodes alone tilted the legs by centimetres at the knee.
    // A sleeve's skeleton curls into the armhole over its first quarter (the sleeve cap, whose
    // cross-sections are slanted), so its nodes count from there.
    const bool sleeve = s.part == GarmentPart::LEFT_SLEEVE || s.part == GarmentPart::RIGHT_SLEEVE;
    const Eigen::Vector3d axis_u = sleeve ? upper_direction(l, along, upper_length, 0.25, axis_g) : axis_g;
    for (std::size_t k = 0; k < l.size(); ++k)
      along[k] = (l[k] - bones[0]).dot(axis_u);
    // The garment's own bend: the direction of its nodes past the upper limb's length.
    const Eigen::Vector3d lower_g = lower_direction(l, along, upper_length, axis_u);
    const Eigen::Vector3d elbow_g = bones[0] + upper_length * axis_u;
    const Eigen::Vector3d elbow_b = bones[0] + upper_length * bone_dir[0];
    // Twist-free frames (eq. 13–15): the limb's axis turned onto the upper limb, and its
    // lower part further onto the lower limb.
    const Eigen::Matrix3d upper = rotation_between(axis_u, bone_dir[0]);
    const Eigen::Matrix3d lower = rotation_between(upper * lower_g, bone_dir[1]) * upper;
    DrivenLimb limb;
    limb.part = s.part;
    std::vector<Eigen::Vector3d> feet;
    for (std::size_t k = 0; k < l.size(); ++k) {
      const bool on_upper = along[k] <= upper_length;
      if (!on_upper) along[k] = upper_length + (l[k] - elbow_g).dot(lower_g);
      const double past = along[k] - upper_length;
      limb.segment.push_back(on_upper ? 0 : 1);
      limb.targets.push_back(on_upper ? Eigen::Vector3d(bones[0] + along[k] * bone_dir[0])
                                      : Eigen::Vector3d(elbow_b + past * bone_dir[1]));
      limb.rotations.push_back(on_upper ? upper : lower);
      feet.push_back(on_upper ? Eigen::Vector3d(bones[0] + along[k] * axis_u)
                              : Eigen::Vector3d(elbow_g + past * lower_g));
    }
    along_axis.push_back(std::move(along));
    axes.push_back(axis_u);
    node_feet.push_back(std::move(feet));
    out.limbs.push_back(std::move(limb));
  }

  // Per-vertex rigid transforms: the torso's, or its node's T2·Q'·T1 (blended with the nearer
  // neighbour node by the vertex's position along the chain).
  std::vector<Eigen::Matrix3d> rotation(nv, R);
  Eigen::MatrixXd rigid(static_cast<Eigen::Index>(nv), 3);
  for (std::size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3d xv = R * point(x, v) + t;
    const std::int32_t li = m_vertex_limb[v];
    if (li < 0) {
      rigid.row(static_cast<Eigen::Index>(v)) = xv.transpose();
      continue;
    }
    const std::vector<Eigen::Vector3d>& l = moved[static_cast<std::size_t>(li)];
    const DrivenLimb& limb = out.limbs[static_cast<std::size_t>(li)];
    const auto k = static_cast<std::size_t>(m_vertex_node[v]);
    auto apply = [&](std::size_t n) {
      // T2·Q'·T1 of eq. 13–15 about the node's foot on the limb's axis rather than the node
      // itself: the node keeps its offset from the axis, so a skeleton that wobbles about the
      // axis (short, wide sleeves) shears nothing.
      return Eigen::Vector3d(limb.targets[n] + limb.rotations[n] * (xv - node_feet[static_cast<std::size_t>(li)][n]));
    };
    Eigen::Vector3d p = apply(k);
    Eigen::Matrix3d Q = limb.rotations[k] * R;
    if (m_options.blend_nodes && l.size() > 1) {
      // Position along the axis relative to the neighbour node on that side; half way to it
      // both transforms weigh the same, so the blend is continuous across the boundary between
      // the two nodes' vertex sets.
      const std::vector<double>& s_k = along_axis[static_cast<std::size_t>(li)];
      const double u = (xv - l[k]).dot(axes[static_cast<std::size_t>(li)]);
      const std::size_t j = u >= 0 ? std::min(k + 1, l.size() - 1) : (k > 0 ? k - 1 : 0);
      const double gap = std::abs(s_k[j] - s_k[k]);
      if (j != k && gap > 1e-9) {
        const double w = std::min(0.5, std::abs(u) / gap);
        p = (1 - w) * p + w * apply(j);
        Q = slerp(Q, limb.rotations[j] * R, w);
      }
    }
    rigid.row(static_cast<Eigen::Index>(v)) = p.transpose();
    rotation[v] = Q;
  }
  out.timings.driving_ms = ms_since(t1);

  // Laplacian surface deformation: handles at their rigid positions, the rest's differential
  // coordinates turned by each vertex's rotation; near a seam the rotation fades from the
  // limb's to the torso's over seam_radius on both sides.
  const auto t2 = Clock::now();
  const BandLaplacianDeformer& deformer = *m_band->deformer;
  const Eigen::MatrixXd& rest_delta = m_band->rest_delta;
  Eigen::MatrixXd delta(rest_delta.rows(), 3);
  const double r = m_options.seam_radius;
  for (std::size_t v = 0; v < nv; ++v) {
    Eigen::Matrix3d Q = rotation[v];
    if (m_seam_distance[v] < r) {
      if (m_vertex_limb[v] >= 0)
        Q = slerp(R, Q, 0.5 + 0.5 * m_seam_distance[v] / r);
      else if (m_seam_limb[v] >= 0)
        Q = slerp(R, out.limbs[static_cast<std::size_t>(m_seam_limb[v])].rotations.front() * R,
                  0.5 - 0.5 * m_seam_distance[v] / r);
    }
    delta.row(static_cast<Eigen::Index>(v)) =
        (Q * rest_delta.row(static_cast<Eigen::Index>(v)).transpose()).transpose();
  }
  Eigen::MatrixXd targets(static_cast<Eigen::Index>(m_handles.size()), 3);
  for (std::size_t c = 0; c < m_handles.size(); ++c)
    targets.row(static_cast<Eigen::Index>(c)) = rigid.row(m_handles[c]);
  // An iterative solve of a large band starts from the torso's and the limb's rigid
  // placements blended smoothly across it (blended_guess()): the rigid positions themselves
  // step at the seam, and a step is slow to smooth out.
  Eigen::MatrixXd guess;
  if (deformer.iterative()) guess = blended_guess(rigid, R, t, out.limbs, node_feet);
  out.positions = deformer.deform(delta, targets, deformer.iterative() ? &guess : nullptr, &out.laplacian_solve);
  out.timings.laplacian_ms = ms_since(t2);
  out.timings.total_ms = ms_since(start);
  return out;
}

Eigen::MatrixXd SkeletonDriver::blended_guess(const Eigen::MatrixXd& rigid, const Eigen::Matrix3d& R,
                                              const Eigen::Vector3d& t, const std::vector<DrivenLimb>& limbs,
                                              const std::vector<std::vector<Eigen::Vector3d>>& node_feet) const {
  Eigen::MatrixXd guess = rigid;
  const std::span<const float> x = m_garment.positions;
  const double r = m_options.seam_radius;
  for (std::size_t v = 0; v < m_garment.vertex_count(); ++v) {
    const std::int32_t li = m_seam_limb[v];
    if (m_seam_distance[v] >= r || li < 0) continue;
    // Signed distance across the seam (limb side positive) mapped to a smoothstep weight: 0 at
    // the band's torso edge, 1/2 on the seam, 1 at its limb edge, where the guess meets the
    // handles' rigid positions.
    const bool on_limb = m_vertex_limb[v] >= 0;
    const double u = 0.5 + 0.5 * (on_limb ? m_seam_distance[v] : -m_seam_distance[v]) / r;
    const double w = u * u * (3 - 2 * u);
    const Eigen::Vector3d xv = R * point(x, v) + t;
    const DrivenLimb& limb = limbs[static_cast<std::size_t>(li)];
    const Eigen::Vector3d limb_side =
        on_limb ? Eigen::Vector3d(rigid.row(static_cast<Eigen::Index>(v)).transpose())
                : Eigen::Vector3d(limb.targets.front() +
                                  limb.rotations.front() * (xv - node_feet[static_cast<std::size_t>(li)].front()));
    guess.row(static_cast<Eigen::Index>(v)) = ((1 - w) * xv + w * limb_side).transpose();
  }
  return guess;
}

SkeletonDriving drive_garment(const Mesh& garment, const GarmentSegmentation& segmentation,
                              std::span<const PartSkeleton> skeletons, const JointPositions& body_joints,
                              const SkeletonDrivingOptions& options, const ProximityIndex* body_surface) {
  const SkeletonDriver driver(garment, segmentation, skeletons, options);
  SkeletonDriving out = driver.drive(body_joints, body_surface);
  out.timings.setup_ms = driver.setup_ms();
  out.timings.total_ms += driver.setup_ms();
  return out;
}

} // namespace vfit
