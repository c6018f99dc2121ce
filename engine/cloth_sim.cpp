#include "cloth_sim.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>

#include "kernels/cloth_collision.h"
#include "kernels/cloth_implicit.h"
#include "kernels/cloth_rk4.h"
#include "kernels/cloth_springs.h"
#include "kernels/error.h"
#include "kernels/proximity.h"

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

struct ClothSim::Impl {
  ClothOptions options;
  ClothSprings springs;
  SpringAdjacency adjacency;
  ClothParticles particles;
  std::vector<float> masses;
  std::vector<float> x, v;
  std::vector<float> saved_x, saved_v; // state before the current step, restored on divergence
  Rk4Workspace workspace;
  ImplicitWorkspace implicit_workspace;
  double substep = 0;
  double total_mass = 0;
  float stretch_floor = 0; // rest length below which stretch is measured against this (m)
  ClothStatus status = ClothStatus::OK;

  std::optional<ProximityIndex> body;
  std::vector<float> body_positions, body_velocities;
  std::vector<std::int32_t> body_triangles;
  ClosestHits hits;
  // Implicit Euler's contact constraints, built from `hits` when they describe the current
  // positions (the query of the last contact pass, taken before its response).
  bool hits_valid = false;
  ImplicitConstraints constraints;
  std::vector<unsigned char> released; // 1: the constraint pulled last step, left free this one

  void update_substep() {
    if (options.integrator == ClothIntegrator::IMPLICIT_EULER) {
      substep = options.implicit_step;
      return;
    }
    const Rk4StepBound b = rk4_stable_step(adjacency, particles);
    substep = std::min(options.max_substep, options.substep_safety * b.max_step);
  }

  void integrate(double h, int count) {
    hits_valid = false;
    for (int s = 0; s < count; ++s) {
      if (options.backend == ClothBackend::SERIAL)
        rk4_step_serial(x, v, adjacency, particles, static_cast<float>(h), workspace);
      else
        rk4_step_tbb(x, v, adjacency, particles, static_cast<float>(h), workspace);
    }
  }

  // One implicit Euler step of h (with the body contacts as constraints of the solve and their
  // friction when contacts_in_solve), then a contact pass; returns the CG iterations.
  int implicit_step(double h, std::size_t& contacts) {
    const ImplicitSolveOptions solve{options.cg_tolerance, options.cg_max_iterations};
    const ImplicitConstraints* c = nullptr;
    const float hf = static_cast<float>(h);
    if (body && options.contacts_in_solve) {
      if (!hits_valid) contacts += resolve_contacts();
      released.resize(masses.size(), 0);
      body_contact_constraints(x, v, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                               contact_parameters(), options.contact_margin, hf, released, constraints);
      c = &constraints;
    }
    const ImplicitSolveReport r =
        options.backend == ClothBackend::SERIAL
            ? implicit_euler_step_serial(x, v, adjacency, particles, hf, solve, implicit_workspace, c)
            : implicit_euler_step_tbb(x, v, adjacency, particles, hf, solve, implicit_workspace, c);
    if (c != nullptr) {
      const std::vector<float>& impulses = implicit_workspace.normal_impulses;
      apply_contact_friction(x, v, particles.inverse_masses, constraints, impulses, hits, body_triangles,
                             body_velocities, options.contact_friction, hf);
      for (std::size_t i = 0; i < released.size(); ++i)
        released[i] = impulses[i] < 0.0f ? 1 : 0;
    }
    contacts += resolve_contacts();
    return r.iterations;
  }

  ContactParameters contact_parameters() const {
    return ContactParameters{options.contact_thickness, options.contact_friction, options.contact_restitution};
  }

  std::size_t resolve_contacts() {
    if (!body) return 0;
    if (options.backend == ClothBackend::SERIAL)
      body->closest_points_serial(x, options.contact_search_radius, hits);
    else
      body->closest_points(x, options.contact_search_radius, hits);
    hits_valid = true;
    return resolve_body_contacts(x, v, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                                 contact_parameters());
  }

  // Divergence check and displacement of the step just taken (restores the state on divergence).
  ClothStepReport finish_step(ClothStepReport r);

  ClothStatus check() const {
    double ke = 0;
    for (std::size_t i = 0; i < masses.size(); ++i) {
      double v2 = 0;
      for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(x[3 * i + k]) || !std::isfinite(v[3 * i + k])) return ClothStatus::DIVERGED_NON_FINITE;
        v2 += double(v[3 * i + k]) * v[3 * i + k];
      }
      ke += 0.5 * masses[i] * v2;
    }
    if (ke > 0.5 * total_mass * options.max_speed * options.max_speed) return ClothStatus::DIVERGED_ENERGY;
    if (max_spring_stretch(x, springs, stretch_floor) > options.max_stretch) return ClothStatus::DIVERGED_STRETCH;
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

  m.x.assign(positions.begin(), positions.end());
  m.v.assign(positions.size(), 0.0f);
  std::vector<double> density(nv);
  for (std::size_t i = 0; i < nv; ++i)
    density[i] = fabric[i]->area_density;
  m.masses = lumped_masses(positions, triangles, density);
  m.particles.inverse_masses.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    m.particles.inverse_masses[i] = m.masses[i] > 0.0f ? 1.0f / m.masses[i] : 0.0f;
    m.total_mass += m.masses[i];
  }
  std::copy(std::begin(options.gravity), std::end(options.gravity), m.particles.gravity);
  m.particles.global_damping = static_cast<float>(options.global_damping);

  m.springs = build_cloth_springs(positions, triangles, SpringTopologyOptions{options.bending});
  for (std::size_t s = 0; s < m.springs.size(); ++s) {
    const std::size_t i = m.springs.ends[2 * s], j = m.springs.ends[2 * s + 1];
    const bool bend = m.springs.kinds[s] == SpringKind::BENDING;
    const double k = 0.5 * (bend ? fabric[i]->bend_stiffness + fabric[j]->bend_stiffness
                                 : fabric[i]->stretch_stiffness + fabric[j]->stretch_stiffness);
    const double zeta = 0.5 * (fabric[i]->damping_ratio + fabric[j]->damping_ratio);
    const double mi = m.masses[i], mj = m.masses[j];
    const double reduced = mi + mj > 0 ? mi * mj / (mi + mj) : 0.0;
    m.springs.stiffness[s] = static_cast<float>(k);
    m.springs.damping[s] = static_cast<float>(2.0 * zeta * std::sqrt(k * reduced));
  }
  m.adjacency = build_spring_adjacency(m.springs, nv);
  // Runaway stretch is judged against at least half the median structural rest length, so a
  // sliver edge of a generated mesh (microns long) stretched by a fraction of a millimetre is
  // not read as divergence.
  std::vector<float> structural;
  for (std::size_t s = 0; s < m.springs.size(); ++s)
    if (m.springs.kinds[s] == SpringKind::STRUCTURAL) structural.push_back(m.springs.rest_lengths[s]);
  if (!structural.empty()) {
    std::nth_element(structural.begin(), structural.begin() + std::ptrdiff_t(structural.size() / 2), structural.end());
    m.stretch_floor = 0.5f * structural[structural.size() / 2];
  }
  m.update_substep();
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
    m.particles.inverse_masses[static_cast<std::size_t>(p)] = 0.0f;
    for (int k = 0; k < 3; ++k)
      m.v[3 * static_cast<std::size_t>(p) + k] = 0.0f;
  }
  m.update_substep();
}

void ClothSim::set_body(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  Impl& m = *m_impl;
  const std::size_t nb = positions.size() / 3;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nb)
      throw Error("body", 0,
                  "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(nb) + ")");
  m.body.emplace(positions, triangles);
  m.body_positions.assign(positions.begin(), positions.end());
  m.body_triangles.assign(triangles.begin(), triangles.end());
  m.body_velocities.clear();
  m.hits_valid = false;
}

void ClothSim::move_body(std::span<const float> positions, double dt) {
  Impl& m = *m_impl;
  if (!m.body) throw Error("body", 0, "move_body called before set_body");
  if (positions.size() != m.body_positions.size())
    throw Error("body", 0,
                "moved body has " + std::to_string(positions.size() / 3) + " vertices, expected " +
                    std::to_string(m.body_positions.size() / 3));
  m.body_velocities.resize(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i)
    m.body_velocities[i] = dt > 0 ? static_cast<float>((positions[i] - m.body_positions[i]) / dt) : 0.0f;
  m.body_positions.assign(positions.begin(), positions.end());
  m.body->refit(positions);
  m.hits_valid = false;
}

ClothStepReport ClothSim::step(double dt) {
  Impl& m = *m_impl;
  ClothStepReport r;
  r.status = m.status;
  if (m.status != ClothStatus::OK || !(dt > 0)) return r;
  m.saved_x = m.x;
  m.saved_v = m.v;
  if (m.options.integrator == ClothIntegrator::IMPLICIT_EULER) {
    const int steps = std::max(1, static_cast<int>(std::ceil(dt / m.substep - 1e-9)));
    for (int s = 0; s < steps; ++s)
      r.solver_iterations += m.implicit_step(dt / steps, r.contacts);
    r.substeps = steps;
    return m.finish_step(r);
  }
  // Contact windows of at most contact_interval, each integrated in equal stable substeps.
  const int windows = m.body ? std::max(1, static_cast<int>(std::ceil(dt / m.options.contact_interval - 1e-9))) : 1;
  const double window = dt / windows;
  const int substeps = std::max(1, static_cast<int>(std::ceil(window / m.substep - 1e-9)));
  for (int w = 0; w < windows; ++w) {
    m.integrate(window / substeps, substeps);
    r.contacts += m.resolve_contacts();
  }
  r.substeps = windows * substeps;
  return m.finish_step(r);
}

ClothStepReport ClothSim::Impl::finish_step(ClothStepReport r) {
  Impl& m = *this;
  m.status = m.check();
  r.status = m.status;
  if (m.status != ClothStatus::OK) {
    m.x = m.saved_x;
    m.v = m.saved_v;
    m.hits_valid = false;
    return r;
  }
  double total = 0;
  for (std::size_t i = 0; i < m.masses.size(); ++i) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double d = double(m.x[3 * i + k]) - m.saved_x[3 * i + k];
      d2 += d * d;
    }
    total += std::sqrt(d2);
  }
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
std::span<const float> ClothSim::positions() const { return m_impl->x; }
std::span<const float> ClothSim::velocities() const { return m_impl->v; }
std::span<const float> ClothSim::masses() const { return m_impl->masses; }
double ClothSim::stable_substep() const { return m_impl->substep; }
ClothStatus ClothSim::status() const { return m_impl->status; }

double ClothSim::kinetic_energy() const {
  const Impl& m = *m_impl;
  double e = 0;
  for (std::size_t i = 0; i < m.masses.size(); ++i)
    for (int k = 0; k < 3; ++k)
      e += 0.5 * m.masses[i] * double(m.v[3 * i + k]) * m.v[3 * i + k];
  return e;
}

double ClothSim::spring_energy() const { return vfit::spring_energy(m_impl->x, m_impl->springs); }

} // namespace vfit
