// SPDX-License-Identifier: Apache-2.0
#include "laplacian_deformation.h"

#include <algorithm>
#include <mutex>
#include <numeric>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

// One TBB task per independent piece of the band (a tee has two, one per armhole).
constexpr std::size_t PIECES_PER_TASK = 1;

// The solver of one piece with `unknowns` free vertices.
BandSolver piece_solver(BandSolver solver, std::size_t unknowns) {
  if (solver != BandSolver::AUTO) return solver;
  if (unknowns >= BAND_PIECE_ITERATIVE_UNKNOWNS) return BandSolver::MULTIGRID;
  return unknowns >= BAND_PIECE_SUPERNODAL_UNKNOWNS ? BandSolver::SUPERNODAL : BandSolver::DIRECT;
}

// [L; w·S] where S selects the constrained vertices.
SparseMatrix stacked_system(const SparseMatrix& L, std::span<const std::int32_t> constrained, double weight) {
  const Eigen::Index n = L.rows(), c = static_cast<Eigen::Index>(constrained.size());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(L.nonZeros() + c));
  for (Eigen::Index r = 0; r < L.outerSize(); ++r)
    for (SparseMatrix::InnerIterator it(L, r); it; ++it)
      t.emplace_back(it.row(), it.col(), it.value());
  for (Eigen::Index k = 0; k < c; ++k)
    t.emplace_back(n + k, constrained[static_cast<std::size_t>(k)], weight);
  SparseMatrix A(n + c, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

// Connected pieces of the free vertices, two being connected when a row of L_F (#R × #F,
// row-major) has both: piece[f] for each free vertex, numbered by their smallest free vertex.
// Returns the number of pieces.
std::int32_t free_pieces(const SparseMatrix& free_block, std::vector<std::int32_t>& piece) {
  std::vector<std::int32_t> parent(static_cast<std::size_t>(free_block.cols()));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[static_cast<std::size_t>(x)] != x)
      x = parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
    return x;
  };
  for (Eigen::Index r = 0; r < free_block.outerSize(); ++r) {
    SparseMatrix::InnerIterator it(free_block, r);
    if (!it) continue;
    const std::int32_t first = find(static_cast<std::int32_t>(it.col()));
    for (++it; it; ++it) {
      const std::int32_t other = find(static_cast<std::int32_t>(it.col()));
      if (other != first) parent[static_cast<std::size_t>(std::max(first, other))] = std::min(first, other);
    }
  }
  // Roots are each piece's smallest member, so numbering the roots in order numbers the pieces
  // by their smallest free vertex.
  piece.assign(parent.size(), -1);
  std::int32_t count = 0;
  for (std::size_t f = 0; f < parent.size(); ++f) {
    const auto root = static_cast<std::size_t>(find(static_cast<std::int32_t>(f)));
    if (piece[root] < 0) piece[root] = count++;
    piece[f] = piece[root];
  }
  return count;
}

} // namespace

struct BandLaplacianDeformer::Piece {
  std::vector<std::int32_t> columns; ///< its free vertices (indices into m_free), ascending; empty: the whole band
  std::vector<std::int32_t> rows;    ///< its rows (indices into m_rows), ascending; empty: the whole band
  std::unique_ptr<SparseLeastSquares> direct;
  std::unique_ptr<SupernodalLeastSquares> supernodal;
  std::unique_ptr<TwoGridLeastSquares> iterative;
  SparseMatrix system; ///< iterative: L[rows, columns], kept for the fallback factorisation
  /// iterative: the exact factorisation, made on the first solve that does not converge.
  mutable std::unique_ptr<SupernodalLeastSquares> fallback;
  std::unique_ptr<std::mutex> fallback_mutex = std::make_unique<std::mutex>();

  /// near_null: MULTIGRID's (#columns × 4). AUTO's MULTIGRID choice (`exact_if_refused`)
  /// factors the piece instead when the two-grid setup refuses it.
  void factor(const SparseMatrix& A, BandSolver solver, const Eigen::MatrixXd& near_null, bool exact_if_refused) {
    if (solver == BandSolver::MULTIGRID) {
      iterative = std::make_unique<TwoGridLeastSquares>(A, near_null);
      if (iterative->ok() || !exact_if_refused) {
        system = A;
        return;
      }
      iterative.reset();
      solver = BandSolver::SUPERNODAL;
    }
    if (solver == BandSolver::SUPERNODAL)
      supernodal = std::make_unique<SupernodalLeastSquares>(A);
    else
      direct = std::make_unique<SparseLeastSquares>(A);
  }
  bool ok() const { return direct ? direct->ok() : supernodal ? supernodal->ok() : iterative->ok(); }

  /// Writes its free vertices' rows of x (#F × 3) from b (#R × 3, all rows of the band);
  /// initial (#F × 3, or null for zeros) starts the iteration, `stats` receives it.
  void solve_into(const Eigen::MatrixXd& b, Eigen::MatrixXd& x, const Eigen::MatrixXd* initial, int iteration_limit,
                  IterativeSolveStats& stats) const {
    const bool whole = columns.empty();
    Eigen::MatrixXd bp, xp;
    if (whole) {
      bp = b;
    } else {
      bp.resize(static_cast<Eigen::Index>(rows.size()), b.cols());
      for (std::size_t r = 0; r < rows.size(); ++r)
        bp.row(static_cast<Eigen::Index>(r)) = b.row(rows[r]);
    }
    if (!iterative) {
      xp = direct ? direct->solve(bp) : supernodal->solve(bp);
    } else {
      const auto n = static_cast<Eigen::Index>(whole ? x.rows() : static_cast<Eigen::Index>(columns.size()));
      xp = Eigen::MatrixXd::Zero(n, b.cols());
      if (initial)
        for (Eigen::Index c = 0; c < n; ++c)
          xp.row(c) = initial->row(whole ? c : columns[static_cast<std::size_t>(c)]);
      stats = iterative->solve(bp, xp, BAND_MULTIGRID_TOLERANCE, iteration_limit);
      if (!stats.converged) {
        // Never a silently inexact answer: the exact factorisation takes over, and says so.
        const std::lock_guard<std::mutex> lock(*fallback_mutex);
        if (!fallback) fallback = std::make_unique<SupernodalLeastSquares>(system);
        if (fallback->ok()) {
          xp = fallback->solve(bp);
          stats.fell_back = true;
        }
      }
    }
    if (whole) {
      x = std::move(xp);
      return;
    }
    for (std::size_t c = 0; c < columns.size(); ++c)
      x.row(columns[c]) = xp.row(static_cast<Eigen::Index>(c));
  }
};

LaplacianDeformer::LaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> constrained, double weight,
                                     bool uniform)
    : m_laplacian(uniform ? uniform_laplacian(mesh.triangle_view(), mesh.vertex_count())
                          : cotangent_laplacian(mesh.position_view(), mesh.triangle_view())),
      m_constrained(constrained.begin(), constrained.end()), m_weight(weight),
      m_solver(stacked_system(m_laplacian, constrained, weight)) {
  for (std::int32_t v : constrained)
    if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertex_count())
      throw Error("laplacian deformation", 0, "constrained vertex " + std::to_string(v) + " out of range");
}

Eigen::MatrixXd LaplacianDeformer::laplacian_coordinates(std::span<const float> positions) const {
  const Eigen::Index n = m_laplacian.rows();
  Eigen::MatrixXd x(n, 3);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k)
      x(v, k) = positions[static_cast<std::size_t>(3 * v + k)];
  return m_laplacian * x;
}

std::vector<float> LaplacianDeformer::deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets) const {
  const Eigen::Index n = m_laplacian.rows(), c = static_cast<Eigen::Index>(m_constrained.size());
  Eigen::MatrixXd b(n + c, 3);
  b.topRows(n) = delta;
  b.bottomRows(c) = m_weight * targets;
  const Eigen::MatrixXd x = m_solver.solve(b);
  std::vector<float> out(static_cast<std::size_t>(3 * n));
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k)
      out[static_cast<std::size_t>(3 * v + k)] = static_cast<float>(x(v, k));
  return out;
}

BandLaplacianDeformer::BandLaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> handles, bool uniform,
                                             BandSolver solver, int iteration_limit)
    : m_handles(handles.begin(), handles.end()), m_iteration_limit(iteration_limit) {
  const std::size_t nv = mesh.vertex_count();
  // column[v]: index among the free vertices (≥ 0) or −1 − index among the handles.
  std::vector<std::int32_t> column(nv, 0);
  for (std::size_t h = 0; h < m_handles.size(); ++h) {
    const std::int32_t v = m_handles[h];
    if (v < 0 || static_cast<std::size_t>(v) >= nv)
      throw Error("laplacian deformation", 0, "handle vertex " + std::to_string(v) + " out of range");
    if (column[static_cast<std::size_t>(v)] < 0)
      throw Error("laplacian deformation", 0, "handle vertex " + std::to_string(v) + " given twice");
    column[static_cast<std::size_t>(v)] = -1 - static_cast<std::int32_t>(h);
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (column[v] >= 0) {
      column[v] = static_cast<std::int32_t>(m_free.size());
      m_free.push_back(static_cast<std::int32_t>(v));
    }
  // Only the rows of L with a free column are used: those of the free vertices and of their
  // neighbours, whose entries come from the faces around them. The Laplacian is built from
  // those faces alone (most of a driven garment is handles), and its other rows dropped.
  std::vector<char> in_band(nv, 0);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t* t = &mesh.triangles[3 * f];
    if (column[static_cast<std::size_t>(t[0])] >= 0 || column[static_cast<std::size_t>(t[1])] >= 0 ||
        column[static_cast<std::size_t>(t[2])] >= 0)
      for (int k = 0; k < 3; ++k)
        in_band[static_cast<std::size_t>(t[k])] = 1;
  }
  std::vector<std::int32_t> band_triangles;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t* t = &mesh.triangles[3 * f];
    if (in_band[static_cast<std::size_t>(t[0])] || in_band[static_cast<std::size_t>(t[1])] ||
        in_band[static_cast<std::size_t>(t[2])])
      band_triangles.insert(band_triangles.end(), t, t + 3);
  }
  m_laplacian =
      uniform ? uniform_laplacian(band_triangles, nv) : cotangent_laplacian(mesh.position_view(), band_triangles);
  m_laplacian.prune(
      [&](Eigen::Index row, Eigen::Index, double) { return in_band[static_cast<std::size_t>(row)] != 0; });
  if (m_free.empty()) return;
  std::vector<Eigen::Triplet<double>> free_entries, handle_entries;
  for (Eigen::Index r = 0; r < m_laplacian.outerSize(); ++r) {
    bool touches = false;
    for (SparseMatrix::InnerIterator it(m_laplacian, r); it && !touches; ++it)
      touches = column[static_cast<std::size_t>(it.col())] >= 0 && it.value() != 0;
    if (!touches) continue;
    const auto row = static_cast<Eigen::Index>(m_rows.size());
    m_rows.push_back(static_cast<std::int32_t>(r));
    for (SparseMatrix::InnerIterator it(m_laplacian, r); it; ++it) {
      const std::int32_t c = column[static_cast<std::size_t>(it.col())];
      if (c >= 0)
        free_entries.emplace_back(row, c, it.value());
      else
        handle_entries.emplace_back(row, -1 - c, it.value());
    }
  }
  const auto nr = static_cast<Eigen::Index>(m_rows.size());
  m_free_block.resize(nr, static_cast<Eigen::Index>(m_free.size()));
  m_free_block.setFromTriplets(free_entries.begin(), free_entries.end());
  m_handle_block.resize(nr, static_cast<Eigen::Index>(m_handles.size()));
  m_handle_block.setFromTriplets(handle_entries.begin(), handle_entries.end());
  if (solver == BandSolver::DIRECT || (solver == BandSolver::AUTO && m_free.size() < BAND_SUPERNODAL_UNKNOWNS)) {
    m_pieces.resize(1);
    m_pieces.front().factor(m_free_block, BandSolver::DIRECT, {}, false);
    return;
  }
  factor_pieces(solver, mesh.positions);
}

void BandLaplacianDeformer::factor_pieces(BandSolver solver, std::span<const float> positions) {
  std::vector<std::int32_t> piece;
  const std::int32_t count = free_pieces(m_free_block, piece);
  m_pieces.resize(static_cast<std::size_t>(count));
  // MULTIGRID's near-null space of a piece: the constant and its free vertices' x, y, z.
  auto near_null = [&](const std::vector<std::int32_t>& columns, BandSolver s) {
    Eigen::MatrixXd B;
    if (s != BandSolver::MULTIGRID) return B;
    const std::size_t n = columns.empty() ? m_free.size() : columns.size();
    B.resize(static_cast<Eigen::Index>(n), 4);
    for (std::size_t c = 0; c < n; ++c) {
      const auto v = static_cast<std::size_t>(m_free[columns.empty() ? c : static_cast<std::size_t>(columns[c])]);
      B.row(static_cast<Eigen::Index>(c)) << 1.0, positions[3 * v], positions[3 * v + 1], positions[3 * v + 2];
    }
    return B;
  };
  if (count == 1) {
    const BandSolver s = piece_solver(solver, m_free.size());
    m_pieces.front().factor(m_free_block, s, near_null({}, s), solver == BandSolver::AUTO);
    return;
  }
  // local[f]: f's column within its piece.
  std::vector<std::int32_t> local(m_free.size());
  for (std::size_t f = 0; f < m_free.size(); ++f) {
    Piece& p = m_pieces[static_cast<std::size_t>(piece[f])];
    local[f] = static_cast<std::int32_t>(p.columns.size());
    p.columns.push_back(static_cast<std::int32_t>(f));
  }
  for (Eigen::Index r = 0; r < m_free_block.outerSize(); ++r) {
    SparseMatrix::InnerIterator it(m_free_block, r);
    if (it)
      m_pieces[static_cast<std::size_t>(piece[static_cast<std::size_t>(it.col())])].rows.push_back(
          static_cast<std::int32_t>(r));
  }
  parallel_for_range(m_pieces.size(), PIECES_PER_TASK, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      Piece& p = m_pieces[i];
      std::vector<Eigen::Triplet<double>> entries;
      for (std::size_t r = 0; r < p.rows.size(); ++r)
        for (SparseMatrix::InnerIterator it(m_free_block, p.rows[r]); it; ++it)
          entries.emplace_back(static_cast<Eigen::Index>(r), local[static_cast<std::size_t>(it.col())], it.value());
      SparseMatrix A(static_cast<Eigen::Index>(p.rows.size()), static_cast<Eigen::Index>(p.columns.size()));
      A.setFromTriplets(entries.begin(), entries.end());
      const BandSolver s = piece_solver(solver, p.columns.size());
      p.factor(A, s, near_null(p.columns, s), solver == BandSolver::AUTO);
    }
  });
}

std::size_t BandLaplacianDeformer::pieces() const { return m_pieces.size(); }

bool BandLaplacianDeformer::iterative() const {
  return std::any_of(m_pieces.begin(), m_pieces.end(), [](const Piece& p) { return p.iterative != nullptr; });
}

bool BandLaplacianDeformer::ok() const {
  if (m_free.empty()) return true;
  return std::all_of(m_pieces.begin(), m_pieces.end(), [](const Piece& p) { return p.ok(); });
}

BandLaplacianDeformer::~BandLaplacianDeformer() = default;
BandLaplacianDeformer::BandLaplacianDeformer(BandLaplacianDeformer&&) noexcept = default;
BandLaplacianDeformer& BandLaplacianDeformer::operator=(BandLaplacianDeformer&&) noexcept = default;

Eigen::MatrixXd BandLaplacianDeformer::laplacian_coordinates(std::span<const float> positions) const {
  const Eigen::Index n = m_laplacian.rows();
  Eigen::MatrixXd x(n, 3);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k)
      x(v, k) = positions[static_cast<std::size_t>(3 * v + k)];
  return m_laplacian * x;
}

std::vector<float> BandLaplacianDeformer::deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets,
                                                 const Eigen::MatrixXd* initial, IterativeSolveStats* stats) const {
  if (stats) *stats = {};
  const Eigen::Index n = m_laplacian.rows();
  std::vector<float> out(static_cast<std::size_t>(3 * n));
  for (std::size_t h = 0; h < m_handles.size(); ++h)
    for (int k = 0; k < 3; ++k)
      out[3 * static_cast<std::size_t>(m_handles[h]) + static_cast<std::size_t>(k)] =
          static_cast<float>(targets(static_cast<Eigen::Index>(h), k));
  if (m_free.empty()) return out;
  // ‖L_F x_F − (δ − L_H t)‖² over the rows that touch a free vertex.
  Eigen::MatrixXd b(static_cast<Eigen::Index>(m_rows.size()), 3);
  for (std::size_t r = 0; r < m_rows.size(); ++r)
    b.row(static_cast<Eigen::Index>(r)) = delta.row(m_rows[r]);
  b -= m_handle_block * targets;
  // The free vertices' initial guess (#F × 3) for the iterative pieces.
  Eigen::MatrixXd x0;
  if (initial && iterative()) {
    x0.resize(static_cast<Eigen::Index>(m_free.size()), 3);
    for (std::size_t f = 0; f < m_free.size(); ++f)
      x0.row(static_cast<Eigen::Index>(f)) = initial->row(m_free[f]);
  }
  const Eigen::MatrixXd* guess = x0.size() ? &x0 : nullptr;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(m_free.size()), b.cols());
  std::vector<IterativeSolveStats> piece_stats(m_pieces.size());
  parallel_for_range(m_pieces.size(), PIECES_PER_TASK, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      m_pieces[i].solve_into(b, x, guess, m_iteration_limit, piece_stats[i]);
  });
  if (stats && iterative()) {
    stats->converged = true;
    for (std::size_t i = 0; i < m_pieces.size(); ++i) {
      if (!m_pieces[i].iterative) continue;
      const IterativeSolveStats& s = piece_stats[i];
      stats->iterations = std::max(stats->iterations, s.iterations);
      stats->relative_residual = std::max(stats->relative_residual, s.relative_residual);
      stats->converged = stats->converged && s.converged;
      stats->fell_back = stats->fell_back || s.fell_back;
    }
  }
  for (std::size_t f = 0; f < m_free.size(); ++f)
    for (int k = 0; k < 3; ++k)
      out[3 * static_cast<std::size_t>(m_free[f]) + static_cast<std::size_t>(k)] =
          static_cast<float>(x(static_cast<Eigen::Index>(f), k));
  return out;
}

} // namespace vfit
