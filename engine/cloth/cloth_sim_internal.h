// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// ClothSim's internals, shared by the files that implement it (engine/cloth/cloth_sim.cpp: set-up
/// and state; cloth_sim_body.cpp: the body, attachments and waistband pins; cloth_sim_contacts.cpp:
/// body contacts; cloth_sim_step.cpp: stepping per integrator and backend). Not part of the API.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "vfit/engine/cloth/cloth_sim.h"
#include "vfit/kernels/cloth_collision.h"
#include "vfit/kernels/cloth_implicit.h"
#include "vfit/kernels/cloth_rk4.h"
#include "vfit/kernels/cloth_springs.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/spatial_hash.h"
#ifdef VFIT_WITH_OPENCL
#include "vfit/kernels/opencl_cloth.h"
#endif

namespace vfit {

// Particles per block of the per-step checks' sums (Impl::state_blocks): the divergence check's
// kinetic energy and the step's mean displacement, summed per block in the caller's order.
constexpr std::size_t STATE_SUM_BLOCK = 2048;

// A vertex pinned to a body triangle (a, b, c): x = a + s·(b − a) + t·(c − a) + h·n̂.
struct BodyAttachment {
  std::int32_t vertex = 0, triangle = 0;
  double s = 0, t = 0, h = 0;
};

// The particles are stored and integrated in the locality numbering of
// kernels/cloth_ordering.h (cloth_particle_order()): `order[k]` is the caller's vertex at internal
// row k, `rank` its inverse. Everything inside Impl (state, masses, springs, adjacency, contacts,
// attachments) is in the internal numbering; the public API speaks the caller's, mapping indices
// on the way in (pin, attach_to_body) and out (attached_vertices), and publishing the state in
// the caller's order (out_x, out_v) when it is read (positions(), velocities()) after a call
// that changed it, not at the end of every such call: a per-frame caller doing step() and
// move_body() and then reading positions() pays one gather of #V × 3 floats, not four. The numbering
// keeps the springs' order, so an RK4 step gives the caller's particles the same bits as it
// would in the caller's numbering (and the implicit step the same up to the CG's float sums).
struct ClothSim::Impl {
  ClothOptions options;
  std::vector<std::int32_t> triangles; // the cloth's, caller numbering, for the waistband search
  std::vector<std::int32_t> order, rank;
  ClothSprings springs;
  SpringAdjacency adjacency;
  ClothParticles particles;
  std::vector<float> masses; // internal numbering
  std::vector<float> x, v;
  // The caller's numbering; out_x and out_v are copies of x and v, refreshed when read while
  // stale (published_positions(), published_velocities()), so a const read may write them.
  mutable std::vector<float> out_x, out_v;
  mutable bool out_x_current = false, out_v_current = false;
  std::vector<float> out_masses;
  std::vector<float> saved_x, saved_v; // state before the current step, restored on divergence
  Rk4Workspace workspace;
  ImplicitWorkspace implicit_workspace;
  double substep = 0;
  double total_mass = 0;
  float stretch_floor = 0; // rest length below which stretch is measured against this (m)
  ClothStatus status = ClothStatus::OK;

  // The body's broad phase: one of the two is set (ClothOptions::broad_phase) once a body is.
  // Shared with the caller when set by set_body(index, …): then the caller refits it, not
  // move_body() (body_shared).
  std::shared_ptr<ProximityIndex> body;
  bool body_shared = false;
  std::optional<SpatialHash> hash;
  std::vector<BodyAttachment> attachments; // ascending vertex
  bool waistband_attached = false;
  // Backend::OPENCL: the device context, and the RK4 integrator holding the adjacency and
  // the inverse masses on the device (null when pin() or attach_to_body() made it stale). The
  // integrator is declared after the context so it is destroyed first.
  std::unique_ptr<OpenClContext> cl_context;
#ifdef VFIT_WITH_OPENCL
  std::unique_ptr<OpenClClothRk4> cl_rk4;
#endif
  std::vector<float> body_positions, body_velocities;
  // Simulated time (s) for which the last move_body()'s velocities still hold: its dt, run down
  // by step(); at zero the body is at rest again (body_velocities cleared, the attached
  // vertices' velocities zeroed), as its positions stay where that move left them.
  double body_motion_left = 0;
  std::vector<std::int32_t> body_triangles;
  ClosestHits hits;
  // Implicit Euler's contact constraints, built from `hits` when they describe the current
  // positions (the query of the last contact pass, taken before its response).
  bool hits_valid = false;
  ImplicitConstraints constraints;
  ImplicitContactSprings contact_springs;
  std::vector<unsigned char> released; // 1: the constraint or spring pulled last step, free this one

  // The contact broad phase kept across passes: a particle last queried at q with signed
  // distance d cannot come closer than d − |x − q| to the body (the distance is 1-Lipschitz),
  // so it is queried again only once |x − q| reaches d minus the contact reach; the others keep
  // their hit rows, which stay farther than the reach (no response, no constraint) exactly as
  // a fresh query's would. Identical contacts to querying every particle, for a closed body.
  std::vector<float> query_positions;  // #V × 3: where each particle was last queried
  std::vector<float> query_allowance;  // #V: motion (m) allowed before the next query
  std::vector<std::int32_t> requeried; // scratch: the particles queried in this pass
  std::vector<float> requery_points;
  std::vector<float> requery_radii; // #requeried search radii (m)
  ClosestHits requery_hits;
  bool candidates_valid = false; // false: the next pass queries every particle
  bool body_closed = false;      // the cache is used on closed bodies only (see set_body)
  int passes_since_full = 0;

  // Continuous contacts (ClothOptions::continuous_contacts): the positions at the start of the
  // step being taken and, per particle, a lower bound of its distance to the body then (its
  // hit row's distance less how far it moved since that query; the distance is 1-Lipschitz);
  // start_body_time: for how long (s) body_velocities moved the body since (move_body()'s dt:
  // the body is moved a frame at a time, before the frame's steps; 0 for an integrator step).
  std::vector<float> step_start, start_bound;
  bool step_start_valid = false;
  double start_body_time = 0;
  std::size_t crossings_undone = 0; // summed over the object's life; step() reports the change
  std::vector<std::int32_t> ccd_rows, ccd_undone;
  std::vector<float> ccd_from, ccd_to, ccd_points;
  SegmentHits ccd_hits;
  ClosestHits ccd_requery;

  // Tethers (set_tethers()), internal numbering: targets #V × 3, radii #V; empty: none.
  std::vector<float> tether_targets, tether_radii;
  // Puts the free particles farther than their radius from their target back on its sphere.
  void apply_tethers();

  // Set-up and state (cloth_sim.cpp).

  // The step in use: implicit_step, or RK4's stable substep (substep_safety × its bound,
  // capped by max_substep).
  void update_substep();
  // The device copy of the inverse masses is stale after a change of pins.
  void masses_changed();

  // Marks the published state (out_x, out_v) stale: called by every operation that changes x
  // or v; the next read of positions() or velocities() gathers it into the caller's numbering.
  void state_changed() { out_x_current = out_v_current = false; }

  // The state in the caller's numbering (positions(), velocities()), gathered if stale.
  const std::vector<float>& published_positions() const;
  const std::vector<float>& published_velocities() const;

  // The body and its attachments (cloth_sim_body.cpp).

  bool has_body() const { return body != nullptr || hash.has_value(); }
  // Where attachment a puts its vertex on the current body.
  void attached_position(const BodyAttachment& a, double out[3]) const;
  // set_body()'s work once the broad phase is in place: the body's copy, caches, attachments.
  void body_set(std::span<const float> positions, std::span<const std::int32_t> faces);
  // Attaches the internal particles `rows` to the body (see ClothSim::attach_to_body).
  void attach_rows(std::span<const std::int32_t> rows);

  // Body contacts (cloth_sim_contacts.cpp).

  // Closest body points of `queries` through the broad phase in use.
  void query_body(std::span<const float> queries, float radius, ClosestHits& out) const;
  // The contact response's thickness, friction and restitution (ClothOptions).
  ContactParameters contact_parameters() const;
  // Farthest signed distance (m) at which a hit row matters: the response's thickness, plus the
  // constraint margin when contacts are in the solve, plus a guard for the float rounding of
  // the distance.
  float contact_reach() const;
  // Records particle i as queried now, at its current position, with its hit row's distance.
  void record_query(std::size_t i, float reach);
  // Brings `hits` up to date for every particle whose row can matter (see query_positions).
  void update_hits();
  // Whether continuous contacts are tested (ClothOptions::continuous_contacts; implicit Euler
  // with the BVH only).
  bool continuous() const;
  // Records the start of a step (before the integrator or move_body() moves x or the body).
  // A start still pending (move_body()'s, not yet met by a contact pass) covers this step too.
  void mark_step_start(double body_time);
  // The body's velocity at hit row i of `h` (zero for a body at rest or no hit).
  std::array<float, 3> body_velocity_at(const ClosestHits& h, std::size_t i) const;
  // After update_hits(): the particles whose path since mark_step_start() went into the body and
  // now lie beyond it are put back where the path entered (ClothOptions::continuous_contacts),
  // their hit rows queried again.
  void undo_crossings();
  // One contact pass: update_hits(), undo_crossings(), then the response; returns the
  // contacts resolved.
  std::size_t resolve_contacts();

  // Stepping (cloth_sim_step.cpp).

  // `count` RK4 substeps of h on the OpenCL device: one upload of the state before, one read
  // after (the contacts between windows are resolved on the host).
  void integrate_opencl(double h, int count);
  // `count` RK4 substeps of h on the backend in use.
  void integrate(double h, int count);
  // One implicit Euler step of h, with the body contacts in the solve (resting contacts as
  // stiff springs, or as B&W constraints when contacts_in_solve) and their friction, then a
  // contact pass; returns the CG iterations.
  int implicit_step(double h, std::size_t& contacts);
  // Divergence check and displacement of the step just taken (restores the state on divergence).
  ClothStepReport finish_step(ClothStepReport r, double dt);
  // The divergence check of the current state (ClothStatus).
  ClothStatus check() const;

  // Runs kernel(block, c0, c1) over fixed blocks of STATE_SUM_BLOCK particles in the caller's
  // order, by TBB unless the backend is serial; a sum over them adds its blocks' partials in
  // block order, so its bits depend on neither the backend nor the thread count.
  std::size_t state_block_count() const { return (masses.size() + STATE_SUM_BLOCK - 1) / STATE_SUM_BLOCK; }
  template <typename Kernel> void state_blocks(const Kernel& kernel) const {
    const std::size_t n = masses.size();
    const std::size_t blocks = state_block_count();
    const auto run = [&](std::size_t b0, std::size_t b1) {
      for (std::size_t b = b0; b < b1; ++b)
        kernel(b, b * STATE_SUM_BLOCK, std::min(n, (b + 1) * STATE_SUM_BLOCK));
    };
    if (options.backend == Backend::SERIAL)
      run(0, blocks);
    else
      parallel_for_range(blocks, 1, run);
  }
};

} // namespace vfit
