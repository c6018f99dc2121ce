#pragma once
/// \file
/// A generic cloth state for the implicit solver's tests (kernels/cloth_implicit*): a jittered
/// n × n grid (side 1 m, numbered row by row) with random spring constants (k 100–500 N/m,
/// damping 0–0.05), positions jittered by up to 0.2 of a cell so that some springs are
/// stretched and some compressed, random velocities (±0.5 m/s), particles of `mass` kg, two
/// pinned corners (0 and n − 1) and a global damping of 0.5. The same seed gives the same cloth.

#include <cstddef>
#include <random>
#include <vector>

#include "geometry/mesh/primitives.h"
#include "kernels/cloth_gather.h"
#include "kernels/cloth_springs.h"

namespace vfit {

/// The state jittered_cloth() builds.
struct JitteredCloth {
  std::vector<float> x, v;     ///< #V × 3 positions (m) and velocities (m/s)
  SpringAdjacency adjacency;   ///< the grid's springs as per-particle rows
  ClothParticles particles;    ///< inverse masses (0 for the two pinned corners), damping
};

/// See the file comment; n ≥ 2.
inline JitteredCloth jittered_cloth(int n, unsigned seed, float mass) {
  const Mesh m = make_grid(n, n, 1.0f, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.2f / float(n), 0.2f / float(n)), kd(100.0f, 500.0f), cd(0.0f, 0.05f),
      vel(-0.5f, 0.5f);
  ClothSprings s = build_cloth_springs(m.position_view(), m.triangle_view());
  for (std::size_t i = 0; i < s.size(); ++i) {
    s.stiffness[i] = kd(rng);
    s.damping[i] = cd(rng);
  }
  JitteredCloth c;
  c.adjacency = build_spring_adjacency(s, m.vertex_count());
  c.x = m.positions;
  for (float& p : c.x)
    p += jitter(rng); // some springs stretched, some compressed
  c.v.resize(c.x.size());
  for (float& q : c.v)
    q = vel(rng);
  c.particles.inverse_masses.assign(m.vertex_count(), 1.0f / mass);
  c.particles.inverse_masses[0] = c.particles.inverse_masses[std::size_t(n - 1)] = 0.0f;
  c.particles.global_damping = 0.5f;
  return c;
}

} // namespace vfit
