// SPDX-License-Identifier: Apache-2.0
#include "two_grid_least_squares.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include <Eigen/CholmodSupport>

#include "parallel.h"

namespace vfit {
namespace {

// Three right-hand sides (x, y, z) interleaved per unknown: one pass over a sparse matrix
// serves all three, where column-major storage would read the matrix three times.
using Block = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

constexpr std::size_t ROW_GRAIN = 4096; // rows per parallel chunk of a sparse product or update
// A coarse aggregate direction under 1 % of the aggregate's extent is dropped as dependent (a
// flat aggregate's normal coordinate), rather than kept as round-off.
constexpr double DEPENDENT = 1e-2;
// CHOLMOD's reciprocal condition estimate of the coarse factor (its smallest over largest
// pivot, squared) at or below which the coarse system counts as singular. A free piece without
// a handle makes the coarse system exactly singular (its constant is a coarse function); the
// coarse systems of driven tees' bands sit at 1e-6 to 1e-4.
constexpr double COARSE_RCOND = 1e-12;

class Factor : public Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> {
public:
  double reciprocal_condition() { return m_cholmodFactor ? cholmod_rcond(m_cholmodFactor, &cholmod()) : 0.0; }
};

// Y = M X over rows [begin, end) of M (#R × #C, compressed row-major); X: #C × 3.
void multiply_rows(const SparseMatrix& M, const Block& X, Block& Y, std::size_t begin, std::size_t end) {
  const int* outer = M.outerIndexPtr();
  const int* inner = M.innerIndexPtr();
  const double* value = M.valuePtr();
  const double* x = X.data();
  double* y = Y.data();
  for (std::size_t r = begin; r < end; ++r) {
    double s0 = 0, s1 = 0, s2 = 0;
    for (int k = outer[r]; k < outer[r + 1]; ++k) {
      const double w = value[k];
      const double* p = x + 3 * static_cast<std::ptrdiff_t>(inner[k]);
      s0 += w * p[0];
      s1 += w * p[1];
      s2 += w * p[2];
    }
    y[3 * r] = s0;
    y[3 * r + 1] = s1;
    y[3 * r + 2] = s2;
  }
}

void multiply(const SparseMatrix& M, const Block& X, Block& Y) {
  Y.resize(M.rows(), 3);
  parallel_for_range(static_cast<std::size_t>(M.rows()), ROW_GRAIN,
                     [&](std::size_t begin, std::size_t end) { multiply_rows(M, X, Y, begin, end); });
}

// Per-column dot products Σ_i X_ic Y_ic, summed serially in row order (thread-count independent).
Eigen::RowVector3d column_dots(const Block& X, const Block& Y) { return X.cwiseProduct(Y).colwise().sum(); }

// Strong couplings of AᵀA, found row by row without forming it: S (#N × #N pattern, values the
// scaled coupling |a_ij| / √(a_ii a_jj)) and the Gershgorin bound max_i Σ_j |a_ij| / √(a_ii a_jj)
// of D^-½ AᵀA D^-½, whose spectrum is D⁻¹AᵀA's.
struct Couplings {
  std::vector<int> start, neighbour;
  std::vector<double> strength;
  double gershgorin = 0;
};

Couplings strong_couplings(const SparseMatrix& A, const SparseMatrix& At, const Eigen::VectorXd& d, double theta) {
  const auto n = static_cast<std::size_t>(At.rows());
  const Eigen::VectorXd scale = d.cwiseSqrt().cwiseInverse();
  Couplings c;
  c.start.assign(n + 1, 0);
  c.neighbour.reserve(n * 20);
  c.strength.reserve(n * 20);
  std::vector<double> accumulated(n, 0.0);
  std::vector<int> touched;
  std::vector<char> seen(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    touched.clear();
    for (SparseMatrix::InnerIterator ri(At, static_cast<Eigen::Index>(i)); ri; ++ri)
      for (SparseMatrix::InnerIterator rj(A, ri.col()); rj; ++rj) {
        const auto j = static_cast<std::size_t>(rj.col());
        if (!seen[j]) {
          seen[j] = 1;
          touched.push_back(static_cast<int>(j));
        }
        accumulated[j] += ri.value() * rj.value();
      }
    double row_sum = 0;
    const double si = scale[static_cast<Eigen::Index>(i)];
    for (int j : touched) { // in the order met: deterministic, and the passes below need no other
      const auto ju = static_cast<std::size_t>(j);
      const double scaled = std::abs(accumulated[ju]) * si * scale[j];
      row_sum += scaled;
      if (ju != i && scaled >= theta) {
        c.neighbour.push_back(j);
        c.strength.push_back(scaled);
      }
      accumulated[ju] = 0;
      seen[ju] = 0;
    }
    c.gershgorin = std::max(c.gershgorin, row_sum);
    c.start[i + 1] = static_cast<int>(c.neighbour.size());
  }
  return c;
}

// Greedy aggregation over the strong couplings (the three passes of Vaněk et al.): whole
// neighbourhoods first, then leftovers joined to their strongest aggregated neighbour, then
// whatever remains grouped with its unaggregated neighbours. Returns #N aggregate ids.
std::vector<std::int32_t> aggregate(const Couplings& s, std::int32_t& count) {
  const std::size_t n = s.start.size() - 1;
  std::vector<std::int32_t> agg(n, -1);
  count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (agg[i] >= 0 || s.start[i] == s.start[i + 1]) continue;
    bool free = true;
    for (int k = s.start[i]; k < s.start[i + 1] && free; ++k)
      free = agg[static_cast<std::size_t>(s.neighbour[k])] < 0;
    if (!free) continue;
    agg[i] = count;
    for (int k = s.start[i]; k < s.start[i + 1]; ++k)
      agg[static_cast<std::size_t>(s.neighbour[k])] = count;
    ++count;
  }
  const std::vector<std::int32_t> first = agg;
  for (std::size_t i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    double best = 0;
    for (int k = s.start[i]; k < s.start[i + 1]; ++k) {
      const std::int32_t a = first[static_cast<std::size_t>(s.neighbour[k])];
      if (a >= 0 && s.strength[k] > best) {
        best = s.strength[k];
        agg[i] = a;
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    agg[i] = count;
    for (int k = s.start[i]; k < s.start[i + 1]; ++k)
      if (agg[static_cast<std::size_t>(s.neighbour[k])] < 0) agg[static_cast<std::size_t>(s.neighbour[k])] = count;
    ++count;
  }
  return agg;
}

} // namespace

struct TwoGridLeastSquares::Impl {
  TwoGridOptions options;
  SparseMatrix A, At;
  Eigen::VectorXd inverse_diagonal;                                ///< 1 / (AᵀA)_ii, #N
  double upper = 1;                                                ///< Gershgorin bound of D⁻¹AᵀA's spectrum
  std::vector<std::int32_t> aggregate_of;                          ///< #N
  std::vector<std::int32_t> members, member_start;                 ///< unknowns by aggregate (ascending in each)
  std::vector<std::int32_t> coarse_start;                          ///< #aggregates + 1: each one's coarse unknowns
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> basis; ///< #N × 4: P's row of each unknown (zero-padded)
  Factor coarse;
  bool ok = false;

  std::size_t aggregates() const { return coarse_start.size() - 1; }
  Eigen::Index coarse_size() const { return coarse_start.back(); }

  /// Buffers of one solve: #R × 3 (scratch) and #N × 3 (the rest), reused by every cycle.
  struct Workspace {
    Block R, D, AD, scratch;
    Eigen::MatrixXd coarse_b;
  };

  // Y = AᵀA X through A and Aᵀ.
  void normal_multiply(const Block& X, Block& Y, Block& scratch) const {
    multiply(A, X, scratch);
    multiply(At, scratch, Y);
  }

  // Chebyshev iteration on AᵀA X = B preconditioned by D⁻¹ over [upper / range, upper] (Saad,
  // Iterative Methods, alg. 12.1): X ← X + q(D⁻¹AᵀA) D⁻¹ (B − AᵀA X). q(D⁻¹M)D⁻¹ is symmetric, and
  // with the spectrum inside the bound |1 − λ q(λ)| < 1, so the same smoother before and after
  // the coarse correction makes the cycle symmetric positive definite. With zero_guess X is
  // taken as zero (one product fewer).
  void smooth(const Block& B, Block& X, bool zero_guess, Workspace& w) const {
    const double lower = upper / options.smoothing_range;
    const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower), sigma = theta / delta;
    double rho = 1 / sigma;
    const auto n = static_cast<std::size_t>(X.rows());
    if (!zero_guess) normal_multiply(X, w.AD, w.scratch);
    w.R.resize(X.rows(), 3);
    w.D.resize(X.rows(), 3);
    parallel_for_range(n, ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        for (int c = 0; c < 3; ++c) {
          const auto r = static_cast<Eigen::Index>(i);
          const double residual = zero_guess ? B(r, c) : B(r, c) - w.AD(r, c);
          w.R(r, c) = residual;
          w.D(r, c) = inverse_diagonal[r] * residual / theta;
          X(r, c) = zero_guess ? w.D(r, c) : X(r, c) + w.D(r, c);
        }
    });
    for (int k = 1; k < options.smoothing_degree; ++k) {
      normal_multiply(w.D, w.AD, w.scratch);
      const double rho_next = 1 / (2 * sigma - rho);
      const double keep = rho_next * rho, step = 2 * rho_next / delta;
      parallel_for_range(n, ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
          for (int c = 0; c < 3; ++c) {
            const auto r = static_cast<Eigen::Index>(i);
            w.R(r, c) -= w.AD(r, c);
            w.D(r, c) = keep * w.D(r, c) + step * inverse_diagonal[r] * w.R(r, c);
            X(r, c) += w.D(r, c);
          }
      });
      rho = rho_next;
    }
  }

  // The two-grid cycle X ≈ (AᵀA)⁻¹ B: smooth, coarse correction P (PᵀAᵀAP)⁻¹ Pᵀ on the
  // residual, smooth again.
  void cycle(const Block& B, Block& X, Workspace& w) const {
    X.resize(B.rows(), 3);
    smooth(B, X, true, w);
    normal_multiply(X, w.AD, w.scratch);
    w.coarse_b.resize(coarse_size(), 3);
    parallel_for_range(aggregates(), ROW_GRAIN / 16, [&](std::size_t begin, std::size_t end) {
      for (std::size_t a = begin; a < end; ++a) {
        const std::int32_t c0 = coarse_start[a], count = coarse_start[a + 1] - c0;
        double sum[4][3] = {};
        for (std::int32_t k = member_start[a]; k < member_start[a + 1]; ++k) {
          const std::int32_t i = members[static_cast<std::size_t>(k)];
          for (int c = 0; c < 3; ++c) {
            const double r = B(i, c) - w.AD(i, c);
            for (std::int32_t f = 0; f < count; ++f)
              sum[f][c] += basis(i, f) * r;
          }
        }
        for (std::int32_t f = 0; f < count; ++f)
          for (int c = 0; c < 3; ++c)
            w.coarse_b(c0 + f, c) = sum[f][c];
      }
    });
    const Eigen::MatrixXd coarse_x = coarse.solve(w.coarse_b);
    parallel_for_range(static_cast<std::size_t>(X.rows()), ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const auto a = static_cast<std::size_t>(aggregate_of[i]);
        const std::int32_t c0 = coarse_start[a], count = coarse_start[a + 1] - c0;
        for (std::int32_t f = 0; f < count; ++f)
          for (int c = 0; c < 3; ++c)
            X(static_cast<Eigen::Index>(i), c) += basis(static_cast<Eigen::Index>(i), f) * coarse_x(c0 + f, c);
      }
    });
    smooth(B, X, false, w);
  }

  void build(const Eigen::MatrixXd& near_null) {
    const auto n = static_cast<std::size_t>(A.cols());
    inverse_diagonal.resize(A.cols());
    for (Eigen::Index i = 0; i < At.rows(); ++i) {
      double d = 0;
      for (SparseMatrix::InnerIterator it(At, i); it; ++it)
        d += it.value() * it.value();
      if (!(d > 0)) return; // a zero column: AᵀA singular
      inverse_diagonal[i] = 1 / d;
    }
    const Eigen::VectorXd d = inverse_diagonal.cwiseInverse();
    const Couplings s = strong_couplings(A, At, d, options.strength);
    upper = s.gershgorin;
    std::int32_t count = 0;
    aggregate_of = aggregate(s, count);
    // Members by aggregate (counting sort keeps them ascending).
    member_start.assign(static_cast<std::size_t>(count) + 1, 0);
    for (std::int32_t a : aggregate_of)
      ++member_start[static_cast<std::size_t>(a) + 1];
    for (std::size_t a = 0; a < static_cast<std::size_t>(count); ++a)
      member_start[a + 1] += member_start[a];
    members.resize(n);
    std::vector<std::int32_t> fill(member_start.begin(), member_start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      members[static_cast<std::size_t>(fill[static_cast<std::size_t>(aggregate_of[i])]++)] =
          static_cast<std::int32_t>(i);
    // Tentative prolongator: per aggregate an orthonormal basis of the near-null vectors
    // restricted to it, the constant first, the others with it projected out.
    const Eigen::Index m = near_null.cols();
    basis = decltype(basis)::Zero(static_cast<Eigen::Index>(n), 4);
    coarse_start.assign(static_cast<std::size_t>(count) + 1, 0);
    for (std::size_t a = 0; a < static_cast<std::size_t>(count); ++a) {
      const Eigen::Index k = member_start[a + 1] - member_start[a];
      Eigen::MatrixXd Bk(k, m);
      for (Eigen::Index r = 0; r < k; ++r)
        Bk.row(r) = near_null.row(members[static_cast<std::size_t>(member_start[a] + r)]);
      Eigen::MatrixXd Q(k, std::min(k, m));
      Eigen::Index q = 0;
      Q.col(q++) = Bk.col(0).normalized();
      Eigen::MatrixXd V = Bk.rightCols(m - 1);
      V -= Q.col(0) * (Q.col(0).transpose() * V);
      const double extent = m > 1 ? V.colwise().norm().maxCoeff() : 0.0;
      for (Eigen::Index j = 0; j < V.cols() && q < Q.cols(); ++j) {
        Eigen::VectorXd v = V.col(j);
        for (int pass = 0; pass < 2; ++pass) // twice: Gram–Schmidt loses orthogonality once
          v -= Q.leftCols(q) * (Q.leftCols(q).transpose() * v);
        const double norm = v.norm();
        if (norm > DEPENDENT * extent && norm > 0) Q.col(q++) = v / norm;
      }
      for (Eigen::Index r = 0; r < k; ++r)
        basis.row(members[static_cast<std::size_t>(member_start[a] + r)]).head(q) = Q.row(r).head(q);
      coarse_start[a + 1] = coarse_start[a] + static_cast<std::int32_t>(q);
    }
    const Eigen::SparseMatrix<double> G = galerkin();
    coarse.compute(G);
    ok = coarse.info() == Eigen::Success && coarse.reciprocal_condition() > COARSE_RCOND;
  }

  // PᵀAᵀAP = (AP)ᵀ(AP), P the tentative prolongator: AP (#R × #coarse) row by row, then its
  // Gram matrix row by row over (AP)ᵀ. Column-major with sorted rows, as CHOLMOD reads it.
  Eigen::SparseMatrix<double> galerkin() const {
    const Eigen::Index nc = coarse_size();
    // AP, compressed row by row: its row r sums A's row r over each entry's coarse functions.
    std::vector<int> ap_start{0}, ap_column;
    std::vector<double> ap_value, row(static_cast<std::size_t>(nc), 0.0);
    ap_column.reserve(static_cast<std::size_t>(A.nonZeros()) * 2);
    ap_value.reserve(static_cast<std::size_t>(A.nonZeros()) * 2);
    std::vector<char> seen(static_cast<std::size_t>(nc), 0);
    std::vector<int> touched;
    for (Eigen::Index r = 0; r < A.outerSize(); ++r) {
      touched.clear();
      for (SparseMatrix::InnerIterator it(A, r); it; ++it) {
        const auto a = static_cast<std::size_t>(aggregate_of[static_cast<std::size_t>(it.col())]);
        for (std::int32_t c = coarse_start[a]; c < coarse_start[a + 1]; ++c) {
          if (!seen[static_cast<std::size_t>(c)]) {
            seen[static_cast<std::size_t>(c)] = 1;
            touched.push_back(c);
          }
          row[static_cast<std::size_t>(c)] += it.value() * basis(it.col(), c - coarse_start[a]);
        }
      }
      std::sort(touched.begin(), touched.end());
      for (int c : touched) {
        ap_column.push_back(c);
        ap_value.push_back(row[static_cast<std::size_t>(c)]);
        row[static_cast<std::size_t>(c)] = 0;
        seen[static_cast<std::size_t>(c)] = 0;
      }
      ap_start.push_back(static_cast<int>(ap_column.size()));
    }
    const Eigen::Map<const SparseMatrix> AP(A.rows(), nc, static_cast<Eigen::Index>(ap_value.size()), ap_start.data(),
                                            ap_column.data(), ap_value.data());
    const SparseMatrix APt = AP.transpose();
    // (AP)ᵀ(AP) column by column (it is symmetric: column i is row i), rows sorted.
    std::vector<int> g_start{0}, g_row;
    std::vector<double> g_value;
    g_row.reserve(static_cast<std::size_t>(nc) * 40);
    g_value.reserve(static_cast<std::size_t>(nc) * 40);
    for (Eigen::Index i = 0; i < nc; ++i) {
      touched.clear();
      for (SparseMatrix::InnerIterator ri(APt, i); ri; ++ri)
        for (Eigen::Map<const SparseMatrix>::InnerIterator rj(AP, ri.col()); rj; ++rj) {
          const auto j = static_cast<std::size_t>(rj.col());
          if (!seen[j]) {
            seen[j] = 1;
            touched.push_back(static_cast<int>(j));
          }
          row[j] += ri.value() * rj.value();
        }
      std::sort(touched.begin(), touched.end());
      for (int j : touched) {
        g_row.push_back(j);
        g_value.push_back(row[static_cast<std::size_t>(j)]);
        row[static_cast<std::size_t>(j)] = 0;
        seen[static_cast<std::size_t>(j)] = 0;
      }
      g_start.push_back(static_cast<int>(g_row.size()));
    }
    return Eigen::Map<const Eigen::SparseMatrix<double>>(nc, nc, static_cast<Eigen::Index>(g_value.size()),
                                                         g_start.data(), g_row.data(), g_value.data());
  }
};

TwoGridLeastSquares::TwoGridLeastSquares(const SparseMatrix& A, const Eigen::MatrixXd& near_null,
                                         const TwoGridOptions& options)
    : m_impl(std::make_unique<Impl>()) {
  assert(near_null.rows() == A.cols() && near_null.cols() >= 1 && near_null.cols() <= 4 &&
         "TwoGridLeastSquares: near-null shape");
  m_impl->options = options;
  m_impl->A = A;
  m_impl->A.makeCompressed();
  m_impl->At = A.transpose();
  m_impl->At.makeCompressed();
  if (A.cols() > 0) m_impl->build(near_null);
}

TwoGridLeastSquares::~TwoGridLeastSquares() = default;
TwoGridLeastSquares::TwoGridLeastSquares(TwoGridLeastSquares&&) noexcept = default;
TwoGridLeastSquares& TwoGridLeastSquares::operator=(TwoGridLeastSquares&&) noexcept = default;

bool TwoGridLeastSquares::ok() const { return m_impl->ok; }

std::size_t TwoGridLeastSquares::coarse_unknowns() const {
  return m_impl->coarse_start.empty() ? 0 : static_cast<std::size_t>(m_impl->coarse_size());
}

IterativeSolveStats TwoGridLeastSquares::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& x, double tolerance,
                                               int max_iterations) const {
  const Impl& s = *m_impl;
  const Eigen::Index n = s.A.cols(), k = b.cols();
  assert(b.rows() == s.A.rows() && "TwoGridLeastSquares::solve: b rows");
  if (x.rows() != n || x.cols() != k) x = Eigen::MatrixXd::Zero(n, k);
  IterativeSolveStats stats;
  stats.converged = true;
  // Columns in groups of three (the last padded with zeros), each column its own CG.
  for (Eigen::Index first = 0; first < k; first += 3) {
    const Eigen::Index width = std::min<Eigen::Index>(3, k - first);
    Block bb = Block::Zero(b.rows(), 3), X = Block::Zero(n, 3);
    bb.leftCols(width) = b.middleCols(first, width);
    X.leftCols(width) = x.middleCols(first, width);
    Impl::Workspace w;
    Block rhs, R, Q, Z, P;
    multiply(s.At, bb, rhs);
    // One scale for the three columns (the same unit, positions in m): a column whose own
    // right-hand side is small (an axis the deformation barely moves) is not driven to a
    // relative accuracy the others do not need, nor stopped early at an absolute error they
    // would not accept.
    const Eigen::RowVector3d column_norm = column_dots(rhs, rhs).cwiseSqrt();
    Eigen::RowVector3d b_norm = Eigen::RowVector3d::Constant(column_norm.maxCoeff());
    for (int c = 0; c < 3; ++c)
      if (column_norm[c] == 0) {
        b_norm[c] = 0;
        X.col(c).setZero();
      }
    s.normal_multiply(X, Q, w.scratch);
    R = rhs - Q;
    Eigen::RowVector3d r_norm = column_dots(R, R).cwiseSqrt();
    auto relative_residual = [&] {
      double worst = 0;
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, b_norm[c] > 0 ? r_norm[c] / b_norm[c] : 0.0);
      return worst;
    };
    int iterations = 0;
    double relative = relative_residual();
    if (relative > tolerance) {
      s.cycle(R, Z, w);
      P = Z;
      Eigen::RowVector3d rz = column_dots(R, Z);
      bool breakdown = false;
      while (iterations < max_iterations && !breakdown) {
        s.normal_multiply(P, Q, w.scratch);
        const Eigen::RowVector3d pq = column_dots(P, Q);
        Eigen::RowVector3d alpha = Eigen::RowVector3d::Zero();
        for (int c = 0; c < 3; ++c) {
          if (b_norm[c] == 0 || r_norm[c] <= tolerance * b_norm[c]) continue; // converged: stops moving
          // pᵀAᵀAp or rᵀz not positive: positive definiteness lost to round-off; stop
          // unconverged (the caller falls back) rather than iterate on garbage.
          if (!(pq[c] > 0) || !(rz[c] > 0))
            breakdown = true;
          else
            alpha[c] = rz[c] / pq[c];
        }
        parallel_for_range(static_cast<std::size_t>(n), ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
          for (std::size_t i = begin; i < end; ++i)
            for (int c = 0; c < 3; ++c) {
              const auto r = static_cast<Eigen::Index>(i);
              X(r, c) += alpha[c] * P(r, c);
              R(r, c) -= alpha[c] * Q(r, c);
            }
        });
        ++iterations;
        r_norm = column_dots(R, R).cwiseSqrt();
        relative = relative_residual();
        if (relative <= tolerance || !std::isfinite(relative)) break;
        s.cycle(R, Z, w);
        const Eigen::RowVector3d rz_next = column_dots(R, Z);
        Eigen::RowVector3d beta;
        for (int c = 0; c < 3; ++c)
          beta[c] = rz[c] > 0 ? rz_next[c] / rz[c] : 0.0;
        parallel_for_range(static_cast<std::size_t>(n), ROW_GRAIN, [&](std::size_t begin, std::size_t end) {
          for (std::size_t i = begin; i < end; ++i)
            for (int c = 0; c < 3; ++c) {
              const auto r = static_cast<Eigen::Index>(i);
              P(r, c) = Z(r, c) + beta[c] * P(r, c);
            }
        });
        rz = rz_next;
      }
    }
    stats.iterations = std::max(stats.iterations, iterations);
    stats.relative_residual = std::max(stats.relative_residual, relative);
    stats.converged = stats.converged && relative <= tolerance;
    x.middleCols(first, width) = X.leftCols(width);
  }
  return stats;
}

} // namespace vfit
