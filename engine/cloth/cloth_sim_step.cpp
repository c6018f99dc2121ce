// SPDX-License-Identifier: Apache-2.0
// ClothSim's stepping: RK4 substeps per backend (serial, TBB, OpenCL) between contact passes,
// implicit Euler steps with the contacts in the solve, the divergence check and run_to_rest().
#include "vfit/engine/cloth/cloth_sim_internal.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace vfit {

// Resting contacts (ClothOptions::resting_contacts) are the particles the last contact pass
// found closer than τ + this (m): those it pushed out to τ, and those left at τ up to the float
// rounding of a distance (~1e-8 m at 5 cm).
constexpr float RESTING_CONTACT_MARGIN = 1e-6f;

void ClothSim::Impl::integrate_opencl([[maybe_unused]] double h, [[maybe_unused]] int count) {
#ifdef VFIT_WITH_OPENCL
  if (!cl_rk4) cl_rk4 = std::make_unique<OpenClClothRk4>(*cl_context, adjacency, particles);
  cl_rk4->set_state(x, v);
  cl_rk4->step(static_cast<float>(h), count);
  cl_rk4->get_state(x, v);
#endif
}

void ClothSim::Impl::integrate(double h, int count) {
  hits_valid = false;
  if (options.backend == Backend::OPENCL) {
    integrate_opencl(h, count);
    return;
  }
  for (int s = 0; s < count; ++s) {
    if (options.backend == Backend::SERIAL)
      rk4_step_serial(x, v, adjacency, particles, static_cast<float>(h), workspace);
    else
      rk4_step_tbb(x, v, adjacency, particles, static_cast<float>(h), workspace);
  }
}

int ClothSim::Impl::implicit_step(double h, std::size_t& contacts) {
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
      options.backend == Backend::SERIAL
          ? implicit_euler_step_serial(x, v, adjacency, particles, hf, solve, implicit_workspace, c, cs)
          : implicit_euler_step_tbb(x, v, adjacency, particles, hf, solve, implicit_workspace, c, cs);
  if (c != nullptr || cs != nullptr) {
    const std::vector<float>& impulses = implicit_workspace.normal_impulses;
    apply_contact_friction(x, v, particles.inverse_masses, c != nullptr ? c->normals : cs->normals, impulses, hits,
                           body_triangles, body_velocities, options.contact_friction, hf);
    for (std::size_t i = 0; i < released.size(); ++i)
      released[i] = impulses[i] < 0.0f ? 1 : 0;
  }
  apply_tethers();
  contacts += resolve_contacts();
  return r.iterations;
}

ClothStatus ClothSim::Impl::check() const {
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
  if (max_spring_stretch(x, springs, stretch_floor, options.backend != Backend::SERIAL) > options.max_stretch)
    return ClothStatus::DIVERGED_STRETCH;
  return ClothStatus::OK;
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
    m.apply_tethers();
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

} // namespace vfit
