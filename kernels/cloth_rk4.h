// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Classical fourth-order Runge–Kutta integration of a mass-spring cloth (seed 000 §6.3,
/// eq. 22–24): x' = v, v' = a(x, v) = f_springs/m + g − μ·v. Each of the four stages is one
/// fused per-particle pass: gather the spring forces of the stage state over the spring adjacency,
/// form the acceleration, add the stage's slopes to the running sums and write the next stage
/// state (cloth_math.h's vfit_rk4_stage_update). Serial and TBB give the same bits.
///
/// How a pass runs on a CPU: one particle per SIMD lane, over the adjacency's sliced rows
/// (SpringAdjacency::slice_offsets, 16 consecutive particles a slice): each column of a slice
/// gathers the 16 lanes' neighbour states and evaluates their springs in one branch-free
/// vectorised step (one square root and one division per spring end,
/// vfit_spring_force_relative), adding each to its lane's running sum, so every particle sums
/// its springs in adjacency order with no scratch and no per-row loop; a column whose
/// neighbours are 16 consecutive particles (SpringAdjacency::slice_consecutive_columns) loads
/// their states as vectors instead of lane by lane. Then the slice's 16 stage updates run as
/// vectors too. The pass is compiled for AVX-512, AVX2 and baseline x86-64 and picked at load
/// time, all without FMA contraction, so every instruction set gives the same bits as the
/// scalar oracle (spring_forces_scatter). A grid numbered row by row has mostly consecutive
/// columns (98 % of a 10^6 grid's); a garment's mesh has none. There, on a CPU with AVX-512
/// (checked at run time; the build targets baseline x86-64), a column loads each neighbour's
/// row of x and of v with one masked 16-byte load into a 128-bit lane and transposes them in
/// registers (cloth_gather.h, gather_rows16: 32 loads and 12 shuffles a column instead of 96
/// scalar loads and their inserts; evaluating the springs from registers with GCC vector types
/// instead of the vectorised loop over the transposed rows gained nothing); other CPUs load the
/// neighbours lane by lane (not with the gather instruction, which GCC's generic tuning
/// emulates). Both give the same bits. The scattered loads hit the cache when the particles are
/// numbered for locality (kernels/cloth_ordering.h, as ClothSim numbers them).
///
/// The schedule: a step does not run the four stages as four passes over all particles, each
/// streaming every spring row and state from memory (at 10^6 particles 0.3 GB a pass, far
/// beyond the caches). Stage s of a slice needs stage s − 1 done on the slices holding its
/// neighbours (SpringAdjacency::slice_neighbor_first/_last), and may overwrite a buffer stage
/// s − 1 read there once those have run stage s − 1 too; so the driver runs the stages as a
/// wavefront, stage 0 advancing 16 slices at a time and each later stage following its
/// predecessor as closely as the neighbours allow, and a slice's rows are read by its four
/// stages while still in cache. In the banded numbering of kernels/cloth_ordering.h the lag
/// between stages is a few hundred slices at 10^6 particles (the catalogue tee: 450 slices from
/// stage 0's front to stage 3's on average, 2.1 MB of rows and states) against the whole mesh
/// for a Morton curve. With more threads the slices are split into contiguous regions, each
/// swept by two ends, one from either side, that claim stage 0's slices as they go and meet
/// wherever they get to: a thread held up by other work (or started late) leaves more of its
/// region to the other instead of holding up the step, as one fixed chunk per thread did (same
/// work, but the step waited for the slower chunk). The slices near the meeting points and
/// region boundaries are finished stage by stage after. Every slice's arithmetic is that of the
/// stage-by-stage passes in any schedule, so the bits do not depend on it, on the thread count
/// or on where the ends meet. The four plain passes stay selectable (Rk4Schedule::PASSES);
/// bench/kernels/cloth_bench.cpp BM_rk4_schedule_* compares the two.
///
/// Stability (the substep bound): the linearised system's eigenvalues λ satisfy
/// λ² + c·λ + k = 0 for Rayleigh quotients c ∈ [0, γ_max], k ∈ [0, ω_max²] of the mass-scaled
/// damping and stiffness matrices M^{-1/2} C M^{-1/2} and M^{-1/2} K M^{-1/2}, so
/// |λ| ≤ γ_max + ω_max. Gershgorin's theorem on the scaled matrices bounds, per free particle i,
///   ω_i² = Σ_{s=(i,j)} k_s·(1/m_i + 1/√(m_i m_j)),   γ_i = μ + Σ_{s=(i,j)} c_s·(1/m_i + 1/√(m_i m_j)),
/// (a pinned neighbour j has 1/m_j = 0). RK4's stability region contains the closed left
/// half-disc of radius 2.6 (checked numerically: |1 + z + z²/2 + z³/6 + z⁴/24| ≤ 1 there), so
///   h ≤ RK4_STABILITY_RADIUS / (ω_max + γ_max),   RK4_STABILITY_RADIUS = 2.5,
/// is stable for springs at or beyond their rest length. A compressed spring adds a negative
/// geometric stiffness k·(1 − L/l) across it that this bound ignores; callers keep a safety
/// factor below 1 for it. For a uniform mesh with stiffness k and masses m this is
/// h ≲ 2.5 / (√(2·deg·k/m)·(1 + 2ζ)), i.e. the familiar h ∝ √(m/k).

#include <cstddef>
#include <span>
#include <vector>

#include "cloth_springs.h"

namespace vfit {

/// Per-particle parameters of the integrator.
struct ClothParticles {
  std::vector<float> inverse_masses;       ///< #V inverse masses (1/kg); 0 pins the particle
  float gravity[3] = {0.0f, -9.81f, 0.0f}; ///< g (m/s²), Y up
  float global_damping = 0.0f;             ///< μ (1/s): the force −μ·m·v on every particle
};

/// Scratch buffers of the RK4 drivers (#V × 3 each), sized by the callee, reusable across
/// steps so a step allocates nothing.
struct Rk4Workspace {
  std::vector<float> acc_x, acc_v;           ///< running weighted sums of the slopes
  std::vector<float> stage_x[2], stage_v[2]; ///< stage states, double-buffered
  std::vector<std::size_t> chunk_stages;     ///< the wavefront's bookkeeping: per end and stage, the slices it ran
};

/// Accelerations a(x, v) (m/s², #V × 3, out resized) of every particle: spring gather plus
/// gravity and global damping, zero for pinned particles. Serial reference.
void cloth_accelerations_serial(std::span<const float> positions, std::span<const float> velocities,
                                const SpringAdjacency& adjacency, const ClothParticles& particles,
                                std::vector<float>& accelerations);

/// One RK4 step of length h (s) in place: positions (m) and velocities (m/s), #V × 3.
/// Pinned particles keep their position; their velocity is left as given (normally zero).
/// Serial range kernels over all particles.
void rk4_step_serial(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                     const ClothParticles& particles, float h, Rk4Workspace& workspace);

/// How a TBB step orders the four stage passes over the slices (see the file comment).
enum class Rk4Schedule {
  AUTO,      ///< WAVEFRONT on one thread, RK4_AUTO_SCHEDULE_THREADED on more
  WAVEFRONT, ///< the stages as a wavefront, swept by one end per thread (rk4_step_chunked())
  PASSES,    ///< four passes over every slice, each split among the threads in CLOTH_PARTICLE_GRAIN tasks
};

/// The schedule Rk4Schedule::AUTO takes on more than one thread: the wavefront, which reads a
/// slice's rows from memory once per step instead of once per stage (file comment);
/// bench/kernels/cloth_bench.cpp BM_rk4_schedule_* compares the two on a host.
inline constexpr Rk4Schedule RK4_AUTO_SCHEDULE_THREADED = Rk4Schedule::WAVEFRONT;

/// TBB driver of rk4_step_serial(): `schedule` (AUTO: see RK4_AUTO_SCHEDULE_THREADED), with
/// one wavefront end per thread (rk4_step_chunked()), each of at least CLOTH_PARTICLE_GRAIN
/// particles. The same bits for every schedule and thread count.
void rk4_step_tbb(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                  const ClothParticles& particles, float h, Rk4Workspace& workspace,
                  Rk4Schedule schedule = Rk4Schedule::AUTO);

/// rk4_step_tbb()'s wavefront with `chunks` ends run in parallel (clamped to [1, #slices]):
/// the slices (SpringAdjacency::slice_offsets) are split into ⌈chunks / 2⌉ contiguous regions,
/// each swept by two ends, one from either side, that meet wherever they get to (the last
/// region by one end when `chunks` is odd). The same bits for every count and meeting point
/// (see the schedule in the file comment): the tests of the schedule call it with counts this
/// machine's thread count would not choose.
void rk4_step_chunked(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                      const ClothParticles& particles, float h, Rk4Workspace& workspace, std::size_t chunks);

/// Radius of the left half-disc used as RK4's stability region in the step bound.
inline constexpr double RK4_STABILITY_RADIUS = 2.5;

/// The bound of the file comment: ω_max (rad/s), γ_max (1/s) and the largest stable step
/// RK4_STABILITY_RADIUS / (ω_max + γ_max) (s; +∞ when nothing moves or nothing is stiff).
struct Rk4StepBound {
  double omega_max = 0;
  double gamma_max = 0;
  double max_step = 0;
};

/// Computes the bound over the free particles of `adjacency` with `particles`' masses and μ.
Rk4StepBound rk4_stable_step(const SpringAdjacency& adjacency, const ClothParticles& particles);

} // namespace vfit
