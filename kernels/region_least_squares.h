// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Least squares over a region of a mesh, factored once and solved many times: the per-round
/// solve of penetration removal (seed 000 eq. 19–21; seed 004 §3.2.2), restricted to the
/// vertices within a few rings of the pushed ones while the rest of the mesh stays fixed.
///
/// In displacements δ = y − y⁰ of the region's vertices R (the fixed ones keep δ = 0):
///   seed 000: min ‖δ − p‖² + λ‖L_R δ‖²                 → (I + λ L_RᵀL_R) δ = p,
///   seed 004: min ‖δ − p‖² + ω_s‖L_R δ − g‖² + ω_d‖δ‖²  → ((1 + ω_d) I + ω_s L_RᵀL_R) δ = p + ω_s L_Rᵀ g,
/// p the pushes, g a drift of the Laplacian coordinates per region row. L_R holds L's region
/// rows and its columns in R. The matrix c·I + w·L_RᵀL_R is symmetric positive definite; its
/// eigenvalues lie in [c, c + w·(2·max degree)²] (Gershgorin on the graph Laplacian), so its
/// condition number reaches ~150 for λ = 1 on a triangle mesh: CG needs ~75 iterations to a
/// 1e-7 residual and ~35 to 1e-3, and a sparse LDLᵀ factorisation, reused over many solves,
/// pays off on small regions.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include "laplacian.h"

namespace vfit {

/// The unknowns of a region solve: the vertices within some rings of seed vertices (R), and
/// the Laplacian rows that touch them (R and one ring more).
struct SolveRegion {
  std::vector<std::int32_t> column;  ///< per vertex: its unknown index in R, or −1 when fixed
  std::vector<std::size_t> vertices; ///< unknown index → vertex, ascending
  std::vector<std::size_t> rows;     ///< Laplacian rows (vertices) whose stencil touches R, ascending
  std::vector<char> moves;           ///< per vertex: 1 when in R
  /// Whether every vertex flagged non-zero in `flagged` (#V) is an unknown of the region.
  bool covers(std::span<const char> flagged) const;
};

/// Grows the vertices with ring[v] == 0 by `rings` rings over L's stencil (#V × #V, its
/// off-diagonal entries the adjacency); returns each vertex's ring (0 = seed), −1 for the
/// vertices not reached. `ring` is #V, −1 for vertices that are not seeds. O(vertices reached ·
/// valence).
std::vector<int> rings_around(const SparseMatrix& L, std::vector<int> ring, int rings);

/// The region of the vertices within `rings` rings of the seeds (`seeds`: #V, non-zero = seed)
/// over L's stencil, with the rows one ring further. No seeds: an empty region.
SolveRegion make_solve_region(const SparseMatrix& L, const std::vector<char>& seeds, int rings);

/// (c·I + w·L_RᵀL_R) δ = rhs for one region, set up once and solved for any number of
/// right-hand sides (#R × 3, the three columns together). Built with `cholesky`, the matrix is
/// factored (sparse LDLᵀ, fill-reducing ordering) and each solve is two triangular sweeps;
/// without, each solve runs Jacobi-preconditioned conjugate gradients to ‖r‖ ≤
/// cg_tolerance·‖rhs‖ per column or 200 iterations (a solve stopped by the cap is returned as
/// it is), its products and dot products TBB-parallel and summed in a fixed order, so the
/// result does not depend on the thread count. Throws vfit::Error ("remove_penetration: the
/// region's system is not positive definite") when the factorisation meets a zero pivot (c = 0 and w = 0).
class RegionSystem {
public:
  RegionSystem(const SparseMatrix& L, const SolveRegion& region, double c, double w, bool cholesky,
               double cg_tolerance);

  /// Region rows of L_R (#rows of the region).
  Eigen::Index rows() const { return m_L.rows(); }
  /// w·L_Rᵀ g for g with one row per region row (#rows × 3): seed 004's drift term.
  Eigen::MatrixXd transpose_times(const Eigen::MatrixXd& g) const { return m_w * (m_Lt * g); }
  /// δ (#R × 3) for `rhs` (#R × 3). `iterations` receives the CG iterations (0 when factored).
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs, int& iterations) const;
  /// Whether the system was factored (`cholesky` at construction).
  bool factored() const { return m_cholesky.has_value(); }

private:
  Eigen::MatrixXd solve_factored(const Eigen::MatrixXd& rhs) const;

  double m_c, m_w, m_cg_tolerance;
  SparseMatrix m_L;                                  // region rows × R
  Eigen::SparseMatrix<double, Eigen::RowMajor> m_Lt; // R × region rows
  Eigen::VectorXd m_inverse_diagonal;
  std::optional<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> m_cholesky;
};

} // namespace vfit
