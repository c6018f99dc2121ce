#pragma once
/// \file
/// Conjugate gradients preconditioned by a smoothed-aggregation algebraic multigrid V-cycle
/// (Vaněk, Mandel & Brezina 1996) for large sparse symmetric positive definite systems whose
/// direct factorisation fills in superlinearly: the normal equations LᵀL of Laplacian surface
/// deformation over a free band of 10^5–10^6 vertices (seed 000 §5.4). The hierarchy is built
/// once per matrix; each V-cycle is linear in the matrix's non-zeros. The near-null space
/// (constants and linear functions) is carried to every level, and the prolongators reproduce
/// it. On that fourth-order system it needs 17, 20 and 22 iterations to a 1e-6 residual for
/// 22,523, 70,224 and 225,558 unknowns, but its setup and V-cycles cost more than CHOLMOD's
/// factorisation at those sizes, so the band solve uses it only on request
/// (BandSolver::MULTIGRID).

#include <cstddef>
#include <memory>

#include <Eigen/Dense>

#include "laplacian.h"

namespace vfit {

/// Parameters of the multigrid hierarchy and its smoother.
struct SmoothedAggregationOptions {
  /// Node J is a strong neighbour of node I when ‖A_IJ‖ ≥ strength · √(‖A_II‖ ‖A_JJ‖);
  /// aggregates grow over strong connections only. 0.02 keeps a bi-Laplacian LᵀL's one- and
  /// two-ring couplings on the finest level (aggregates of about two rings, 4.7× fewer unknowns
  /// on the next level); measured on driven tees' bands, it needed fewer iterations than 0.08
  /// or 0.15.
  double strength = 0.02;
  /// Levels are added until the coarsest has at most this many unknowns; it is factored (LDLᵀ).
  std::size_t coarse_size = 1500;
  /// Hard limit on the number of levels, the finest included.
  int max_levels = 12;
  /// Degree of the Chebyshev polynomial smoother in D⁻¹A (D: A's diagonal blocks, one per
  /// node; block Jacobi), applied before and after each coarse correction (that many products
  /// with A each).
  int smoothing_degree = 3;
  /// The smoother damps D⁻¹A's spectrum in [λ_max / smoothing_range, λ_max]; the rest is the
  /// coarse levels' job.
  double smoothing_range = 20.0;
};

/// What one solve did.
struct IterativeSolveStats {
  int iterations = 0;             ///< conjugate-gradient iterations (one V-cycle each)
  double relative_residual = 0.0; ///< max over columns of ‖b − A x‖ / ‖b‖ at exit
  bool converged = false;         ///< every column reached the tolerance within the limit
};

/// Precompute/solve: builds the aggregation hierarchy of a sparse SPD matrix A (#N × #N, both
/// triangles stored, symmetric) once, then solves A X = B for any right-hand sides by
/// preconditioned conjugate gradients. Products with A run in parallel (parallel.h); the
/// results do not depend on the thread count.
class SmoothedAggregationSolver {
public:
  /// Builds the hierarchy. ok() is false when the coarsest level's factorisation finds A
  /// singular (ldlt_pivots_regular() fails: for a Laplacian system, a connected piece with no
  /// constraint) — a status, as for SparseLeastSquares. Asserts A is square.
  /// near_null: #N × m vectors A nearly annihilates, which the coarse levels must represent
  /// exactly; empty for the constant vector alone. For LᵀL of a mesh Laplacian pass the
  /// constant and the vertices' x, y, z (#N × 4): linear functions are L's kernel away from
  /// the boundary, and a hierarchy without them needs iterations that grow with resolution.
  explicit SmoothedAggregationSolver(const SparseMatrix& A, const Eigen::MatrixXd& near_null = {},
                                     const SmoothedAggregationOptions& options = {});
  ~SmoothedAggregationSolver();
  SmoothedAggregationSolver(SmoothedAggregationSolver&&) noexcept;
  SmoothedAggregationSolver& operator=(SmoothedAggregationSolver&&) noexcept;

  /// Whether the coarsest level's factorisation succeeded (see the constructor).
  bool ok() const;

  /// Solves A X = B column by column (B: #N × k), starting from X (#N × k, the initial guess;
  /// resized to zeros when its shape differs), until ‖B_c − A X_c‖ ≤ tolerance · ‖B_c‖ for every
  /// column c or after max_iterations. A zero column of B gives a zero column of X. Only when
  /// ok(): otherwise the coarse solves, and so X, are undefined.
  IterativeSolveStats solve(const Eigen::MatrixXd& B, Eigen::MatrixXd& X, double tolerance, int max_iterations) const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// Y = A X for a compressed row-major sparse A (#R × #C) and dense X (#C × k); Y is resized to
/// #R × k. Rows in parallel chunks, each row summed in storage order (the same bits for any
/// thread count).
void parallel_multiply(const SparseMatrix& A, const Eigen::MatrixXd& X, Eigen::MatrixXd& Y);

} // namespace vfit
