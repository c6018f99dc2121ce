#include "scan_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <numbers>
#include <optional>

#include <ceres/ceres.h>
#include <tbb/task_group.h>

#include "gltf_body.h"
#include "joint_estimation.h"
#include "kernels/error.h"
#include "kernels/parallel.h"
#include "kernels/proximity.h"
#include "mannequin.h"
#include "scan_pose_search.h"
#include "scan_skin_transfer.h"

namespace vfit {
namespace {

using Clock = std::chrono::steady_clock;
using Vec3 = Eigen::Vector3d;
constexpr int BODY_POSE = 3 * (JOINT_COUNT - 1);
// log s, β1 (legs), β2 (arms), β3 (shoulders), then the elbows' shift along the arm (see ELBOW_STEP).
constexpr int SHAPE_PARAMS = 5;
// An elbow shift of 1 moves both elbows this far (m) toward their shoulders along the T-pose's
// arm, the forearms' skin with them: rigs disagree on where the arm bends (the corpus body's rig
// at 50 % of shoulder → wrist, our mannequin at 55 %, 3-6 cm apart at the fitted scale), and a
// template that bends a few cm from where the scan's arm bends fits a bent arm by bending less
// and turning the upper arm, so that the arm unposed with its weights (stage 5) keeps a residual
// bend and its elbow is estimated 3-9 cm off (measured on the corpus body in 20 poses: 13 of them
// had an elbow past 3 cm without the shift, 8 with it). The knees' place was tried the same way
// and changed nothing measurable (the ankle of a bent leg stayed 3.7 cm off), so it is not fitted.
constexpr double ELBOW_STEP = 0.02;
constexpr double SHAPE_LIMIT = 3.0;       // |β| ≤ 3 σ, as the keypoint fit
constexpr double LOG_SCALE_LIMIT = 0.35;  // s within ×0.70–×1.42 of the average body
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

// The template's rest joints move with β through the keypoint model's basis (k = 1, 2, 3).
struct ShapeModel {
  JointPositions mean = JointPositions::Zero();
  std::array<JointPositions, 3> basis{};
  JointPositions elbows = JointPositions::Zero(); // the elbows' shift per unit (ELBOW_STEP)

  JointPositions displacement(const double* shape) const {
    JointPositions d = shape[4] * elbows;
    for (int k = 0; k < 3; ++k)
      d += shape[k + 1] * basis[static_cast<std::size_t>(k)];
    return d;
  }
};

// One correspondence: a template point (rest position at the average shape and its ≤ 4 skin
// influences) and its target in the scan; the residual weighs the offset across the plane of
// `normal` fully and along it by `tangential` (1: point-to-point).
struct Pair {
  Vec3 rest;
  std::array<int, 4> joint{};
  std::array<double, 4> weight{};
  Vec3 target, normal;
  double sqrt_weight = 1, tangential = 1;
};

struct State {
  std::array<double, 3> global{};
  std::array<double, BODY_POSE> body{};
  std::array<double, 3> trans{};
  std::array<double, SHAPE_PARAMS> shape{};
};

Pose pose_of(const double* global, const double* body, const double* trans) {
  Pose p;
  p.axis_angle.row(0) = Eigen::RowVector3d(global[0], global[1], global[2]);
  for (int j = 1; j < JOINT_COUNT; ++j)
    for (int a = 0; a < 3; ++a)
      p.axis_angle(j, a) = body[3 * (j - 1) + a];
  p.translation = Vec3(trans[0], trans[1], trans[2]);
  return p;
}
Pose pose_of(const State& s) { return pose_of(s.global.data(), s.body.data(), s.trans.data()); }
JointPositions rest_joints_of(const ShapeModel& m, const double* shape) {
  return std::exp(shape[0]) * (m.mean + m.displacement(shape));
}

Eigen::Matrix3d skew(const Vec3& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Right Jacobian of SO(3): R(φ + δ) ≈ R(φ) exp([J_r(φ) δ]×).
Eigen::Matrix3d right_jacobian(const Vec3& phi) {
  const double t = phi.norm();
  const Eigen::Matrix3d K = skew(phi);
  if (t < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * K + K * K / 6.0;
  return Eigen::Matrix3d::Identity() - (1 - std::cos(t)) / (t * t) * K + (t - std::sin(t)) / (t * t * t) * K * K;
}

// Eq. 4's data term for every pair in one residual block, so that the skeleton's forward
// kinematics runs once per evaluation. Pose and translation derivatives are analytic
// (articulated ICP): a rotation δ of joint j's axis-angle turns every point's share skinned to
// j's subtree about the posed joint p_j, so ∂x/∂r_j = −[x_j − m_j p_j]× R_j J_r(r_j), with x_j,
// m_j the point's skinned position and weight summed over that subtree. The 4 shape numbers
// move the rest skeleton and vertices together and are differentiated by forward differences.
class DataCost final : public ceres::CostFunction {
public:
  DataCost(const ShapeModel& model, const std::vector<Pair>& pairs) : m_model(model), m_pairs(pairs) {
    set_num_residuals(3 * static_cast<int>(pairs.size()));
    *mutable_parameter_block_sizes() = {3, BODY_POSE, 3, SHAPE_PARAMS};
  }

  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    const Pose pose = pose_of(p[0], p[1], p[2]);
    const double s = std::exp(p[3][0]);
    const JointPositions dJ = m_model.displacement(p[3]);
    const JointPositions J = s * (m_model.mean + dJ);
    const auto G = joint_world_transforms(J, pose);
    std::array<Eigen::Isometry3d, JOINT_COUNT> A;
    for (int j = 0; j < JOINT_COUNT; ++j)
      A[static_cast<std::size_t>(j)] = G[static_cast<std::size_t>(j)] * Eigen::Translation3d(-J.row(j).transpose());
    residuals(A, dJ, s, r);
    if (!jac) return true;
    if (jac[0] || jac[1] || jac[2]) pose_jacobians(p, G, A, dJ, s, jac);
    if (jac[3]) {
      // Forward differences: steps of 1e-6 on numbers of order 0.1–1 (log s, β in σ).
      std::vector<double> shifted(static_cast<std::size_t>(num_residuals()));
      for (int k = 0; k < SHAPE_PARAMS; ++k) {
        std::array<double, SHAPE_PARAMS> shape{};
        std::copy(p[3], p[3] + SHAPE_PARAMS, shape.begin());
        const double h = 1e-6 * std::max(1.0, std::abs(shape[static_cast<std::size_t>(k)]));
        shape[static_cast<std::size_t>(k)] += h;
        const double s2 = std::exp(shape[0]);
        const JointPositions dJ2 = m_model.displacement(shape.data());
        const JointPositions J2 = s2 * (m_model.mean + dJ2);
        residuals(skinning_transforms(J2, pose), dJ2, s2, shifted.data());
        for (int i = 0; i < num_residuals(); ++i)
          jac[3][i * SHAPE_PARAMS + k] = (shifted[static_cast<std::size_t>(i)] - r[i]) / h;
      }
    }
    return true;
  }

private:
  Vec3 rest_of(const Pair& q, const JointPositions& dJ, double s) const {
    Vec3 offset = Vec3::Zero();
    for (int k = 0; k < 4; ++k)
      offset += q.weight[k] * dJ.row(q.joint[k]).transpose();
    return s * (q.rest + offset);
  }
  static Eigen::Matrix3d projector(const Pair& q) {
    const Eigen::Matrix3d nn = q.normal * q.normal.transpose();
    return q.sqrt_weight * (nn + q.tangential * (Eigen::Matrix3d::Identity() - nn));
  }

  void residuals(const std::array<Eigen::Isometry3d, JOINT_COUNT>& A, const JointPositions& dJ, double s,
                 double* r) const {
    for (std::size_t i = 0; i < m_pairs.size(); ++i) {
      const Pair& q = m_pairs[i];
      const Vec3 rest = rest_of(q, dJ, s);
      Vec3 x = Vec3::Zero();
      for (int k = 0; k < 4; ++k)
        if (q.weight[k] != 0.0) x += q.weight[k] * (A[static_cast<std::size_t>(q.joint[k])] * rest);
      Eigen::Map<Vec3>(r + 3 * i) = projector(q) * (x - q.target);
    }
  }

  void pose_jacobians(double const* const* p, const std::array<Eigen::Isometry3d, JOINT_COUNT>& G,
                      const std::array<Eigen::Isometry3d, JOINT_COUNT>& A, const JointPositions& dJ, double s,
                      double** jac) const {
    std::array<Eigen::Matrix3d, JOINT_COUNT> B; // world rotation of each joint times its right Jacobian
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const double* r = j == 0 ? p[0] : p[1] + 3 * (j - 1);
      B[static_cast<std::size_t>(j)] = G[static_cast<std::size_t>(j)].linear() * right_jacobian(Vec3(r[0], r[1], r[2]));
    }
    const auto rows = static_cast<std::size_t>(num_residuals());
    if (jac[0]) std::fill(jac[0], jac[0] + rows * 3, 0.0);
    if (jac[1]) std::fill(jac[1], jac[1] + rows * BODY_POSE, 0.0);
    if (jac[2]) std::fill(jac[2], jac[2] + rows * 3, 0.0);
    std::array<Vec3, JOINT_COUNT> xs;
    std::array<double, JOINT_COUNT> ms;
    std::vector<int> touched;
    for (std::size_t i = 0; i < m_pairs.size(); ++i) {
      const Pair& q = m_pairs[i];
      const Vec3 rest = rest_of(q, dJ, s);
      touched.clear();
      for (int k = 0; k < 4; ++k) {
        if (q.weight[k] == 0.0) continue;
        const Vec3 y = A[static_cast<std::size_t>(q.joint[k])] * rest;
        for (int a = q.joint[k]; a >= 0; a = joint_parent(a)) {
          const auto u = static_cast<std::size_t>(a);
          if (std::find(touched.begin(), touched.end(), a) == touched.end()) {
            touched.push_back(a);
            xs[u].setZero();
            ms[u] = 0;
          }
          xs[u] += q.weight[k] * y;
          ms[u] += q.weight[k];
        }
      }
      const Eigen::Matrix3d P = projector(q);
      for (int j : touched) {
        const auto u = static_cast<std::size_t>(j);
        const Eigen::Matrix3d D = P * (-skew(xs[u] - ms[u] * G[u].translation()) * B[u]);
        double* block = j == 0 ? jac[0] : jac[1];
        if (!block) continue;
        const int width = j == 0 ? 3 : BODY_POSE, col = j == 0 ? 0 : 3 * (j - 1);
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            block[(3 * i + a) * width + col + b] = D(a, b);
      }
      if (jac[2])
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            jac[2][(3 * i + a) * 3 + b] = P(a, b);
    }
  }

  const ShapeModel& m_model;
  const std::vector<Pair>& m_pairs;
};

// Pose prior (T-pose-relative axis-angle; a knee bends about +X, the left elbow about −Y): a
// weak L2 toward the T-pose, stronger on the twists a surface barely shows, and one-sided
// limits that keep knees and elbows hinging the anatomical way.
struct Limit {
  int joint, axis;
  double lo, hi;
};
const std::vector<Limit>& pose_limits() {
  static const std::vector<Limit> limits = {
      {idx(Joint::LEFT_KNEE), 0, -0.05, 2.6},   {idx(Joint::LEFT_KNEE), 1, -0.3, 0.3},
      {idx(Joint::LEFT_KNEE), 2, -0.15, 0.15},  {idx(Joint::RIGHT_KNEE), 0, -0.05, 2.6},
      {idx(Joint::RIGHT_KNEE), 1, -0.3, 0.3},   {idx(Joint::RIGHT_KNEE), 2, -0.15, 0.15},
      {idx(Joint::LEFT_ELBOW), 1, -2.6, 0.05},  {idx(Joint::LEFT_ELBOW), 2, -0.2, 0.2},
      {idx(Joint::RIGHT_ELBOW), 1, -0.05, 2.6}, {idx(Joint::RIGHT_ELBOW), 2, -0.2, 0.2},
  };
  return limits;
}
// Weights in metres of mean data error per radian: the data term is a mean of squared
// distances, so a 1 rad departure from the T-pose costs as much as 3 mm of mean error, and
// 0.1 rad past a limit as much as 1 cm.
constexpr double POSE_L2 = 0.003;
constexpr double TWIST_L2 = 0.02;
constexpr double LIMIT_WEIGHT = 0.1;
constexpr double SHAPE_L2 = 0.002; // per population σ
// The elbow's place is a rig's convention more than a body's: a quarter of SHAPE_L2, so that
// the data moves it (with SHAPE_L2 the elbows moved 0.7-1.3 cm where they needed 3-6).
constexpr double ELBOW_L2 = SHAPE_L2 / 4;

struct PosePrior {
  static int residual_count() { return BODY_POSE + static_cast<int>(pose_limits().size()); }
  template <typename T> bool operator()(const T* body, T* r) const {
    int k = 0;
    for (int i = 0; i < BODY_POSE; ++i) {
      const int joint = i / 3 + 1, axis = i % 3;
      const bool arm_twist = axis == 0 && (joint == idx(Joint::LEFT_SHOULDER) || joint == idx(Joint::RIGHT_SHOULDER) ||
                                           joint == idx(Joint::LEFT_ELBOW) || joint == idx(Joint::RIGHT_ELBOW));
      const bool leg_twist = axis == 1 && (joint == idx(Joint::LEFT_HIP) || joint == idx(Joint::RIGHT_HIP));
      r[k++] = T((arm_twist || leg_twist) ? TWIST_L2 : POSE_L2) * body[i];
    }
    for (const Limit& l : pose_limits()) {
      const T& x = body[3 * (l.joint - 1) + l.axis];
      r[k++] = T(LIMIT_WEIGHT) * (x > T(l.hi) ? x - T(l.hi) : (x < T(l.lo) ? x - T(l.lo) : T(0)));
    }
    return true;
  }
};

struct ShapePrior {
  template <typename T> bool operator()(const T* shape, T* r) const {
    for (int k = 0; k < SHAPE_PARAMS - 1; ++k)
      r[k] = T(k < 3 ? SHAPE_L2 : ELBOW_L2) * shape[k + 1];
    return true;
  }
};

int solve(const ShapeModel& model, const std::vector<Pair>& pairs, State& s, int iterations, int threads) {
  ceres::Problem problem;
  // The pairs in one block per thread, which Ceres evaluates side by side; each block runs the
  // skeleton's forward kinematics once per evaluation.
  const int blocks = std::clamp(threads, 1, 2);
  std::vector<std::vector<Pair>> chunks(static_cast<std::size_t>(blocks));
  for (std::size_t i = 0; i < pairs.size(); ++i)
    chunks[i * static_cast<std::size_t>(blocks) / pairs.size()].push_back(pairs[i]);
  for (const std::vector<Pair>& chunk : chunks)
    if (!chunk.empty())
      problem.AddResidualBlock(new DataCost(model, chunk), nullptr,
                               std::vector<double*>{s.global.data(), s.body.data(), s.trans.data(), s.shape.data()});
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<PosePrior, ceres::DYNAMIC, BODY_POSE>(new PosePrior, PosePrior::residual_count()),
      nullptr, s.body.data());
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ShapePrior, SHAPE_PARAMS - 1, SHAPE_PARAMS>(new ShapePrior),
                           nullptr, s.shape.data());
  problem.SetParameterLowerBound(s.shape.data(), 0, -LOG_SCALE_LIMIT);
  problem.SetParameterUpperBound(s.shape.data(), 0, LOG_SCALE_LIMIT);
  for (int k = 1; k < SHAPE_PARAMS; ++k) {
    problem.SetParameterLowerBound(s.shape.data(), k, -SHAPE_LIMIT);
    problem.SetParameterUpperBound(s.shape.data(), k, SHAPE_LIMIT);
  }
  ceres::Solver::Options o;
  // One dense block over 79 parameters: no structure to exploit, the 79 × 79 normal equations
  // are the cheapest solve.
  o.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  o.max_num_iterations = iterations;
  o.num_threads = std::clamp(threads, 1, 2);
  o.logging_type = ceres::SILENT;
  o.function_tolerance = 1e-5;
  ceres::Solver::Summary summary;
  ceres::Solve(o, &problem, &summary);
  return summary.num_successful_steps + summary.num_unsuccessful_steps;
}

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

// The centre (x, z) of a standing body: the middle of the extent (between the 10th and 90th
// percentiles) of the vertices at 10–35 % of its height, where only the legs are (arms reach no
// lower than the crotch in A- or T-pose, and an unweighted centroid or an upper band leans
// towards densely meshed heads and hands). Not the median: over two legs it falls on one leg or
// the other (8 cm off the mid-plane on the corpus body standing straight, 23 cm with one foot
// raised behind, farther than the search's shifts reach).
Vec3 body_centre(std::span<const float> positions, double lo, double hi) {
  std::vector<double> xs, zs;
  for (std::size_t v = 0; v < positions.size() / 3; ++v) {
    const double h = (positions[3 * v + 1] - lo) / (hi - lo);
    if (h < 0.10 || h > 0.35) continue;
    xs.push_back(positions[3 * v]);
    zs.push_back(positions[3 * v + 2]);
  }
  if (xs.empty()) return Vec3::Zero();
  auto middle = [](std::vector<double>& a) {
    auto at = [&](double q) {
      const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(a.size() - 1));
      std::nth_element(a.begin(), a.begin() + k, a.end());
      return a[static_cast<std::size_t>(k)];
    };
    return 0.5 * (at(0.1) + at(0.9));
  };
  return {middle(xs), 0, middle(zs)};
}

// Mends `unposed` (a copy of `posed` with moved vertices) where the move tore the surface: a
// vertex most of whose edges came out longer than TEAR_STRETCH times their posed length plus
// TEAR_SLACK is moved as its mended neighbours moved (their mean displacement), outward from the
// intact surface. Unposing is nearly rigid per part where the weights are right; a few vertices
// with another part's weights (a fingertip of a hand folded on the belly) fly off and span webs
// from the hand to the belly that hide where the arm leaves the torso from the joint estimator.
constexpr double TEAR_STRETCH = 2.0, TEAR_SLACK = 0.01;
void mend_torn_vertices(Mesh& unposed, const Mesh& posed) {
  const std::size_t n = unposed.vertex_count();
  auto length = [](const Mesh& m, std::int32_t a, std::int32_t b) {
    return (Eigen::Vector3f::Map(&m.positions[3 * static_cast<std::size_t>(a)]) -
            Eigen::Vector3f::Map(&m.positions[3 * static_cast<std::size_t>(b)]))
        .norm();
  };
  std::vector<int> edges(n, 0), torn(n, 0);
  std::vector<std::vector<std::int32_t>> neighbours(n);
  for (std::size_t f = 0; f < unposed.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = unposed.triangles[3 * f + k], b = unposed.triangles[3 * f + (k + 1) % 3];
      const bool t = length(unposed, a, b) > TEAR_STRETCH * length(posed, a, b) + TEAR_SLACK;
      for (std::int32_t v : {a, b}) {
        ++edges[static_cast<std::size_t>(v)];
        torn[static_cast<std::size_t>(v)] += t;
      }
      neighbours[static_cast<std::size_t>(a)].push_back(b);
      neighbours[static_cast<std::size_t>(b)].push_back(a);
    }
  std::vector<bool> settled(n);
  std::vector<std::size_t> front;
  for (std::size_t v = 0; v < n; ++v)
    settled[v] = 2 * torn[v] <= edges[v];
  // Rings of torn vertices, each from the settled ones around it.
  for (bool changed = true; changed;) {
    changed = false;
    front.clear();
    for (std::size_t v = 0; v < n; ++v)
      if (!settled[v])
        for (std::int32_t w : neighbours[v])
          if (settled[static_cast<std::size_t>(w)]) {
            front.push_back(v);
            break;
          }
    for (std::size_t v : front) {
      Eigen::Vector3f shift = Eigen::Vector3f::Zero();
      int count = 0;
      for (std::int32_t w : neighbours[v])
        if (settled[static_cast<std::size_t>(w)]) {
          const auto u = 3 * static_cast<std::size_t>(w);
          shift += Eigen::Vector3f::Map(&unposed.positions[u]) - Eigen::Vector3f::Map(&posed.positions[u]);
          ++count;
        }
      Eigen::Vector3f::Map(&unposed.positions[3 * v]) =
          Eigen::Vector3f::Map(&posed.positions[3 * v]) + shift / static_cast<float>(count);
    }
    for (std::size_t v : front)
      settled[v] = changed = true;
  }
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
  // Stage 0: the template and the shape basis, each built from the mannequin generator on
  // first use (seconds; nothing afterwards), side by side on two cores.
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
    const ScanPoseSearch found = search_scan_pose(f.tmpl, scan.positions, pose_of(s), s.shape[0]);
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
    std::array<Eigen::Isometry3d, JOINT_COUNT> A;
    auto unpose = [&](const SkinWeights& w, double drop) {
      Pose apose;
      apose.axis_angle(idx(Joint::LEFT_SHOULDER), 2) = -drop;
      apose.axis_angle(idx(Joint::RIGHT_SHOULDER), 2) = drop;
      A = skinning_transforms(fit.rest_joints, fit.pose);
      const auto B = skinning_transforms(fit.rest_joints, apose);
      for (std::size_t k = 0; k < A.size(); ++k)
        A[k] = A[k] * B[k].inverse();
      Mesh unposed = scan;
      for (std::size_t v = 0; v < scan.vertex_count(); ++v) {
        Eigen::Matrix<double, 3, 4> M = Eigen::Matrix<double, 3, 4>::Zero();
        for (int k = 0; k < 4; ++k)
          M += w.weights[4 * v + k] * A[static_cast<std::size_t>(w.joints[4 * v + k])].matrix().topRows<3>();
        const Vec3 p = M.leftCols<3>().inverse() *
                       (Vec3(scan.positions[3 * v], scan.positions[3 * v + 1], scan.positions[3 * v + 2]) - M.col(3));
        for (int a = 0; a < 3; ++a)
          unposed.positions[3 * v + a] = static_cast<float>(p[a]);
      }
      mend_torn_vertices(unposed, scan);
      return unposed;
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
    for (int attempt = 0; attempt < 4 && !rest; ++attempt) {
      if (attempt == 2) plain = interpolate_skin_weights(posed_template, f.tmpl.weights, scan.positions);
      try {
        rest = estimate_joints(unpose(attempt < 2 ? fit.rigged.weights : *plain,
                                      (attempt % 2 == 0 ? 45.0 : 30.0) * std::numbers::pi / 180));
      } catch (const Error& e) {
        if (attempt == 0) failure = e.what();
      }
    }
    if (rest) {
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
  fit.total_ms = elapsed_ms(t_start);
  fit.total_cpu_ms = cpu_ms(t_start);
  return fit;
}

} // namespace vfit
