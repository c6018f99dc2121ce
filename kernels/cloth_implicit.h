// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Implicit (backward) Euler integration of a mass-spring cloth (Baraff & Witkin 1998, §3 and
/// §5; seed 004 §2 uses it): one linearised backward-Euler step of length h solves
///   (M − h·∂f/∂v − h²·∂f/∂x)·Δv = h·(f₀ + h·∂f/∂x·v₀)                       (B&W eq. 16)
/// for the velocity change Δv, then v₁ = v₀ + Δv, x₁ = x₀ + h·v₁. f is the cloth's force of
/// kernels/cloth_rk4.h (springs, gravity m·g, global damping −μ·m·v); the spring Jacobian
/// blocks are cloth_math.h's vfit_spring_system_block (compressed springs' negative
/// transverse stiffness clamped to zero, so the matrix is symmetric positive definite),
/// evaluated with the force by vfit_spring_implicit_terms_relative in one vectorised loop per
/// block of rows; the product A·p in CG runs over the adjacency's sliced rows, one particle per
/// SIMD lane, as the RK4 gather (cloth_rk4.h).
///
/// The solve is a conjugate gradient preconditioned by the inverse 3×3 diagonal blocks (block
/// Jacobi), matrix-free over the CSR spring adjacency: each particle gathers its own row, so no
/// atomics. Pinned particles (inverse mass 0) are constraints handled by B&W's filter (§5.3):
/// their rows and columns are projected out, their Δv is 0 and they never move. Body contacts
/// enter either as the same filter (ImplicitConstraints) or as stiff one-sided springs on the
/// diagonal (ImplicitContactSprings). Dot products are summed in double per fixed chunk of
/// particles (within a chunk one running sum per SIMD lane, the lanes then added in order) and
/// the chunk sums added in chunk order, so the serial and TBB drivers give the same bits for any
/// thread count.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "cloth_implicit_system.h"
#include "cloth_rk4.h"
#include "cloth_springs.h"

namespace vfit {

/// Contact constraints of one step (Baraff & Witkin §5.3's filter, for particles resting on a
/// body): particle i with a nonzero unit `normals` row may not choose its velocity change along
/// that normal; it takes Δv·n = targets[i] (m/s) exactly and solves for the other two
/// directions. Both arrays empty = no constraint; otherwise normals is #V × 3 (unit or zero)
/// and targets #V. A pinned particle stays fully constrained whatever its row says.
struct ImplicitConstraints {
  std::vector<float> normals; ///< #V × 3: the constrained direction, zero for a free particle
  std::vector<float> targets; ///< #V: the prescribed Δv·n (m/s), ignored where normals is zero
  bool empty() const { return normals.empty(); }
};

/// Resting contacts as stiff one-sided springs of the implicit step (an implicit penalty: the
/// contact force f = −k·g·n on the gap g = g₀ + n·(x − x₀), linearised like the cloth's springs,
/// B&W eq. 16), for particles lying on a body. The spring only adds h²·k·n·nᵀ to the particle's
/// diagonal block and (−h·k·g₀ − h²·k·n·v₀)·n to its right-hand side, so the block-Jacobi
/// preconditioner absorbs its stiffness and CG needs no more iterations; unlike B&W's filter
/// (ImplicitConstraints) its neighbours see the contact within the same solve without the
/// constraint's exact velocity target. One-sided: a spring whose impulse comes out pulling
/// (λ < 0, see implicit_euler_step_serial) is removed and the step solved again from that
/// answer (ImplicitSolveOptions::warm_start) within release_iterations CG iterations. Both
/// arrays empty = none; otherwise normals #V × 3 (unit, or zero for no spring) and stiffness #V.
struct ImplicitContactSprings {
  std::vector<float> normals;   ///< #V × 3: the body's outward unit normal at the contact, or zero
  std::vector<float> gaps;      ///< #V: g₀ (m), the gap beyond the contact thickness at the step start
  std::vector<float> stiffness; ///< #V: k (N/m), > 0 where normals is nonzero
  int release_iterations = 5;   ///< CG iteration budget of the solve after removing pulling springs
  bool empty() const { return normals.empty(); }
};

struct ImplicitCoarseSpace;

/// Owner of the two-level preconditioner's coarse level (kernels/cloth_implicit_coarse.h; built
/// on first use). A copy starts empty: the copy rebuilds its own on first use.
class ImplicitCoarseHolder {
public:
  ImplicitCoarseHolder();                                           ///< empty
  ImplicitCoarseHolder(const ImplicitCoarseHolder&);                ///< empty (nothing is copied)
  ImplicitCoarseHolder& operator=(const ImplicitCoarseHolder&);     ///< empties this one
  ImplicitCoarseHolder(ImplicitCoarseHolder&&) noexcept;            ///< takes the other's coarse level
  ImplicitCoarseHolder& operator=(ImplicitCoarseHolder&&) noexcept; ///< takes the other's coarse level
  ~ImplicitCoarseHolder();                                          ///< frees the coarse level
  ImplicitCoarseSpace& get(); ///< the coarse level, created empty on the first call

private:
  std::unique_ptr<ImplicitCoarseSpace> m_space;
};

/// Scratch of the solver (#V × 3 each, sized by the callee) and the system, reused across steps.
struct ImplicitWorkspace {
  ImplicitSystem system;
  ImplicitCoarseHolder coarse; ///< the TWO_LEVEL preconditioner's coarse level
  std::vector<float> dv, r, z, p, q;
  std::vector<double> partials; ///< one entry per reduction chunk and quantity
  /// Two entries per reduction chunk (patch P) of the last solve: ImplicitSolveOptions::
  /// per_patch's bound on ‖r_P‖², then ‖r_P‖² at exit ((N·s)² both).
  std::vector<double> patches;
  /// #V, written by a solve with constraints: the impulse (N·s) the constraint applied along
  /// its normal, ((A·Δv − b)·n); negative when it pulled the particle towards the body (B&W's
  /// release test), zero for unconstrained particles. Written by a step with contact springs
  /// too: each spring's impulse −h·k·(g₀ + h·n·v₁), zero for particles without a spring and for
  /// springs removed as pulling.
  std::vector<float> normal_impulses;
  std::vector<unsigned char> contact_active; ///< #V scratch of a step with contact springs
};

/// What one implicit solve did.
struct ImplicitSolveReport {
  int iterations = 0;           ///< CG iterations
  double relative_residual = 0; ///< ‖r‖/‖b‖ at exit (0 when b = 0)
  /// max over patches of ‖r_P‖/√(n_P/n · scale) at exit, per_patch's ratio (computed with or
  /// without it; ≥ relative_residual, its weighted mean; 0 when b = 0 or tolerance = 0)
  double patch_residual = 0;
  bool converged = false; ///< relative_residual ≤ tolerance (and patch_residual, with per_patch)
};

/// Assembles the system for a step of h (s) at the state (positions m, velocities m/s, #V × 3)
/// into `system` (resized). `parallel` selects the TBB driver (same bits as serial).
/// with_off_diagonal = false leaves system.off_diagonal empty: the CSR blocks S_e are read only
/// by the TWO_LEVEL coarse level and by dense oracles (the CG's product and row_times() read
/// the sliced springs), and writing them is 24 B per adjacency entry per step (2.7 MB on the
/// 6,000-vertex tee); every other array gets the same bits either way.
void assemble_implicit_system(std::span<const float> positions, std::span<const float> velocities,
                              const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                              ImplicitSystem& system, bool parallel, bool with_off_diagonal = true);

/// out = filtered A·p (#V × 3 each, out resized); pinned rows of out are 0 and pinned entries
/// of p are ignored. Serial; for tests and for building a dense oracle.
void implicit_system_multiply(const ImplicitSystem& system, const SpringAdjacency& adjacency, std::span<const float> p,
                              std::vector<float>& out);

/// Solves A·Δv = b by block-Jacobi-preconditioned, filtered CG into workspace.dv (#V × 3, m/s),
/// starting from Δv = 0 (or from workspace.dv with options.warm_start; B&W's modified PCG
/// starting from the constrained values when
/// `constraints` is given and not empty: the residual, search directions and A·p are projected
/// by the filter S_i = I − n·nᵀ, so constrained components stay at their targets). With
/// constraints, also writes workspace.normal_impulses. `parallel` selects the TBB driver (same
/// bits as serial).
ImplicitSolveReport solve_implicit_system(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                          ImplicitWorkspace& workspace, bool parallel,
                                          const ImplicitConstraints* constraints = nullptr);

/// The aggregates of the TWO_LEVEL coarse space: #V labels in [0, count) (count written).
/// Greedy aggregation over the spring adjacency in particle order: a particle whose neighbours
/// are all unassigned starts an aggregate with them, a particle left over joins its first
/// neighbour's aggregate (or starts its own when it has none), so an aggregate is a patch of
/// about one spring ring (≈ 10–15 particles on a triangle mesh with bending springs); the same
/// rule is then applied to the aggregates' graph while the mean size is below half of
/// options.aggregate_particles (or, when that is 0, while there are more than 2,048). The
/// same labels for any thread count (serial, depends on the adjacency only).
std::vector<std::int32_t> implicit_coarse_aggregates(const SpringAdjacency& adjacency,
                                                     const ImplicitSolveOptions& options, std::size_t& count);

/// z = M⁻¹·r (#V × 3 each, z resized): the preconditioner solve_implicit_system() applies
/// with `options` (and `constraints`, as there) to workspace.system, r filtered first (S·r), so
/// z = S·A_ii⁻¹·S·r per particle, plus P·(Pᵀ·S·A·S·P)⁻¹·Pᵀ·S·r with TWO_LEVEL (pinned rows of z
/// are 0). Serial; for tests (symmetry, positive definiteness) and oracles.
void apply_implicit_preconditioner(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                   ImplicitWorkspace& workspace, std::span<const float> r, std::vector<float>& z,
                                   const ImplicitConstraints* constraints = nullptr);

/// One implicit Euler step of h (s) in place: assemble, add the contact springs when given,
/// solve (with the contact constraints when given), v += Δv, x += h·v for the free particles
/// (pinned ones keep x and v). With contact springs, each spring's impulse λ = −h·k·(g₀ +
/// h·n·v₁) is checked after the solve; springs with λ < 0 are removed and the system solved
/// again from the first answer (at most release_iterations CG iterations, counted in the
/// report); workspace.normal_impulses holds the kept springs' λ (springs still pulling after
/// that solve keep their negative λ: the caller may release them for the next step). Serial
/// range kernels.
ImplicitSolveReport implicit_euler_step_serial(std::span<float> positions, std::span<float> velocities,
                                               const SpringAdjacency& adjacency, const ClothParticles& particles,
                                               float h, const ImplicitSolveOptions& options,
                                               ImplicitWorkspace& workspace,
                                               const ImplicitConstraints* constraints = nullptr,
                                               const ImplicitContactSprings* contact_springs = nullptr);

/// TBB driver of implicit_euler_step_serial() (chunks of CLOTH_IMPLICIT_CHUNK particles); the
/// same bits for any thread count.
ImplicitSolveReport implicit_euler_step_tbb(std::span<float> positions, std::span<float> velocities,
                                            const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                                            const ImplicitSolveOptions& options, ImplicitWorkspace& workspace,
                                            const ImplicitConstraints* constraints = nullptr,
                                            const ImplicitContactSprings* contact_springs = nullptr);

} // namespace vfit
