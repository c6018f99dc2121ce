#include "engine/cloth/cloth_sim.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "geometry/garment/waistband.h"
#include "kernels/cloth_collision.h"
#include "kernels/cloth_implicit.h"
#include "kernels/cloth_ordering.h"
#include "kernels/cloth_rk4.h"
#include "kernels/cloth_springs.h"
#include "kernels/error.h"
#include "kernels/hole_caps.h"
#include "kernels/opencl_context.h"
#include "kernels/parallel.h"
#include "kernels/proximity.h"
#include "kernels/spatial_hash.h"
#ifdef VFIT_WITH_OPENCL
#include "kernels/opencl_cloth.h"
#endif

namespace vfit {

const char* to_string(ClothStatus status) {
  switch (status) {
  case ClothStatus::OK: return "ok";
  case ClothStatus::DIVERGED_NON_FINITE: return "diverged: non-finite state";
  case ClothStatus::DIVERGED_ENERGY: return "diverged: energy blow-up";
  case ClothStatus::DIVERGED_STRETCH: return "diverged: runaway stretch";
  }
  return "unknown";
}

// Guard (m) added to the contact reach for the float rounding of a signed distance (~1e-8 m
// at 5 cm) and of the motion bound.
constexpr float CONTACT_REACH_GUARD = 1e-4f;
// Every this many contact passes every particle is queried again (see Impl::update_hits):
// insurance for the one case the distance bound does not cover, a side flip of a particle
// already buried in a self-overlapping posed body.
constexpr int CONTACT_FULL_QUERY_PASSES = 32;

// Resting contacts (ClothOptions::resting_contacts) are the particles the last contact pass
// found closer than τ + this (m): those it pushed out to τ, and those left at τ up to the float
// rounding of a distance (~1e-8 m at 5 cm).
constexpr float RESTING_CONTACT_MARGIN = 1e-6f;

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
  std::optional<ProximityIndex> body;
  std::optional<SpatialHash> hash;
  std::vector<BodyAttachment> attachments; // ascending vertex
  bool waistband_attached = false;
  // ClothBackend::OPENCL: the device context, and the RK4 integrator holding the adjacency and
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

  void update_substep() {
    if (options.integrator == ClothIntegrator::IMPLICIT_EULER) {
      substep = options.implicit_step;
      return;
    }
    const Rk4StepBound b = rk4_stable_step(adjacency, particles);
    substep = std::min(options.max_substep, options.substep_safety * b.max_step);
  }

  bool has_body() const { return body.has_value() || hash.has_value(); }

  // Closest body points of `queries` through the broad phase in use.
  void query_body(std::span<const float> queries, float radius, ClosestHits& out) const {
    const bool serial = options.backend == ClothBackend::SERIAL;
    if (hash) {
      if (serial)
        hash->closest_points_serial(queries, radius, out);
      else
        hash->closest_points(queries, radius, out);
    } else if (serial) {
      body->closest_points_serial(queries, radius, out);
    } else {
      body->closest_points(queries, radius, out);
    }
  }

  // The device copy of the inverse masses is stale after a change of pins.
  void masses_changed() {
#ifdef VFIT_WITH_OPENCL
    cl_rk4.reset();
#endif
    update_substep();
  }

  // `count` RK4 substeps of h on the OpenCL device: one upload of the state before, one read
  // after (the contacts between windows are resolved on the host).
  void integrate_opencl([[maybe_unused]] double h, [[maybe_unused]] int count) {
#ifdef VFIT_WITH_OPENCL
    if (!cl_rk4) cl_rk4 = std::make_unique<OpenClClothRk4>(*cl_context, adjacency, particles);
    cl_rk4->set_state(x, v);
    cl_rk4->step(static_cast<float>(h), count);
    cl_rk4->get_state(x, v);
#endif
  }

  // Where attachment a puts its vertex on the current body.
  void attached_position(const BodyAttachment& a, double out[3]) const {
    const std::int32_t* t = body_triangles.data() + 3 * static_cast<std::size_t>(a.triangle);
    const float* p[3] = {&body_positions[3 * std::size_t(t[0])], &body_positions[3 * std::size_t(t[1])],
                         &body_positions[3 * std::size_t(t[2])]};
    double e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = double(p[1][k]) - p[0][k];
      e2[k] = double(p[2][k]) - p[0][k];
    }
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& c : n)
      c = len > 0 ? c / len : 0.0;
    for (int k = 0; k < 3; ++k)
      out[k] = p[0][k] + a.s * e1[k] + a.t * e2[k] + a.h * n[k];
  }

  void integrate(double h, int count) {
    hits_valid = false;
    if (options.backend == ClothBackend::OPENCL) {
      integrate_opencl(h, count);
      return;
    }
    for (int s = 0; s < count; ++s) {
      if (options.backend == ClothBackend::SERIAL)
        rk4_step_serial(x, v, adjacency, particles, static_cast<float>(h), workspace);
      else
        rk4_step_tbb(x, v, adjacency, particles, static_cast<float>(h), workspace);
    }
  }

  // One implicit Euler step of h, with the body contacts in the solve (resting contacts as
  // stiff springs, or as B&W constraints when contacts_in_solve) and their friction, then a
  // contact pass; returns the CG iterations.
  int implicit_step(double h, std::size_t& contacts) {
    ImplicitSolveOptions solve{options.cg_tolerance, options.cg_max_iterations};
    solve.preconditioner = options.cg_preconditioner;
    solve.per_patch = options.cg_per_patch;
    const ImplicitConstraints* c = nullptr;
    const ImplicitContactSprings* cs = nullptr;
    const float hf = static_cast<float>(h);
    if (has_body() && (options.contacts_in_solve || options.resting_contacts)) {
      if (!hits_valid) contacts += resolve_contacts();
      released.resize(masses.size(), 0);
      if (options.contacts_in_solve) {
        body_contact_constraints(x, v, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                                 contact_parameters(), options.contact_margin, hf, released, constraints);
        c = &constraints;
      } else {
        body_contact_springs(x, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                             contact_parameters(), RESTING_CONTACT_MARGIN, options.resting_contact_stiffness, hf,
                             released, contact_springs);
        cs = &contact_springs;
      }
    }
    mark_step_start(0.0);
    const ImplicitSolveReport r =
        options.backend == ClothBackend::SERIAL
            ? implicit_euler_step_serial(x, v, adjacency, particles, hf, solve, implicit_workspace, c, cs)
            : implicit_euler_step_tbb(x, v, adjacency, particles, hf, solve, implicit_workspace, c, cs);
    if (c != nullptr || cs != nullptr) {
      const std::vector<float>& impulses = implicit_workspace.normal_impulses;
      apply_contact_friction(x, v, particles.inverse_masses, c != nullptr ? c->normals : cs->normals, impulses, hits,
                             body_triangles, body_velocities, options.contact_friction, hf);
      for (std::size_t i = 0; i < released.size(); ++i)
        released[i] = impulses[i] < 0.0f ? 1 : 0;
    }
    contacts += resolve_contacts();
    return r.iterations;
  }

  ContactParameters contact_parameters() const {
    return ContactParameters{options.contact_thickness, options.contact_friction, options.contact_restitution};
  }

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

  // Farthest signed distance (m) at which a hit row matters: the response's thickness, plus the
  // constraint margin when contacts are in the solve, plus a guard for the float rounding of
  // the distance.
  float contact_reach() const {
    return options.contact_thickness + (options.contacts_in_solve ? options.contact_margin : 0.0f) +
           CONTACT_REACH_GUARD;
  }

  void record_query(std::size_t i, float reach) {
    for (int k = 0; k < 3; ++k)
      query_positions[3 * i + k] = x[3 * i + k];
    const float d = hits.triangles[i] < 0 ? options.contact_search_radius : hits.signed_distances[i];
    query_allowance[i] = d - reach;
  }

  // Brings `hits` up to date for every particle whose row can matter (see query_positions).
  void update_hits() {
    const std::size_t n = masses.size();
    const float reach = contact_reach();
    const bool full = !options.contact_candidates || !body_closed || !candidates_valid ||
                      ++passes_since_full >= CONTACT_FULL_QUERY_PASSES;
    if (full) {
      query_body(x, options.contact_search_radius, hits);
      query_positions.resize(3 * n);
      query_allowance.resize(n);
      for (std::size_t i = 0; i < n; ++i)
        record_query(i, reach);
      candidates_valid = true;
      passes_since_full = 0;
      return;
    }
    requeried.clear();
    requery_points.clear();
    requery_radii.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const float a = query_allowance[i];
      if (a > 0.0f) {
        float moved2 = 0.0f;
        for (int k = 0; k < 3; ++k) {
          const float d = x[3 * i + k] - query_positions[3 * i + k];
          moved2 += d * d;
        }
        if (moved2 < a * a) continue;
      }
      requeried.push_back(static_cast<std::int32_t>(i));
      float to_old_point2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        requery_points.push_back(x[3 * i + k]);
        const float d = x[3 * i + k] - hits.points[3 * i + k];
        to_old_point2 += d * d;
      }
      // The old closest point is still on the (unmoved) body: the new closest point is no
      // farther than it, so a search radius just past it finds the same answer as the full
      // radius, pruning most of the BVH traversal.
      const float radius = hits.triangles[i] < 0
                               ? options.contact_search_radius
                               : std::min(options.contact_search_radius,
                                          std::sqrt(to_old_point2) * (1.0f + 1e-5f) + CONTACT_REACH_GUARD);
      requery_radii.push_back(radius);
    }
    if (body && options.backend != ClothBackend::SERIAL)
      body->closest_points(requery_points, requery_radii, requery_hits);
    else
      query_body(requery_points, options.contact_search_radius, requery_hits);
    for (std::size_t r = 0; r < requeried.size(); ++r) {
      const auto i = static_cast<std::size_t>(requeried[r]);
      hits.copy_row(i, requery_hits, r);
      record_query(i, reach);
    }
  }

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

  // Implicit Euler only: under RK4 the particles put back at their path's entry stretched their
  // springs past what the explicit substeps absorb (the 4 cm rod drop from 1.8 m, ClothSim.
  // FastClothDoesNotTunnelThroughAThinRod with RK4: runaway stretch at frame 39).
  bool continuous() const {
    return options.continuous_contacts && body.has_value() && options.integrator == ClothIntegrator::IMPLICIT_EULER;
  }

  // Records the start of a step (before the integrator or move_body() moves x or the body).
  // A start still pending (move_body()'s, not yet met by a contact pass) covers this step too.
  void mark_step_start(double body_time) {
    if (!continuous() || step_start_valid) return;
    start_body_time = body_time;
    const std::size_t n = masses.size();
    step_start.assign(x.begin(), x.end());
    start_bound.assign(n, 0.0f);
    if (candidates_valid && hits.size() == n && query_positions.size() == 3 * n)
      for (std::size_t i = 0; i < n; ++i) {
        const float d = hits.triangles[i] < 0 ? options.contact_search_radius : hits.signed_distances[i];
        float moved2 = 0.0f;
        for (int k = 0; k < 3; ++k) {
          const float e = x[3 * i + k] - query_positions[3 * i + k];
          moved2 += e * e;
        }
        start_bound[i] = std::max(0.0f, d - std::sqrt(moved2));
      }
    step_start_valid = true;
  }

  // The body's velocity at hit row i of `h` (zero for a body at rest or no hit).
  std::array<float, 3> body_velocity_at(const ClosestHits& h, std::size_t i) const {
    if (body_velocities.empty() || h.triangles[i] < 0) return {0.0f, 0.0f, 0.0f};
    const std::int32_t* t = body_triangles.data() + 3 * static_cast<std::size_t>(h.triangles[i]);
    const float u = h.barycentrics[2 * i], w = h.barycentrics[2 * i + 1], c[3] = {1.0f - u - w, u, w};
    float out[3] = {0.0f, 0.0f, 0.0f};
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k < 3; ++k)
        out[k] += c[a] * body_velocities[3 * static_cast<std::size_t>(t[a]) + k];
    return {out[0], out[1], out[2]};
  }

  // After update_hits(): the particles whose path since mark_step_start() went into the body and
  // now lie beyond it are put back where the path entered (ClothOptions::continuous_contacts),
  // their hit rows queried again.
  void undo_crossings() {
    if (!step_start_valid) return;
    step_start_valid = false;
    const double h = start_body_time;
    const std::size_t n = masses.size();
    float body_speed = 0.0f; // the fastest body vertex: the most it moved towards a particle
    for (std::size_t b = 0; b + 2 < body_velocities.size(); b += 3)
      body_speed = std::max(body_speed, std::sqrt(body_velocities[b] * body_velocities[b] +
                                                  body_velocities[b + 1] * body_velocities[b + 1] +
                                                  body_velocities[b + 2] * body_velocities[b + 2]));
    const float body_moved = body_speed * static_cast<float>(h);
    const float min_path = 2.0f * options.contact_thickness;
    ccd_rows.clear();
    ccd_from.clear();
    ccd_to.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (particles.inverse_masses[i] == 0.0f) continue;
      float moved2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        const float e = x[3 * i + k] - step_start[3 * i + k];
        moved2 += e * e;
      }
      // A path shorter than both its start's distance (it cannot reach the surface) and 2τ
      // (from the surface it cannot pass the middle of a part thicker than 4τ, 1.2 cm by
      // default: the discrete response pushes it back out on its own side) is not tested.
      const float reach = std::sqrt(moved2) + body_moved;
      if (reach < start_bound[i] || reach < min_path) continue;
      // The path relative to the body: from where the start lies once the body has moved on.
      const std::array<float, 3> vb = body_velocity_at(hits, i);
      const float hf = static_cast<float>(h);
      const float from[3] = {step_start[3 * i] + hf * vb[0], step_start[3 * i + 1] + hf * vb[1],
                             step_start[3 * i + 2] + hf * vb[2]};
      if (from[0] == x[3 * i] && from[1] == x[3 * i + 1] && from[2] == x[3 * i + 2]) continue; // no relative motion
      ccd_rows.push_back(static_cast<std::int32_t>(i));
      ccd_from.insert(ccd_from.end(), {from[0], from[1], from[2]});
      ccd_to.insert(ccd_to.end(), {x[3 * i], x[3 * i + 1], x[3 * i + 2]});
    }
    if (ccd_rows.empty()) return;
    body->first_hits(ccd_from, ccd_to, ccd_hits);
    ccd_undone.clear();
    ccd_points.clear();
    const float gap = 0.5f * options.contact_thickness; // inside τ: the response lifts it to τ
    for (std::size_t r = 0; r < ccd_rows.size(); ++r) {
      if (ccd_hits.triangles[r] == -1) continue;
      const float* nm = ccd_hits.normals.data() + 3 * r;
      const float dir[3] = {ccd_to[3 * r] - ccd_from[3 * r], ccd_to[3 * r + 1] - ccd_from[3 * r + 1],
                            ccd_to[3 * r + 2] - ccd_from[3 * r + 2]};
      if (dir[0] * nm[0] + dir[1] * nm[1] + dir[2] * nm[2] >= 0.0f) continue; // met from inside
      const auto i = static_cast<std::size_t>(ccd_rows[r]);
      // Where the discrete response would push it: along the outward normal of its closest point.
      const float d = hits.triangles[i] < 0 ? INFINITY : hits.signed_distances[i];
      if (d < 0.0f) {
        float out[3], len2 = 0.0f;
        for (int k = 0; k < 3; ++k) {
          out[k] = hits.points[3 * i + k] - x[3 * i + k]; // inside: towards the closest point
          len2 += out[k] * out[k];
        }
        // A shallow entry, pushed back out on its own side: the discrete response is right.
        if (len2 > 0.0f && out[0] * nm[0] + out[1] * nm[1] + out[2] * nm[2] >= 0.0f) continue;
      }
      const float t = ccd_hits.t[r];
      for (int k = 0; k < 3; ++k) {
        x[3 * i + k] = ccd_from[3 * r + k] + t * dir[k] + gap * nm[k];
        ccd_points.push_back(x[3 * i + k]);
      }
      ccd_undone.push_back(static_cast<std::int32_t>(i));
    }
    if (ccd_undone.empty()) return;
    crossings_undone += ccd_undone.size();
    query_body(ccd_points, options.contact_search_radius, ccd_requery);
    const float reach = contact_reach();
    for (std::size_t r = 0; r < ccd_undone.size(); ++r) {
      const auto i = static_cast<std::size_t>(ccd_undone[r]);
      hits.copy_row(i, ccd_requery, r);
      if (query_positions.size() == 3 * n) record_query(i, reach);
    }
    state_changed();
  }

  std::size_t resolve_contacts() {
    if (!has_body()) return 0;
    update_hits();
    undo_crossings();
    hits_valid = true;
    return resolve_body_contacts(x, v, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                                 contact_parameters());
  }

  // Divergence check and displacement of the step just taken (restores the state on divergence).
  ClothStepReport finish_step(ClothStepReport r, double dt);

  // Marks the published state (out_x, out_v) stale: called by every operation that changes x
  // or v; the next read of positions() or velocities() gathers it into the caller's numbering.
  void state_changed() { out_x_current = out_v_current = false; }

  // The state in the caller's numbering (positions(), velocities()), gathered if stale.
  const std::vector<float>& published_positions() const {
    if (!out_x_current) gather_rows(x, rank, 3, out_x);
    out_x_current = true;
    return out_x;
  }
  const std::vector<float>& published_velocities() const {
    if (!out_v_current) gather_rows(v, rank, 3, out_v);
    out_v_current = true;
    return out_v;
  }

  // Attaches the internal particles `rows` to the body (see ClothSim::attach_to_body).
  void attach_rows(std::span<const std::int32_t> rows);

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
    if (options.backend == ClothBackend::SERIAL)
      run(0, blocks);
    else
      parallel_for_range(blocks, 1, run);
  }

  ClothStatus check() const {
    // Per block: 1 when a coordinate is not finite, and its kinetic energy.
    std::vector<double> energy(state_block_count(), 0.0);
    std::vector<unsigned char> non_finite(energy.size(), 0);
    state_blocks([&](std::size_t b, std::size_t c0, std::size_t c1) {
      double ke = 0;
      for (std::size_t c = c0; c < c1; ++c) {
        const auto i = static_cast<std::size_t>(rank[c]);
        double v2 = 0;
        for (int k = 0; k < 3; ++k) {
          if (!std::isfinite(x[3 * i + k]) || !std::isfinite(v[3 * i + k])) {
            non_finite[b] = 1;
            return;
          }
          v2 += double(v[3 * i + k]) * v[3 * i + k];
        }
        ke += 0.5 * masses[i] * v2;
      }
      energy[b] = ke;
    });
    double ke = 0;
    for (std::size_t b = 0; b < energy.size(); ++b) {
      if (non_finite[b]) return ClothStatus::DIVERGED_NON_FINITE;
      ke += energy[b];
    }
    if (ke > 0.5 * total_mass * options.max_speed * options.max_speed) return ClothStatus::DIVERGED_ENERGY;
    if (max_spring_stretch(x, springs, stretch_floor, options.backend != ClothBackend::SERIAL) > options.max_stretch)
      return ClothStatus::DIVERGED_STRETCH;
    return ClothStatus::OK;
  }
};

namespace {

void check_fabric(const Fabric& f, std::size_t index) {
  const auto bad = [&](const char* what) {
    throw Error("fabric " + std::to_string(index) + " (" + f.name + ")", 0,
                std::string(what) + " must be finite and ≥ 0");
  };
  if (!(f.area_density >= 0) || !std::isfinite(f.area_density)) bad("area_density");
  if (!(f.stretch_stiffness >= 0) || !std::isfinite(f.stretch_stiffness)) bad("stretch_stiffness");
  if (!(f.bend_stiffness >= 0) || !std::isfinite(f.bend_stiffness)) bad("bend_stiffness");
  if (!(f.damping_ratio >= 0) || !std::isfinite(f.damping_ratio)) bad("damping_ratio");
}

// Lumped masses: ρ_i × one third of the area of each triangle of vertex i.
std::vector<float> lumped_masses(std::span<const float> p, std::span<const std::int32_t> tris,
                                 const std::vector<double>& density) {
  std::vector<double> m(density.size(), 0.0);
  for (std::size_t f = 0; f < tris.size() / 3; ++f) {
    const std::size_t a = tris[3 * f], b = tris[3 * f + 1], c = tris[3 * f + 2];
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(p[3 * b + k]) - p[3 * a + k];
      w[k] = double(p[3 * c + k]) - p[3 * a + k];
    }
    const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
    const double third = std::sqrt(cx * cx + cy * cy + cz * cz) / 6.0;
    for (std::size_t i : {a, b, c})
      m[i] += density[i] * third;
  }
  return std::vector<float>(m.begin(), m.end());
}

} // namespace

ClothSim::ClothSim(std::span<const float> positions, std::span<const std::int32_t> triangles,
                   const ClothOptions& options)
    : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.options = options;
  const std::size_t nv = positions.size() / 3;
  if (positions.size() % 3 != 0) throw Error("cloth", 0, "positions must hold 3 floats per vertex");
  if (triangles.size() % 3 != 0) throw Error("cloth", 0, "triangles must hold 3 indices per face");
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (!std::isfinite(positions[i])) throw Error("cloth", 0, "vertex " + std::to_string(i / 3) + " is not finite");
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nv)
      throw Error("cloth", 0,
                  "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(nv) + ")");
  if (options.fabrics.empty()) throw Error("cloth", 0, "no fabric given");
  if (options.integrator == ClothIntegrator::IMPLICIT_EULER &&
      (!(options.implicit_step > 0) || !std::isfinite(options.implicit_step)))
    throw Error("cloth", 0, "implicit_step must be finite and > 0, got " + std::to_string(options.implicit_step));
  for (std::size_t f = 0; f < options.fabrics.size(); ++f)
    check_fabric(options.fabrics[f], f);
  if (options.backend == ClothBackend::OPENCL) {
    if (options.integrator != ClothIntegrator::RK4)
      throw Error("cloth", 0, "the OpenCL backend runs the RK4 integrator only (set integrator = RK4)");
#ifndef VFIT_WITH_OPENCL
    throw Error("cloth", 0, "the OpenCL backend was requested but this build has no OpenCL");
#endif
  }
  if (!options.vertex_fabric.empty() && options.vertex_fabric.size() != nv)
    throw Error("cloth", 0,
                "vertex_fabric has " + std::to_string(options.vertex_fabric.size()) + " entries for " +
                    std::to_string(nv) + " vertices");
  std::vector<const Fabric*> fabric(nv, &options.fabrics[0]);
  for (std::size_t i = 0; i < options.vertex_fabric.size(); ++i) {
    const std::int32_t f = options.vertex_fabric[i];
    if (f < 0 || static_cast<std::size_t>(f) >= options.fabrics.size())
      throw Error("cloth", 0,
                  "vertex " + std::to_string(i) + " has fabric index " + std::to_string(f) + " of " +
                      std::to_string(options.fabrics.size()) + " fabrics");
    fabric[i] = &options.fabrics[static_cast<std::size_t>(f)];
  }

  m.triangles.assign(triangles.begin(), triangles.end());
  std::vector<double> density(nv);
  for (std::size_t i = 0; i < nv; ++i)
    density[i] = fabric[i]->area_density;
  m.out_masses = lumped_masses(positions, triangles, density);
  for (std::size_t i = 0; i < nv; ++i)
    m.total_mass += m.out_masses[i];
  std::copy(std::begin(options.gravity), std::end(options.gravity), m.particles.gravity);
  m.particles.global_damping = static_cast<float>(options.global_damping);

  m.springs = build_cloth_springs(positions, triangles, SpringTopologyOptions{options.bending});
  for (std::size_t s = 0; s < m.springs.size(); ++s) {
    const std::size_t i = m.springs.ends[2 * s], j = m.springs.ends[2 * s + 1];
    const bool bend = m.springs.kinds[s] == SpringKind::BENDING;
    const double k = 0.5 * (bend ? fabric[i]->bend_stiffness + fabric[j]->bend_stiffness
                                 : fabric[i]->stretch_stiffness + fabric[j]->stretch_stiffness);
    const double zeta = 0.5 * (fabric[i]->damping_ratio + fabric[j]->damping_ratio);
    const double mi = m.out_masses[i], mj = m.out_masses[j];
    const double reduced = mi + mj > 0 ? mi * mj / (mi + mj) : 0.0;
    m.springs.stiffness[s] = static_cast<float>(k);
    m.springs.damping[s] = static_cast<float>(2.0 * zeta * std::sqrt(k * reduced));
  }
  // Into the internal numbering (see Impl).
  m.order = cloth_particle_order(nv, m.springs);
  m.rank = inverse_permutation(m.order);
  m.springs = renumber_cloth_springs(m.springs, m.rank);
  gather_rows(positions, m.order, 3, m.x);
  m.v.assign(positions.size(), 0.0f);
  gather_rows(m.out_masses, m.order, 1, m.masses);
  m.particles.inverse_masses.resize(nv);
  for (std::size_t i = 0; i < nv; ++i)
    m.particles.inverse_masses[i] = m.masses[i] > 0.0f ? 1.0f / m.masses[i] : 0.0f;
  m.adjacency = build_spring_adjacency(m.springs, nv);
  // Runaway stretch is judged against at least half the median structural rest length, so a
  // sliver edge of a generated mesh (microns long) stretched by a fraction of a millimetre is
  // not read as divergence, and against at least the contact thickness τ: a contact pass moves
  // a particle by up to τ at once (out to the gap), which on a fine mesh's sub-millimetre edges
  // is a tenfold stretch that the next steps relax (see ClothOptions::max_stretch).
  std::vector<float> structural;
  for (std::size_t s = 0; s < m.springs.size(); ++s)
    if (m.springs.kinds[s] == SpringKind::STRUCTURAL) structural.push_back(m.springs.rest_lengths[s]);
  if (!structural.empty()) {
    std::nth_element(structural.begin(), structural.begin() + std::ptrdiff_t(structural.size() / 2), structural.end());
    m.stretch_floor = 0.5f * structural[structural.size() / 2];
  }
  if (std::isfinite(options.contact_thickness)) m.stretch_floor = std::max(m.stretch_floor, options.contact_thickness);
  m.update_substep();
  m.state_changed();
  if (options.backend == ClothBackend::OPENCL) m.cl_context = std::make_unique<OpenClContext>(options.opencl_device);
}

ClothSim::~ClothSim() = default;
ClothSim::ClothSim(ClothSim&&) noexcept = default;
ClothSim& ClothSim::operator=(ClothSim&&) noexcept = default;

void ClothSim::pin(std::span<const std::int32_t> vertices) {
  Impl& m = *m_impl;
  for (std::int32_t p : vertices) {
    if (p < 0 || static_cast<std::size_t>(p) >= m.masses.size())
      throw Error("cloth", 0,
                  "pinned vertex " + std::to_string(p) + " outside [0, " + std::to_string(m.masses.size()) + ")");
    const auto row = static_cast<std::size_t>(m.rank[static_cast<std::size_t>(p)]);
    m.particles.inverse_masses[row] = 0.0f;
    for (int k = 0; k < 3; ++k)
      m.v[3 * row + k] = 0.0f;
  }
  m.masses_changed();
  m.state_changed();
}

void ClothSim::set_body(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  Impl& m = *m_impl;
  const std::size_t nb = positions.size() / 3;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nb)
      throw Error("body", 0,
                  "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(nb) + ")");
  if (m.options.broad_phase == ClothBroadPhase::SPATIAL_HASH) {
    m.hash.emplace(positions, triangles);
    m.body.reset();
  } else {
    m.body.emplace(positions, triangles);
    m.hash.reset();
  }
  m.body_positions.assign(positions.begin(), positions.end());
  m.body_triangles.assign(triangles.begin(), triangles.end());
  m.body_velocities.clear();
  m.hits_valid = false;
  m.candidates_valid = false;
  m.step_start_valid = false; // a path is tested against the body it was taken beside
  m.body_closed = build_hole_caps(triangles, nb).loop_count() == 0;
  std::vector<std::int32_t> attach; // internal rows
  for (const BodyAttachment& a : m.attachments)
    attach.push_back(a.vertex);
  if (m.options.waistband_pins && !m.waistband_attached) {
    // Searched in the caller's numbering, on the caller's triangles, as the function documents.
    for (std::int32_t b : waistband_vertices(m.published_positions(), m.triangles, m.options.waistband_width))
      attach.push_back(m.rank[static_cast<std::size_t>(b)]);
    m.waistband_attached = true;
  }
  m.attachments.clear();
  if (!attach.empty()) m.attach_rows(attach);
  m.state_changed();
}

void ClothSim::attach_to_body(std::span<const std::int32_t> vertices) {
  Impl& m = *m_impl;
  if (!m.has_body()) throw Error("cloth", 0, "attach_to_body called before set_body");
  std::vector<std::int32_t> rows;
  rows.reserve(vertices.size());
  for (std::int32_t p : vertices) {
    if (p < 0 || static_cast<std::size_t>(p) >= m.masses.size())
      throw Error("cloth", 0,
                  "attached vertex " + std::to_string(p) + " outside [0, " + std::to_string(m.masses.size()) + ")");
    rows.push_back(m.rank[static_cast<std::size_t>(p)]);
  }
  m.attach_rows(rows);
  m.state_changed();
}

void ClothSim::Impl::attach_rows(std::span<const std::int32_t> vertices) {
  Impl& m = *this;
  std::vector<float> points;
  points.reserve(3 * vertices.size());
  for (std::int32_t p : vertices)
    for (int k = 0; k < 3; ++k)
      points.push_back(m.x[3 * static_cast<std::size_t>(p) + k]);
  ClosestHits found;
  m.query_body(points, INFINITY, found);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    if (found.triangles[i] < 0) continue; // an empty body: nothing to attach to
    BodyAttachment a;
    a.vertex = vertices[i];
    a.triangle = found.triangles[i];
    const std::int32_t* t = m.body_triangles.data() + 3 * static_cast<std::size_t>(a.triangle);
    const float* c[3] = {&m.body_positions[3 * std::size_t(t[0])], &m.body_positions[3 * std::size_t(t[1])],
                         &m.body_positions[3 * std::size_t(t[2])]};
    double e1[3], e2[3], r[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = double(c[1][k]) - c[0][k];
      e2[k] = double(c[2][k]) - c[0][k];
      r[k] = double(points[3 * i + k]) - c[0][k];
    }
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const auto dot = [](const double* p, const double* q) { return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]; };
    const double g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2), det = dot(n, n);
    if (det > 1e-12 * g11 * g22 && det > 0) {
      // Lagrange's identity: det of the Gram matrix [g11 g12; g12 g22] is |e1 × e2|².
      a.h = dot(r, n) / std::sqrt(det);
      const double r1 = dot(r, e1), r2 = dot(r, e2); // the normal part of r is orthogonal to e1, e2
      a.s = (g22 * r1 - g12 * r2) / det;
      a.t = (g11 * r2 - g12 * r1) / det;
    } else {
      a.s = found.barycentrics[2 * i];
      a.t = found.barycentrics[2 * i + 1];
    }
    const auto at = std::lower_bound(m.attachments.begin(), m.attachments.end(), a.vertex,
                                     [](const BodyAttachment& b, std::int32_t row) { return b.vertex < row; });
    if (at != m.attachments.end() && at->vertex == a.vertex)
      *at = a;
    else
      m.attachments.insert(at, a);
    const auto row = static_cast<std::size_t>(a.vertex);
    m.particles.inverse_masses[row] = 0.0f;
    for (int k = 0; k < 3; ++k)
      m.v[3 * row + k] = 0.0f;
  }
  m.masses_changed();
}

std::vector<std::int32_t> ClothSim::attached_vertices() const {
  std::vector<std::int32_t> out;
  out.reserve(m_impl->attachments.size());
  for (const BodyAttachment& a : m_impl->attachments)
    out.push_back(m_impl->order[static_cast<std::size_t>(a.vertex)]);
  std::sort(out.begin(), out.end());
  return out;
}

void ClothSim::move_body(std::span<const float> positions, double dt) {
  Impl& m = *m_impl;
  if (!m.has_body()) throw Error("body", 0, "move_body called before set_body");
  if (positions.size() != m.body_positions.size())
    throw Error("body", 0,
                "moved body has " + std::to_string(positions.size() / 3) + " vertices, expected " +
                    std::to_string(m.body_positions.size() / 3));
  // The particles' paths relative to the body over this move are tested at the next contact
  // pass (ClothOptions::continuous_contacts): the move carries a limb up to its whole frame's
  // motion at once, through cloth in its way.
  m.mark_step_start(dt > 0 ? dt : 0.0);
  m.body_velocities.resize(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i)
    m.body_velocities[i] = dt > 0 ? static_cast<float>((positions[i] - m.body_positions[i]) / dt) : 0.0f;
  m.body_positions.assign(positions.begin(), positions.end());
  m.body_motion_left = dt > 0 ? dt : 0.0;
  if (m.hash)
    m.hash->update(positions);
  else
    m.body->refit(positions);
  m.hits_valid = false;
  m.candidates_valid = false;
  for (const BodyAttachment& a : m.attachments) {
    double to[3];
    m.attached_position(a, to);
    const auto row = 3 * static_cast<std::size_t>(a.vertex);
    for (int k = 0; k < 3; ++k) {
      m.v[row + k] = dt > 0 ? static_cast<float>((to[k] - m.x[row + k]) / dt) : 0.0f;
      m.x[row + k] = static_cast<float>(to[k]);
    }
  }
  m.state_changed();
}

ClothStepReport ClothSim::step(double dt) {
  Impl& m = *m_impl;
  ClothStepReport r;
  r.status = m.status;
  if (m.status != ClothStatus::OK || !(dt > 0)) return r;
  m.saved_x = m.x;
  m.saved_v = m.v;
  const std::size_t undone_before = m.crossings_undone;
  if (m.options.integrator == ClothIntegrator::IMPLICIT_EULER) {
    const int steps = std::max(1, static_cast<int>(std::ceil(dt / m.substep - 1e-9)));
    for (int s = 0; s < steps; ++s)
      r.solver_iterations += m.implicit_step(dt / steps, r.contacts);
    r.substeps = steps;
    r.crossings_undone = m.crossings_undone - undone_before;
    return m.finish_step(r, dt);
  }
  // Contact windows of at most contact_interval, each integrated in equal stable substeps.
  const int windows =
      m.has_body() ? std::max(1, static_cast<int>(std::ceil(dt / m.options.contact_interval - 1e-9))) : 1;
  const double window = dt / windows;
  const int substeps = std::max(1, static_cast<int>(std::ceil(window / m.substep - 1e-9)));
  for (int w = 0; w < windows; ++w) {
    m.integrate(window / substeps, substeps);
    r.contacts += m.resolve_contacts();
  }
  r.substeps = windows * substeps;
  r.crossings_undone = m.crossings_undone - undone_before;
  return m.finish_step(r, dt);
}

ClothStepReport ClothSim::Impl::finish_step(ClothStepReport r, double dt) {
  Impl& m = *this;
  m.status = m.check();
  r.status = m.status;
  if (m.status != ClothStatus::OK) {
    m.x = m.saved_x;
    m.v = m.saved_v;
    m.hits_valid = false;
    m.candidates_valid = false;
    m.step_start_valid = false;
    m.state_changed();
    return r;
  }
  if (m.body_motion_left > 0) {
    // The move's interval is spent: the body stands where move_body() left it.
    m.body_motion_left -= dt;
    if (m.body_motion_left <= 1e-9 * dt) {
      m.body_motion_left = 0;
      m.body_velocities.clear();
      for (const BodyAttachment& a : m.attachments)
        for (std::size_t k = 0; k < 3; ++k)
          m.v[3 * static_cast<std::size_t>(a.vertex) + k] = 0.0f;
    }
  }
  m.state_changed();
  std::vector<double> moved(m.state_block_count(), 0.0);
  m.state_blocks([&](std::size_t b, std::size_t c0, std::size_t c1) {
    double sum = 0;
    for (std::size_t c = c0; c < c1; ++c) { // in the caller's order
      const auto i = static_cast<std::size_t>(m.rank[c]);
      double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(m.x[3 * i + k]) - m.saved_x[3 * i + k];
        d2 += d * d;
      }
      sum += std::sqrt(d2);
    }
    moved[b] = sum;
  });
  double total = 0;
  for (double sum : moved)
    total += sum;
  r.mean_displacement = m.masses.empty() ? 0.0 : total / static_cast<double>(m.masses.size());
  return r;
}

ClothRestReport ClothSim::run_to_rest(const ClothRestOptions& options) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  ClothRestReport r;
  // Implicit Euler steps longer than step_dt are taken whole; their displacement is scaled to
  // step_dt, so the threshold keeps meaning the same residual speed (M / step_dt).
  const double stride = m_impl->options.integrator == ClothIntegrator::IMPLICIT_EULER
                            ? std::max(options.step_dt, m_impl->substep)
                            : options.step_dt;
  while (r.simulated_seconds < options.max_simulated_seconds) {
    const ClothStepReport s = step(stride);
    r.status = s.status;
    if (s.status != ClothStatus::OK) break;
    ++r.steps;
    r.simulated_seconds += stride;
    r.mean_displacement = s.mean_displacement * (options.step_dt / stride);
    r.solver_iterations += s.solver_iterations;
    if (r.mean_displacement < options.displacement_threshold) {
      r.converged = true;
      break;
    }
    if (options.max_wall_seconds > 0 &&
        std::chrono::duration<double>(Clock::now() - start).count() > options.max_wall_seconds)
      break;
  }
  r.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return r;
}

std::size_t ClothSim::particle_count() const { return m_impl->masses.size(); }
std::size_t ClothSim::spring_count() const { return m_impl->springs.size(); }
std::span<const float> ClothSim::positions() const { return m_impl->published_positions(); }
std::span<const float> ClothSim::velocities() const { return m_impl->published_velocities(); }
std::span<const float> ClothSim::masses() const { return m_impl->out_masses; }
double ClothSim::stable_substep() const { return m_impl->substep; }
ClothStatus ClothSim::status() const { return m_impl->status; }

double ClothSim::kinetic_energy() const {
  const Impl& m = *m_impl;
  const std::vector<float>& v = m.published_velocities();
  double e = 0;
  for (std::size_t i = 0; i < m.out_masses.size(); ++i)
    for (int k = 0; k < 3; ++k)
      e += 0.5 * m.out_masses[i] * double(v[3 * i + k]) * v[3 * i + k];
  return e;
}

double ClothSim::spring_energy() const { return vfit::spring_energy(m_impl->x, m_impl->springs); }

} // namespace vfit
