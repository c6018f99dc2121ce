// SPDX-License-Identifier: Apache-2.0
// The two-level preconditioner of the implicit solve (ImplicitPreconditioner::TWO_LEVEL).
#include <cmath>
#include <cstring>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "jittered_cloth.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/cloth_gather.h"
#include "vfit/kernels/cloth_implicit.h"

namespace vfit {
namespace {

using Cloth = JitteredCloth; // tests/support/jittered_cloth.h

// Dense 3·#V matrices of the filter S, the filtered operator S·A·S and the preconditioner M⁻¹
// (columns by apply_implicit_preconditioner on unit vectors).
struct Dense {
  Eigen::MatrixXd S, A, M;
};

Dense dense_operators(const Cloth& c, ImplicitWorkspace& w, const ImplicitSolveOptions& o,
                      const ImplicitConstraints* k) {
  const std::size_t nv = c.adjacency.particle_count();
  const auto n = Eigen::Index(3 * nv);
  Dense d{Eigen::MatrixXd::Zero(n, n), Eigen::MatrixXd::Zero(n, n), Eigen::MatrixXd::Zero(n, n)};
  for (std::size_t i = 0; i < nv; ++i) {
    if (!w.system.free[i]) continue;
    Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
    if (k != nullptr) {
      const Eigen::Vector3d nn(k->normals[3 * i], k->normals[3 * i + 1], k->normals[3 * i + 2]);
      s -= nn * nn.transpose();
    }
    d.S.block(Eigen::Index(3 * i), Eigen::Index(3 * i), 3, 3) = s;
  }
  std::vector<float> unit(3 * nv, 0.0f), column;
  for (Eigen::Index col = 0; col < n; ++col) {
    unit[std::size_t(col)] = 1.0f;
    implicit_system_multiply(w.system, c.adjacency, unit, column);
    for (Eigen::Index row = 0; row < n; ++row)
      d.A(row, col) = column[std::size_t(row)];
    unit[std::size_t(col)] = 0.0f;
  }
  d.A = d.S * d.A * d.S;
  for (Eigen::Index col = 0; col < n; ++col) {
    unit[std::size_t(col)] = 1.0f;
    apply_implicit_preconditioner(c.adjacency, o, w, unit, column, k);
    for (Eigen::Index row = 0; row < n; ++row)
      d.M(row, col) = column[std::size_t(row)];
    unit[std::size_t(col)] = 0.0f;
  }
  return d;
}

// The two-level preconditioner against its definition, built densely in double: M⁻¹ = S·D⁻¹·S
// + S·P₀·(P₀ᵀ·S·A·S·P₀)⁻¹·P₀ᵀ·S, P₀ the translations of aggregates of 16 consecutive particles
// (the first 16 rows of the 12 × 12 grid: 9 aggregates), D the diagonal blocks. Without and with
// contact normals (every third particle). The apply is float (its inputs are the float system,
// its output rounded to float), the coarse solve in double: relative 1e-5 of ‖M⁻¹‖. It is
// symmetric to that rounding and positive definite on the free directions: the smallest
// eigenvalue of M⁻¹ restricted to range(S) (S·M⁻¹·S + (I − S)) is positive.
TEST(ClothImplicitTwoLevel, PreconditionerIsItsDefinitionAndSymmetricPositiveDefinite) {
  const Cloth c = jittered_cloth(12, 21u, 2e-3f);
  const std::size_t nv = c.adjacency.particle_count();
  ImplicitSolveOptions o;
  o.preconditioner = ImplicitPreconditioner::TWO_LEVEL;
  o.aggregate_particles = 16;
  const ImplicitConstraints k = random_constraints(c, 22u, 0.1f);
  for (const ImplicitConstraints* constraints : {static_cast<const ImplicitConstraints*>(nullptr), &k}) {
    ImplicitWorkspace w;
    assemble_implicit_system(c.x, c.v, c.adjacency, c.particles, 0.005f, w.system, false);
    const Dense d = dense_operators(c, w, o, constraints);
    const auto n = Eigen::Index(3 * nv);
    Eigen::MatrixXd Dinv = Eigen::MatrixXd::Zero(n, n);
    for (std::size_t i = 0; i < nv; ++i) {
      if (!w.system.free[i]) continue;
      const float* b = w.system.diagonal.data() + 6 * i;
      Eigen::Matrix3d block;
      block << b[0], b[1], b[2], b[1], b[3], b[4], b[2], b[4], b[5];
      // The block-Jacobi part as ImplicitSystem::preconditioner defines it: A_ii shifted by
      // 2⁻¹⁸ of its springs' trace (tr A_ii − 3·m_i), which keeps a light particle's float
      // inverse positive definite.
      block += Eigen::Matrix3d::Identity() * (0x1p-18 * (block.trace() - 3.0 * w.system.inertia[i]));
      Dinv.block(Eigen::Index(3 * i), Eigen::Index(3 * i), 3, 3) = block.inverse();
    }
    std::size_t aggregates = 0;
    const std::vector<std::int32_t> label = implicit_coarse_aggregates(c.adjacency, o, aggregates);
    Eigen::MatrixXd P0 = Eigen::MatrixXd::Zero(n, Eigen::Index(3 * aggregates));
    for (std::size_t i = 0; i < nv; ++i)
      for (Eigen::Index a = 0; a < 3; ++a)
        P0(Eigen::Index(3 * i) + a, Eigen::Index(3 * std::size_t(label[i])) + a) = 1.0;
    const Eigen::MatrixXd P = d.S * P0;
    const Eigen::MatrixXd coarse = P.transpose() * d.A * P;
    const Eigen::MatrixXd expected = d.S * Dinv * d.S + P * coarse.ldlt().solve(P.transpose());
    const double scale = expected.norm();
    EXPECT_LT((d.M - expected).norm(), 1e-5 * scale) << (constraints ? "with contacts" : "no contacts");
    EXPECT_LT((d.M - d.M.transpose()).norm(), 1e-5 * scale);
    const Eigen::MatrixXd on_free =
        d.S * (0.5 * (d.M + d.M.transpose())) * d.S + (Eigen::MatrixXd::Identity(n, n) - d.S);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(on_free).eigenvalues().minCoeff(), 0.0);
    // Random vectors: rᵀ·M⁻¹·r > 0 for every filtered r ≠ 0.
    std::mt19937 rng(23u);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (int t = 0; t < 20; ++t) {
      Eigen::VectorXd r(n);
      for (Eigen::Index q = 0; q < n; ++q)
        r(q) = gauss(rng);
      r = d.S * r;
      EXPECT_GT(r.dot(d.M * r), 0.0) << "vector " << t;
    }
  }
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

ImplicitSolveOptions two_level(double tolerance, int max_iterations) {
  ImplicitSolveOptions o{tolerance, max_iterations};
  o.preconditioner = ImplicitPreconditioner::TWO_LEVEL;
  return o;
}

// Two-level CG (tolerance 1e-6) against a dense LDLT solve in double of the free rows, as
// ClothImplicit.ConjugateGradientMatchesADenseSolve does for block Jacobi: the same 1e-4
// relative bound (float CG's residual drift, ~cond·ε_float, with margin). With contact
// constraints, against block-Jacobi CG at 1e-6 (itself checked against the dense KKT solve in
// ClothImplicit.ConstrainedSolveMatchesADenseKktSolve): 2e-4 relative, both drifts added.
TEST(ClothImplicitTwoLevel, ConjugateGradientMatchesADenseSolveAndBlockJacobi) {
  const Cloth c = jittered_cloth(12, 3u, 2e-3f);
  const std::size_t nv = c.adjacency.particle_count();
  ImplicitWorkspace w;
  assemble_implicit_system(c.x, c.v, c.adjacency, c.particles, 0.005f, w.system, false);
  const DenseFreeSystem dense = dense_free_system(w.system, c.adjacency);
  const std::vector<std::size_t>& free_rows = dense.free_rows;
  const auto n = static_cast<Eigen::Index>(free_rows.size());
  const Eigen::MatrixXd& A = dense.A;
  const Eigen::VectorXd& b = dense.b;
  const Eigen::VectorXd exact = A.ldlt().solve(b);
  const ImplicitSolveReport r = solve_implicit_system(c.adjacency, two_level(1e-6, 500), w, false);
  EXPECT_TRUE(r.converged) << r.relative_residual;
  Eigen::VectorXd cg(n);
  for (Eigen::Index k = 0; k < n; ++k)
    cg(k) = w.dv[free_rows[std::size_t(k)]];
  EXPECT_LT((cg - exact).norm(), 1e-4 * exact.norm()) << "after " << r.iterations << " iterations";
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_EQ(w.dv[k], 0.0f); // pinned

  const ImplicitConstraints k = random_constraints(c, 4u, 0.1f);
  ImplicitWorkspace wb;
  wb.system = w.system;
  const ImplicitSolveReport rt = solve_implicit_system(c.adjacency, two_level(1e-6, 500), w, false, &k);
  const ImplicitSolveReport rb = solve_implicit_system(c.adjacency, ImplicitSolveOptions{1e-6, 500}, wb, false, &k);
  ASSERT_TRUE(rt.converged && rb.converged) << rt.relative_residual << " " << rb.relative_residual;
  double diff = 0, norm = 0;
  for (std::size_t q = 0; q < 3 * nv; ++q) {
    diff += std::pow(double(w.dv[q]) - wb.dv[q], 2);
    norm += std::pow(double(wb.dv[q]), 2);
  }
  EXPECT_LT(std::sqrt(diff), 2e-4 * std::sqrt(norm));
  double impulse_diff = 0, impulse_norm = 0;
  for (std::size_t i = 0; i < nv; ++i) {
    impulse_diff += std::pow(double(w.normal_impulses[i]) - wb.normal_impulses[i], 2);
    impulse_norm += std::pow(double(wb.normal_impulses[i]), 2);
  }
  EXPECT_LT(std::sqrt(impulse_diff), 2e-3 * std::sqrt(impulse_norm)); // a residual-sized difference (see the KKT test)
}

// A stiff cloth (h²·k/m ≈ 300: light particles, a long step), where block Jacobi's iterations
// grow with the grid: the two-level preconditioner needs fewer at every size, and its advantage
// grows with refinement (measured at tolerance 1e-6: 39 against 126 on 24 × 24, 38 against 180
// on 48 × 48; the two-level count stays flat).
TEST(ClothImplicitTwoLevel, FewerIterationsThanBlockJacobiOnARefinedGrid) {
  double previous_ratio = 1.0;
  for (const int n : {24, 48}) {
    const Cloth c = jittered_cloth(n, 31u, 1e-4f);
    ImplicitWorkspace wb, wt;
    assemble_implicit_system(c.x, c.v, c.adjacency, c.particles, 0.01f, wb.system, false);
    wt.system = wb.system;
    const ImplicitSolveReport rb = solve_implicit_system(c.adjacency, ImplicitSolveOptions{1e-6, 2000}, wb, false);
    const ImplicitSolveReport rt = solve_implicit_system(c.adjacency, two_level(1e-6, 2000), wt, false);
    ASSERT_TRUE(rb.converged && rt.converged);
    const double ratio = double(rt.iterations) / double(rb.iterations);
    EXPECT_LT(rt.iterations, rb.iterations) << n << " × " << n;
    EXPECT_LT(ratio, previous_ratio) << n << " × " << n << ": " << rt.iterations << " against " << rb.iterations;
    RecordProperty("iterations_" + std::to_string(n),
                   std::to_string(rt.iterations) + " / " + std::to_string(rb.iterations));
    previous_ratio = ratio;
  }
}

// TWO_LEVEL and AUTO keep the drivers' contract: the TBB driver gives the serial bits (the
// aggregation is serial; the coarse assembly and restriction sum each aggregate in one task in
// member order; the coarse factorisation and solve are serial), with and without constraints.
// AUTO (tolerance 1e-4) switches on the stiff cloth (block Jacobi takes more than 16
// iterations) after its first step, and then needs fewer iterations than block Jacobi does; on
// the soft one (heavier particles: fewer) it stays block Jacobi, bit for bit.
TEST(ClothImplicitTwoLevel, TbbEqualsSerialBitForBitAndAutoSwitchesOnStiffCloth) {
  const Cloth c = jittered_cloth(120, 5u, 1e-4f); // 14,400 particles: several chunks and aggregate blocks
  const ImplicitConstraints k = random_constraints(c, 6u, 0.1f);
  for (const ImplicitPreconditioner p : {ImplicitPreconditioner::TWO_LEVEL, ImplicitPreconditioner::AUTO})
    for (const ImplicitConstraints* constraints : {static_cast<const ImplicitConstraints*>(nullptr), &k}) {
      std::vector<float> xs = c.x, vs = c.v, xt = c.x, vt = c.v;
      ImplicitWorkspace ws, wt;
      ImplicitSolveOptions o{1e-4, 100};
      o.preconditioner = p;
      for (int step = 0; step < 3; ++step) {
        const ImplicitSolveReport a =
            implicit_euler_step_serial(xs, vs, c.adjacency, c.particles, 1.0f / 60, o, ws, constraints);
        const ImplicitSolveReport b =
            implicit_euler_step_tbb(xt, vt, c.adjacency, c.particles, 1.0f / 60, o, wt, constraints);
        EXPECT_EQ(a.iterations, b.iterations) << "step " << step;
      }
      EXPECT_TRUE(same_bits(xs, xt));
      EXPECT_TRUE(same_bits(vs, vt));
      if (constraints != nullptr) {
        EXPECT_TRUE(same_bits(ws.normal_impulses, wt.normal_impulses));
      }
    }
  // AUTO against block Jacobi, step by step.
  for (const float mass : {1e-4f, 1.0f}) {
    const Cloth d = jittered_cloth(40, 7u, mass);
    std::vector<float> xa = d.x, va = d.v, xb = d.x, vb = d.v;
    ImplicitWorkspace wa, wb;
    ImplicitSolveOptions automatic{1e-4, 200};
    automatic.preconditioner = ImplicitPreconditioner::AUTO;
    const ImplicitSolveReport a0 =
        implicit_euler_step_serial(xa, va, d.adjacency, d.particles, 1.0f / 60, automatic, wa);
    const ImplicitSolveReport b0 =
        implicit_euler_step_serial(xb, vb, d.adjacency, d.particles, 1.0f / 60, ImplicitSolveOptions{1e-4, 200}, wb);
    EXPECT_EQ(a0.iterations, b0.iterations) << "mass " << mass; // the first step is block Jacobi's
    EXPECT_TRUE(same_bits(xa, xb));
    const ImplicitSolveReport a1 =
        implicit_euler_step_serial(xa, va, d.adjacency, d.particles, 1.0f / 60, automatic, wa);
    const ImplicitSolveReport b1 =
        implicit_euler_step_serial(xb, vb, d.adjacency, d.particles, 1.0f / 60, ImplicitSolveOptions{1e-4, 200}, wb);
    // Both branches are taken: the light cloth is the stiff one.
    EXPECT_EQ(b0.iterations > automatic.two_level_after, mass < 1e-3f) << "mass " << mass << ": " << b0.iterations;
    if (b0.iterations > automatic.two_level_after) {
      EXPECT_LT(a1.iterations, b1.iterations) << "mass " << mass;
    } else {
      EXPECT_EQ(a1.iterations, b1.iterations) << "mass " << mass;
      EXPECT_TRUE(same_bits(xa, xb)) << "mass " << mass;
    }
    RecordProperty("auto_first_step_iterations_" + std::to_string(mass), std::to_string(b0.iterations));
  }
}

} // namespace
} // namespace vfit
