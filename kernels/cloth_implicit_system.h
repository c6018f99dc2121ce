// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The implicit-Euler step's linear system and solve options (seed 000 §6.3 integrated
/// implicitly; Baraff & Witkin's A Δv = b), shared by the solver (cloth_implicit.h), its
/// per-block kernels (cloth_implicit_blocks.h) and its coarse space (cloth_implicit_coarse.h).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "spring_adjacency.h"

namespace vfit {

/// Particles per reduction chunk (and per TBB task) of the implicit solver. Fixed, so the
/// order of every floating-point sum is independent of the thread count.
/// 512: a 6,000-particle garment splits into 12 chunks, which two threads share evenly (2,048
/// gave 3 chunks, one thread doing two of them).
inline constexpr std::size_t CLOTH_IMPLICIT_CHUNK = 512;
static_assert(CLOTH_IMPLICIT_CHUNK % CLOTH_SLICE_WIDTH == 0, "a chunk covers whole slices");

/// Preconditioner of the implicit step's conjugate gradient.
enum class ImplicitPreconditioner : std::int8_t {
  /// The inverse 3×3 diagonal blocks A_ii⁻¹ (the default).
  BLOCK_JACOBI = 0,
  /// Block Jacobi plus a coarse-grid correction (additive two-level Schwarz): M⁻¹ = S·D⁻¹·S +
  /// P·(Pᵀ·A·P)⁻¹·Pᵀ, P the piecewise-constant translations of aggregates of neighbouring
  /// particles (implicit_coarse_aggregates()), filtered as the solve (S); the 3×3-block coarse
  /// matrix is assembled in double and factored (CHOLMOD, supernodal) per solve (the re-solve
  /// after releasing pulling contact springs reuses it). Symmetric positive definite as a sum
  /// of two such terms, so CG stays CG, to the same tolerance; the smooth error block Jacobi
  /// leaves (a garment's sag as a whole) is removed in one step.
  TWO_LEVEL = 1,
  /// BLOCK_JACOBI until a solve with it takes more than ImplicitSolveOptions::two_level_after
  /// iterations, TWO_LEVEL from the next solve on (for the workspace's life): a garment lying
  /// on a body, whose smooth modes block Jacobi resolves slowly, switches; a mass-dominated
  /// system (a few iterations per step, where the coarse level's factorisation and solve cost
  /// more than they save) stays. The switch depends on iteration counts only, so the serial and
  /// TBB drivers switch at the same step.
  AUTO = 2,
};

/// Stopping rule and preconditioner of the conjugate gradient.
struct ImplicitSolveOptions {
  /// Stop when ‖r‖ ≤ tolerance·‖b‖ (filtered residual and right-hand side, Euclidean norms in
  /// N·s) and, with per_patch, the same holds on every patch at its share of ‖b‖² (below).
  /// 1e-3 leaves a velocity error far below what one step changes; at rest b → 0 and the
  /// relative test still drives the solve, so the equilibrium is the true f(x) = 0.
  double tolerance = 1e-3;
  int max_iterations = 200; ///< also stops here (the step is then taken with the last iterate)
  /// Also require, on every patch P of CLOTH_IMPLICIT_CHUNK consecutive particles (the
  /// reduction chunks; in ClothSim's Cuthill–McKee numbering, kernels/cloth_ordering.h, a
  /// strip of neighbouring particles: part of one cross-section ring of a 10⁶-vertex garment,
  /// a few whole rings of a 6,000-vertex one), ‖r_P‖² ≤ tolerance²·(n_P / n)·scale, n_P
  /// and n the free particles in P and in all, scale the global test's ‖b‖² (or ‖r₀‖²): the
  /// RMS residual impulse per particle of every patch within tolerance of the whole cloth's
  /// RMS right-hand side per particle. The global test alone dilutes with the particle count:
  /// at 10⁶ particles and 1e-2 it passes with a patch of 10⁴ particles still 10 % wrong (or 100
  /// left entirely unsolved), which let a 10⁶-vertex tee's truncation error grow into a
  /// runaway-stretch front on its upper back within 12 steps; per patch, an error confined to
  /// one patch is held to the tolerance whatever the cloth's size (its bound is intensive).
  /// The per-patch bounds sum to the global one, so this only adds iterations where the error
  /// is uneven. Same bits for any thread count (fixed chunks).
  bool per_patch = true;
  /// Start from workspace.dv (#V × 3, m/s; a previous solution) instead of Δv = 0; the relative
  /// test is then against the initial residual ‖r₀‖ (the part of the answer still missing), as
  /// ‖b‖ would be met at once by a good start whose error never shrinks. Ignored with
  /// constraints, which set their own start.
  bool warm_start = false;
  /// Start from the best uniform velocity change instead of Δv = 0 (unconstrained solves
  /// without warm_start): Δv₀ = P·c on the free particles, c = (Pᵀ·A·P)⁻¹·Pᵀ·b with P the
  /// 3 columns of a common translation, the Galerkin answer on that space, so the start's error
  /// is A-orthogonal to every common translation and its energy norm no larger than Δv = 0's.
  /// The stopping test keeps ‖b‖ as its scale. Block Jacobi alone removes a smooth error
  /// slowly, one spring ring per iteration: a cloth falling freely before it touches the body
  /// (the response to gravity is nearly a common translation) can take the iteration cap at
  /// every step.
  bool translation_start = true;
  /// translation_start is kept only when it leaves ‖r₀‖ ≤ translation_keep·‖b‖ (it answers
  /// most of the step, as in free fall); otherwise the solve starts from Δv = 0 as without
  /// it. Where contacts hold part of the cloth, a common translation is not the shape of the
  /// answer: started from it, the truncated solve left some of it in the resting parts, which
  /// kept a drape moving longer before it came to rest.
  double translation_keep = 0.1;
  ImplicitPreconditioner preconditioner = ImplicitPreconditioner::BLOCK_JACOBI;
  /// TWO_LEVEL: the mean particles per aggregate to reach (see implicit_coarse_aggregates());
  /// 0 = as few coarsening passes as leave at most 2,048 aggregates.
  std::size_t aggregate_particles = 0;
  /// AUTO: block-Jacobi iterations beyond which the workspace switches to TWO_LEVEL. The
  /// coarse level's assembly, factorisation and per-iteration solve cost a few iterations of
  /// the product per step, so it pays where block Jacobi needs many more (a garment lying on a
  /// body) and not where it needs a few (a mass-dominated system).
  int two_level_after = 16;
};

/// The linear system of one implicit step, assembled at the step start (x₀, v₀). Row i of
/// A = M − h·∂f/∂v − h²·∂f/∂x is A_ii·p_i − Σ_e S_e·p_j over particle i's adjacency entries e
/// (neighbour j); pinned rows are filtered out.
struct ImplicitSystem {
  /// 6 × #adjacency entries: S_e (kg), component-major (xx of every entry, then xy, xz, yy,
  /// yz, zz), so a loop over entries reads each component contiguously and vectorises.
  std::vector<float> off_diagonal;
  /// The same springs in the adjacency's sliced rows (SpringAdjacency::slice_offsets) in
  /// rank-one form, which the CG's product reads (one particle per SIMD lane): 5 × #slots,
  /// component-major (u_x, u_y, u_z, a, t), S_e = a·u·uᵀ + t·I with u the spring's unit
  /// direction, a = h·c + h²·(k − t') and t = h²·t' (t' = k·(1 − L/l) clamped at 0); zero in
  /// the null slots. Applied as a·u·(u·d) + t·d: the float rounding of S_e's six entries (2⁻²⁴
  /// of a each) would act on every direction, the rank-one form's only on d's component
  /// along u, so a light particle's weak (out-of-plane) direction keeps its mass term.
  std::vector<float> sliced_springs;
  std::vector<float> diagonal; ///< #V × 6: A_ii = D_i + Σ_e S_e (kg), D_i below
  /// #V × 6: D_i = A_ii − Σ_e S_e, the particle's own part of its diagonal block: m_i·(1 +
  /// h·μ)·I plus a contact spring's h²·k·n·nᵀ (kg), zero when pinned. The CG's product forms
  /// row i as D_i·p_i + Σ_e S_e·(p_i − p_j), the springs acting on relative values only: the
  /// same value as A_ii·p_i − Σ_e S_e·p_j, but without summing h²·k terms that cancel to
  /// leave m_i·p_i, whose float rounding (≈ 2⁻²⁴·h²·Σk per row) outweighs the mass term of a
  /// fine mesh's light particles (a sliver's 10⁻¹⁰–10⁻⁹ kg against h²·Σk ≈ 0.03–0.06 kg at
  /// h = 5 ms) and made the rounded A indefinite there (CG then diverged).
  std::vector<float> particle_blocks;
  /// #V: D_i without a contact spring, m_i·(1 + h·μ) (kg), 0 when pinned.
  std::vector<float> inertia;
  /// A_ii⁻¹ (1/kg; A_ii shifted by 2⁻¹⁸ of its springs' trace first, which keeps the float
  /// inverse positive definite for a light particle and changes CG's convergence only), zero
  /// for pinned particles, by slices of CLOTH_SLICE_WIDTH particles (so a slice's lanes read
  /// each component contiguously): 6 × W floats per slice, component c of particle i at
  /// 6·W·⌊i / W⌋ + W·c + (i mod W), components ordered as `diagonal`'s.
  std::vector<float> preconditioner;
  std::vector<float> rhs;          ///< #V × 3: b = h·(f₀ + h·∂f/∂x·v₀) (N·s), zero when pinned
  std::vector<unsigned char> free; ///< #V: 1 = free particle, 0 = pinned (filtered)
};

} // namespace vfit
