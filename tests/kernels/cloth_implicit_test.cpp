#include "kernels/cloth_implicit.h"

#include <cmath>
#include <cstring>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "geometry/mesh/primitives.h"
#include "kernels/cloth_gather.h"

namespace vfit {
namespace {
using namespace cloth_detail;

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

Eigen::Matrix3d dense(vfit_sym3 s) {
  Eigen::Matrix3d m;
  m << s.xx, s.xy, s.xz, s.xy, s.yy, s.yz, s.xz, s.yz, s.zz;
  return m;
}

// A jittered grid (side 1 m) with random per-spring constants, two pinned corners, masses m,
// random velocities: a generic state for the solver.
struct Cloth {
  std::vector<float> x, v;
  SpringAdjacency adjacency;
  ClothParticles particles;
};

Cloth jittered_cloth(int n, unsigned seed, float mass) {
  const Mesh m = make_grid(n, n, 1.0f, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.2f / float(n), 0.2f / float(n)), kd(100.0f, 500.0f),
      cd(0.0f, 0.05f), vel(-0.5f, 0.5f);
  ClothSprings s = build_cloth_springs(m.position_view(), m.triangle_view());
  for (std::size_t i = 0; i < s.size(); ++i) {
    s.stiffness[i] = kd(rng);
    s.damping[i] = cd(rng);
  }
  Cloth c;
  c.adjacency = build_spring_adjacency(s, m.vertex_count());
  c.x = m.positions;
  for (float& p : c.x)
    p += jitter(rng); // some springs stretched, some compressed
  c.v.resize(c.x.size());
  for (float& q : c.v)
    q = vel(rng);
  c.particles.inverse_masses.assign(m.vertex_count(), 1.0f / mass);
  c.particles.inverse_masses[0] = c.particles.inverse_masses[std::size_t(n - 1)] = 0.0f;
  c.particles.global_damping = 0.5f;
  return c;
}

// K = ∂f_i/∂x_j (h = 1, c = 0, unclamped) against central differences of vfit_spring_force in
// x_j, and D = ∂f_i/∂v_j against differences in v_j (the force is linear in v, so those are
// exact up to rounding). Step ε = 2⁻¹⁰ m on a spring ~1 m long: the central difference's
// truncation is ~k·ε²/l² ≈ 1e-6·k, and float rounding of the force (~k·6e-8) divided by 2ε is
// ~3e-5·k; tolerance 1e-3·k. Covers a stretched and a compressed spring (the transverse term
// changes sign).
TEST(ClothImplicit, SpringJacobianMatchesFiniteDifferencesOfTheForce) {
  const vfit_vec3 xi{0.1f, -0.2f, 0.05f}, vi{0.3f, -0.1f, 0.2f}, vj{-0.2f, 0.4f, 0.1f};
  const float k = 300.0f, c = 0.7f;
  for (const float rest : {0.8f, 1.3f}) { // the spring below is ~1.07 m: stretched, then compressed
    const vfit_vec3 xj{0.9f, 0.3f, -0.3f};
    const Eigen::Matrix3d K = dense(vfit_spring_system_block(xi, xj, rest, k, 0.0f, 1.0f, 0));
    const Eigen::Matrix3d S = dense(vfit_spring_system_block(xi, xj, rest, k, c, 1.0f, 0));
    const Eigen::Matrix3d D = S - K; // h = 1: S = D + K
    const float eps = 1.0f / 1024.0f;
    for (int a = 0; a < 3; ++a) {
      vfit_vec3 xp = xj, xm = xj, vp = vj, vm = vj;
      (&xp.x)[a] += eps;
      (&xm.x)[a] -= eps;
      (&vp.x)[a] += eps;
      (&vm.x)[a] -= eps;
      const vfit_vec3 fxp = vfit_spring_force(xi, xp, vi, vj, rest, k, 0.0f),
                      fxm = vfit_spring_force(xi, xm, vi, vj, rest, k, 0.0f);
      const vfit_vec3 fvp = vfit_spring_force(xi, xj, vi, vp, rest, k, c),
                      fvm = vfit_spring_force(xi, xj, vi, vm, rest, k, c);
      for (int b = 0; b < 3; ++b) {
        const double dfdx = (double((&fxp.x)[b]) - (&fxm.x)[b]) / (2.0 * eps);
        const double dfdv = (double((&fvp.x)[b]) - (&fvm.x)[b]) / (2.0 * eps);
        EXPECT_NEAR(K(b, a), dfdx, 1e-3 * k) << "rest " << rest << " ∂f" << b << "/∂x" << a;
        EXPECT_NEAR(D(b, a), dfdv, 1e-3 * k) << "rest " << rest << " ∂f" << b << "/∂v" << a;
      }
    }
    // Clamped: a compressed spring loses its negative transverse stiffness and stays PSD.
    const Eigen::Matrix3d clamped = dense(vfit_spring_system_block(xi, xj, rest, k, 0.0f, 1.0f, 1));
    const Eigen::Vector3d eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(clamped).eigenvalues();
    EXPECT_GE(eig.minCoeff(), -1e-4 * k) << "rest " << rest;
    if (rest < 1.0f) {
      EXPECT_NEAR((clamped - K).norm(), 0.0, 1e-6 * k); // stretched: nothing clamped
    } else {
      EXPECT_LT(K.eigenvalues().real().minCoeff(), -1.0); // the exact one is indefinite
    }
  }
}

// The assembled operator is symmetric positive definite on the free particles, and CG
// (tolerance 1e-6) matches a dense LDLT solve in double. Float CG on a system of condition
// ~10² (h²k/m ≈ 0.3 against m): the recursively updated residual can drift from the true one by
// ~cond·ε_float; 1e-4 relative covers that with margin.
TEST(ClothImplicit, ConjugateGradientMatchesADenseSolve) {
  const Cloth c = jittered_cloth(7, 3u, 2e-3f);
  const std::size_t nv = c.adjacency.particle_count();
  ImplicitWorkspace w;
  assemble_implicit_system(c.x, c.v, c.adjacency, c.particles, 0.005f, w.system, false);
  std::vector<std::size_t> free_rows;
  for (std::size_t i = 0; i < nv; ++i)
    if (w.system.free[i])
      for (std::size_t k = 0; k < 3; ++k)
        free_rows.push_back(3 * i + k);
  ASSERT_EQ(free_rows.size(), 3 * (nv - 2));
  const auto n = static_cast<Eigen::Index>(free_rows.size());
  Eigen::MatrixXd A(n, n);
  Eigen::VectorXd b(n);
  std::vector<float> unit(3 * nv, 0.0f), column;
  for (Eigen::Index col = 0; col < n; ++col) {
    unit[free_rows[col]] = 1.0f;
    implicit_system_multiply(w.system, c.adjacency, unit, column);
    unit[free_rows[col]] = 0.0f;
    for (Eigen::Index row = 0; row < n; ++row)
      A(row, col) = column[free_rows[row]];
    b(col) = w.system.rhs[free_rows[col]];
  }
  EXPECT_LT((A - A.transpose()).norm(), 1e-6 * A.norm());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(A).eigenvalues().minCoeff(), 0.0);
  const Eigen::VectorXd exact = A.ldlt().solve(b);

  const ImplicitSolveReport r = solve_implicit_system(c.adjacency, ImplicitSolveOptions{1e-6, 500}, w, false);
  EXPECT_TRUE(r.converged) << r.relative_residual;
  EXPECT_GT(r.iterations, 1);
  Eigen::VectorXd cg(n);
  for (Eigen::Index k = 0; k < n; ++k)
    cg(k) = w.dv[free_rows[k]];
  EXPECT_LT((cg - exact).norm(), 1e-4 * exact.norm()) << "after " << r.iterations << " iterations";
  for (std::size_t k = 0; k < 3; ++k) // pinned particles get no velocity change
    EXPECT_EQ(w.dv[k], 0.0f);
}

TEST(ClothImplicit, TbbEqualsSerialBitForBit) {
  const Cloth c = jittered_cloth(120, 5u, 1e-4f); // 14,400 particles: several chunks
  std::vector<float> xs = c.x, vs = c.v, xt = c.x, vt = c.v;
  ImplicitWorkspace ws, wt;
  const ImplicitSolveOptions o{1e-4, 100};
  for (int step = 0; step < 3; ++step) {
    const ImplicitSolveReport a = implicit_euler_step_serial(xs, vs, c.adjacency, c.particles, 1.0f / 120, o, ws);
    const ImplicitSolveReport b = implicit_euler_step_tbb(xt, vt, c.adjacency, c.particles, 1.0f / 120, o, wt);
    EXPECT_EQ(a.iterations, b.iterations);
  }
  EXPECT_TRUE(same_bits(xs, xt));
  EXPECT_TRUE(same_bits(vs, vt));
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(xs[k], c.x[k]) << "pinned particle moved";
}

// Two free masses on a spring at 100× RK4's stable step (where RK4 explodes, see
// ClothRk4.StableStepBoundIsTightForTwoMassesOnASpring): backward Euler's amplification
// 1/(1 + h²ω²) < 1 makes the stretch shrink at every step, never overshoot into growth.
TEST(ClothImplicit, StableAtAHundredTimesTheRk4BoundOnASpring) {
  ClothSprings s;
  s.ends = {0, 1};
  s.rest_lengths = {1.0f};
  s.stiffness = {200.0f};
  s.damping = {0.0f};
  s.kinds = {SpringKind::STRUCTURAL};
  const SpringAdjacency adj = build_spring_adjacency(s, 2);
  ClothParticles particles;
  particles.inverse_masses = {10.0f, 10.0f};
  particles.gravity[1] = 0.0f;
  const float h = float(100.0 * rk4_stable_step(adj, particles).max_step);
  std::vector<float> x = {0, 0, 0, 1.1f, 0, 0}, v(6, 0.0f);
  ImplicitWorkspace w;
  double stretch = 0.1;
  for (int i = 0; i < 50; ++i) {
    implicit_euler_step_serial(x, v, adj, particles, h, ImplicitSolveOptions{1e-6, 50}, w);
    const double now = std::abs(x[3] - x[0] - 1.0);
    EXPECT_LE(now, stretch + 1e-6) << "step " << i;
    stretch = now;
  }
  EXPECT_LT(stretch, 1e-3);
}

// A whole cloth (grid 30 × 30, stiff springs, gravity, two pins) at 100× its RK4 bound: stays
// finite, its springs never stretch beyond 1.5× and its kinetic energy stays below what a free
// fall from the pins over the whole run could give.
TEST(ClothImplicit, ClothStaysBoundedAtAHundredTimesTheRk4Bound) {
  Cloth c = jittered_cloth(30, 9u, 1e-4f);
  std::fill(c.v.begin(), c.v.end(), 0.0f);
  const double h = 100.0 * rk4_stable_step(c.adjacency, c.particles).max_step;
  ImplicitWorkspace w;
  double t = 0;
  for (int i = 0; i < 60; ++i, t += h) {
    implicit_euler_step_tbb(c.x, c.v, c.adjacency, c.particles, float(h), ImplicitSolveOptions{}, w);
    double v2max = 0;
    for (std::size_t p = 0; p < c.adjacency.particle_count(); ++p) {
      double v2 = 0;
      for (int k = 0; k < 3; ++k) {
        ASSERT_TRUE(std::isfinite(c.x[3 * p + k]) && std::isfinite(c.v[3 * p + k])) << "step " << i;
        v2 += double(c.v[3 * p + k]) * c.v[3 * p + k];
      }
      v2max = std::max(v2max, v2);
    }
    EXPECT_LT(std::sqrt(v2max), 9.81 * (t + h) + 1.0) << "step " << i; // g·t plus the initial 0.5 m/s range
  }
  for (std::size_t e = 0; e < c.adjacency.neighbors.size(); ++e) {
    const std::size_t i = std::size_t(std::upper_bound(c.adjacency.offsets.begin(), c.adjacency.offsets.end(),
                                                       std::int32_t(e)) -
                                      c.adjacency.offsets.begin() - 1);
    const std::size_t j = std::size_t(c.adjacency.neighbors[e]);
    double l2 = 0;
    for (int k = 0; k < 3; ++k)
      l2 += std::pow(double(c.x[3 * j + k]) - c.x[3 * i + k], 2);
    EXPECT_LT(std::sqrt(l2), 1.5 * c.adjacency.rest_lengths[e]);
  }
  EXPECT_GT(t, 0.3); // the run covered a real fall, not a few microseconds
}

} // namespace
} // namespace vfit
