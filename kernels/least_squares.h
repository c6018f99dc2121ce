// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Sparse linear least squares with a reused factorisation: the solver behind Laplacian surface
/// deformation (seed 000 §5.4), penetration removal (seed 000 eq. 19–21; seed 004 §3.2.2, one
/// factorisation for up to three iterations) and skeleton contraction (§5.1).

#include <memory>

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "laplacian.h"

namespace vfit {

/// The pivot ratio below which an LDLᵀ factorisation of a symmetric positive semi-definite
/// matrix counts as singular (ldlt_pivots_regular()).
inline constexpr double LDLT_PIVOT_RATIO = 1e-12;

/// Whether the pivots D (#N) of an LDLᵀ factorisation of a symmetric positive semi-definite
/// matrix show it regular: the smallest above LDLT_PIVOT_RATIO × max(1, largest |pivot|).
/// Eigen's LDLᵀ of a singular PSD matrix "succeeds" with zero or round-off pivots (a
/// Laplacian system with an unconstrained connected piece), so this is the check after
/// info() == Success. Non-finite pivots (NaN input) give false; no pivots (a 0 × 0 matrix) give true.
bool ldlt_pivots_regular(const Eigen::VectorXd& pivots);

/// min_x ‖A x − b‖² for a fixed sparse A (#R × #N, full column rank) and any number of
/// right-hand sides: AᵀA is factored once (sparse LDLᵀ with fill-reducing ordering) and each
/// solve() costs two triangular solves. Columns of b are solved independently (x, y, z).
class SparseLeastSquares {
public:
  /// Factors AᵀA. ok() is false when it is singular (ldlt_pivots_regular() fails: A lacks full
  /// column rank, e.g. a Laplacian system with no constraint on some connected component) — a
  /// status, not an exception, since callers add constraints and retry.
  explicit SparseLeastSquares(const SparseMatrix& A);
  ~SparseLeastSquares();
  SparseLeastSquares(SparseLeastSquares&&) noexcept;
  SparseLeastSquares& operator=(SparseLeastSquares&&) noexcept;

  bool ok() const;
  /// x = argmin ‖A x − b‖² for each column of b (#R × k); returns #N × k.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;
  /// Solves the normal equations AᵀA x = rhs directly (rhs: #N × k), for callers that assemble
  /// Aᵀb themselves.
  Eigen::MatrixXd solve_normal(const Eigen::MatrixXd& rhs) const;

  Eigen::Index unknowns() const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
