// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// ClothSim: the mass-spring cloth of seed 000 §6.3 (eq. 22–24) and seed 004 §2 — particles
/// with masses from the fabric's area density, structural and bending springs with damping,
/// gravity and global damping, implicit Euler in large steps (Baraff & Witkin 1998, as seed
/// 004 §2) or RK4 in stable substeps, pinning, body collision
/// through the proximity core with thickness, friction and restitution (resting contacts held
/// inside the implicit solve), a run-to-rest
/// convergence test (seed 004 §3.2.1) and divergence detection. Steps a frame at a time for
/// real-time apps (step(dt), move_body() refits a moving body) or runs to rest for fitting.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vfit/engine/cloth/fabric.h"
#include "vfit/kernels/backend.h"

namespace vfit {
class ProximityIndex; // kernels/proximity.h
} // namespace vfit

namespace vfit {
enum class ImplicitPreconditioner : std::int8_t; // kernels/cloth_implicit.h
} // namespace vfit

namespace vfit {

/// Where a simulation stands. Anything but OK is sticky: the state stays at the last good
/// step (a diverged state is never exposed or written out) and step() does nothing more.
enum class ClothStatus : std::int8_t {
  OK = 0,
  DIVERGED_NON_FINITE, ///< a position or velocity became NaN or infinite
  DIVERGED_ENERGY,     ///< kinetic energy exceeded ½·M·max_speed² (energy blow-up)
  DIVERGED_STRETCH,    ///< a spring exceeded max_stretch times its rest length (see ClothOptions)
};

/// "ok", "diverged: non-finite state", "diverged: energy blow-up", "diverged: runaway stretch".
const char* to_string(ClothStatus status);

/// Which broad phase finds each particle's closest body triangle for the contacts. The BVH is
/// the default.
enum class ClothBroadPhase : std::int8_t {
  BVH = 0, ///< the Embree BVH of the proximity core (kernels/proximity.h), refitted on move_body
  /// seed 004's spatial hash of the body (Teschner et al. 2003, kernels/spatial_hash.h),
  /// refilled on move_body
  SPATIAL_HASH = 1,
};

/// Which time integrator advances the cloth.
enum class ClothIntegrator : std::int8_t {
  RK4 = 0,            ///< explicit RK4 (eq. 23–24) in substeps under its stability bound (≈ √(m/k))
  IMPLICIT_EULER = 1, ///< linearised backward Euler (kernels/cloth_implicit.h): large steps, damped
};

/// Everything a ClothSim is built with.
struct ClothOptions {
  /// Fabrics of the cloth; `vertex_fabric` picks one per vertex (per-vertex overrides, e.g. a
  /// denim waistband on a jersey body). A spring between two fabrics takes the mean of their
  /// constants; a vertex's mass uses its own fabric's density.
  std::vector<Fabric> fabrics = {fabric_preset("cotton_jersey")};
  std::vector<std::int32_t> vertex_fabric; ///< #V indices into fabrics, or empty: all fabric 0
  float gravity[3] = {0.0f, -9.81f, 0.0f}; ///< m/s², Y up
  double global_damping = 0.5;             ///< μ (1/s): the drag force −μ·m·v (eq. 22's f^d)
  bool bending = true;                     ///< bending springs across adjacent triangles
  /// The integrator. Implicit Euler is the default: its step is not bounded by the springs'
  /// stiffness (RK4's is, ≈ √(m/k)), so run_to_rest() for fitting takes far fewer steps; its
  /// numerical damping (of the fast modes chiefly) only shortens the way to rest. RK4 is the
  /// accurate choice for dynamics at small steps.
  ClothIntegrator integrator = ClothIntegrator::IMPLICIT_EULER;
  /// Implicit Euler: the longest step (s); step(dt) takes ⌈dt / implicit_step⌉ equal steps and
  /// resolves body contacts after each one. A particle falling at 2 m/s moves 17 mm per
  /// default step, under half the thinnest limb, so contacts still catch it.
  double implicit_step = 1.0 / 120.0;
  /// Implicit Euler: CG stops at ‖r‖ ≤ cg_tolerance·‖b‖ (residual and right-hand side impulses,
  /// N·s) and, with cg_per_patch, at the same ratio on every patch of the cloth. At rest the
  /// relative test solves f(x) = 0 to cg_tolerance (see
  /// ClothSim.ImplicitEulerSettlesToTheSameSagAsRk4).
  double cg_tolerance = 1e-2;
  /// Implicit Euler: the relative test also holds per patch of 512 particles (kernels/
  /// cloth_implicit.h, ImplicitSolveOptions::per_patch): every patch's RMS residual impulse per
  /// particle within cg_tolerance of the whole cloth's RMS right-hand side per particle, so the
  /// test does not loosen as the particle count grows (the global test alone can pass with the
  /// error held by a few particles, which on a large cloth can grow into a runaway stretch).
  bool cg_per_patch = true;
  int cg_max_iterations = 200; ///< implicit Euler: CG iteration cap per step
  /// Implicit Euler: the CG's preconditioner (kernels/cloth_implicit.h); value-initialised to
  /// BLOCK_JACOBI. AUTO switches to the two-level preconditioner once a step takes more than 16
  /// iterations (a garment resting on a body). AUTO is not the default: it changes where the
  /// cloth comes to rest (by millimetres on the catalogue tee).
  ImplicitPreconditioner cg_preconditioner{};
  /// RK4: substep = substep_safety × the RK4 stability bound of kernels/cloth_rk4.h (≈ √(m/k)),
  /// capped by max_substep. Below 1 to cover compressed springs, which the bound ignores.
  double substep_safety = 0.8;
  double max_substep = 2e-3; ///< s
  /// Which implementation runs the integrator (kernels/backend.h). SERIAL and TBB give the same
  /// bits for the same input; OPENCL agrees with them within float tolerance (a device's sqrt
  /// and division may differ by an ulp; tests/opencl/opencl_cloth_test.cpp states the bound after
  /// N steps).
  /// - SERIAL: one thread (the reference).
  /// - TBB: TBB over particles (gather per particle, no atomics).
  /// - OPENCL: RK4 forces and stages on an OpenCL device (kernels/opencl_cloth.h; PoCL on a CPU,
  ///   or a GPU's ICD), picked by opencl_device. Body contacts stay on the host (the proximity
  ///   core): every contact window uploads the state (#V × 6 floats) and reads it back after the
  ///   window's substeps, so a contact window costs two transfers of 24 bytes per particle;
  ///   without a body, one upload and one read per step(dt). RK4 only: constructing a ClothSim
  ///   with IMPLICIT_EULER and OPENCL throws vfit::Error ("cloth: the OpenCL backend runs the
  ///   RK4 integrator only"); a build without OpenCL throws vfit::Error ("cloth: … this build
  ///   has no OpenCL"). An OpenCL call failing later (allocation, kernel launch) throws
  ///   std::runtime_error ("OpenCL: <what>: … failed with code N"), not vfit::Error.
  Backend backend = Backend::TBB;
  /// Backend::OPENCL: the device selector of select_opencl_device() (kernels/
  /// opencl_context.h); empty = VFIT_OPENCL_DEVICE or the first device. The context is opened
  /// in the ClothSim constructor, which throws vfit::Error listing the devices when none
  /// matches or none exists. Ignored by the other backends.
  std::string opencl_device;
  /// The broad phase of the body contacts, built by set_body() (SPATIAL_HASH: cell side = the
  /// body's mean edge length) and updated by move_body(). Both give the same closest triangle,
  /// distance and side (so the same contacts) up to ties between equally close triangles.
  ClothBroadPhase broad_phase = ClothBroadPhase::BVH;

  /// Body contacts query only the particles that may have come within reach of the body since
  /// their last query (its distance then minus how far they moved since: the distance to the
  /// body changes no faster than the particle moves), every particle on the first pass after
  /// set_body(), move_body() or a divergence, and every 32nd pass. On a closed body this gives
  /// the same contacts, bit for bit, as querying every particle (false) at a fraction of the
  /// queries once the cloth slows down; a body with holes (capped for the side test) is always
  /// queried in full, as the side across a hole's cap can flip away from the surface. With the
  /// BVH and a parallel backend a re-query also searches only as far as the particle's previous
  /// closest point (which bounds the new distance).
  bool contact_candidates = true;
  /// Implicit Euler's body contacts are continuous (BVH broad phase; RK4's are discrete: the
  /// particles put back would stretch their springs past what its explicit substeps absorb): a
  /// particle that moved, relative to the body, at least as far as its distance to the body at the
  /// step's start (the distance being 1-Lipschitz, no other can have crossed the surface) and at
  /// least 2τ (a shorter path from the surface cannot pass the middle of a part thicker than 4τ,
  /// 1.2 cm by default) has its path tested against the body (ProximityIndex::first_hits); when the
  /// path entered the body and the particle now lies outside beyond it (through a limb) or inside
  /// nearer the far side (where the closest point, hence the push-out, is on the far side), it is
  /// put back where its path entered, and the contact response takes it from there. The path is
  /// relative to the body: move_body() moves it a frame at a time, before the frame's steps, so the
  /// next contact pass tests the paths over that move. The discrete test alone lets cloth tunnel
  /// once it moves about half a limb's thickness per step (tests/engine/cloth_sim_test.cpp:
  /// ClothSim.FastClothDoesNotTunnelThroughAThinRod,
  /// ClothSim.AFastRodCarriesClothInsteadOfPassingThroughIt). Particles starting inside the body
  /// are left to the discrete test. With the spatial hash broad phase the test is not made.
  bool continuous_contacts = true;
  float contact_thickness = 0.003f; ///< τ (m): gap kept to the body
  float contact_friction = 0.3f;    ///< Coulomb μ_f against the body
  float contact_restitution = 0.0f; ///< e ∈ [0, 1]
  /// RK4: contacts are resolved at least this often (s) (implicit Euler: after every step).
  /// A particle moving at speed s travels s·contact_interval between checks; it is caught as
  /// long as that stays below the depth at which the closest body point flips to the far side
  /// (half the thinnest limb): at 2 m/s and the default 1/240 s, 8 mm.
  double contact_interval = 1.0 / 240.0;
  /// Body triangles farther than this from a particle (m) are not searched: a particle deeper
  /// inside the body than this is not found. Bounds the query cost.
  float contact_search_radius = 0.05f;
  /// Implicit Euler: particles within τ + contact_margin (m) of the body become constraints of
  /// the solve (Baraff & Witkin §5.3's filter: no velocity change into the body, the step ends
  /// at the gap τ, Coulomb friction from the constraint's impulse), released for one step when
  /// the constraint pulled; particles the constraints miss (fast ones) are still caught by the
  /// contact pass after every step. Off by default: it is only marginally stable (particles at
  /// the edge of the contact region alternate between constrained and released, so the cloth
  /// may not come to rest, and may diverge). Takes precedence over resting_contacts.
  bool contacts_in_solve = false;
  float contact_margin = 0.002f; ///< m; see contacts_in_solve
  /// Implicit Euler: the particles resting on the body (those the last contact pass found
  /// within the gap τ and pushed out to it) are held by stiff one-sided springs inside the
  /// solve (kernels/cloth_implicit.h, ImplicitContactSprings; cloth_collision.h,
  /// body_contact_springs): the solve sees the contact, so a resting particle no longer sinks
  /// by h²·g each step to be pushed back out by the contact pass, which jiggled its neighbours
  /// and kept the cloth creeping; a spring that would pull is removed and the step solved again
  /// (5 more CG iterations at most), and left off for the next step; the contact's friction
  /// comes from the spring's impulse (apply_contact_friction), the contact pass still catches
  /// the particles arriving.
  bool resting_contacts = true;
  /// κ, dimensionless: a resting contact's spring has stiffness κ·m/h² (m: the particle's mass,
  /// h: the step), so one step leaves 1/(1 + κ) of the particle's velocity into the body. The
  /// penetration it allows before the contact pass, h²·g/κ ≈ 0.01 mm under the particle's own
  /// weight at the default step, is far below τ.
  float resting_contact_stiffness = 20.0f;

  /// Waistband auto-pins: when a body is first set, the band of the garment within
  /// waistband_width of its waist opening (waistband_vertices(), geometry/garment/waistband.h,
  /// of the cloth's positions at that moment) is attached to the body (attach_to_body()), so a
  /// bottom garment (trousers, shorts, skirt) cannot slide down and follows the body. A cloth
  /// without a boundary pins nothing.
  /// waistband_width is checked then: set_body() throws vfit::Error ("waistband: band_width
  /// must be finite and ≥ 0") for a negative or non-finite one.
  bool waistband_pins = false;
  /// Width of the pinned band (m), measured along the garment's edges from the waist opening:
  /// 3 cm, the height of a typical elastic waistband (2.5–4 cm).
  double waistband_width = 0.03;

  double max_speed = 50; ///< m/s: the energy blow-up threshold (as an RMS speed)
  /// Runaway stretch: any spring longer than this × its rest length, a rest length being taken
  /// as at least half the median edge length (so slivers of a generated mesh do not trip it)
  /// and at least contact_thickness: the contact pass moves a particle by up to τ at once, which
  /// on a fine mesh can stretch a short spring many times over for a step or two without a
  /// runaway. A real blow-up grows step by step and is caught once a spring passes
  /// max_stretch·τ (3 cm by default).
  double max_stretch = 10;
};

/// What one step(dt) did.
struct ClothStepReport {
  ClothStatus status = ClothStatus::OK;
  int substeps = 0;             ///< RK4 substeps or implicit Euler steps taken
  int solver_iterations = 0;    ///< implicit Euler: CG iterations, summed over the steps
  std::size_t contacts = 0;     ///< particle–body contacts resolved (summed over contact passes)
  double mean_displacement = 0; ///< mean |x_after − x_before| over the particles (m)
  /// Particles whose path through the body was undone (ClothOptions::continuous_contacts).
  std::size_t crossings_undone = 0;
};

/// Stopping rule of run_to_rest() (seed 004 §3.2.1: mean per-vertex displacement between two
/// simulation steps below M = 0.008 mm).
struct ClothRestOptions {
  double step_dt = 0.01;                    ///< s of simulated time per step compared
  double displacement_threshold = 0.008e-3; ///< M (m)
  double max_simulated_seconds = 10;        ///< stop (not converged) after this much simulated time
  double max_wall_seconds = 0;              ///< also stop after this wall time; 0 = no limit
};

/// What run_to_rest() did.
struct ClothRestReport {
  ClothStatus status = ClothStatus::OK;
  bool converged = false;          ///< the displacement fell below the threshold
  int steps = 0;                   ///< step() calls made (of step_dt, or of implicit_step when longer)
  double simulated_seconds = 0;    ///< s
  double wall_seconds = 0;         ///< s
  double mean_displacement = 0;    ///< of the last step, scaled to one step_dt (m)
  long long solver_iterations = 0; ///< implicit Euler: CG iterations over all steps
};

/// A mass-spring cloth over a triangle mesh. Particles are the mesh vertices; their masses are
/// ρ times one third of the area of their triangles (a vertex in no triangle, having no mass,
/// is pinned). Springs per kernels/cloth_springs.h with rest lengths from the input positions.
/// Internally the particles are renumbered for the force gathers' locality (kernels/
/// cloth_ordering.h, cloth_particle_order()); every index and array of this API (positions,
/// velocities, masses, pins, attachments, per-vertex fabrics) is in the caller's numbering.
class ClothSim {
public:
  /// positions: #V × 3 (m), also the rest shape; triangles: #F × 3 indices. Throws vfit::Error
  /// naming the element for an index out of range, a fabric index out of range, a vertex_fabric
  /// of the wrong size, a non-finite position or a fabric constant that is negative.
  ClothSim(std::span<const float> positions, std::span<const std::int32_t> triangles, const ClothOptions& options = {});
  ~ClothSim();
  ClothSim(ClothSim&&) noexcept;
  ClothSim& operator=(ClothSim&&) noexcept;
  ClothSim(const ClothSim&) = delete;
  ClothSim& operator=(const ClothSim&) = delete;

  /// Pins `vertices` (indices in [0, #V); throws vfit::Error otherwise) at their current
  /// positions, with zero velocity. Recomputes the stable substep.
  void pin(std::span<const std::int32_t> vertices);

  /// Sets the body to collide with: a closed, outward-oriented mesh (#B × 3 positions in m,
  /// #T × 3 triangles), indexed by the broad phase of ClothOptions::broad_phase. Replaces any
  /// previous body; vertices attached to the previous body are attached to the new one (at
  /// their current positions). With ClothOptions::waistband_pins, the first body set attaches
  /// the waistband (waistband_vertices()). Throws vfit::Error ("body: face F has vertex index
  /// …") for an index out of range; positions are not checked for finiteness here (the broad
  /// phase's constructor checks them: "proximity mesh"/"spatial hash mesh" errors).
  void set_body(std::span<const float> positions, std::span<const std::int32_t> triangles);
  /// As above, sharing `index` (a ProximityIndex over exactly these positions and triangles,
  /// built with the default OpenMeshSide) instead of building one, so several cloths, and the
  /// caller's own queries, use one index of a moving body. The caller refits `index` to the new
  /// positions before each move_body(), which then leaves it alone (it refits an index of its
  /// own), and does not refit it while this simulation steps. Throws vfit::Error ("body: …")
  /// with the SPATIAL_HASH broad phase, for a null index or one whose vertex or face count
  /// differs from the mesh's, and for an index out of range.
  void set_body(std::shared_ptr<ProximityIndex> index, std::span<const float> positions,
                std::span<const std::int32_t> triangles);
  /// Moves the body (same topology) over the last `dt` seconds: refits the BVH (no rebuild) or
  /// refills the spatial hash, takes the body's velocity as (new − old)/dt for friction, and
  /// moves the attached vertices with their body triangles (their velocity becomes (new −
  /// old)/dt too, which the springs' damping sees). Those velocities hold for the next `dt`
  /// seconds of step(); after them, without another move_body(), the body and the attached
  /// vertices are at rest where this move left them (a kept velocity would drag the cloth on
  /// through friction and damping while the body stands still). Throws vfit::Error when no body
  /// is set or the vertex count differs.
  void move_body(std::span<const float> positions, double dt);

  /// Pins `vertices` (indices in [0, #V)) to the body. Throws vfit::Error ("cloth: attach_to_body
  /// called before set_body" / "cloth: attached vertex N outside [0, #V)"); nothing is attached
  /// then. Each is attached to its closest body triangle (a, b, c), searched at any distance, by
  /// the coordinates (s, t, h) with x = a + s·(b − a) + t·(c − a) + h·n̂, n̂ the triangle's unit
  /// normal: the barycentrics of x's projection onto the triangle's plane and its offset along
  /// the normal.
  /// The vertex keeps its position now and follows the triangle exactly under rigid motions of
  /// the body (affinely under deformations). A degenerate closest triangle (zero area) gets its
  /// closest point's barycentrics and h = 0 (the vertex then moves onto it at the next
  /// move_body). Attaching a vertex twice re-attaches it. An attached vertex gets zero inverse
  /// mass and velocity (the integrator leaves it alone) and the stable substep is recomputed.
  /// A body with no triangles attaches nothing.
  void attach_to_body(std::span<const std::int32_t> vertices);
  /// The vertices attached by attach_to_body() (or the waistband pins), ascending, each once;
  /// empty before any attachment.
  std::vector<std::int32_t> attached_vertices() const;

  /// Restarts the cloth from `positions` (#V × 3, m, caller's numbering) with `velocities`
  /// (#V × 3, m/s) or, when that span is empty, at rest: for a cut in a motion (a clip looping
  /// back, the first frame of a clip far from the pose the cloth was built in), where stepping
  /// through the jump would fling the cloth. Pinned and attached vertices stay pinned; an
  /// attached vertex is put back on its body triangle (its given position is ignored). The rest
  /// lengths are unchanged. Clears a divergence (status() is OK again) and the contact caches, so
  /// no path is tested across the jump. Throws vfit::Error ("cloth: set_state …") naming the
  /// first non-finite coordinate or a size other than #V × 3; the state is unchanged then.
  void set_state(std::span<const float> positions, std::span<const float> velocities = {});

  /// Max-distance tethers, a cloth driven by an animation leashed to its animated shape: after
  /// every implicit step's solve (RK4: every contact window's substeps), before the contact pass,
  /// a free particle farther than radii[i] (m) from targets[i] is put back on that sphere and
  /// loses its velocity away from the target. targets: #V × 3 (m), radii: #V (each ≥ 0 or +∞),
  /// caller's numbering; both empty: no tethers. The tethers stay until set again. Throws
  /// vfit::Error ("cloth: set_tethers …") for other sizes, a non-finite target or a negative or
  /// NaN radius; the tethers are unchanged then. O(#V).
  void set_tethers(std::span<const float> targets, std::span<const float> radii);

  /// Advances by dt (s, ≥ 0) in steps of at most stable_substep(): RK4 substeps with body
  /// contacts resolved every contact_interval, or implicit Euler steps each followed by body
  /// contacts. On divergence restores the state from before the call and
  /// reports the status.
  ClothStepReport step(double dt);

  /// Steps by options.step_dt (implicit Euler: by implicit_step when that is longer, its
  /// displacement scaled to step_dt) until the mean displacement per step_dt is below the
  /// threshold, or a limit is reached, or the simulation diverges.
  ClothRestReport run_to_rest(const ClothRestOptions& options = {});

  std::size_t particle_count() const;
  std::size_t spring_count() const;
  /// #V × 3 (m), in the caller's vertex numbering. The simulator integrates in a numbering of
  /// its own (kernels/cloth_ordering.h) and copies the state into the caller's when it is read
  /// after a call that changed it (step, move_body, pin, …), so a frame of step() and
  /// move_body() costs one copy, at the read; the same values as a copy after every call. The
  /// span stays valid and unchanged until the next non-const call. A first read after a change
  /// writes the copy: reading one ClothSim from several threads at once is not supported.
  std::span<const float> positions() const;
  /// #V × 3 (m/s), in the caller's numbering, copied when read as positions() is.
  std::span<const float> velocities() const;
  std::span<const float> masses() const; ///< #V (kg); 0 for an isolated vertex
  double stable_substep() const;         ///< the (sub)step in use (s): RK4's or implicit_step
  ClothStatus status() const;
  double kinetic_energy() const; ///< ½ Σ m v² (J)
  double spring_energy() const;  ///< ½ Σ k (l − L)² (J)

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
