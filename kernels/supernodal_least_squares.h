// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Sparse linear least squares factored by CHOLMOD's supernodal Cholesky (SuiteSparse, already
/// linked through Ceres): the same normal equations as SparseLeastSquares (least_squares.h),
/// for the large systems where a simplicial LDLᵀ's column-by-column updates dominate, such as
/// the free band of Laplacian surface deformation on a 10^5–10^6-vertex garment (seed 000
/// §5.4). Supernodes turn the fill-in's work into dense blocks (BLAS), and CHOLMOD keeps the
/// better of its AMD and METIS orderings.

#include <memory>

#include <Eigen/Dense>

#include "laplacian.h"

namespace vfit {

/// min_x ‖A x − b‖² for a fixed sparse A (#R × #N, full column rank) and any number of
/// right-hand sides: AᵀA = LLᵀ is factored once, and each solve() costs two triangular solves
/// per column of b. It pays on large systems (from about 20,000 unknowns); below, a simplicial
/// LDLᵀ (SparseLeastSquares) is as fast.
class SupernodalLeastSquares {
public:
  /// Factors AᵀA. ok() is false when CHOLMOD finds it not positive definite, or when CHOLMOD's
  /// reciprocal condition estimate (the smallest over the largest pivot of AᵀA, its LLᵀ
  /// factor's diagonal ratio squared) is at most 10^-6: A lacks full column rank, e.g. a
  /// Laplacian system with an unconstrained connected piece — a status. That bar is stricter
  /// than SparseLeastSquares' (smallest LDLᵀ pivot ≤ 10^-12 of the largest): systems with
  /// pivot ratios between 10^-12 and 10^-6 are refused here and accepted there.
  explicit SupernodalLeastSquares(const SparseMatrix& A);
  ~SupernodalLeastSquares();
  SupernodalLeastSquares(SupernodalLeastSquares&&) noexcept;
  SupernodalLeastSquares& operator=(SupernodalLeastSquares&&) noexcept;

  /// Whether the factorisation succeeded (see the constructor); solve() only when true.
  bool ok() const;
  /// x = argmin ‖A x − b‖² for each column of b (#R × k); returns #N × k.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
