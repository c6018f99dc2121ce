// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/region_least_squares.h"

#include <cmath>

#include <Eigen/SparseCholesky>
#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/laplacian.h"

namespace vfit {
namespace {

// A tube's uniform Laplacian: every vertex has valence 6 away from the rims, so k rings around a
// vertex hold a known, growing number of vertices.
SparseMatrix tube_laplacian(std::size_t& vertex_count) {
  const Mesh tube = make_tube(30, 40, 0.1f, 0.5f);
  vertex_count = tube.vertex_count();
  return uniform_laplacian(tube.triangle_view(), vertex_count);
}

TEST(RegionLeastSquares, RingsGrowOverTheStencilAndTheRowsReachOneRingFurther) {
  std::size_t nv = 0;
  const SparseMatrix L = tube_laplacian(nv);
  std::vector<char> seeds(nv, 0);
  seeds[nv / 2] = 1;
  const SolveRegion r0 = make_solve_region(L, seeds, 0);
  EXPECT_EQ(r0.vertices.size(), 1u);
  EXPECT_EQ(r0.rows.size(), 7u); // the seed and its six neighbours
  const SolveRegion r2 = make_solve_region(L, seeds, 2);
  EXPECT_EQ(r2.vertices.size(), 19u); // 1 + 6 + 12 on a valence-6 mesh
  EXPECT_TRUE(r2.covers(seeds));
  for (std::size_t k = 0; k < r2.vertices.size(); ++k) {
    EXPECT_EQ(r2.column[r2.vertices[k]], std::int32_t(k));
    EXPECT_EQ(r2.moves[r2.vertices[k]], 1);
  }
  std::vector<char> far(nv, 0);
  far[0] = 1;
  EXPECT_FALSE(r2.covers(far));
  EXPECT_TRUE(make_solve_region(L, std::vector<char>(nv, 0), 3).vertices.empty());
}

// Both solves against a dense solve of (c·I + w·L_RᵀL_R) δ = rhs, the matrix built independently
// from the region's rows and columns of L. The factorisation is exact to rounding (1e-10 on
// values of order 1); CG to a 1e-10 relative residual of a matrix whose condition number is
// below 200 leaves an error under 200 · 1e-10 relative.
TEST(RegionLeastSquares, FactoredAndConjugateGradientSolvesAgreeWithADenseSolve) {
  std::size_t nv = 0;
  const SparseMatrix L = tube_laplacian(nv);
  std::vector<char> seeds(nv, 0);
  for (std::size_t v = nv / 3; v < nv / 3 + 40; ++v)
    seeds[v] = 1;
  const SolveRegion region = make_solve_region(L, seeds, 4);
  const auto n = Eigen::Index(region.vertices.size());
  const auto m = Eigen::Index(region.rows.size());
  Eigen::MatrixXd LR = Eigen::MatrixXd::Zero(m, n);
  for (Eigen::Index r = 0; r < m; ++r)
    for (SparseMatrix::InnerIterator it(L, Eigen::Index(region.rows[std::size_t(r)])); it; ++it)
      if (const std::int32_t c = region.column[std::size_t(it.col())]; c >= 0) LR(r, c) = it.value();
  for (const auto& [c, w] : {std::pair{1.0, 1.0}, std::pair{1.8, 6.0}}) {
    const Eigen::MatrixXd M = c * Eigen::MatrixXd::Identity(n, n) + w * LR.transpose() * LR;
    const Eigen::MatrixXd rhs = Eigen::MatrixXd::Random(n, 3);
    const Eigen::MatrixXd want = M.ldlt().solve(rhs);
    int iterations = -1;
    const RegionSystem factored(L, region, c, w, true, 1e-10);
    EXPECT_TRUE(factored.factored());
    EXPECT_LT((factored.solve(rhs, iterations) - want).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_EQ(iterations, 0);
    const RegionSystem cg(L, region, c, w, false, 1e-10);
    EXPECT_FALSE(cg.factored());
    EXPECT_LT((cg.solve(rhs, iterations) - want).cwiseAbs().maxCoeff(), 1e-7 * want.cwiseAbs().maxCoeff());
    EXPECT_GT(iterations, 0);
    EXPECT_LT(iterations, 200);
    // transpose_times: w·L_Rᵀ g.
    const Eigen::MatrixXd g = Eigen::MatrixXd::Random(m, 3);
    EXPECT_LT((factored.transpose_times(g) - w * LR.transpose() * g).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_EQ(factored.rows(), m);
  }
}

TEST(RegionLeastSquares, ANonPositiveSystemIsRefused) {
  std::size_t nv = 0;
  const SparseMatrix L = tube_laplacian(nv);
  std::vector<char> seeds(nv, 0);
  seeds[nv / 2] = 1;
  const SolveRegion region = make_solve_region(L, seeds, 2);
  EXPECT_THROW(RegionSystem(L, region, 0.0, 0.0, true, 1e-3), Error); // the zero matrix
}

} // namespace
} // namespace vfit
