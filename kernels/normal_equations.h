// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The part SparseLeastSquares (least_squares.h) and SupernodalLeastSquares
/// (supernodal_least_squares.h) share: min_x ‖A x − b‖² through the normal equations
/// AᵀA x = Aᵀb, with Aᵀ kept for the right-hand sides and AᵀA factored once by a sparse
/// Cholesky-type factorisation. Each solver wraps it and applies its own singularity bar.
/// Internal to kernels/: not included by public headers.

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "laplacian.h"

namespace vfit {

/// Factorisation: an Eigen sparse solver over Eigen::SparseMatrix<double> (column-major), with
/// compute(), info() and solve(). A: #R × #N.
template <typename Factorisation> struct NormalEquations {
  Eigen::SparseMatrix<double> At; ///< Aᵀ (#N × #R), column-major: Aᵀ b is a fast product
  Factorisation factor;           ///< of AᵀA
  bool factored = false;          ///< factor.info() was Success; the caller's bar decides ok()

  explicit NormalEquations(const SparseMatrix& A) : At(A.transpose()) {
    factor.compute(Eigen::SparseMatrix<double>(At * A));
    factored = factor.info() == Eigen::Success;
  }

  /// AᵀA x = rhs, column by column (rhs: #N × k).
  Eigen::MatrixXd solve_normal(const Eigen::MatrixXd& rhs) const {
    Eigen::MatrixXd x(rhs.rows(), rhs.cols());
    for (Eigen::Index c = 0; c < rhs.cols(); ++c)
      x.col(c) = factor.solve(rhs.col(c));
    return x;
  }

  /// argmin ‖A x − b‖² per column of b (#R × k).
  Eigen::MatrixXd solve(const Eigen::MatrixXd& b) const { return solve_normal(At * b); }
};

} // namespace vfit
