#pragma once
// Private to kernels/cloth_*.cpp: the shared C-subset math (cloth_math.h) brought into C++, and
// the per-particle spring gather every CPU cloth kernel uses. Not a public header.

#include <cmath>
#include <cstddef>
#include <cstdint>

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

// Marks a cloth kernel compiled also for AVX2 and AVX-512, picked at load time by the CPU
// (GCC/Clang function multiversioning on x86-64 ELF): its spring loops are gathers and
// square roots over 8 or 16 lanes instead of 4. Neither instruction set brings FMA, so the
// arithmetic (IEEE single precision, no contraction) and the bits are those of the default
// build.
#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__)
#define VFIT_CLOTH_MULTIVERSION __attribute__((target_clones("avx512f", "avx2", "default")))
#define VFIT_CLOTH_INLINE __attribute__((always_inline)) inline // into each clone
#else
#define VFIT_CLOTH_MULTIVERSION
#define VFIT_CLOTH_INLINE inline
#endif

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

// Adjacency entries per block of gather_spring_forces(): its scratch (9 floats per entry,
// 9 KB) stays in the L1 cache.
inline constexpr std::size_t GATHER_BLOCK_ENTRIES = 256;

// The gather's scratch, structure of arrays over a block's entries.
struct GatherBlock {
  alignas(64) float d[3][GATHER_BLOCK_ENTRIES];  // x_j − x_i
  alignas(64) float dv[3][GATHER_BLOCK_ENTRIES]; // v_j − v_i
  alignas(64) float f[3][GATHER_BLOCK_ENTRIES];  // the entry's spring force on its owner
};

// Copies x_j − x_i and v_j − v_i of the entries of particles [first, last) into s, from entry e0.
VFIT_CLOTH_INLINE void gather_relative_states(const float* x, const float* v, const SpringAdjacency& adj,
                                              std::size_t first, std::size_t last, std::int32_t e0, GatherBlock& s) {
  const std::int32_t* offsets = adj.offsets.data();
  const std::int32_t* neighbors = adj.neighbors.data();
  for (std::size_t p = first; p < last; ++p) {
    const vfit_vec3 xp = load3(x, p), vp = load3(v, p);
    for (std::int32_t e = offsets[p]; e < offsets[p + 1]; ++e) {
      const auto k = static_cast<std::size_t>(e - e0);
      const auto j = static_cast<std::size_t>(neighbors[e]);
      s.d[0][k] = x[3 * j] - xp.x;
      s.d[1][k] = x[3 * j + 1] - xp.y;
      s.d[2][k] = x[3 * j + 2] - xp.z;
      s.dv[0][k] = v[3 * j] - vp.x;
      s.dv[1][k] = v[3 * j + 1] - vp.y;
      s.dv[2][k] = v[3 * j + 2] - vp.z;
    }
  }
}

// The end of the block of rows that starts at row `first` (< end) of a CSR adjacency: the
// longest run [first, last) of rows within [first, end) holding at most `cap` entries in all.
// The caller handles a first row longer than cap alone.
inline std::size_t block_end(const std::int32_t* offsets, std::size_t first, std::size_t end, std::int32_t cap) {
  std::size_t last = first + 1;
  while (last < end && offsets[last + 1] - offsets[first] <= cap)
    ++last;
  return last;
}

// Calls sink(i, f) for each particle i in [begin, end), in order, with f = gather_spring_force(x,
// v, adj, i), bit for bit. The springs of a block of consecutive particles are evaluated in one
// loop over their entries, whose relative positions and velocities are gathered into
// structure-of-arrays scratch first, so that loop vectorises (vfit_spring_force_relative has
// no branch); each particle then adds its entries' forces in adjacency order, as
// gather_spring_force does. A row longer than a block is gathered alone.
template <typename Sink>
VFIT_CLOTH_INLINE void gather_spring_forces(const float* x, const float* v, const SpringAdjacency& adj,
                                            std::size_t begin, std::size_t end, GatherBlock& s, const Sink& sink) {
  constexpr auto CAP = static_cast<std::int32_t>(GATHER_BLOCK_ENTRIES);
  const std::int32_t* offsets = adj.offsets.data();
  std::size_t i = begin;
  while (i < end) {
    const std::int32_t e0 = offsets[i];
    if (offsets[i + 1] - e0 > CAP) {
      sink(i, gather_spring_force(x, v, adj, i));
      ++i;
      continue;
    }
    const std::size_t last = block_end(offsets, i, end, CAP);
    const auto count = static_cast<std::size_t>(offsets[last] - e0);
    gather_relative_states(x, v, adj, i, last, e0, s);
    const float* rest = adj.rest_lengths.data() + e0;
    const float* stiffness = adj.stiffness.data() + e0;
    const float* damping = adj.damping.data() + e0;
    for (std::size_t k = 0; k < count; ++k) {
      const vfit_vec3 fs =
          vfit_spring_force_relative(vfit_vec3{s.d[0][k], s.d[1][k], s.d[2][k]},
                                     vfit_vec3{s.dv[0][k], s.dv[1][k], s.dv[2][k]}, rest[k], stiffness[k], damping[k]);
      s.f[0][k] = fs.x;
      s.f[1][k] = fs.y;
      s.f[2][k] = fs.z;
    }
    for (std::size_t p = i; p < last; ++p) {
      vfit_vec3 f{0.0f, 0.0f, 0.0f};
      for (std::int32_t e = offsets[p]; e < offsets[p + 1]; ++e) {
        const auto k = static_cast<std::size_t>(e - e0);
        f.x += s.f[0][k];
        f.y += s.f[1][k];
        f.z += s.f[2][k];
      }
      sink(p, f);
    }
    i = last;
  }
}
} // namespace vfit::cloth_detail
