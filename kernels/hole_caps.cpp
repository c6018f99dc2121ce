// SPDX-License-Identifier: Apache-2.0
#include "hole_caps.h"

#include <algorithm>
#include <cassert>

namespace vfit {

HoleCaps build_hole_caps(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  assert(triangles.size() % 3 == 0 && "triangles must be #F × 3");
  struct HalfEdge {
    std::int32_t lo, hi, from, to;
  };
  const std::size_t face_count = triangles.size() / 3;
  std::vector<HalfEdge> half(3 * face_count);
  for (std::size_t f = 0; f < face_count; ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::int32_t a = triangles[3 * f + k], b = triangles[3 * f + (k + 1) % 3];
      half[3 * f + k] = HalfEdge{std::min(a, b), std::max(a, b), a, b};
    }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.lo != y.lo ? x.lo < y.lo : x.hi != y.hi ? x.hi < y.hi : x.from < y.from;
  });
  // Boundary: an undirected edge met exactly once. A degenerate edge (a = a) is never one.
  std::vector<HalfEdge> boundary;
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i + 1;
    while (j < half.size() && half[j].lo == half[i].lo && half[j].hi == half[i].hi)
      ++j;
    if (j == i + 1 && half[i].lo != half[i].hi) boundary.push_back(half[i]);
    i = j;
  }
  HoleCaps caps;
  caps.loop_offsets.push_back(0);
  if (boundary.empty()) return caps;
  // Outgoing boundary half-edges by start vertex, for chaining a→b then b→c.
  std::sort(boundary.begin(), boundary.end(),
            [](const HalfEdge& x, const HalfEdge& y) { return x.from != y.from ? x.from < y.from : x.to < y.to; });
  std::vector<char> used(boundary.size(), 0);
  auto next_from = [&](std::int32_t v) -> std::size_t {
    auto it = std::lower_bound(boundary.begin(), boundary.end(), v,
                               [](const HalfEdge& h, std::int32_t x) { return h.from < x; });
    for (; it != boundary.end() && it->from == v; ++it) {
      const auto i = static_cast<std::size_t>(it - boundary.begin());
      if (!used[i]) return i;
    }
    return boundary.size();
  };
  for (std::size_t seed = 0; seed < boundary.size(); ++seed) {
    if (used[seed]) continue;
    const auto centroid = static_cast<std::int32_t>(vertex_count + caps.loop_count());
    const std::int32_t start = boundary[seed].from;
    // Walk until the loop returns to its start or (on a malformed boundary) cannot continue;
    // the fan closes the chain either way.
    for (std::size_t i = seed; i < boundary.size();) {
      used[i] = 1;
      const HalfEdge& h = boundary[i];
      caps.loop_vertices.push_back(h.from);
      caps.triangles.insert(caps.triangles.end(), {h.to, h.from, centroid});
      if (h.to == start) break;
      i = next_from(h.to);
    }
    caps.loop_offsets.push_back(static_cast<std::int32_t>(caps.loop_vertices.size()));
  }
  return caps;
}

void capped_positions(std::span<const float> positions, const HoleCaps& caps, std::vector<float>& capped) {
  const std::size_t vertex_count = positions.size() / 3, loops = caps.loop_count();
  capped.resize(3 * (vertex_count + loops));
  std::copy(positions.begin(), positions.end(), capped.begin());
  for (std::size_t l = 0; l < loops; ++l) {
    double sum[3] = {0.0, 0.0, 0.0};
    const auto begin = static_cast<std::size_t>(caps.loop_offsets[l]),
               end = static_cast<std::size_t>(caps.loop_offsets[l + 1]);
    for (std::size_t i = begin; i < end; ++i)
      for (std::size_t k = 0; k < 3; ++k)
        sum[k] += positions[3 * static_cast<std::size_t>(caps.loop_vertices[i]) + k];
    for (std::size_t k = 0; k < 3; ++k)
      capped[3 * (vertex_count + l) + k] = static_cast<float>(sum[k] / static_cast<double>(end - begin));
  }
}

} // namespace vfit
