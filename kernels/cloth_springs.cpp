// SPDX-License-Identifier: Apache-2.0
#include "cloth_springs.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include "cloth_gather.h"
#include "parallel.h"

namespace vfit {
namespace {
using namespace cloth_detail;

std::uint64_t edge_key(std::int32_t a, std::int32_t b) {
  const auto lo = static_cast<std::uint32_t>(std::min(a, b)), hi = static_cast<std::uint32_t>(std::max(a, b));
  return (std::uint64_t{lo} << 32) | hi;
}

double distance(std::span<const float> p, std::int32_t a, std::int32_t b) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double d = double(p[3 * std::size_t(b) + k]) - p[3 * std::size_t(a) + k];
    s += d * d;
  }
  return std::sqrt(s);
}

void add_spring(ClothSprings& s, std::span<const float> positions, std::int32_t a, std::int32_t b, SpringKind kind) {
  s.ends.push_back(std::min(a, b));
  s.ends.push_back(std::max(a, b));
  s.rest_lengths.push_back(static_cast<float>(distance(positions, a, b)));
  s.kinds.push_back(kind);
}

// Per-particle gather over the slices [begin, end).
template <bool ROW_LOADS>
VFIT_CLOTH_INLINE void gather_slices(const float* x, const float* v, const SpringAdjacency& adj, float* out,
                                     std::size_t begin, std::size_t end) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t n = adj.particle_count();
  SliceForces f;
  for (std::size_t slice = begin; slice < end; ++slice) {
    slice_spring_forces<ROW_LOADS>(x, v, adj, slice, f);
    for (std::size_t l = 0, i = W * slice; l < W && i < n; ++l, ++i)
      store3(out, i, vfit_vec3{f.f[0][l], f.f[1][l], f.f[2][l]});
  }
}

VFIT_CLOTH_MULTIVERSION void gather_range_lanes(const float* x, const float* v, const SpringAdjacency& adj, float* out,
                                                std::size_t begin, std::size_t end) {
  gather_slices<false>(x, v, adj, out, begin, end);
}

#if VFIT_CLOTH_AVX512
VFIT_CLOTH_AVX512_TARGET void gather_range_rows(const float* x, const float* v, const SpringAdjacency& adj, float* out,
                                                std::size_t begin, std::size_t end) {
  gather_slices<true>(x, v, adj, out, begin, end);
}
#endif

// The serial range kernel of the force drivers: the RK4 pass's gather (cloth_rk4.cpp picks its
// variant the same way), so the force tests against the scatter check the RK4 pass's loads.
void gather_range(const float* x, const float* v, const SpringAdjacency& adj, float* out, std::size_t begin,
                  std::size_t end) {
#if VFIT_CLOTH_AVX512
  if (avx512_available()) {
    gather_range_rows(x, v, adj, out, begin, end);
    return;
  }
#endif
  gather_range_lanes(x, v, adj, out, begin, end);
}

// Fills adj's sliced rows from its CSR rows (see SpringAdjacency::slice_offsets).
void build_slices(SpringAdjacency& adj) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t n = adj.particle_count(), slices = (n + W - 1) / W;
  assert(n < std::size_t{0x7fffffff} / 3 && "3·j must fit a 32-bit index");
  adj.slice_offsets.assign(slices + 1, 0);
  for (std::size_t s = 0; s < slices; ++s) {
    std::int32_t width = 0;
    for (std::size_t i = W * s; i < std::min(n, W * s + W); ++i)
      width = std::max(width, adj.offsets[i + 1] - adj.offsets[i]);
    adj.slice_offsets[s + 1] = adj.slice_offsets[s] + static_cast<std::int32_t>(W) * width;
  }
  const auto slots = static_cast<std::size_t>(adj.slice_offsets[slices]);
  adj.slice_neighbor_offsets.assign(slots, 0);
  adj.slice_rest_lengths.assign(slots, 0.0f);
  adj.slice_stiffness.assign(slots, 0.0f);
  adj.slice_damping.assign(slots, 0.0f);
  for (std::size_t s = 0; s < slices; ++s)
    for (std::size_t l = 0; l < W; ++l) {
      const std::size_t i = std::min(W * s + l, n - 1);
      const bool real = W * s + l < n;
      const auto width = static_cast<std::size_t>(adj.slice_offsets[s + 1] - adj.slice_offsets[s]) / W;
      for (std::size_t k = 0; k < width; ++k) {
        const std::size_t slot = static_cast<std::size_t>(adj.slice_offsets[s]) + W * k + l;
        const auto e = static_cast<std::size_t>(adj.offsets[i]) + k;
        if (real && e < static_cast<std::size_t>(adj.offsets[i + 1])) {
          adj.slice_neighbor_offsets[slot] = 3 * adj.neighbors[e];
          adj.slice_rest_lengths[slot] = adj.rest_lengths[e];
          adj.slice_stiffness[slot] = adj.stiffness[e];
          adj.slice_damping[slot] = adj.damping[e];
        } else {
          adj.slice_neighbor_offsets[slot] = 3 * static_cast<std::int32_t>(i);
        }
      }
    }
  adj.slice_consecutive_columns.assign(slices, 0u);
  for (std::size_t s = 0; s < slices; ++s) {
    const auto first = static_cast<std::size_t>(adj.slice_offsets[s]);
    const auto end = static_cast<std::size_t>(adj.slice_offsets[s + 1]);
    const std::size_t width = std::min<std::size_t>(32, (end - first) / W);
    for (std::size_t k = 0; k < width; ++k) {
      const std::int32_t* column = adj.slice_neighbor_offsets.data() + first + W * k;
      bool consecutive = true;
      for (std::size_t l = 1; l < W; ++l)
        consecutive = consecutive && column[l] == column[0] + 3 * static_cast<std::int32_t>(l);
      if (consecutive) adj.slice_consecutive_columns[s] |= std::uint32_t{1} << k;
    }
  }
  adj.slice_neighbor_first.resize(slices);
  adj.slice_neighbor_last.resize(slices);
  for (std::size_t s = 0; s < slices; ++s) {
    auto first = static_cast<std::int32_t>(s), last = first;
    for (auto slot = static_cast<std::size_t>(adj.slice_offsets[s]);
         slot < static_cast<std::size_t>(adj.slice_offsets[s + 1]); ++slot) {
      const std::int32_t neighbor_slice = adj.slice_neighbor_offsets[slot] / 3 / static_cast<std::int32_t>(W);
      first = std::min(first, neighbor_slice);
      last = std::max(last, neighbor_slice);
    }
    adj.slice_neighbor_first[s] = first;
    adj.slice_neighbor_last[s] = last;
  }
}
} // namespace

ClothSprings build_cloth_springs(std::span<const float> positions, std::span<const std::int32_t> triangles,
                                 const SpringTopologyOptions& options) {
  const std::size_t nf = triangles.size() / 3;
  ClothSprings s;
  // Edge → (first triangle's opposite vertex, second one's, count of triangles).
  struct EdgeUse {
    std::int32_t opposite[2] = {-1, -1};
    int count = 0;
  };
  std::unordered_map<std::uint64_t, std::size_t> edge_index;
  std::vector<EdgeUse> uses;
  edge_index.reserve(3 * nf / 2 + 1);
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = triangles[3 * f + k], b = triangles[3 * f + (k + 1) % 3],
                         c = triangles[3 * f + (k + 2) % 3];
      assert(a >= 0 && b >= 0 && c >= 0 && "triangle index out of range");
      if (a == b) continue;
      auto [it, fresh] = edge_index.try_emplace(edge_key(a, b), uses.size());
      if (fresh) {
        uses.emplace_back();
        add_spring(s, positions, a, b, SpringKind::STRUCTURAL);
      }
      EdgeUse& u = uses[it->second];
      if (u.count < 2) u.opposite[u.count] = c;
      ++u.count;
    }
  if (options.bending) {
    std::unordered_set<std::uint64_t> bent;
    for (const EdgeUse& u : uses) {
      if (u.count != 2) continue; // boundary or non-manifold edge: no well-defined fold
      const std::int32_t c = u.opposite[0], d = u.opposite[1];
      if (c == d || edge_index.count(edge_key(c, d)) || !bent.insert(edge_key(c, d)).second) continue;
      add_spring(s, positions, c, d, SpringKind::BENDING);
    }
  }
  s.stiffness.assign(s.size(), 0.0f);
  s.damping.assign(s.size(), 0.0f);
  return s;
}

SpringAdjacency build_spring_adjacency(const ClothSprings& springs, std::size_t particle_count) {
  SpringAdjacency adj;
  const std::size_t ns = springs.size();
  adj.offsets.assign(particle_count + 1, 0);
  for (std::int32_t p : springs.ends) {
    assert(p >= 0 && static_cast<std::size_t>(p) < particle_count && "spring end out of range");
    ++adj.offsets[static_cast<std::size_t>(p) + 1];
  }
  for (std::size_t i = 0; i < particle_count; ++i)
    adj.offsets[i + 1] += adj.offsets[i];
  adj.neighbors.resize(2 * ns);
  adj.springs.resize(2 * ns);
  adj.rest_lengths.resize(2 * ns);
  adj.stiffness.resize(2 * ns);
  adj.damping.resize(2 * ns);
  std::vector<std::int32_t> cursor(adj.offsets.begin(), adj.offsets.end() - 1);
  // Counting sort in spring order keeps each particle's rows ascending in spring index.
  for (std::size_t s = 0; s < ns; ++s)
    for (int end = 0; end < 2; ++end) {
      const std::int32_t i = springs.ends[2 * s + end], j = springs.ends[2 * s + 1 - end];
      const std::int32_t e = cursor[static_cast<std::size_t>(i)]++;
      adj.neighbors[e] = j;
      adj.springs[e] = static_cast<std::int32_t>(s);
      adj.rest_lengths[e] = springs.rest_lengths[s];
      adj.stiffness[e] = springs.stiffness[s];
      adj.damping[e] = springs.damping[s];
    }
  build_slices(adj);
  return adj;
}

void spring_forces_scatter(std::span<const float> positions, std::span<const float> velocities,
                           const ClothSprings& springs, std::vector<float>& forces) {
  forces.assign(positions.size(), 0.0f);
  const float* x = positions.data();
  const float* v = velocities.data();
  float* f = forces.data();
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const auto i = static_cast<std::size_t>(springs.ends[2 * s]), j = static_cast<std::size_t>(springs.ends[2 * s + 1]);
    const float L = springs.rest_lengths[s], k = springs.stiffness[s], c = springs.damping[s];
    // Each end evaluates the shared formula from its own side, as the gather does.
    const vfit_vec3 fi = vfit_spring_force(load3(x, i), load3(x, j), load3(v, i), load3(v, j), L, k, c);
    const vfit_vec3 fj = vfit_spring_force(load3(x, j), load3(x, i), load3(v, j), load3(v, i), L, k, c);
    f[3 * i] += fi.x;
    f[3 * i + 1] += fi.y;
    f[3 * i + 2] += fi.z;
    f[3 * j] += fj.x;
    f[3 * j + 1] += fj.y;
    f[3 * j + 2] += fj.z;
  }
}

void spring_forces_serial(std::span<const float> positions, std::span<const float> velocities,
                          const SpringAdjacency& adjacency, std::vector<float>& forces) {
  assert(positions.size() == 3 * adjacency.particle_count() && "adjacency built for another particle count");
  forces.resize(positions.size());
  gather_range(positions.data(), velocities.data(), adjacency, forces.data(), 0, adjacency.slice_count());
}

void spring_forces_tbb(std::span<const float> positions, std::span<const float> velocities,
                       const SpringAdjacency& adjacency, std::vector<float>& forces) {
  assert(positions.size() == 3 * adjacency.particle_count() && "adjacency built for another particle count");
  forces.resize(positions.size());
  const float* x = positions.data();
  const float* v = velocities.data();
  float* out = forces.data();
  parallel_for_range(adjacency.slice_count(), CLOTH_PARTICLE_GRAIN / CLOTH_SLICE_WIDTH,
                     [&](std::size_t b, std::size_t e) { gather_range(x, v, adjacency, out, b, e); });
}

double spring_energy(std::span<const float> positions, const ClothSprings& springs) {
  double e = 0;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const double stretch = distance(positions, springs.ends[2 * s], springs.ends[2 * s + 1]) - springs.rest_lengths[s];
    e += 0.5 * springs.stiffness[s] * stretch * stretch;
  }
  return e;
}

namespace {
// max_spring_stretch() over the springs [begin, end), from `worst`.
double max_stretch_range(std::span<const float> positions, const ClothSprings& springs, float min_rest_length,
                         std::size_t begin, std::size_t end, double worst) {
  for (std::size_t s = begin; s < end; ++s) {
    const double L = std::max(springs.rest_lengths[s], min_rest_length);
    if (!(L > 0.0)) continue;
    const double l = distance(positions, springs.ends[2 * s], springs.ends[2 * s + 1]);
    // A NaN length must read as runaway, not be skipped by the comparison.
    if (!(l <= worst * L)) worst = std::isnan(l) ? std::numeric_limits<double>::infinity() : l / L;
  }
  return worst;
}
} // namespace

double max_spring_stretch(std::span<const float> positions, const ClothSprings& springs, float min_rest_length,
                          bool parallel) {
  if (springs.size() == 0) return 0.0;
  if (!parallel || springs.size() <= SPRING_STRETCH_GRAIN)
    return max_stretch_range(positions, springs, min_rest_length, 0, springs.size(), 1.0);
  // A maximum per fixed block of springs, then theirs: the same value as the serial scan (a
  // maximum does not depend on the order; a NaN anywhere reads as +∞ in its block).
  const std::size_t blocks = (springs.size() + SPRING_STRETCH_GRAIN - 1) / SPRING_STRETCH_GRAIN;
  std::vector<double> worst(blocks, 1.0);
  parallel_for_range(blocks, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b)
      worst[b] = max_stretch_range(positions, springs, min_rest_length, b * SPRING_STRETCH_GRAIN,
                                   std::min(springs.size(), (b + 1) * SPRING_STRETCH_GRAIN), 1.0);
  });
  return *std::max_element(worst.begin(), worst.end());
}

} // namespace vfit
