// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Laplacian surface deformation (seed 000 §5.4, after Sorkine et al. 2004): positions x that
/// keep given differential coordinates δ while constrained vertices reach their targets,
/// argmin ‖L x − δ‖² + w² Σ_c ‖x_c − t_c‖², solved per axis with one factorisation reused for
/// every new set of targets and δ.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/least_squares.h"
#include "vfit/kernels/supernodal_least_squares.h"
#include "vfit/kernels/two_grid_least_squares.h"

namespace vfit {

class LaplacianDeformer {
public:
  /// mesh: the rest surface (its cotangent Laplacian is used; uniform when `uniform`).
  /// constrained: vertex indices held near their targets with weight `weight` (≥ 1 keeps
  /// them within about 1/weight² of the target's pull against the Laplacian term).
  /// ok() is false when the system is singular (a connected part has no constraint).
  LaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> constrained, double weight, bool uniform = false);

  bool ok() const { return m_solver.ok(); }

  /// δ of arbitrary positions (#V × 3, m): L · x. Pass the rigidly transformed mesh to get the
  /// rotated detail that deform() should preserve.
  Eigen::MatrixXd laplacian_coordinates(std::span<const float> positions) const;

  /// Solves for all vertices. delta: #V × 3; targets: #C × 3 (m), in `constrained` order.
  /// Returns #V × 3 positions as floats (flat).
  std::vector<float> deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets) const;

private:
  SparseMatrix m_laplacian;
  std::vector<std::int32_t> m_constrained;
  double m_weight;
  SparseLeastSquares m_solver;
};

/// How BandLaplacianDeformer solves its normal equations L_Fᵀ L_F x_F = L_Fᵀ b.
enum class BandSolver {
  /// DIRECT below BAND_SUPERNODAL_UNKNOWNS free vertices (one factorisation of the whole
  /// band: the Table-1 garments' 600–3,300). From there on the band is split into its
  /// connected pieces (a tee's two armholes), which are independent systems, set up and
  /// solved concurrently (one TBB task each): by MULTIGRID when a piece has at least
  /// BAND_PIECE_ITERATIVE_UNKNOWNS free vertices, by SUPERNODAL from
  /// BAND_PIECE_SUPERNODAL_UNKNOWNS, by DIRECT below. The factored pieces give the
  /// least-squares solution up to round-off, the iterative ones within BAND_MULTIGRID_TOLERANCE.
  AUTO = 0,
  /// Simplicial sparse LDLᵀ (SparseLeastSquares) of the whole band at once: exact; fastest for
  /// small bands, but its fill-in makes the factorisation grow about as #F^1.8.
  DIRECT = 1,
  /// CHOLMOD's supernodal Cholesky (SupernodalLeastSquares) of each connected piece of the
  /// band, the pieces concurrently: exact, the same fill-in worked in dense blocks; still
  /// superlinear (about #F^1.4).
  SUPERNODAL = 2,
  /// Conjugate gradients preconditioned by a two-grid cycle (TwoGridLeastSquares: aggregates
  /// of ~20 free vertices carrying the constant and linear functions, the coarse system
  /// factored) on each connected piece, the pieces concurrently, from the caller's initial
  /// guess, to BAND_MULTIGRID_TOLERANCE. 15–18 iterations for bands of 22,523 to 225,558
  /// free vertices; about linear in #F but for the coarse factorisation (of ~#F / 5 unknowns). A piece whose
  /// iteration does not converge within the iteration limit is factored by SUPERNODAL and
  /// solved exactly instead, and the solve reports it (IterativeSolveStats::fell_back).
  MULTIGRID = 3,
};

/// BandSolver::AUTO's switch from one factorisation of the whole band to its pieces solved
/// concurrently. Below it lie the Table-1 garments' bands (600–3,300 free vertices), which
/// keep their single simplicial factorisation.
inline constexpr std::size_t BAND_SUPERNODAL_UNKNOWNS = 5000;
/// BandSolver::AUTO: pieces with at least this many free vertices are factored by SUPERNODAL,
/// smaller ones by DIRECT (below about this size the two cost about the same).
inline constexpr std::size_t BAND_PIECE_SUPERNODAL_UNKNOWNS = 5000;
/// BandSolver::AUTO: pieces with at least this many free vertices are solved by MULTIGRID,
/// about where its near-linear cost overtakes SUPERNODAL's superlinear factorisation.
inline constexpr std::size_t BAND_PIECE_ITERATIVE_UNKNOWNS = 25000;
/// BandSolver::MULTIGRID's stopping rule: ‖L_Fᵀ(b − L_F x)‖ ≤ this × ‖L_Fᵀ b‖ per axis, ‖L_Fᵀ b‖
/// the largest of the three axes' (positions share one unit). On driven tees (from the blended
/// rigid guess, 42 mm at worst from the solution) it left the free vertices within 0.010 mm
/// (22,523 free), 0.022 mm (70,224) and 0.036 mm (225,558) of the factored solution, 0.001 to
/// 0.003 mm on average.
inline constexpr double BAND_MULTIGRID_TOLERANCE = 1e-7;
/// BandSolver::MULTIGRID's iteration limit per piece, past which the piece falls back to its
/// exact factorisation: about 3× the 13–18 iterations driven tees need, so that a stalled
/// iteration costs a few solves' time, not hundreds.
inline constexpr int BAND_MULTIGRID_ITERATIONS = 50;

/// Laplacian surface deformation with the handles held exactly (hard constraints): only the
/// free vertices are unknowns, argmin over x_F of ‖L x − δ‖² with x_H = t. Rows of L that touch
/// no free vertex are constant and dropped, so the factorisation is of the free band's system
/// alone (#F unknowns, not #V): far cheaper when most of the mesh is handles, as in skeleton
/// driving (seed 000 §5.4). (The square system of the free rows alone, L_FF x_F = δ_F − L_FH t,
/// factors faster, but leaves the handle rows next to the band all the residual: the driven
/// catalogue tee's mean edge-length change away from the joints rose from 2.5 % to 3.7 %, over
/// the 3 % that skeleton_driving_test allows.)
/// ok() is false when the reduced system is singular: a connected piece of free vertices with
/// no handle in its Laplacian stencil.
class BandLaplacianDeformer {
public:
  /// mesh: the rest surface (cotangent Laplacian; uniform when `uniform`). handles: vertex
  /// indices held at their targets, in any order, each once; throws vfit::Error("laplacian
  /// deformation", …) naming a handle out of range.
  /// solver: how the free band's system is solved (BandSolver); all give the same positions,
  /// MULTIGRID up to BAND_MULTIGRID_TOLERANCE. iteration_limit: MULTIGRID's conjugate-gradient
  /// iterations per piece before it falls back to the exact factorisation (≥ 0).
  BandLaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> handles, bool uniform = false,
                        BandSolver solver = BandSolver::AUTO, int iteration_limit = BAND_MULTIGRID_ITERATIONS);
  ~BandLaplacianDeformer();
  BandLaplacianDeformer(BandLaplacianDeformer&&) noexcept;
  BandLaplacianDeformer& operator=(BandLaplacianDeformer&&) noexcept;

  /// False when the free band's system is singular (a free piece touches no handle; for
  /// MULTIGRID, its coarse system is): callers check it before deform(). True for an empty band.
  bool ok() const;

  /// Independent systems the band is solved as: its connected pieces for AUTO (from
  /// BAND_SUPERNODAL_UNKNOWNS free vertices on), SUPERNODAL and MULTIGRID; 1 for DIRECT and a
  /// smaller band under AUTO; 0 for an empty band.
  std::size_t pieces() const;

  /// True when some piece of the free band is solved by BandSolver::MULTIGRID (after AUTO's
  /// choice): deform() then uses an initial guess.
  bool iterative() const;

  /// δ = L · x for positions (#V × 3 flat, m) of this mesh: #V × 3. Only the rows deform()
  /// reads are kept (free vertices and their neighbours, built from the faces around them);
  /// the others are zero.
  Eigen::MatrixXd laplacian_coordinates(std::span<const float> positions) const;

  /// delta: #V × 3 target differential coordinates (only the rows that touch a free vertex
  /// are read); targets: #H × 3 (m), in `handles` order. Returns #V × 3 positions as floats
  /// (flat): handles at their targets exactly, free vertices from the least squares.
  /// initial (optional, #V × 3, m; only the free rows are read): MULTIGRID's starting guess,
  /// e.g. the vertices' rigid positions, which saves iterations (zeros when absent); ignored by
  /// DIRECT and SUPERNODAL. stats (optional) receives MULTIGRID's iterations and residual, the
  /// worst over its pieces, converged when every piece's iteration converged, and fell_back
  /// when some piece was solved by its exact factorisation instead (zeros and converged false
  /// when no piece is iterative). converged and fell_back both false: a piece's iteration did
  /// not converge and CHOLMOD refused its factorisation (singular to its bar, not to the
  /// two-grid setup's); that piece's positions are then the last iterate.
  std::vector<float> deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets,
                            const Eigen::MatrixXd* initial = nullptr, IterativeSolveStats* stats = nullptr) const;

  /// The free vertices (not handles), ascending: the unknowns.
  const std::vector<std::int32_t>& free_vertices() const { return m_free; }

private:
  /// Splits the band into its connected pieces and sets each up (concurrently) with `solver`
  /// (AUTO: by the piece's size); positions: the mesh's (#V × 3), MULTIGRID's near-null space.
  void factor_pieces(BandSolver solver, std::span<const float> positions);

  SparseMatrix m_laplacian;            ///< #V × #V, rows of the free vertices and their neighbours only
  std::vector<std::int32_t> m_handles; ///< #H, caller's order
  std::vector<std::int32_t> m_free;    ///< #F ascending
  std::vector<std::int32_t> m_rows;    ///< rows of L with a free column, ascending
  SparseMatrix m_free_block;           ///< L[rows, F]
  SparseMatrix m_handle_block;         ///< L[rows, H] (columns in `handles` order)
  /// One independent system of the band: a connected piece of free vertices and the rows
  /// that touch it, solved by SparseLeastSquares, SupernodalLeastSquares or
  /// TwoGridLeastSquares (defined in the .cpp).
  struct Piece;
  std::vector<Piece> m_pieces;
  int m_iteration_limit = BAND_MULTIGRID_ITERATIONS;
};

} // namespace vfit
