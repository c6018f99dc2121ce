// SPDX-License-Identifier: Apache-2.0
#include "scan_fit_solve.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <ceres/ceres.h>

#include "body.h"
#include "vfit/kernels/parallel.h"

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
//
// The block hands Ceres the pairs' 3·#pairs residuals compressed to PARAMS + 1 numbers with the
// same cost, gradient and Gauss–Newton matrix, so Levenberg–Marquardt takes the same steps
// (to rounding): with H = JᵀJ = Pᵀ L D Lᵀ P (pivoted LDLᵀ), g = Jᵀr and c = rᵀr, the block's
// Jacobian is J' = [√D Lᵀ P; 0] and its residual r' = [√D⁻¹ L⁻¹ P g; √(c − ‖√D⁻¹ L⁻¹ P g‖²)]:
// J'ᵀJ' = H, J'ᵀr' = g, r'ᵀr' = c, and the model's cost ‖J'δ + r'‖² = ‖Jδ + r‖² for every step δ.
// Without a Jacobian only the cost counts, so the residual is [0; √c]. Ceres then never holds
// the 3·#pairs × PARAMS Jacobian (7,200 × 80 for 2,400 pairs): H is accumulated from small
// fixed chunks of pairs, side by side and summed in chunk order (the same bits at any thread
// count), the rest of the solve is on PARAMS rows.
class DataCost final : public ceres::CostFunction {
public:
  static constexpr int PARAMS = 3 + BODY_POSE + 3 + SHAPE_PARAMS; ///< columns: global, body, translation, shape

  DataCost(const ShapeModel& model, const std::vector<Pair>& pairs, int threads)
      : m_model(model), m_pairs(pairs), m_threads(threads) {
    set_num_residuals(PARAMS + 1);
    *mutable_parameter_block_sizes() = {3, BODY_POSE, 3, SHAPE_PARAMS};
  }

  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    Kinematics k;
    k.pose = pose_of(p[0], p[1], p[2]);
    for (int b = 0; b <= SHAPE_PARAMS; ++b) {
      // b = 0: at p; b > 0: shape number b − 1 stepped forward by h (steps of 1e-6 on numbers
      // of order 0.1–1: log s, β in σ).
      std::array<double, SHAPE_PARAMS> shape{};
      std::copy(p[3], p[3] + SHAPE_PARAMS, shape.begin());
      if (b > 0) {
        const auto i = static_cast<std::size_t>(b - 1);
        k.step[i] = 1e-6 * std::max(1.0, std::abs(shape[i]));
        shape[i] += k.step[i];
      }
      Shaped& sh = k.shaped[static_cast<std::size_t>(b)];
      sh.s = std::exp(shape[0]);
      sh.dJ = m_model.displacement(shape.data());
      const JointPositions J = sh.s * (m_model.mean + sh.dJ);
      if (b == 0) {
        k.G = joint_world_transforms(J, k.pose);
        for (int j = 0; j < JOINT_COUNT; ++j)
          sh.A[static_cast<std::size_t>(j)] =
              k.G[static_cast<std::size_t>(j)] * Eigen::Translation3d(-J.row(j).transpose());
        if (!jac) break;
      } else {
        sh.A = skinning_transforms(J, k.pose);
      }
    }
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const double* rj = j == 0 ? p[0] : p[1] + 3 * (j - 1);
      k.B[static_cast<std::size_t>(j)] =
          k.G[static_cast<std::size_t>(j)].linear() * right_jacobian(Vec3(rj[0], rj[1], rj[2]));
    }

    const std::size_t chunks = (m_pairs.size() + CHUNK - 1) / CHUNK;
    std::vector<Normal> partial(chunks);
    auto run = [&](std::size_t begin, std::size_t end) {
      for (std::size_t c = begin; c < end; ++c)
        accumulate(k, c * CHUNK, std::min(m_pairs.size(), (c + 1) * CHUNK), jac != nullptr, partial[c]);
    };
    if (m_threads > 1)
      parallel_for_range(chunks, 1, run);
    else
      run(0, chunks);
    Normal total;
    for (const Normal& n : partial) {
      total.c += n.c;
      if (jac) {
        total.H += n.H;
        total.g += n.g;
      }
    }
    std::fill(r, r + PARAMS, 0.0);
    if (!jac) {
      r[PARAMS] = std::sqrt(total.c);
      return true;
    }
    // The compression (see the class comment). D's entries at or below this fraction of the
    // largest are rank the pairs do not have (joints no pair is skinned to): zero rows.
    constexpr double RANK_TOLERANCE = 1e-13;
    const Eigen::Matrix<double, PARAMS, PARAMS> H = total.H.selfadjointView<Eigen::Lower>();
    const Eigen::LDLT<Eigen::Matrix<double, PARAMS, PARAMS>> ldlt(H);
    const Eigen::Matrix<double, PARAMS, 1> D = ldlt.vectorD();
    const double floor = RANK_TOLERANCE * std::max(D.maxCoeff(), 0.0);
    Eigen::Matrix<double, PARAMS, PARAMS> L = ldlt.matrixL();
    Eigen::Matrix<double, PARAMS, 1> y = ldlt.transpositionsP() * total.g;
    L.triangularView<Eigen::UnitLower>().solveInPlace(y);
    // J' = √D Lᵀ P, i.e. J'ᵀ = Pᵀ L √D.
    const Eigen::Matrix<double, PARAMS, PARAMS> Jt = ldlt.transpositionsP().transpose() * L;
    double explained = 0;
    std::array<double, PARAMS> root{};
    for (int i = 0; i < PARAMS; ++i) {
      if (D[i] <= floor) continue;
      root[static_cast<std::size_t>(i)] = std::sqrt(D[i]);
      r[i] = y[i] / root[static_cast<std::size_t>(i)];
      explained += r[i] * r[i];
    }
    r[PARAMS] = std::sqrt(std::max(0.0, total.c - explained));
    constexpr std::array<int, 4> WIDTH = {3, BODY_POSE, 3, SHAPE_PARAMS}, FIRST = {0, 3, 3 + BODY_POSE, 6 + BODY_POSE};
    for (int b = 0; b < 4; ++b) {
      double* block = jac[b];
      if (!block) continue;
      const int w = WIDTH[static_cast<std::size_t>(b)], first = FIRST[static_cast<std::size_t>(b)];
      for (int i = 0; i <= PARAMS; ++i)
        for (int a = 0; a < w; ++a)
          block[i * w + a] = i < PARAMS ? root[static_cast<std::size_t>(i)] * Jt(first + a, i) : 0.0;
    }
    return true;
  }

private:
  static constexpr std::size_t CHUNK = 256; // pairs per chunk of the normal equations, summed in chunk order

  struct Shaped {
    double s = 1;
    JointPositions dJ = JointPositions::Zero();
    std::array<Eigen::Isometry3d, JOINT_COUNT> A;
  };
  // The skeleton at the evaluation point ([0]) and at each forward-differenced shape ([1..]).
  struct Kinematics {
    Pose pose;
    std::array<Shaped, SHAPE_PARAMS + 1> shaped;
    std::array<double, SHAPE_PARAMS> step{};
    std::array<Eigen::Isometry3d, JOINT_COUNT> G;
    std::array<Eigen::Matrix3d, JOINT_COUNT> B; // world rotation of each joint times its right Jacobian
  };
  // A chunk's share of the normal equations: JᵀJ (lower triangle), Jᵀr, rᵀr.
  struct Normal {
    Eigen::Matrix<double, PARAMS, PARAMS, Eigen::RowMajor> H =
        Eigen::Matrix<double, PARAMS, PARAMS, Eigen::RowMajor>::Zero();
    Eigen::Matrix<double, PARAMS, 1> g = Eigen::Matrix<double, PARAMS, 1>::Zero();
    double c = 0;
  };

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
  Vec3 residual(const Pair& q, const Shaped& sh, const Eigen::Matrix3d& P) const {
    const Vec3 rest = rest_of(q, sh.dJ, sh.s);
    Vec3 x = Vec3::Zero();
    for (int k = 0; k < 4; ++k)
      if (q.weight[k] != 0.0) x += q.weight[k] * (sh.A[static_cast<std::size_t>(q.joint[k])] * rest);
    return P * (x - q.target);
  }

  // Pairs [begin, end): their residuals' squared norm and, `with_jacobian`, their JᵀJ (lower
  // triangle) and Jᵀr. A pair's 3 Jacobian rows are non-zero only in the columns of the joints
  // its influences hang from (and translation and shape): ~25 of PARAMS, so each pair's rows are
  // kept compact and their products scattered into H, a tenth of a dense product's work.
  void accumulate(const Kinematics& k, std::size_t begin, std::size_t end, bool with_jacobian, Normal& out) const {
    const Shaped& at = k.shaped[0];
    std::array<Vec3, JOINT_COUNT> xs;
    std::array<double, JOINT_COUNT> ms;
    std::vector<int> touched;
    std::array<int, PARAMS> column{};      // the compact rows' columns in the full Jacobian
    Eigen::Matrix<double, 3, PARAMS> rows; // a pair's rows, compact (first `m` columns)
    for (std::size_t i = begin; i < end; ++i) {
      const Pair& q = m_pairs[i];
      const Eigen::Matrix3d P = projector(q);
      const Vec3 ri = residual(q, at, P);
      out.c += ri.squaredNorm();
      if (!with_jacobian) continue;
      const Vec3 rest = rest_of(q, at.dJ, at.s);
      touched.clear();
      for (int w = 0; w < 4; ++w) {
        if (q.weight[w] == 0.0) continue;
        const Vec3 y = at.A[static_cast<std::size_t>(q.joint[w])] * rest;
        for (int a = q.joint[w]; a >= 0; a = joint_parent(a)) {
          const auto u = static_cast<std::size_t>(a);
          if (std::find(touched.begin(), touched.end(), a) == touched.end()) {
            touched.push_back(a);
            xs[u].setZero();
            ms[u] = 0;
          }
          xs[u] += q.weight[w] * y;
          ms[u] += q.weight[w];
        }
      }
      int m = 0;
      auto add_block = [&](int first, int width) {
        for (int a = 0; a < width; ++a)
          column[static_cast<std::size_t>(m + a)] = first + a;
        m += width;
      };
      std::sort(touched.begin(), touched.end()); // columns ascending: H's lower triangle is b ≤ a below
      for (int j : touched) {
        const auto u = static_cast<std::size_t>(j);
        rows.middleCols<3>(m) = P * (-skew(xs[u] - ms[u] * k.G[u].translation()) * k.B[u]);
        add_block(3 * j, 3);
      }
      rows.middleCols<3>(m) = P;
      add_block(3 + BODY_POSE, 3);
      for (int b = 0; b < SHAPE_PARAMS; ++b)
        rows.col(m + b) =
            (residual(q, k.shaped[static_cast<std::size_t>(b + 1)], P) - ri) / k.step[static_cast<std::size_t>(b)];
      add_block(6 + BODY_POSE, SHAPE_PARAMS);
      for (int a = 0; a < m; ++a) {
        const double x = rows(0, a), y = rows(1, a), z = rows(2, a);
        const int ca = column[static_cast<std::size_t>(a)];
        out.g[ca] += x * ri[0] + y * ri[1] + z * ri[2];
        double* h = out.H.data() + static_cast<std::ptrdiff_t>(ca) * PARAMS; // row ca (row-major)
        for (int b = 0; b <= a; ++b)
          h[column[static_cast<std::size_t>(b)]] += x * rows(0, b) + y * rows(1, b) + z * rows(2, b);
      }
    }
  }

  const ShapeModel& m_model;
  const std::vector<Pair>& m_pairs;
  int m_threads;
};

// Pose prior (T-pose-relative axis-angle; a knee bends about +X, the left elbow about −Y): a
// weak L2 toward the T-pose, stronger on the twists a surface barely shows, and one-sided
// limits that keep knees and elbows hinging the anatomical way.
// The wrists are held as firmly as a twist about all three axes: a hand is a small, flat part
// of the surface, so with the weak pull its rotation drifted wherever the solver stopped in a
// flat valley (the corpus body's elbows_bent, a symmetric pose: left wrist (8, −20, −27)°,
// right (0, 6, 16)°; a change of the normal equations' rounding moved its left hand joint
// 2.84 → 3.05 cm off the rig's). Held so, over the corpus scan test's 26 poses the hand joints
// are 0.82 cm off on average and at most 1.05 cm (were 1.07 and 2.84 cm).
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
      const bool wrist = joint == idx(Joint::LEFT_WRIST) || joint == idx(Joint::RIGHT_WRIST);
      r[k++] = T((arm_twist || leg_twist || neck_lean || wrist) ? TWIST_L2 : POSE_L2) * body[i];
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
  if (!pairs.empty())
    problem.AddResidualBlock(new DataCost(model, pairs, std::clamp(threads, 1, 2)), nullptr,
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
  // One dense block over 80 parameters: no structure to exploit, the 80 × 80 normal equations
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
