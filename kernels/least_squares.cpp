#include "least_squares.h"

#include <Eigen/SparseCholesky>

namespace vfit {

struct SparseLeastSquares::Impl {
  Eigen::SparseMatrix<double> At; // Aᵀ, column-major: Aᵀ b is a fast product
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  bool ok = false;
};

SparseLeastSquares::SparseLeastSquares(const SparseMatrix& A) : m_impl(std::make_unique<Impl>()) {
  m_impl->At = A.transpose();
  const Eigen::SparseMatrix<double> AtA = m_impl->At * A;
  m_impl->ldlt.compute(AtA);
  m_impl->ok = m_impl->ldlt.info() == Eigen::Success;
  if (m_impl->ok) {
    // LDLᵀ of a singular PSD matrix "succeeds" with zero pivots; treat tiny pivots as failure.
    const auto d = m_impl->ldlt.vectorD();
    const double scale = std::max(1.0, d.cwiseAbs().maxCoeff());
    m_impl->ok = d.minCoeff() > 1e-12 * scale;
  }
}

SparseLeastSquares::~SparseLeastSquares() = default;
SparseLeastSquares::SparseLeastSquares(SparseLeastSquares&&) noexcept = default;
SparseLeastSquares& SparseLeastSquares::operator=(SparseLeastSquares&&) noexcept = default;

bool SparseLeastSquares::ok() const { return m_impl->ok; }

Eigen::Index SparseLeastSquares::unknowns() const { return m_impl->At.rows(); }

Eigen::MatrixXd SparseLeastSquares::solve_normal(const Eigen::MatrixXd& rhs) const {
  Eigen::MatrixXd x(rhs.rows(), rhs.cols());
  for (Eigen::Index c = 0; c < rhs.cols(); ++c) x.col(c) = m_impl->ldlt.solve(rhs.col(c));
  return x;
}

Eigen::MatrixXd SparseLeastSquares::solve(const Eigen::MatrixXd& b) const {
  return solve_normal(m_impl->At * b);
}

} // namespace vfit
