#pragma once
// Private to kernels/cloth_*.cpp: the shared C-subset math (cloth_math.h) brought into C++, and
// the per-particle spring gather every CPU cloth kernel uses. Not a public header.

#include <cmath>
#include <cstddef>

#include "cloth_springs.h"

namespace vfit::cloth_detail {
using std::sqrt; // cloth_math.h calls sqrt(float) as OpenCL C does.
#include "cloth_math.h"

inline vfit_vec3 load3(const float* p, std::size_t i) { return vfit_vec3{p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }

inline void store3(float* p, std::size_t i, vfit_vec3 v) {
  p[3 * i] = v.x;
  p[3 * i + 1] = v.y;
  p[3 * i + 2] = v.z;
}

// Σ of the spring forces on particle i (N) at the state (x, v), in adjacency order.
inline vfit_vec3 gather_spring_force(const float* x, const float* v, const SpringAdjacency& adj, std::size_t i) {
  const vfit_vec3 xi = load3(x, i), vi = load3(v, i);
  vfit_vec3 f{0.0f, 0.0f, 0.0f};
  for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
    const auto j = static_cast<std::size_t>(adj.neighbors[e]);
    const vfit_vec3 fs =
        vfit_spring_force(xi, load3(x, j), vi, load3(v, j), adj.rest_lengths[e], adj.stiffness[e], adj.damping[e]);
    f.x += fs.x;
    f.y += fs.y;
    f.z += fs.z;
  }
  return f;
}
} // namespace vfit::cloth_detail
