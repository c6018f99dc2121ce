// SPDX-License-Identifier: Apache-2.0
#include "supernodal_least_squares.h"

#include <Eigen/CholmodSupport>

#include "normal_equations.h"

namespace vfit {

namespace {

// CHOLMOD's factor with its reciprocal condition estimate, min(diag L) / max(diag L), which the
// Eigen wrapper does not expose.
class Factor : public Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> {
public:
  double reciprocal_condition() { return m_cholmodFactor ? cholmod_rcond(m_cholmodFactor, &cholmod()) : 0.0; }
};

// cholmod_rcond squares its diagonal ratio for an LLᵀ factor, so this is a pivot ratio of AᵀA:
// stricter than SparseLeastSquares' LDLT_PIVOT_RATIO (see the header).
constexpr double SUPERNODAL_RCOND = 1e-6;

} // namespace

struct SupernodalLeastSquares::Impl : NormalEquations<Factor> {
  // A singular PSD matrix often "succeeds" with round-off pivots, hence the condition bar.
  explicit Impl(const SparseMatrix& A)
      : NormalEquations(A), ok(factored && factor.reciprocal_condition() > SUPERNODAL_RCOND) {}
  bool ok;
};

SupernodalLeastSquares::SupernodalLeastSquares(const SparseMatrix& A) : m_impl(std::make_unique<Impl>(A)) {}

SupernodalLeastSquares::~SupernodalLeastSquares() = default;
SupernodalLeastSquares::SupernodalLeastSquares(SupernodalLeastSquares&&) noexcept = default;
SupernodalLeastSquares& SupernodalLeastSquares::operator=(SupernodalLeastSquares&&) noexcept = default;

bool SupernodalLeastSquares::ok() const { return m_impl->ok; }

Eigen::MatrixXd SupernodalLeastSquares::solve(const Eigen::MatrixXd& b) const {
  return m_impl->factor.solve(Eigen::MatrixXd(m_impl->At * b));
}

} // namespace vfit
