// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/laplacian.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "vfit/geometry/garment/laplacian_deformation.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/least_squares.h"
#include "vfit/kernels/supernodal_least_squares.h"
#include "vfit/kernels/two_grid_least_squares.h"

namespace vfit {
namespace {

TEST(Laplacian, ConstantsAreInTheKernelAndTheOperatorIsSymmetric) {
  const Mesh m = make_uv_sphere(12, 20, 0.3f);
  for (const SparseMatrix& L : {uniform_laplacian(m.triangle_view(), m.vertex_count()),
                                cotangent_laplacian(m.position_view(), m.triangle_view())}) {
    const Eigen::VectorXd ones = Eigen::VectorXd::Ones(L.cols());
    EXPECT_LT((L * ones).cwiseAbs().maxCoeff(), 1e-12); // rows sum to zero exactly up to rounding
    const SparseMatrix diff = SparseMatrix(L.transpose()) - L;
    EXPECT_LT(diff.cwiseAbs().sum(), 1e-9);
    for (Eigen::Index i = 0; i < L.rows(); ++i)
      EXPECT_GT(L.coeff(i, i), 0.0); // a sphere has no obtuse pairs
  }
}

// The uniform Laplacian against a dense oracle built edge by edge from the faces: degree on the
// diagonal, −1 per distinct neighbour; a face with a repeated vertex adds only its real edge,
// an unused vertex gets an empty row (0 on the diagonal). Exact: the entries are integers.
TEST(Laplacian, UniformMatchesADenseAdjacencyOracle) {
  Mesh m = make_uv_sphere(7, 11, 0.3f);
  const std::int32_t n = std::int32_t(m.vertex_count());
  m.positions.insert(m.positions.end(), {5.0f, 5.0f, 5.0f}); // an isolated vertex n
  std::vector<std::int32_t> triangles = m.triangles;
  triangles.insert(triangles.end(), {0, 0, 5, 3, 9, 3}); // repeated vertices: edges 0–5 and 3–9 only
  const std::size_t count = std::size_t(n) + 1;
  Eigen::MatrixXd oracle = Eigen::MatrixXd::Zero(Eigen::Index(count), Eigen::Index(count));
  for (std::size_t f = 0; f < triangles.size() / 3; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = triangles[3 * f + std::size_t(k)], b = triangles[3 * f + std::size_t(k + 1) % 3];
      if (a != b) oracle(a, b) = oracle(b, a) = -1.0;
    }
  for (Eigen::Index i = 0; i < oracle.rows(); ++i)
    oracle(i, i) = -(oracle.row(i).sum() - oracle(i, i));
  const SparseMatrix L = uniform_laplacian(triangles, count);
  ASSERT_EQ(L.rows(), Eigen::Index(count));
  EXPECT_EQ((Eigen::MatrixXd(L) - oracle).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_TRUE(L.isCompressed());
  for (Eigen::Index r = 0; r < L.outerSize(); ++r) { // columns strictly ascending in every row
    Eigen::Index previous = -1;
    for (SparseMatrix::InnerIterator it(L, r); it; ++it) {
      EXPECT_GT(it.col(), previous);
      previous = it.col();
    }
  }
}

TEST(Laplacian, CotangentWeightsReproduceLinearFunctionsOnAFlatGrid) {
  // On a planar mesh the cotangent Laplacian of a linear function vanishes at interior
  // vertices (discrete harmonicity); the uniform one does not on an irregular grid.
  Mesh m = make_grid(9, 9, 1.0f, 1.0f);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const int i = int(v) / 9, j = int(v) % 9;
    if (i > 0 && i < 8 && j > 0 && j < 8) {
      m.positions[3 * v] += jitter(rng);
      m.positions[3 * v + 2] += jitter(rng);
    }
  }
  const SparseMatrix L = cotangent_laplacian(m.position_view(), m.triangle_view());
  Eigen::VectorXd f(m.vertex_count());
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    f[v] = 2.0 * m.positions[3 * v] - 3.0 * m.positions[3 * v + 2] + 1.0;
  const Eigen::VectorXd Lf = L * f;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const int i = int(v) / 9, j = int(v) % 9;
    if (i > 0 && i < 8 && j > 0 && j < 8) {
      EXPECT_NEAR(Lf[v], 0.0, 1e-5) << "vertex " << v; // float positions
    }
  }
}

TEST(SparseLeastSquares, MatchesADenseQrOracleAndReportsRankDeficiency) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Triplet<double>> t;
  for (int r = 0; r < 60; ++r)
    for (int c = 0; c < 20; ++c)
      if (u(rng) > 0.5) t.emplace_back(r, c, u(rng));
  for (int c = 0; c < 20; ++c)
    t.emplace_back(60 + c, c, 1.0); // full column rank
  SparseMatrix A(80, 20);
  A.setFromTriplets(t.begin(), t.end());
  Eigen::MatrixXd b(80, 3);
  for (int i = 0; i < b.size(); ++i)
    b.data()[i] = u(rng);
  const SparseLeastSquares ls(A);
  ASSERT_TRUE(ls.ok());
  const Eigen::MatrixXd x = ls.solve(b);
  const Eigen::MatrixXd oracle = Eigen::MatrixXd(A).colPivHouseholderQr().solve(b);
  EXPECT_LT((x - oracle).cwiseAbs().maxCoeff(), 1e-9); // well conditioned: LDLᵀ and QR agree
  SparseMatrix rank_deficient(10, 3);
  rank_deficient.insert(0, 0) = 1.0;
  rank_deficient.insert(1, 1) = 1.0; // column 2 is empty
  EXPECT_FALSE(SparseLeastSquares(rank_deficient).ok());
}

TEST(SparseLeastSquares, PivotsAreRegularOnlyAboveTheRatioOfTheLargest) {
  EXPECT_TRUE(ldlt_pivots_regular(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(ldlt_pivots_regular(Eigen::VectorXd()));                 // a 0 × 0 system
  EXPECT_FALSE(ldlt_pivots_regular(Eigen::Vector2d(1, 0)));            // a zero pivot: singular
  EXPECT_FALSE(ldlt_pivots_regular(Eigen::Vector2d(1, -1e-3)));        // PSD input never pivots below 0
  EXPECT_FALSE(ldlt_pivots_regular(Eigen::Vector2d(1e6, 1e-7)));       // ratio 1e-13
  EXPECT_TRUE(ldlt_pivots_regular(Eigen::Vector2d(1e6, 1e-5)));        // ratio 1e-11
  EXPECT_FALSE(ldlt_pivots_regular(Eigen::Vector2d(1e-3, 1e-13)));     // the scale is at least 1
  EXPECT_FALSE(ldlt_pivots_regular(Eigen::Vector2d(1, std::nan("")))); // NaNs: not regular
}

// CHOLMOD's supernodal factor solves the same normal equations; its own singularity bar
// (reciprocal condition 1e-6) refuses the same rank-deficient system.
TEST(SupernodalLeastSquares, AgreesWithTheSimplicialSolverAndReportsRankDeficiency) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Triplet<double>> t;
  for (int r = 0; r < 90; ++r)
    for (int c = 0; c < 30; ++c)
      if (u(rng) > 0.6) t.emplace_back(r, c, u(rng));
  for (int c = 0; c < 30; ++c)
    t.emplace_back(90 + c, c, 1.0); // full column rank
  SparseMatrix A(120, 30);
  A.setFromTriplets(t.begin(), t.end());
  Eigen::MatrixXd b(120, 3);
  for (int i = 0; i < b.size(); ++i)
    b.data()[i] = u(rng);
  const SupernodalLeastSquares supernodal(A);
  const SparseLeastSquares simplicial(A);
  ASSERT_TRUE(supernodal.ok());
  ASSERT_TRUE(simplicial.ok());
  // Well conditioned (the identity rows): both factorisations agree to round-off.
  EXPECT_LT((supernodal.solve(b) - simplicial.solve(b)).cwiseAbs().maxCoeff(), 1e-9);
  SparseMatrix rank_deficient(10, 3);
  rank_deficient.insert(0, 0) = 1.0;
  rank_deficient.insert(1, 1) = 1.0; // column 2 is empty
  EXPECT_FALSE(SupernodalLeastSquares(rank_deficient).ok());
}

// The free band of a tube (rings × segments, 0.4 m long) whose bottom and top fifths are
// handles, the top sheared 5 cm: A = L[rows, free] (cotangent Laplacian), b = L x_rest − L[rows,
// handles] t, near_null = [1 x y z] of the free vertices (the system BandLaplacianDeformer solves).
struct TubeBand {
  SparseMatrix A;
  Eigen::MatrixXd b, near_null;
  TubeBand(int rings, int segments, bool with_handles = true) {
    const Mesh tube = make_tube(rings, segments, 0.05f, 0.4f);
    const SparseMatrix L = cotangent_laplacian(tube.positions, tube.triangles);
    const auto nv = static_cast<Eigen::Index>(tube.vertex_count());
    std::vector<std::int32_t> column(static_cast<std::size_t>(nv), -1);
    Eigen::MatrixXd x(nv, 3), t = Eigen::MatrixXd::Zero(nv, 3);
    std::vector<Eigen::Index> free;
    for (Eigen::Index v = 0; v < nv; ++v) {
      x.row(v) << tube.positions[3 * v], tube.positions[3 * v + 1], tube.positions[3 * v + 2];
      const bool handle = with_handles && (x(v, 1) < 0.08 || x(v, 1) > 0.32);
      if (handle) {
        t.row(v) = x.row(v) + Eigen::RowVector3d(x(v, 1) > 0.32 ? 0.05 : 0.0, 0, 0);
      } else {
        column[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(free.size());
        free.push_back(v);
      }
    }
    std::vector<Eigen::Triplet<double>> entries;
    for (Eigen::Index r = 0; r < L.outerSize(); ++r)
      for (SparseMatrix::InnerIterator it(L, r); it; ++it)
        if (column[static_cast<std::size_t>(it.col())] >= 0)
          entries.emplace_back(r, column[static_cast<std::size_t>(it.col())], it.value());
    A.resize(nv, static_cast<Eigen::Index>(free.size()));
    A.setFromTriplets(entries.begin(), entries.end());
    b = L * x - L * t; // t is zero on the free vertices
    near_null.resize(static_cast<Eigen::Index>(free.size()), 4);
    for (std::size_t f = 0; f < free.size(); ++f)
      near_null.row(static_cast<Eigen::Index>(f)) << 1.0, x.row(free[f]);
  }
};

double worst_row_distance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).rowwise().norm().maxCoeff();
}

// The two-grid CG solves the band's least squares to its tolerance: against CHOLMOD's exact
// factorisation, and with an iteration count that does not grow with the resolution (the
// coarse space carries the linear functions; were it missing them, or the cycle not SPD, the
// 4× finer tube would need far more iterations or stall).
TEST(TwoGridLeastSquares, AgreesWithTheFactorisationAndKeepsItsIterationsUnderRefinement) {
  int iterations[2] = {};
  for (int level = 0; level < 2; ++level) {
    const TubeBand band(level == 0 ? 100 : 200, level == 0 ? 50 : 100);
    const TwoGridLeastSquares two_grid(band.A, band.near_null);
    const SupernodalLeastSquares exact(band.A);
    ASSERT_TRUE(two_grid.ok() && exact.ok());
    // Aggregates of about two rings: several unknowns per coarse function.
    EXPECT_LT(two_grid.coarse_unknowns(), static_cast<std::size_t>(band.A.cols()) / 2);
    const Eigen::MatrixXd reference = exact.solve(band.b);
    Eigen::MatrixXd x; // from zeros
    const IterativeSolveStats stats = two_grid.solve(band.b, x, 1e-9, 200);
    EXPECT_TRUE(stats.converged);
    EXPECT_FALSE(stats.fell_back);
    EXPECT_LE(stats.relative_residual, 1e-9);
    iterations[level] = stats.iterations;
    // A 1e-9 normal-equations residual on this 0.4 m tube: measured 4e-9 m and 8e-9 m from the
    // factorisation (which moves vertices up to 5 cm); 1e-7 m leaves room for other compilers'
    // round-off, not for a missed iteration (1e-5 m at a 1e-7 residual).
    EXPECT_LT(worst_row_distance(x, reference), 1e-7);
    EXPECT_GT(reference.cwiseAbs().maxCoeff(), 0.01);
  }
  EXPECT_GT(iterations[0], 0);
  // Mesh-independent convergence: 4× the unknowns, at most a few iterations more (measured
  // 26 and 23).
  EXPECT_LE(iterations[1], iterations[0] + 5);
}

// Columns beyond three are solved in further groups, a zero column stays zero, and the
// iteration limit is honoured with converged false.
TEST(TwoGridLeastSquares, SolvesManyColumnsAndReportsTheIterationLimit) {
  const TubeBand band(60, 30);
  const TwoGridLeastSquares two_grid(band.A, band.near_null);
  ASSERT_TRUE(two_grid.ok());
  Eigen::MatrixXd b(band.b.rows(), 5);
  b << band.b, Eigen::VectorXd::Zero(band.b.rows()), band.b.col(0);
  Eigen::MatrixXd x;
  const IterativeSolveStats stats = two_grid.solve(b, x, 1e-9, 200);
  ASSERT_TRUE(stats.converged);
  EXPECT_EQ(x.cols(), 5);
  EXPECT_EQ(x.col(3).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::MatrixXd reference = SupernodalLeastSquares(band.A).solve(b);
  EXPECT_LT((x - reference).cwiseAbs().maxCoeff(), 1e-7); // as in the test above (measured 3e-9 m)
  Eigen::MatrixXd y;
  const IterativeSolveStats limited = two_grid.solve(band.b, y, 1e-9, 2);
  EXPECT_FALSE(limited.converged);
  EXPECT_EQ(limited.iterations, 2);
  EXPECT_GT(limited.relative_residual, 1e-9);
}

// A band with no handle at all: the constant is in AᵀA's kernel and in the coarse space, so
// the coarse factorisation refuses it.
TEST(TwoGridLeastSquares, ReportsASingularSystem) {
  const TubeBand band(40, 20, false);
  EXPECT_FALSE(TwoGridLeastSquares(band.A, band.near_null).ok());
  EXPECT_FALSE(SupernodalLeastSquares(band.A).ok());
}

TEST(LaplacianDeformer, KeepsTheShapeFollowsHandlesAndReusesItsFactorisation) {
  const Mesh tube = make_tube(20, 16, 0.05f, 0.5f);
  std::vector<std::int32_t> handles;
  for (int j = 0; j < 16; ++j) {
    handles.push_back(j);           // bottom ring
    handles.push_back(19 * 16 + j); // top ring
  }
  const LaplacianDeformer deformer(tube, handles, 10.0);
  ASSERT_TRUE(deformer.ok());
  const Eigen::MatrixXd delta = deformer.laplacian_coordinates(tube.positions);
  Eigen::MatrixXd targets(handles.size(), 3);
  for (std::size_t k = 0; k < handles.size(); ++k)
    for (int c = 0; c < 3; ++c)
      targets(k, c) = tube.positions[3 * handles[k] + c];
  // Targets at rest: the rest shape comes back.
  std::vector<float> out = deformer.deform(delta, targets);
  for (std::size_t i = 0; i < out.size(); ++i)
    ASSERT_NEAR(out[i], tube.positions[i], 1e-5);
  // Every target moved by the same offset: the whole tube translates (δ is translation-free).
  Eigen::MatrixXd moved = targets;
  moved.rowwise() += Eigen::RowVector3d(0.1, -0.2, 0.3);
  out = deformer.deform(delta, moved);
  for (std::size_t v = 0; v < tube.vertex_count(); ++v) {
    ASSERT_NEAR(out[3 * v], tube.positions[3 * v] + 0.1, 1e-5);
    ASSERT_NEAR(out[3 * v + 1], tube.positions[3 * v + 1] - 0.2, 1e-5);
  }
  // Only the top ring moves sideways: the middle follows part of the way, smoothly.
  Eigen::MatrixXd shear = targets;
  for (std::size_t k = 1; k < handles.size(); k += 2)
    shear(k, 0) += 0.1;
  out = deformer.deform(delta, shear);
  const std::size_t mid = 10 * 16;
  EXPECT_GT(out[3 * mid] - tube.positions[3 * mid], 0.02);
  EXPECT_LT(out[3 * mid] - tube.positions[3 * mid], 0.08);
}

} // namespace
} // namespace vfit
