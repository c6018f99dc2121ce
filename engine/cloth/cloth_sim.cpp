// SPDX-License-Identifier: Apache-2.0
// ClothSim's set-up (options and mesh validation, masses, springs, the internal numbering),
// pins, the published state and the accessors.
#include "vfit/engine/cloth/cloth_sim.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

#include "vfit/engine/cloth/cloth_sim_internal.h"
#include "vfit/kernels/cloth_ordering.h"
#include "vfit/kernels/error.h"

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

void ClothSim::Impl::update_substep() {
  if (options.integrator == ClothIntegrator::IMPLICIT_EULER) {
    substep = options.implicit_step;
    return;
  }
  const Rk4StepBound b = rk4_stable_step(adjacency, particles);
  substep = std::min(options.max_substep, options.substep_safety * b.max_step);
}

void ClothSim::Impl::masses_changed() {
#ifdef VFIT_WITH_OPENCL
  cl_rk4.reset();
#endif
  update_substep();
}

const std::vector<float>& ClothSim::Impl::published_positions() const {
  if (!out_x_current) gather_rows(x, rank, 3, out_x);
  out_x_current = true;
  return out_x;
}

const std::vector<float>& ClothSim::Impl::published_velocities() const {
  if (!out_v_current) gather_rows(v, rank, 3, out_v);
  out_v_current = true;
  return out_v;
}

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
  if (options.backend == Backend::OPENCL) {
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
  if (options.backend == Backend::OPENCL) m.cl_context = std::make_unique<OpenClContext>(options.opencl_device);
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
