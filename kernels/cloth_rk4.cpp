#include "cloth_rk4.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "cloth_gather.h"
#include "parallel.h"

namespace vfit {
namespace {
using namespace cloth_detail;

// The arrays one RK4 stage pass reads and writes.
struct StagePass {
  const float* xs; // stage state read by the gather (#V × 3)
  const float* vs;
  const float* x0; // step start
  const float* v0;
  float* acc_x;
  float* acc_v;
  float* next_x; // next stage state, or the result at stage 3 (may alias x0/v0: own row only)
  float* next_v;
};

// One stage pass over the slices [begin, end) of the particles: the spring gather fused with
// the stage update. Stage 0 does not read the running sums (it starts them) and stage 3 does not
// write them (it writes the step's result): 48 bytes per particle and step less to move.
VFIT_CLOTH_MULTIVERSION void stage_range(const StagePass& p, const SpringAdjacency& adj,
                                         const ClothParticles& particles, float h, int stage, std::size_t begin,
                                         std::size_t end) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t n = adj.particle_count();
  const vfit_vec3 g{particles.gravity[0], particles.gravity[1], particles.gravity[2]};
  const float* inv_mass = particles.inverse_masses.data();
  const vfit_vec3 zero{0.0f, 0.0f, 0.0f};
  SliceForces forces;
  for (std::size_t slice = begin; slice < end; ++slice) {
    slice_spring_forces(p.xs, p.vs, adj, slice, forces);
    for (std::size_t l = 0, i = W * slice; l < W && i < n; ++l, ++i) {
      const vfit_vec3 vs = load3(p.vs, i);
      const vfit_vec3 a = vfit_particle_acceleration(vfit_vec3{forces.f[0][l], forces.f[1][l], forces.f[2][l]}, vs,
                                                     inv_mass[i], g, particles.global_damping);
      vfit_vec3 acc_x = stage == 0 ? zero : load3(p.acc_x, i), acc_v = stage == 0 ? zero : load3(p.acc_v, i), nx, nv;
      // Pinned particles move with their given velocity in no stage: hold them at x0.
      const vfit_vec3 slope_x = inv_mass[i] == 0.0f ? zero : vs;
      vfit_rk4_stage_update(load3(p.x0, i), load3(p.v0, i), slope_x, a, h, stage, &acc_x, &acc_v, &nx, &nv);
      if (stage != 3) {
        store3(p.acc_x, i, acc_x);
        store3(p.acc_v, i, acc_v);
      }
      store3(p.next_x, i, nx);
      store3(p.next_v, i, nv);
    }
  }
}

// Runs the four stage passes; `run(kernel)` runs kernel(begin, end) over all slices.
template <typename Driver>
void rk4_step(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
              const ClothParticles& particles, float h, Rk4Workspace& w, const Driver& run) {
  const std::size_t n = positions.size();
  assert(n == 3 * adjacency.particle_count() && velocities.size() == n && "state and adjacency sizes differ");
  assert(particles.inverse_masses.size() == adjacency.particle_count() && "one inverse mass per particle");
  for (auto* buf : {&w.acc_x, &w.acc_v, &w.stage_x[0], &w.stage_x[1], &w.stage_v[0], &w.stage_v[1]})
    buf->resize(n);
  float* x = positions.data();
  float* v = velocities.data();
  const float* read_x = x;
  const float* read_v = v;
  for (int stage = 0; stage < 4; ++stage) {
    const bool last = stage == 3;
    float* write_x = last ? x : w.stage_x[stage % 2].data();
    float* write_v = last ? v : w.stage_v[stage % 2].data();
    const StagePass pass{read_x, read_v, x, v, w.acc_x.data(), w.acc_v.data(), write_x, write_v};
    run([&](std::size_t b, std::size_t e) { stage_range(pass, adjacency, particles, h, stage, b, e); });
    read_x = write_x;
    read_v = write_v;
  }
}
} // namespace

void cloth_accelerations_serial(std::span<const float> positions, std::span<const float> velocities,
                                const SpringAdjacency& adjacency, const ClothParticles& particles,
                                std::vector<float>& accelerations) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && "adjacency built for another particle count");
  accelerations.resize(3 * nv);
  const vfit_vec3 g{particles.gravity[0], particles.gravity[1], particles.gravity[2]};
  for (std::size_t i = 0; i < nv; ++i)
    store3(accelerations.data(), i,
           vfit_particle_acceleration(gather_spring_force(positions.data(), velocities.data(), adjacency, i),
                                      load3(velocities.data(), i), particles.inverse_masses[i], g,
                                      particles.global_damping));
}

void rk4_step_serial(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                     const ClothParticles& particles, float h, Rk4Workspace& workspace) {
  const std::size_t slices = adjacency.slice_count();
  rk4_step(positions, velocities, adjacency, particles, h, workspace,
           [slices](const auto& kernel) { kernel(std::size_t{0}, slices); });
}

void rk4_step_tbb(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                  const ClothParticles& particles, float h, Rk4Workspace& workspace) {
  const std::size_t slices = adjacency.slice_count();
  rk4_step(positions, velocities, adjacency, particles, h, workspace, [slices](const auto& kernel) {
    parallel_for_range(slices, CLOTH_PARTICLE_GRAIN / CLOTH_SLICE_WIDTH, kernel);
  });
}

Rk4StepBound rk4_stable_step(const SpringAdjacency& adjacency, const ClothParticles& particles) {
  Rk4StepBound b;
  const std::vector<float>& inv = particles.inverse_masses;
  double omega2_max = 0;
  for (std::size_t i = 0; i < adjacency.particle_count(); ++i) {
    if (inv[i] == 0.0f) continue; // pinned: not a degree of freedom
    double omega2 = 0, gamma = particles.global_damping;
    for (std::int32_t e = adjacency.offsets[i]; e < adjacency.offsets[i + 1]; ++e) {
      const double weight = double(inv[i]) + std::sqrt(double(inv[i]) * inv[adjacency.neighbors[e]]);
      omega2 += adjacency.stiffness[e] * weight;
      gamma += adjacency.damping[e] * weight;
    }
    omega2_max = std::max(omega2_max, omega2);
    b.gamma_max = std::max(b.gamma_max, gamma);
  }
  b.omega_max = std::sqrt(omega2_max);
  const double rate = b.omega_max + b.gamma_max;
  b.max_step = rate > 0 ? RK4_STABILITY_RADIUS / rate : std::numeric_limits<double>::infinity();
  return b;
}

} // namespace vfit
