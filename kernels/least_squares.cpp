// SPDX-License-Identifier: Apache-2.0
#include "least_squares.h"

#include <Eigen/SparseCholesky>

#include "normal_equations.h"

namespace vfit {

bool ldlt_pivots_regular(const Eigen::VectorXd& pivots) {
  if (pivots.size() == 0) return true;
  // minCoeff()/maxCoeff() skip NaNs, so non-finite pivots are refused first.
  if (!pivots.allFinite()) return false;
  const double scale = std::max(1.0, pivots.cwiseAbs().maxCoeff());
  return pivots.minCoeff() > LDLT_PIVOT_RATIO * scale;
}

struct SparseLeastSquares::Impl : NormalEquations<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> {
  explicit Impl(const SparseMatrix& A) : NormalEquations(A), ok(factored && ldlt_pivots_regular(factor.vectorD())) {}
  bool ok;
};

SparseLeastSquares::SparseLeastSquares(const SparseMatrix& A) : m_impl(std::make_unique<Impl>(A)) {}

SparseLeastSquares::~SparseLeastSquares() = default;
SparseLeastSquares::SparseLeastSquares(SparseLeastSquares&&) noexcept = default;
SparseLeastSquares& SparseLeastSquares::operator=(SparseLeastSquares&&) noexcept = default;

bool SparseLeastSquares::ok() const { return m_impl->ok; }

Eigen::Index SparseLeastSquares::unknowns() const { return m_impl->At.rows(); }

Eigen::MatrixXd SparseLeastSquares::solve_normal(const Eigen::MatrixXd& rhs) const { return m_impl->solve_normal(rhs); }

Eigen::MatrixXd SparseLeastSquares::solve(const Eigen::MatrixXd& b) const { return m_impl->solve(b); }

} // namespace vfit
