// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Sparse linear least squares min ‖A x − b‖² by conjugate gradients on the normal equations
/// AᵀA x = Aᵀb, preconditioned by a symmetric two-grid cycle: for the free band of Laplacian
/// surface deformation on 10^5–10^6-vertex garments (seed 000 §5.4), whose exact factorisation
/// (supernodal_least_squares.h) grows about as #N^1.4. The coarse space is aggregation-based
/// (Vaněk, Mandel & Brezina 1996, without the prolongator smoothing): the unknowns are grouped
/// into aggregates of about two rings over AᵀA's strong couplings, and on each aggregate the
/// near-null vectors (for a mesh Laplacian: the constant and the linear functions x, y, z)
/// span the coarse functions. The coarse Galerkin system, about 5× smaller, is factored by
/// CHOLMOD; a Chebyshev smoother in D⁻¹AᵀA (D: its diagonal) runs before and after the coarse
/// correction, damping the spectrum up to a guaranteed (Gershgorin) bound, so the cycle is
/// symmetric positive definite and CG's convergence theory holds. AᵀA is never formed:
/// products go through A and Aᵀ. On driven tees' bands the iterations stay at 15–18 from
/// 22,523 to 225,558 unknowns (to a 1e-7 residual).

#include <cstddef>
#include <memory>

#include <Eigen/Dense>

#include "laplacian.h"

namespace vfit {

/// What one iterative solve did.
struct IterativeSolveStats {
  int iterations = 0;             ///< conjugate-gradient iterations (one two-grid cycle each)
  double relative_residual = 0.0; ///< max over columns of ‖Aᵀ(b − A x)‖ / ‖Aᵀb‖ at exit
  bool converged = false;         ///< every column reached the tolerance within the limit
  /// The iteration did not converge and the exact factorisation solved the system instead
  /// (BandLaplacianDeformer); `iterations` and `relative_residual` are the iteration's.
  bool fell_back = false;
};

/// Parameters of the two-grid preconditioner.
struct TwoGridOptions {
  /// Unknown j is a strong neighbour of i when |(AᵀA)_ij| ≥ strength · √((AᵀA)_ii (AᵀA)_jj);
  /// aggregates grow over strong couplings. 0.02 keeps a bi-Laplacian's one- and two-ring
  /// couplings: aggregates of about 20 unknowns, a coarse system ~5× smaller.
  double strength = 0.02;
  /// Degree of the Chebyshev smoother before and after the coarse correction (that many
  /// products with AᵀA each, one fewer from the zero initial guess).
  int smoothing_degree = 3;
  /// The smoother damps D⁻¹AᵀA's spectrum in [λ / smoothing_range, λ], λ its Gershgorin bound;
  /// the rest is the coarse correction's job.
  double smoothing_range = 20.0;
};

/// Precompute/solve: builds the aggregates, the coarse system and its factorisation for a fixed
/// sparse A (#R × #N, full column rank) once, then solves min ‖A x − b‖² for any right-hand
/// sides from a starting guess. Deterministic: the same bits for any thread count.
class TwoGridLeastSquares {
public:
  /// near_null: #N × m (m ≥ 1) vectors that AᵀA nearly annihilates, first column the constant;
  /// for a mesh Laplacian the constant and the unknowns' rest x, y, z (#N × 4). ok() is false
  /// when AᵀA has a zero diagonal entry or the coarse system's factorisation finds it singular
  /// or ill-conditioned (CHOLMOD's reciprocal condition estimate ≤ 10^-12: a Laplacian system
  /// with an unconstrained connected piece, whose constant lies in the coarse space) — a
  /// status. Asserts near_null has #N rows.
  TwoGridLeastSquares(const SparseMatrix& A, const Eigen::MatrixXd& near_null, const TwoGridOptions& options = {});
  ~TwoGridLeastSquares();
  TwoGridLeastSquares(TwoGridLeastSquares&&) noexcept;
  TwoGridLeastSquares& operator=(TwoGridLeastSquares&&) noexcept;

  /// Whether the setup succeeded (see the constructor); solve() only when true.
  bool ok() const;
  /// Unknowns of the coarse system (the aggregates' coarse functions summed).
  std::size_t coarse_unknowns() const;

  /// b: #R × k right-hand sides; x: #N × k, the starting guess on entry (resized to zeros when
  /// its shape differs), the solution on exit. Stops when ‖Aᵀ(b_c − A x_c)‖ ≤ tolerance ·
  /// ‖Aᵀb_c‖ for every column c, or after max_iterations (converged false). A column with
  /// Aᵀb_c = 0 gives x_c = 0.
  IterativeSolveStats solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& x, double tolerance, int max_iterations) const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
