#include "smoothed_aggregation.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/SparseCholesky>

#include "least_squares.h"
#include "parallel.h"

namespace vfit {
namespace {

constexpr std::size_t ROW_GRAIN = 2048; // rows per parallel chunk of a sparse product
constexpr int POWER_ITERATIONS = 15;    // for λ_max(D⁻¹A): a few per cent low, hence the margin below
constexpr double LAMBDA_MARGIN = 1.1;   // power iteration underestimates; a smoother tuned too low diverges

struct Level {
  SparseMatrix A;
  SparseMatrix inv_block; ///< D⁻¹: the inverse of A's diagonal blocks (one per node)
  double lambda_max = 1;
  SparseMatrix P; ///< this level × next level
  SparseMatrix R; ///< Pᵀ
};

Eigen::VectorXd diagonal(const SparseMatrix& A) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(A.rows());
  for (Eigen::Index r = 0; r < A.outerSize(); ++r)
    for (SparseMatrix::InnerIterator it(A, r); it; ++it)
      if (it.col() == r) d[r] += it.value();
  return d;
}

// λ_max of D⁻¹A, whose spectrum is real and positive for SPD A and SPD block diagonal D
// (similar to D^-½ A D^-½).
double largest_eigenvalue(const SparseMatrix& A, const SparseMatrix& inv_block) {
  Eigen::MatrixXd x(A.rows(), 1), y, z;
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    x(i, 0) = 1.0 + 0.5 * std::sin(double(i)); // fixed, not orthogonal to the top eigenvector in practice
  double lambda = 1;
  for (int k = 0; k < POWER_ITERATIONS; ++k) {
    x /= x.norm();
    parallel_multiply(A, x, y);
    parallel_multiply(inv_block, y, z);
    lambda = z.norm();
    x.swap(z);
  }
  return lambda * LAMBDA_MARGIN;
}

// The inverse of A's diagonal blocks, one block per node (a node's unknowns are consecutive):
// block Jacobi, so that the unknowns one aggregate contributes to a coarse level (its
// constant and linear parts) are relaxed together. A block that is not positive definite
// falls back to its diagonal.
SparseMatrix block_inverse(const SparseMatrix& A, const std::vector<std::int32_t>& dof_node) {
  const auto n = static_cast<Eigen::Index>(dof_node.size());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(dof_node.size() * 4);
  for (Eigen::Index begin = 0; begin < n;) {
    Eigen::Index end = begin + 1;
    while (end < n && dof_node[static_cast<std::size_t>(end)] == dof_node[static_cast<std::size_t>(begin)]) ++end;
    const Eigen::Index k = end - begin;
    Eigen::MatrixXd block = Eigen::MatrixXd::Zero(k, k);
    for (Eigen::Index i = begin; i < end; ++i)
      for (SparseMatrix::InnerIterator it(A, i); it; ++it)
        if (it.col() >= begin && it.col() < end) block(i - begin, it.col() - begin) = it.value();
    const Eigen::LLT<Eigen::MatrixXd> llt(block);
    Eigen::MatrixXd inverse;
    if (llt.info() == Eigen::Success)
      inverse = llt.solve(Eigen::MatrixXd::Identity(k, k));
    else
      inverse = block.diagonal().cwiseAbs().cwiseMax(1e-300).cwiseInverse().asDiagonal();
    for (Eigen::Index i = 0; i < k; ++i)
      for (Eigen::Index j = 0; j < k; ++j)
        if (inverse(i, j) != 0) t.emplace_back(begin + i, begin + j, inverse(i, j));
    begin = end;
  }
  SparseMatrix D(n, n);
  D.setFromTriplets(t.begin(), t.end());
  D.makeCompressed();
  return D;
}

bool strong(const SparseMatrix::InnerIterator& it, Eigen::Index row, const Eigen::VectorXd& d, double theta) {
  return it.col() != row && std::abs(it.value()) >= theta * std::sqrt(std::abs(d[row] * d[it.col()]));
}

// Node-to-node coupling strengths: S_IJ = ‖A[dofs of I, dofs of J]‖_F (nodes × nodes). On the
// finest level every node is one unknown and S = |A|.
SparseMatrix node_strength(const SparseMatrix& A, const std::vector<std::int32_t>& dof_node, std::int32_t nodes) {
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(A.nonZeros()));
  for (Eigen::Index i = 0; i < A.outerSize(); ++i)
    for (SparseMatrix::InnerIterator it(A, i); it; ++it)
      t.emplace_back(dof_node[static_cast<std::size_t>(i)], dof_node[static_cast<std::size_t>(it.col())],
                     it.value() * it.value());
  SparseMatrix S(nodes, nodes);
  S.setFromTriplets(t.begin(), t.end());
  for (Eigen::Index k = 0; k < S.nonZeros(); ++k)
    S.valuePtr()[k] = std::sqrt(S.valuePtr()[k]);
  return S;
}

// Greedy aggregation of the nodes over their strong connections in S (the three passes of
// Vaněk et al.): whole neighbourhoods first, then leftovers joined to their strongest
// aggregated neighbour, then whatever remains grouped with its unaggregated neighbours.
// Returns #nodes aggregate ids.
std::vector<std::int32_t> aggregate(const SparseMatrix& S, double theta, std::int32_t& count) {
  const Eigen::Index n = S.rows();
  const Eigen::VectorXd d = diagonal(S);
  std::vector<std::int32_t> agg(static_cast<std::size_t>(n), -1);
  count = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] >= 0) continue;
    bool any = false, free = true;
    for (SparseMatrix::InnerIterator it(S, i); it && free; ++it)
      if (strong(it, i, d, theta)) {
        any = true;
        free = agg[static_cast<std::size_t>(it.col())] < 0;
      }
    if (!any || !free) continue;
    agg[static_cast<std::size_t>(i)] = count;
    for (SparseMatrix::InnerIterator it(S, i); it; ++it)
      if (strong(it, i, d, theta)) agg[static_cast<std::size_t>(it.col())] = count;
    ++count;
  }
  const std::vector<std::int32_t> first = agg;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] >= 0) continue;
    double best = 0;
    for (SparseMatrix::InnerIterator it(S, i); it; ++it)
      if (strong(it, i, d, theta) && first[static_cast<std::size_t>(it.col())] >= 0 && std::abs(it.value()) > best) {
        best = std::abs(it.value());
        agg[static_cast<std::size_t>(i)] = first[static_cast<std::size_t>(it.col())];
      }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (agg[static_cast<std::size_t>(i)] >= 0) continue;
    agg[static_cast<std::size_t>(i)] = count;
    for (SparseMatrix::InnerIterator it(S, i); it; ++it)
      if (strong(it, i, d, theta) && agg[static_cast<std::size_t>(it.col())] < 0)
        agg[static_cast<std::size_t>(it.col())] = count;
    ++count;
  }
  return agg;
}

// A level's tentative prolongator and the next level's near-null space: per aggregate, an
// orthonormal basis Q of the near-null vectors restricted to its unknowns (P_tent's block) and
// their coefficients R = Qᵀ B in it (the coarse B's rows). The span is found from the vectors
// with their first one (the constant) projected out and scaled by the aggregate's extent, so
// that a flat aggregate's dependent coordinate is dropped rather than kept as round-off.
struct Tentative {
  SparseMatrix P;
  Eigen::MatrixXd B;
  std::vector<std::int32_t> dof_node; ///< coarse unknown → coarse node (aggregate)
};

constexpr double DEPENDENT = 1e-2; // a direction under 1 % of the aggregate's extent is dropped

Tentative tentative_prolongator(const std::vector<std::int32_t>& dof_node, const std::vector<std::int32_t>& node_agg,
                                std::int32_t aggregates, const Eigen::MatrixXd& B) {
  const auto n = static_cast<std::size_t>(B.rows());
  const Eigen::Index m = B.cols();
  std::vector<std::int32_t> start(static_cast<std::size_t>(aggregates) + 1, 0), dofs(n);
  for (std::size_t i = 0; i < n; ++i)
    ++start[static_cast<std::size_t>(node_agg[static_cast<std::size_t>(dof_node[i])]) + 1];
  for (std::size_t a = 0; a < static_cast<std::size_t>(aggregates); ++a)
    start[a + 1] += start[a];
  std::vector<std::int32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    dofs[static_cast<std::size_t>(fill[static_cast<std::size_t>(node_agg[static_cast<std::size_t>(dof_node[i])])]++)] =
        static_cast<std::int32_t>(i);
  Tentative out;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(n * static_cast<std::size_t>(m));
  std::vector<Eigen::RowVectorXd> coarse_rows;
  for (std::size_t a = 0; a < static_cast<std::size_t>(aggregates); ++a) {
    const auto k = static_cast<Eigen::Index>(start[a + 1] - start[a]);
    if (k == 0) continue;
    Eigen::MatrixXd Bk(k, m);
    for (Eigen::Index r = 0; r < k; ++r)
      Bk.row(r) = B.row(dofs[static_cast<std::size_t>(start[a] + r)]);
    std::vector<Eigen::VectorXd> q;
    const double first_norm = Bk.col(0).norm();
    if (first_norm > 0) q.push_back(Bk.col(0) / first_norm);
    Eigen::MatrixXd V = Bk.rightCols(m - 1);
    if (!q.empty()) V -= q.front() * (q.front().transpose() * V);
    const double extent = m > 1 ? V.colwise().norm().maxCoeff() : 0.0;
    for (Eigen::Index j = 0; j < V.cols(); ++j) {
      Eigen::VectorXd v = V.col(j);
      for (int pass = 0; pass < 2; ++pass) // twice: Gram–Schmidt loses orthogonality once
        for (const Eigen::VectorXd& u : q)
          v -= u * u.dot(v);
      const double norm = v.norm();
      if (norm > DEPENDENT * extent && norm > 0 && static_cast<Eigen::Index>(q.size()) < k) q.push_back(v / norm);
    }
    for (const Eigen::VectorXd& u : q) {
      const auto column = static_cast<std::int32_t>(coarse_rows.size());
      for (Eigen::Index r = 0; r < k; ++r)
        t.emplace_back(dofs[static_cast<std::size_t>(start[a] + r)], column, u[r]);
      coarse_rows.push_back(u.transpose() * Bk);
      out.dof_node.push_back(static_cast<std::int32_t>(a));
    }
  }
  out.P.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(coarse_rows.size()));
  out.P.setFromTriplets(t.begin(), t.end());
  out.B.resize(static_cast<Eigen::Index>(coarse_rows.size()), m);
  for (std::size_t c = 0; c < coarse_rows.size(); ++c)
    out.B.row(static_cast<Eigen::Index>(c)) = coarse_rows[c];
  return out;
}

// P = (I − ω D_F⁻¹ A_F) P_tent: the tentative prolongator smoothed by one damped Jacobi step on
// the filtered matrix A_F (couplings between strongly connected nodes kept, the others lumped
// onto the diagonal, so the basis functions spread over strong connections only). Lumping
// keeps A_F 1 = A 1 but not A_F x = A x for the other near-null vectors, so with more than the
// constant (`filter` false) A itself is used: P then reproduces the linear functions that LᵀL
// annihilates, and the coarse levels keep representing them. On driven tees' bands that took
// the CG from 18 / 29 / 56 iterations (22,523 / 70,224 / 225,558 unknowns) to 17 / 20 / 22.
SparseMatrix smoothed_prolongator(const SparseMatrix& A, const std::vector<std::int32_t>& dof_node, const SparseMatrix& S,
                                  double theta, bool filter, const SparseMatrix& tentative) {
  const Eigen::Index n = A.rows();
  const Eigen::VectorXd sd = diagonal(S);
  std::vector<Eigen::Index> mark(static_cast<std::size_t>(S.rows()), -1);
  std::vector<Eigen::Triplet<double>> filtered;
  filtered.reserve(static_cast<std::size_t>(A.nonZeros()));
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::int32_t node = dof_node[static_cast<std::size_t>(i)];
    mark[static_cast<std::size_t>(node)] = i;
    for (SparseMatrix::InnerIterator it(S, node); it; ++it)
      if (strong(it, node, sd, theta)) mark[static_cast<std::size_t>(it.col())] = i;
    double lumped = 0;
    for (SparseMatrix::InnerIterator it(A, i); it; ++it)
      if (!filter || it.col() == i || mark[static_cast<std::size_t>(dof_node[static_cast<std::size_t>(it.col())])] == i)
        filtered.emplace_back(i, it.col(), it.value());
      else
        lumped += it.value();
    filtered.emplace_back(i, i, lumped);
  }
  SparseMatrix AF(n, n);
  AF.setFromTriplets(filtered.begin(), filtered.end());
  AF.makeCompressed();
  const SparseMatrix inv_dF = block_inverse(AF, dof_node);
  const double omega = 4.0 / 3.0 / largest_eigenvalue(AF, inv_dF);
  const SparseMatrix smoothing = -omega * (inv_dF * AF);
  const SparseMatrix correction = smoothing * tentative;
  SparseMatrix P = tentative + correction;
  P.makeCompressed();
  return P;
}

} // namespace

void parallel_multiply(const SparseMatrix& A, const Eigen::MatrixXd& X, Eigen::MatrixXd& Y) {
  assert(A.cols() == X.rows() && "parallel_multiply: shapes differ");
  assert(A.isCompressed() && "parallel_multiply: A must be compressed");
  Y.resize(A.rows(), X.cols());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  parallel_for_range(static_cast<std::size_t>(A.rows()), ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
    for (Eigen::Index c = 0; c < X.cols(); ++c) {
      const double* x = X.col(c).data();
      double* y = Y.col(c).data();
      for (std::size_t r = begin; r < end; ++r) {
        double sum = 0;
        for (int k = outer[r]; k < outer[r + 1]; ++k)
          sum += value[k] * x[inner[k]];
        y[r] = sum;
      }
    }
  });
}

struct SmoothedAggregationSolver::Impl {
  SmoothedAggregationOptions options;
  std::vector<Level> levels; ///< finest first; the last is factored
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> coarsest;
  bool ok = false;

  // Chebyshev iteration on A X = B preconditioned by D⁻¹, over [λ_max / range, λ_max]
  // (Saad, Iterative Methods, alg. 12.1): degree products with A, fewer from a zero guess.
  void smooth(const Level& l, const Eigen::MatrixXd& B, Eigen::MatrixXd& X, bool zero_guess) const {
    const double upper = l.lambda_max, lower = upper / options.smoothing_range;
    const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower), sigma = theta / delta;
    double rho = 1 / sigma;
    Eigen::MatrixXd R, AD;
    if (zero_guess) {
      R = B;
    } else {
      parallel_multiply(l.A, X, AD);
      R = B - AD;
    }
    Eigen::MatrixXd D, DR;
    parallel_multiply(l.inv_block, R, D);
    D /= theta;
    for (int k = 0; k < options.smoothing_degree; ++k) {
      X += D;
      if (k + 1 == options.smoothing_degree) break;
      parallel_multiply(l.A, D, AD);
      R -= AD;
      const double rho_next = 1 / (2 * sigma - rho);
      parallel_multiply(l.inv_block, R, DR);
      D = (rho_next * rho) * D + (2 * rho_next / delta) * DR;
      rho = rho_next;
    }
  }

  Eigen::MatrixXd vcycle(std::size_t level, const Eigen::MatrixXd& B) const {
    if (level + 1 == levels.size()) {
      Eigen::MatrixXd X(B.rows(), B.cols());
      for (Eigen::Index c = 0; c < B.cols(); ++c)
        X.col(c) = coarsest.solve(B.col(c));
      return X;
    }
    const Level& l = levels[level];
    Eigen::MatrixXd X = Eigen::MatrixXd::Zero(B.rows(), B.cols()), AX, coarse_b, correction;
    smooth(l, B, X, true);
    parallel_multiply(l.A, X, AX);
    parallel_multiply(l.R, B - AX, coarse_b);
    parallel_multiply(l.P, vcycle(level + 1, coarse_b), correction);
    X += correction;
    smooth(l, B, X, false);
    return X;
  }
};

SmoothedAggregationSolver::SmoothedAggregationSolver(const SparseMatrix& A, const Eigen::MatrixXd& near_null,
                                                     const SmoothedAggregationOptions& options)
    : m_impl(std::make_unique<Impl>()) {
  assert(A.rows() == A.cols() && "SmoothedAggregationSolver: A must be square");
  assert((near_null.size() == 0 || near_null.rows() == A.rows()) && "SmoothedAggregationSolver: near-null rows");
  m_impl->options = options;
  SparseMatrix current = A;
  current.makeCompressed();
  Eigen::MatrixXd B = near_null.size() ? near_null : Eigen::MatrixXd::Ones(A.rows(), 1);
  std::vector<std::int32_t> dof_node(static_cast<std::size_t>(A.rows()));
  for (std::size_t i = 0; i < dof_node.size(); ++i)
    dof_node[i] = static_cast<std::int32_t>(i);
  auto nodes = static_cast<std::int32_t>(A.rows());
  for (;;) {
    Level l;
    l.A = std::move(current);
    l.inv_block = block_inverse(l.A, dof_node);
    const bool last = static_cast<std::size_t>(l.A.rows()) <= options.coarse_size ||
                      static_cast<int>(m_impl->levels.size()) + 1 >= options.max_levels;
    if (!last) {
      l.lambda_max = largest_eigenvalue(l.A, l.inv_block);
      const SparseMatrix S = node_strength(l.A, dof_node, nodes);
      std::int32_t count = 0;
      const double theta = options.strength;
      const std::vector<std::int32_t> agg = aggregate(S, theta, count);
      Tentative tentative = tentative_prolongator(dof_node, agg, count, B);
      // Coarsening that stalls (almost no strong connections) would only add levels.
      if (static_cast<double>(tentative.P.cols()) < 0.8 * static_cast<double>(l.A.rows())) {
        l.P = smoothed_prolongator(l.A, dof_node, S, theta, B.cols() == 1, tentative.P);
        l.R = l.P.transpose();
        const SparseMatrix AP = l.A * l.P;
        current = l.R * AP;
        current.makeCompressed();
        B = std::move(tentative.B);
        dof_node = std::move(tentative.dof_node);
        nodes = count;
        m_impl->levels.push_back(std::move(l));
        continue;
      }
    }
    m_impl->coarsest.compute(Eigen::SparseMatrix<double>(l.A));
    m_impl->levels.push_back(std::move(l));
    break;
  }
  m_impl->ok = m_impl->coarsest.info() == Eigen::Success && ldlt_pivots_regular(m_impl->coarsest.vectorD());
}

SmoothedAggregationSolver::~SmoothedAggregationSolver() = default;
SmoothedAggregationSolver::SmoothedAggregationSolver(SmoothedAggregationSolver&&) noexcept = default;
SmoothedAggregationSolver& SmoothedAggregationSolver::operator=(SmoothedAggregationSolver&&) noexcept = default;

bool SmoothedAggregationSolver::ok() const { return m_impl->ok; }

IterativeSolveStats SmoothedAggregationSolver::solve(const Eigen::MatrixXd& B, Eigen::MatrixXd& X, double tolerance,
                                                     int max_iterations) const {
  const SparseMatrix& A = m_impl->levels.front().A;
  const Eigen::Index k = B.cols();
  if (X.rows() != B.rows() || X.cols() != k) X = Eigen::MatrixXd::Zero(B.rows(), k);
  const Eigen::RowVectorXd b_norm = B.colwise().norm();
  for (Eigen::Index c = 0; c < k; ++c)
    if (b_norm[c] == 0) X.col(c).setZero();
  Eigen::MatrixXd AX, Q;
  parallel_multiply(A, X, AX);
  Eigen::MatrixXd R = B - AX;
  IterativeSolveStats stats;
  // Each column runs its own CG (own step lengths); a converged column stops moving.
  auto residuals = [&] {
    double worst = 0;
    for (Eigen::Index c = 0; c < k; ++c)
      worst = std::max(worst, b_norm[c] > 0 ? R.col(c).norm() / b_norm[c] : 0.0);
    return worst;
  };
  stats.relative_residual = residuals();
  if (stats.relative_residual <= tolerance) {
    stats.converged = true;
    return stats;
  }
  Eigen::MatrixXd Z = m_impl->vcycle(0, R);
  Eigen::MatrixXd P = Z;
  Eigen::RowVectorXd rz = R.cwiseProduct(Z).colwise().sum();
  while (stats.iterations < max_iterations) {
    parallel_multiply(A, P, Q);
    const Eigen::RowVectorXd pq = P.cwiseProduct(Q).colwise().sum();
    for (Eigen::Index c = 0; c < k; ++c) {
      const bool done = b_norm[c] == 0 || R.col(c).norm() <= tolerance * b_norm[c];
      const double alpha = done || pq[c] <= 0 ? 0.0 : rz[c] / pq[c];
      X.col(c) += alpha * P.col(c);
      R.col(c) -= alpha * Q.col(c);
    }
    ++stats.iterations;
    stats.relative_residual = residuals();
    if (stats.relative_residual <= tolerance) {
      stats.converged = true;
      break;
    }
    Z = m_impl->vcycle(0, R);
    const Eigen::RowVectorXd rz_next = R.cwiseProduct(Z).colwise().sum();
    for (Eigen::Index c = 0; c < k; ++c)
      P.col(c) = Z.col(c) + (rz[c] != 0 ? rz_next[c] / rz[c] : 0.0) * P.col(c);
    rz = rz_next;
  }
  return stats;
}

} // namespace vfit
