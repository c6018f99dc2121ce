#include "supernodal_least_squares.h"

#include <Eigen/CholmodSupport>

namespace vfit {

namespace {

// CHOLMOD's factor with its reciprocal condition estimate, min(diag L) / max(diag L), which the
// Eigen wrapper does not expose.
class Factor : public Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> {
public:
  double reciprocal_condition() { return m_cholmodFactor ? cholmod_rcond(m_cholmodFactor, &cholmod()) : 0.0; }
};

} // namespace

struct SupernodalLeastSquares::Impl {
  Eigen::SparseMatrix<double> At; // Aᵀ, column-major: Aᵀ b is a fast product
  Factor llt;
  bool ok = false;
};

SupernodalLeastSquares::SupernodalLeastSquares(const SparseMatrix& A) : m_impl(std::make_unique<Impl>()) {
  m_impl->At = A.transpose();
  const Eigen::SparseMatrix<double> AtA = m_impl->At * A;
  m_impl->llt.compute(AtA);
  m_impl->ok = m_impl->llt.info() == Eigen::Success;
  // A singular PSD matrix often "succeeds" with round-off pivots. cholmod_rcond squares its
  // diagonal ratio for an LLᵀ factor, so this is a pivot ratio of AᵀA: 1e-6, stricter than
  // SparseLeastSquares' 1e-12 (see the header).
  if (m_impl->ok) m_impl->ok = m_impl->llt.reciprocal_condition() > 1e-6;
}

SupernodalLeastSquares::~SupernodalLeastSquares() = default;
SupernodalLeastSquares::SupernodalLeastSquares(SupernodalLeastSquares&&) noexcept = default;
SupernodalLeastSquares& SupernodalLeastSquares::operator=(SupernodalLeastSquares&&) noexcept = default;

bool SupernodalLeastSquares::ok() const { return m_impl->ok; }

Eigen::MatrixXd SupernodalLeastSquares::solve(const Eigen::MatrixXd& b) const {
  const Eigen::MatrixXd rhs = m_impl->At * b;
  return m_impl->llt.solve(rhs);
}

} // namespace vfit
