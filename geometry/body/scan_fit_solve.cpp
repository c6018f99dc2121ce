#include "scan_fit_solve.h"

#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>

#include "body.h"

namespace vfit::scan_detail {

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

namespace {

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
// The neck's sideways lean (about Z) is held as firmly as a twist: the spine's lean and the
// neck's both put the head to one side, and the head joint tilts the head alone, so with the
// weak pull the neck took a lean the spine should have (the corpus body's contrapposto: the
// rig's 4° lean of spine2 fitted as 1° of spine and 8° of neck) or leaned against a lean of the
// spine the scan did not have (a random pose: spine −5°, neck +10°), each trading the
// template's shoulder-shape mismatch for an untilted or tilted chest. The surface barely tells
// them apart (the two fits of contrapposto score within 3 % of each other); which one is right
// shows in the joints estimated on the scan unposed with it (scan_fit.cpp, stage 5).
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
      const bool neck_lean = axis == 2 && joint == idx(Joint::NECK);
      r[k++] = T((arm_twist || leg_twist || neck_lean) ? TWIST_L2 : POSE_L2) * body[i];
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

} // namespace

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

} // namespace vfit::scan_detail
