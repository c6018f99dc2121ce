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

/// min_x ‖A x − b‖² for a fixed sparse A (#R × #N, full column rank) and any number of
/// right-hand sides: AᵀA is factored once (sparse LDLᵀ with fill-reducing ordering) and each
/// solve() costs two triangular solves. Columns of b are solved independently (x, y, z).
class SparseLeastSquares {
public:
  /// Factors AᵀA. ok() is false when it is singular (A lacks full column rank: e.g. a
  /// Laplacian system with no constraint on some connected component) — a status, not an
  /// exception, since callers add constraints and retry.
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
