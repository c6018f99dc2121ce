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

#include "cloth_rk4.h"
#include "cloth_springs.h"

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
  std::unique_ptr<ImplicitCoarseSpace> space_;
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
