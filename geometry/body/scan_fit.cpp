// SPDX-License-Identifier: Apache-2.0
#include "scan_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numbers>
#include <optional>
#include <tuple>

#include <tbb/task_group.h>

#include "gltf_body.h"
#include "joint_estimation.h"
#include "mannequin.h"
#include "scan_fit_solve.h"
#include "scan_pose_search.h"
#include "scan_skin_transfer.h"
#include "scan_unpose.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

// The 95th-percentile scan-to-template distance (m) past which the fit is reported as poor.
// Measured: the 27 corpus poses of hm08_body 29–34 mm (its shape is not the
// template's), 20 random poses of the survey 30–33 mm, the mannequin's presets as walking scans
// 11–31 mm; a kneeling hm08 (both knees at 90°) 279 mm.
constexpr double POOR_FIT_P95 = 0.06;

using namespace scan_detail;
using Clock = std::chrono::steady_clock;
constexpr std::size_t WEIGHT_GRAIN = 512; // scan vertices per TBB task when interpolating weights

// A stage's start: wall clock and the process's CPU clock (all its threads).
struct StageClock {
  Clock::time_point wall = Clock::now();
  std::clock_t cpu = std::clock();
};
double elapsed_ms(const StageClock& t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0.wall).count();
}
double cpu_ms(const StageClock& t0) { return 1000.0 * static_cast<double>(std::clock() - t0.cpu) / CLOCKS_PER_SEC; }

Vec3 face_normal(std::span<const float> positions, std::span<const std::int32_t> triangles, std::int32_t f) {
  auto P = [&](int k) {
    const std::int32_t v = triangles[3 * static_cast<std::size_t>(f) + k];
    return Vec3(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
  };
  const Vec3 n = (P(1) - P(0)).cross(P(2) - P(0));
  return n.norm() > 0 ? Vec3(n.normalized()) : Vec3::UnitY();
}

// Blends the ≤ 12 influences of three corners into the 4 largest, renormalised.
void blend_influences(const SkinWeights& w, const std::array<std::int32_t, 3>& corners,
                      const std::array<double, 3>& bary, std::array<int, 4>& joint, std::array<double, 4>& weight) {
  largest_blended_influences(w, corners, bary, joint, weight);
  const double sum = weight[0] + weight[1] + weight[2] + weight[3];
  for (double& x : weight)
    x = sum > 0 ? x / sum : 0;
  if (sum <= 0) weight[0] = 1;
}

std::array<double, 3> barycentric(const ClosestHits& h, std::size_t i) {
  const double u = h.barycentrics[2 * i], v = h.barycentrics[2 * i + 1];
  return {1 - u - v, u, v};
}
std::array<std::int32_t, 3> corners(std::span<const std::int32_t> triangles, std::int32_t f) {
  const auto b = 3 * static_cast<std::size_t>(f);
  return {triangles[b], triangles[b + 1], triangles[b + 2]};
}

struct Distances {
  double mean = 0, p95 = 0;
};
Distances distance_stats(const ClosestHits& hits) {
  std::vector<double> d;
  d.reserve(hits.size());
  for (std::size_t i = 0; i < hits.size(); ++i)
    if (hits.triangles[i] >= 0) d.push_back(std::abs(hits.signed_distances[i]));
  if (d.empty()) return {};
  Distances s;
  for (double x : d)
    s.mean += x;
  s.mean /= static_cast<double>(d.size());
  const auto k = static_cast<std::size_t>(0.95 * static_cast<double>(d.size() - 1));
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
  s.p95 = d[k];
  return s;
}

// The template of the fit: rest vertices at the average shape, its weights and faces.
struct Fitter {
  const Body& tmpl;
  ShapeModel model;
  std::vector<Vec3> rest; // template rest vertices
  std::span<const float> scan;
  std::span<const std::int32_t> scan_faces;
  std::optional<ProximityIndex> scan_index;
  std::vector<Vec3> scan_normals;
  std::optional<ProximityIndex> tmpl_index;
  std::vector<float> posed;

  // The template posed by `s` (eq. 3), and its proximity index refitted.
  void pose_template(const State& s) {
    const JointPositions dJ = model.displacement(s.shape.data());
    const double scale = std::exp(s.shape[0]);
    std::vector<float> shaped(3 * rest.size());
    for (std::size_t v = 0; v < rest.size(); ++v) {
      Vec3 p = rest[v];
      for (int k = 0; k < 4; ++k)
        p += tmpl.weights.weights[4 * v + k] * dJ.row(tmpl.weights.joints[4 * v + k]).transpose();
      for (int a = 0; a < 3; ++a)
        shaped[3 * v + a] = static_cast<float>(scale * p[a]);
    }
    linear_blend_skinning(shaped, tmpl.weights, skinning_transforms(scale * (model.mean + dJ), pose_of(s)), posed);
    if (tmpl_index)
      tmpl_index->refit(posed);
    else
      tmpl_index.emplace(posed, tmpl.mesh.triangles);
  }

  Distances scan_distances() const {
    ClosestHits hits;
    tmpl_index->closest_points(scan, std::numeric_limits<float>::infinity(), hits);
    return distance_stats(hits);
  }

  // Correspondences of one ICP round, both directions, each direction's weights summing to 1.
  std::vector<Pair> pairs(const std::vector<std::size_t>& scan_samples, const std::vector<std::size_t>& tmpl_samples,
                          double reject) const {
    const auto& faces = tmpl.mesh.triangles;
    std::vector<Pair> out;
    std::vector<double> dist;
    const std::vector<Vec3> tmpl_normals = area_weighted_vertex_normals(posed, faces);
    // Scan point → closest template point.
    std::vector<float> q(3 * scan_samples.size());
    for (std::size_t i = 0; i < scan_samples.size(); ++i)
      for (int a = 0; a < 3; ++a)
        q[3 * i + a] = scan[3 * scan_samples[i] + a];
    ClosestHits hits;
    tmpl_index->closest_points(q, static_cast<float>(reject), hits);
    const std::size_t first_back = [&] {
      for (std::size_t i = 0; i < scan_samples.size(); ++i) {
        if (hits.triangles[i] < 0) continue;
        const Vec3 n = face_normal(posed, faces, hits.triangles[i]);
        if (!scan_normals.empty() && scan_normals[scan_samples[i]].dot(n) < 0) continue; // opposite sides
        Pair p;
        const auto c = corners(faces, hits.triangles[i]);
        const auto b = barycentric(hits, i);
        p.rest = b[0] * rest[c[0]] + b[1] * rest[c[1]] + b[2] * rest[c[2]];
        blend_influences(tmpl.weights, c, b, p.joint, p.weight);
        p.target = Vec3(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
        p.normal = n;
        p.tangential = 0.2;
        out.push_back(p);
        dist.push_back(std::abs(hits.signed_distances[i]));
      }
      return out.size();
    }();
    // Template vertex → closest scan point (meshes only: a point cloud has no surface to project on).
    if (scan_index) {
      q.assign(3 * tmpl_samples.size(), 0.f);
      for (std::size_t i = 0; i < tmpl_samples.size(); ++i)
        for (int a = 0; a < 3; ++a)
          q[3 * i + a] = posed[3 * tmpl_samples[i] + a];
      scan_index->closest_points(q, static_cast<float>(reject), hits);
      for (std::size_t i = 0; i < tmpl_samples.size(); ++i) {
        if (hits.triangles[i] < 0) continue;
        const Vec3 n = face_normal(scan, scan_faces, hits.triangles[i]);
        if (tmpl_normals[tmpl_samples[i]].dot(n) < 0) continue;
        Pair p;
        const std::size_t v = tmpl_samples[i];
        p.rest = rest[v];
        for (int k = 0; k < 4; ++k) {
          p.joint[k] = tmpl.weights.joints[4 * v + k];
          p.weight[k] = tmpl.weights.weights[4 * v + k];
        }
        p.target = Vec3(hits.points[3 * i], hits.points[3 * i + 1], hits.points[3 * i + 2]);
        p.normal = n;
        p.tangential = 0.2;
        out.push_back(p);
        dist.push_back(std::abs(hits.signed_distances[i]));
      }
    }
    // Geman–McClure weights, iteratively reweighted: σ a little above the typical distance, so
    // that pairs well off the rest (a hand on a hip, a scan artefact) count for little.
    std::vector<double> sorted = dist;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double sigma = std::max(0.005, sorted.empty() ? 0.01 : 2.0 * sorted[sorted.size() / 2]);
    const double n_front = static_cast<double>(std::max<std::size_t>(first_back, 1));
    const double n_back = static_cast<double>(std::max<std::size_t>(out.size() - first_back, 1));
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double g = sigma * sigma / (sigma * sigma + dist[i] * dist[i]);
      out[i].sqrt_weight = g / std::sqrt(i < first_back ? n_front : n_back);
    }
    return out;
  }
};

// The centre (x, z) of a standing body: per axis, the median of three band centres, each the
// middle of the extent (between the 10th and 90th percentiles) of the vertices in a band of
// heights: 10–35 % (the legs alone: arms reach no lower than the crotch in A- or T-pose),
// 30–45 % (thighs and crotch) and 38–52 % (the hips, where hanging hands also are). Not a
// centroid or the median vertex: an unweighted centroid leans towards densely meshed heads and
// hands, and over two legs the median falls on one leg or the other (8 cm off the mid-plane on
// the corpus body standing straight). Each band alone fails some pose: the legs' band sits
// 22-26 cm behind the pelvis with a foot raised far behind (the scan test's survey, seeds 9 and
// 10), the hips' band 15-16 cm off where hands hang beside or in front of them (legs_apart,
// contrapposto), farther than the pose search's shifts reach (8 cm a sweep). Over the corpus
// scan test's 26 poses and 12 survey poses the median of the three is at most 11.2 cm (mean
// 3.5 cm) from the pelvis, the legs' band alone up to 25.7 cm (mean 6.2 cm).
Vec3 body_centre(std::span<const float> positions, double lo, double hi) {
  auto middle = [](std::vector<double>& a) {
    auto at = [&](double q) {
      const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(a.size() - 1));
      std::nth_element(a.begin(), a.begin() + k, a.end());
      return a[static_cast<std::size_t>(k)];
    };
    return 0.5 * (at(0.1) + at(0.9));
  };
  std::vector<double> cx, cz;
  for (const auto& [band_lo, band_hi] : {std::pair{0.10, 0.35}, std::pair{0.30, 0.45}, std::pair{0.38, 0.52}}) {
    std::vector<double> xs, zs;
    for (std::size_t v = 0; v < positions.size() / 3; ++v) {
      const double h = (positions[3 * v + 1] - lo) / (hi - lo);
      if (h < band_lo || h > band_hi) continue;
      xs.push_back(positions[3 * v]);
      zs.push_back(positions[3 * v + 2]);
    }
    if (xs.empty()) continue;
    cx.push_back(middle(xs));
    cz.push_back(middle(zs));
  }
  if (cx.empty()) return Vec3::Zero();
  auto median = [](std::vector<double> a) {
    std::sort(a.begin(), a.end());
    return a.size() % 2 == 1 ? a[a.size() / 2] : 0.5 * (a[a.size() / 2 - 1] + a[a.size() / 2]);
  };
  return {median(cx), 0, median(cz)};
}

void check_scan(const Mesh& scan, const std::string& source) {
  if (scan.vertex_count() < 100)
    throw Error(source, 0, "a scan needs at least 100 points, got " + std::to_string(scan.vertex_count()));
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t v = 0; v < scan.vertex_count(); ++v) {
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(scan.positions[3 * v + a]))
        throw Error(source, 0, "vertex " + std::to_string(v) + " has a non-finite coordinate");
    lo = std::min<double>(lo, scan.positions[3 * v + 1]);
    hi = std::max<double>(hi, scan.positions[3 * v + 1]);
  }
  if (hi - lo < 0.8 || hi - lo > 2.5)
    throw Error(source, 0,
                "the scan is " + std::to_string(hi - lo) + " m tall; expected a body in metres, Y up (0.8-2.5 m)");
}

} // namespace

const Body& scan_fit_template() {
  static const Body body = [] {
    MannequinOptions o;
    o.pose = RestPose::TPOSE;
    o.target_vertices = 3000;
    return make_mannequin(o);
  }();
  return body;
}

SkinWeights interpolate_skin_weights(const Mesh& mesh, const SkinWeights& weights, std::span<const float> points) {
  if (mesh.face_count() == 0) throw Error("skin weight interpolation", 0, "the source mesh has no faces");
  validate_skin_weights(weights, mesh.vertex_count(), "skin weight interpolation");
  const ProximityIndex index(mesh.positions, mesh.triangles);
  ClosestHits hits;
  index.closest_points(points, std::numeric_limits<float>::infinity(), hits);
  SkinWeights out;
  out.joints.assign(4 * hits.size(), 0);
  out.weights.assign(4 * hits.size(), 0.f);
  parallel_for_range(hits.size(), WEIGHT_GRAIN, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      std::array<int, 4> joint{};
      std::array<double, 4> weight{};
      blend_influences(weights, corners(mesh.triangles, hits.triangles[i]), barycentric(hits, i), joint, weight);
      for (int k = 0; k < 4; ++k) {
        out.joints[4 * i + k] = joint[k];
        out.weights[4 * i + k] = static_cast<float>(weight[k]);
      }
    }
  });
  return out;
}

Pose relative_pose(const JointPositions& rest, const Pose& from, const Pose& to, const JointPositions& rigged_joints) {
  const auto G1 = joint_world_transforms(rest, from);
  const auto G2 = joint_world_transforms(rest, to);
  std::array<Eigen::Matrix3d, JOINT_COUNT> W;
  Pose out;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const auto u = static_cast<std::size_t>(j);
    W[u] = G2[u].linear() * G1[u].linear().transpose();
    const Eigen::Matrix3d local =
        j == 0 ? W[0] : Eigen::Matrix3d(W[static_cast<std::size_t>(joint_parent(j))].transpose() * W[u]);
    out.axis_angle.row(j) = matrix_to_axis_angle(local).transpose();
  }
  // The rigged root maps x to W₀ (x − J′₀) + J′₀ + t; the skeleton's pelvis-attached points
  // go to W₀ (x − G1₀.t) + G2₀.t. Equal for every x when:
  const Vec3 J0 = rigged_joints.row(0).transpose();
  out.translation = G2[0].translation() - W[0] * G1[0].translation() - J0 + W[0] * J0;
  return out;
}

ScanFit fit_scan(const Mesh& scan, const std::string& source, const ScanFitOptions& options) {
  const StageClock t_start;
  check_scan(scan, source);
  ScanFit fit;
  // Stage 0: the template (a meshed mannequin, about a second) and the shape basis (uncalibrated
  // mannequins, milliseconds), each built on first use (nothing afterwards), side by side.
  StageClock t0;
  {
    tbb::task_group builds;
    builds.run([] { scan_fit_template(); });
    mannequin_keypoint_model();
    builds.wait();
  }
  fit.stages.push_back({"template", 0, 0, elapsed_ms(t0), 0, 0, {}, cpu_ms(t0)});
  Fitter f{scan_fit_template(), {}, {}, scan.positions, scan.triangles, {}, {}, {}, {}};
  f.model.mean = f.tmpl.joints;
  const KeypointBodyModel& kp = mannequin_keypoint_model();
  for (int k = 0; k < 3; ++k)
    f.model.basis[static_cast<std::size_t>(k)] = kp.basis[static_cast<std::size_t>(k + 1)].topRows<JOINT_COUNT>();
  // The elbow shift: each elbow toward its shoulder along the T-pose's arm (the forearm's
  // vertices follow by their weights).
  for (Joint j : {Joint::LEFT_ELBOW, Joint::RIGHT_ELBOW}) {
    const Vec3 arm = f.model.mean.row(idx(j)).transpose() - f.model.mean.row(joint_parent(idx(j))).transpose();
    f.model.elbows.row(idx(j)) = -ELBOW_STEP * arm.normalized().transpose();
  }
  for (std::size_t v = 0; v < f.tmpl.mesh.vertex_count(); ++v)
    f.rest.emplace_back(f.tmpl.mesh.positions[3 * v], f.tmpl.mesh.positions[3 * v + 1],
                        f.tmpl.mesh.positions[3 * v + 2]);
  if (scan.face_count() > 0) {
    f.scan_index.emplace(scan.positions, scan.triangles);
    f.scan_normals = area_weighted_vertex_normals(scan.positions, scan.triangles);
  }

  // Stage 1: the skeleton fitted to the joints estimated on the scan; else the T-pose placed
  // on the scan's feet at its height.
  t0 = StageClock{};
  // Closes a stage that moved the template: its distances to the scan, then its wall time.
  auto finish_stage = [&](ScanFitStage stage, const State& state) {
    const Distances d = f.scan_distances();
    stage.joints = posed_joints(rest_joints_of(f.model, state.shape.data()), pose_of(state));
    stage.ms = elapsed_ms(t0);
    stage.cpu_ms = cpu_ms(t0);
    stage.mean_distance = d.mean;
    stage.p95_distance = d.p95;
    fit.stages.push_back(stage);
    return d;
  };
  ScanFitStage init{"init", 0, 0, 0, 0, 0, {}};
  State s;
  double lo = INFINITY, hi = -INFINITY, tmpl_lo = INFINITY, tmpl_hi = -INFINITY;
  Vec3 centre = Vec3::Zero();
  for (std::size_t v = 0; v < scan.vertex_count(); ++v) {
    lo = std::min<double>(lo, scan.positions[3 * v + 1]);
    hi = std::max<double>(hi, scan.positions[3 * v + 1]);
  }
  Vec3 tmpl_centre = Vec3::Zero();
  for (const Vec3& p : f.rest) {
    tmpl_lo = std::min(tmpl_lo, p.y());
    tmpl_hi = std::max(tmpl_hi, p.y());
  }
  centre = body_centre(scan.positions, lo, hi);
  {
    std::vector<float> rest_flat;
    for (const Vec3& p : f.rest)
      for (int a = 0; a < 3; ++a)
        rest_flat.push_back(static_cast<float>(p[a]));
    tmpl_centre = body_centre(rest_flat, tmpl_lo, tmpl_hi);
  }
  s.shape[0] = std::clamp(std::log((hi - lo) / (tmpl_hi - tmpl_lo)), -LOG_SCALE_LIMIT, LOG_SCALE_LIMIT);
  std::optional<JointEstimate> estimate;
  try {
    estimate = estimate_joints(scan);
  } catch (const Error& e) {
    fit.warnings.push_back(std::string("joint estimation failed on the scan, starting from the A-pose: ") + e.what());
  }
  const double s0 = std::exp(s.shape[0]);
  if (estimate) {
    fit.initialised_from_joints = true;
    const Vec3 t = estimate->joints.row(0).transpose() - s0 * f.model.mean.row(0).transpose();
    s.trans = {t.x(), t.y(), t.z()};
    std::vector<Pair> joints(JOINT_COUNT);
    for (int j = 0; j < JOINT_COUNT; ++j) {
      Pair& p = joints[static_cast<std::size_t>(j)];
      p.rest = f.model.mean.row(j).transpose();
      p.joint = {j, 0, 0, 0};
      p.weight = {1, 0, 0, 0};
      p.target = estimate->joints.row(j).transpose();
      p.normal = Vec3::UnitY();
      p.tangential = 1;
      p.sqrt_weight = estimate->confidence[static_cast<std::size_t>(j)] / std::sqrt(double(JOINT_COUNT));
    }
    init.iterations = solve(f.model, joints, s, 50, options.threads);
  } else {
    // The A-pose (arms 45° down), the pose scanners ask for, standing on the scan's floor.
    s.body[static_cast<std::size_t>(3 * (idx(Joint::LEFT_SHOULDER) - 1) + 2)] = -0.25 * std::numbers::pi;
    s.body[static_cast<std::size_t>(3 * (idx(Joint::RIGHT_SHOULDER) - 1) + 2)] = 0.25 * std::numbers::pi;
    const Vec3 t = Vec3(centre.x() - s0 * tmpl_centre.x(), lo - s0 * tmpl_lo, centre.z() - s0 * tmpl_centre.z());
    s.trans = {t.x(), t.y(), t.z()};
  }
  f.pose_template(s);
  finish_stage(init, s);

  // Stage 2: each part's orientation searched in turn (a walking or arms-raised scan is far
  // from any A- or T-pose start, and ICP only finds the nearest minimum).
  t0 = StageClock{};
  {
    const ScanPoseSearch found =
        search_scan_pose(f.tmpl, scan.positions, pose_of(s), s.shape[0], options.search, f.scan_normals);
    for (int a = 0; a < 3; ++a) {
      s.global[static_cast<std::size_t>(a)] = found.pose.axis_angle(0, a);
      s.trans[static_cast<std::size_t>(a)] = found.pose.translation[a];
    }
    for (int j = 1; j < JOINT_COUNT; ++j)
      for (int a = 0; a < 3; ++a)
        s.body[static_cast<std::size_t>(3 * (j - 1) + a)] = found.pose.axis_angle(j, a);
    s.shape[0] = std::clamp(found.log_scale, -LOG_SCALE_LIMIT, LOG_SCALE_LIMIT);
    f.pose_template(s);
    finish_stage({"search", 0, found.evaluations, 0, 0, 0, {}}, s);
  }

  // Stage 3: ICP rounds.
  t0 = StageClock{};
  ScanFitStage icp{"icp", 0, 0, 0, 0, 0, {}};
  const auto scan_samples = spread_indices(scan.vertex_count(), options.scan_samples);
  const auto tmpl_samples = spread_indices(f.rest.size(), options.template_samples);
  const int rounds = std::max(1, options.icp_rounds);
  for (int r = 0; r < rounds; ++r) {
    const double reject = options.reject_distance * (1.0 - 0.5 * r / std::max(1, rounds - 1));
    const std::vector<Pair> pairs = f.pairs(scan_samples, tmpl_samples, reject);
    if (pairs.size() < 50) {
      fit.warnings.push_back("ICP round " + std::to_string(r + 1) + ": only " + std::to_string(pairs.size()) +
                             " correspondences within " + std::to_string(reject) + " m; stopped");
      break;
    }
    icp.iterations += solve(f.model, pairs, s, std::max(1, options.iterations_per_round), options.threads);
    f.pose_template(s);
  }
  const Distances d_icp = finish_stage(icp, s);

  // Results.
  fit.pose = pose_of(s);
  fit.scale = std::exp(s.shape[0]);
  fit.shape = {0.0, s.shape[1], s.shape[2], s.shape[3]};
  fit.measurements = KeypointBodyModel::measurements(fit.shape);
  for (std::string_view n : BodyMeasurements::names())
    fit.measurements[n] *= fit.scale;
  fit.rest_joints = rest_joints_of(f.model, s.shape.data());
  fit.joints = posed_joints(fit.rest_joints, fit.pose);

  // Stage 4: the scan's skin weights from the posed template (seed 001 §5.2), side- and
  // part-aware (scan_skin_transfer.h): plain closest points hand an arm held against the torso
  // the torso's weights, and folded hands each other's, which unposing then tears apart.
  t0 = StageClock{};
  Mesh posed_template = f.tmpl.mesh;
  posed_template.positions = f.posed;
  fit.rigged.mesh = scan;
  fit.rigged.joints = fit.joints;
  fit.rigged.weights = transfer_skin_weights(posed_template, f.tmpl.weights, scan);
  fit.rigged.rest_pose = classify_rest_pose(fit.joints);
  fit.rigged.source = source;
  fit.stages.push_back({"weights", 0, 0, elapsed_ms(t0), d_icp.mean, d_icp.p95, {}, cpu_ms(t0)});

  // Stage 5: the joints. The template's joints follow the mannequin's conventions, which put a
  // joint a few cm from where rigs put it inside another body's surface (collars, head, elbows);
  // estimate_joints() is calibrated on real rigs but needs an A- or T-pose. So the scan is
  // unposed into the fitted template's A-pose by inverting each vertex's blended skinning
  // transform (inverse LBS with the interpolated weights), its joints estimated there, and each
  // carried back by the mean of the skinning transforms of the two bones that meet there (its
  // parent's, which ends at the joint, and its own), as the skin at a joint is weighted half to
  // each. With the parent's alone, the template's compensations (a neck pitched forward to fit a
  // head that sits further forward than the mannequin's, an upper arm turned to fit a bend) moved
  // the joint with them: over 20 corpus poses the mean of the two lowered the mean joint error in
  // 9 poses (by up to 0.14 cm) and raised it in one, and took 3 joints under 3 cm.
  t0 = StageClock{};
  if (scan.face_count() > 0) {
    // Unposed into an A-pose rather than the T-pose: raised hands' fingers can top the head.
    // `drop`: the upper arms' angle below horizontal (rad). A[k]: bone k's skinning transform
    // from that pose into the scan.
    // Only the limbs and the spine are unposed: the collars, the neck and the head (and, below, the
    // ankles and feet) keep their
    // fitted rotations (each upper arm is turned so that it still points `drop` below
    // horizontal). Those rotations are mostly the template making up for a shape it cannot take
    // (the corpus body's rest pose itself fits with collars turned 16-20° and the neck pitched
    // 9° forward, the head 8° back), and undoing them with the template's weights, which share
    // the shoulder girdle and the neck with their neighbours differently from the scan's own
    // rig, bent the unposed scan's shoulders and neck out of shape; the estimator reads collars,
    // neck and head in whatever modest turn they come. Over the 20 corpus poses: head 1.5-2.9 ->
    // 0.4-1.2 cm, mean joint error 1.33 -> 1.18 cm, joints past 2.5 cm 20 -> 6, past 3 cm 7 -> 2,
    // mean re-posing error 5.3 -> 4.5 mm (worst 11.1 -> 9.9 mm).
    // The ankles and feet keep theirs too, for the same reason: the scan's feet were never turned
    // at the ankle, yet the fit pitched the template's 13-24° toes down to make up for its thighs
    // and shanks, and undoing that tipped the unposed feet up, so the estimator measured the ball
    // of the foot short of the toes. Over 12 random poses (corpus scan test's random_pose(), seeds
    // 9-11): worst foot 5.2, 6.7 and 9.6 cm -> 2.4, 2.9 and 5.4 cm (the last now estimated on the
    // unposed scan, which its tipped foot had failed); the other 9 poses and 12 more held out
    // (seeds 12-14) stay under 3 cm; the corpus test's 20 poses' worst foot or ankle 1.3-2.6 ->
    // 0.7-1.4 cm.
    std::array<Eigen::Isometry3d, JOINT_COUNT> A;
    auto unpose = [&](const SkinWeights& w, double drop) {
      Pose apose;
      for (Joint j : {Joint::NECK, Joint::HEAD, Joint::LEFT_COLLAR, Joint::RIGHT_COLLAR, Joint::LEFT_ANKLE,
                      Joint::RIGHT_ANKLE, Joint::LEFT_FOOT, Joint::RIGHT_FOOT})
        apose.axis_angle.row(idx(j)) = fit.pose.axis_angle.row(idx(j));
      for (const auto& [collar, shoulder, sign] : {std::tuple{Joint::LEFT_COLLAR, Joint::LEFT_SHOULDER, -1.0},
                                                   std::tuple{Joint::RIGHT_COLLAR, Joint::RIGHT_SHOULDER, 1.0}}) {
        const Eigen::Matrix3d girdle = axis_angle_to_matrix(fit.pose.axis_angle.row(idx(collar)).transpose());
        const Eigen::Matrix3d arm = axis_angle_to_matrix(Vec3(0, 0, sign * drop));
        apose.axis_angle.row(idx(shoulder)) =
            matrix_to_axis_angle(Eigen::Matrix3d(girdle.transpose() * arm)).transpose();
      }
      A = skinning_transforms(fit.rest_joints, fit.pose);
      const auto B = skinning_transforms(fit.rest_joints, apose);
      for (std::size_t k = 0; k < A.size(); ++k)
        A[k] = A[k] * B[k].inverse();
      return unpose_scan(scan, w, A);
    };
    // With the rigged scan's weights into the A-pose scanners ask for (45°); where the estimator
    // rejects that unposed scan, with the arms 30° below horizontal (still an A-pose to the
    // estimator): an arm whose skin the weights leave a little short of straight, or that was
    // folded against the belly, can touch the torso at 45° and stand clear at 30°; then both
    // again with plain closest-point weights, which drag a limb the fit left far off along with
    // the part it lies against instead.
    std::optional<JointEstimate> rest;
    std::string failure;
    std::optional<SkinWeights> plain;
    const SkinWeights* used = nullptr; // the weights the accepted unposing used
    for (int attempt = 0; attempt < 4 && !rest; ++attempt) {
      if (attempt == 2) plain = interpolate_skin_weights(posed_template, f.tmpl.weights, scan.positions);
      try {
        used = attempt < 2 ? &fit.rigged.weights : &*plain;
        rest = estimate_joints(unpose(*used, (attempt % 2 == 0 ? 45.0 : 30.0) * std::numbers::pi / 180));
      } catch (const Error& e) {
        if (attempt == 0) failure = e.what();
      }
    }
    // The limbs turned about the joints just estimated instead of the template's: where the
    // template's shoulder stands well off the scan's (elbows_bent's right one 4 cm too high after
    // the fit, the arms lowered 25° below the unposing's A-pose), the arm unposed about it slides
    // against the torso, and the estimator reads the shoulder from that sheared seam. Each limb
    // whose seam that stretches clearly less (seam_stretch(), by more than PIVOT_GAIN) keeps the
    // new pivot, and the joints are estimated again on the scan so unposed. Over the corpus test's
    // 20 poses (80 limbs) the seam's stretch moved by -3.5 to +9.9 % in all limbs but two, and
    // where it fell there the joints gained nothing (arms_raised's arms, -1 and -2 %, re-pivoted
    // took its right elbow 1.7 -> 2.6 cm and its re-posing 4.1 -> 5.5 mm); elbows_bent's arms,
    // -13 and -16 %, take it (right shoulder 3.1 -> 2.4 cm, re-posing 6.5 -> 5.0 mm). Any gain
    // from 3.5 to 13 % picks the same limbs.
    if (rest) {
      constexpr double PIVOT_GAIN = 0.05;
      std::array<Eigen::Isometry3d, JOINT_COUNT> kept = A;
      int count = 0;
      for (int root : limb_roots()) {
        const int chain = skin_chain_of_joint(root);
        std::array<Eigen::Isometry3d, JOINT_COUNT> moved = A;
        move_limb_pivot(moved, root, rest->joints.row(root).transpose());
        if (seam_stretch(scan, *used, moved, chain) < (1 - PIVOT_GAIN) * seam_stretch(scan, *used, A, chain)) {
          move_limb_pivot(kept, root, rest->joints.row(root).transpose());
          ++count;
        }
      }
      if (count > 0) {
        try {
          rest = estimate_joints(unpose_scan(scan, *used, kept));
          A = kept;
          fit.repivoted_limbs = count;
        } catch (const Error&) { // the first estimate stands
        }
      }
      for (int j = 0; j < JOINT_COUNT; ++j) {
        const auto parent = static_cast<std::size_t>(j == 0 ? 0 : joint_parent(j));
        const Vec3 x = rest->joints.row(j).transpose();
        fit.joints.row(j) = (0.5 * (A[parent] * x + A[static_cast<std::size_t>(j)] * x)).transpose();
      }
      fit.joints_estimated_unposed = true;
    } else {
      fit.warnings.push_back(
          std::string("joint estimation failed on the unposed scan; the template's joints are kept: ") + failure);
    }
  }
  fit.rigged.joints = fit.joints;
  fit.rigged.rest_pose = classify_rest_pose(fit.joints);
  fit.stages.push_back({"joints", 0, 0, elapsed_ms(t0), d_icp.mean, d_icp.p95, fit.joints, cpu_ms(t0)});
  if (d_icp.p95 > POOR_FIT_P95) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "the fitted body lies %.0f mm from the scan at the 95th percentile (mean %.0f mm; a good fit "
                  "leaves 10-35 mm, this warning comes past %.0f): the scan's pose is likely one the fit does not "
                  "reach (kneeling, sitting, lying) or it is not a whole body; check the joints before using the "
                  "rigged scan",
                  1e3 * d_icp.p95, 1e3 * d_icp.mean, 1e3 * POOR_FIT_P95);
    fit.warnings.push_back(line);
  }
  fit.total_ms = elapsed_ms(t_start);
  fit.total_cpu_ms = cpu_ms(t_start);
  return fit;
}

} // namespace vfit
