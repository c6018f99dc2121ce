// SPDX-License-Identifier: Apache-2.0
#include "cloth_ordering.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <limits>
#include <numeric>

namespace vfit {
namespace {

// The particle graph of the springs (each spring both ways) in compressed rows, each row in
// ascending neighbour order.
struct Graph {
  std::vector<std::int32_t> offsets, neighbors;
  std::int32_t degree(std::int32_t i) const { return offsets[std::size_t(i) + 1] - offsets[std::size_t(i)]; }
};

Graph spring_graph(const ClothSprings& springs, std::size_t n) {
  Graph g;
  g.offsets.assign(n + 1, 0);
  for (std::int32_t p : springs.ends) {
    assert(p >= 0 && static_cast<std::size_t>(p) < n && "spring end out of range");
    ++g.offsets[static_cast<std::size_t>(p) + 1];
  }
  for (std::size_t i = 0; i < n; ++i)
    g.offsets[i + 1] += g.offsets[i];
  g.neighbors.resize(springs.ends.size());
  std::vector<std::int32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t a = springs.ends[2 * s], b = springs.ends[2 * s + 1];
    g.neighbors[static_cast<std::size_t>(fill[static_cast<std::size_t>(a)]++)] = b;
    g.neighbors[static_cast<std::size_t>(fill[static_cast<std::size_t>(b)]++)] = a;
  }
  for (std::size_t i = 0; i < n; ++i)
    std::sort(g.neighbors.begin() + g.offsets[i], g.neighbors.begin() + g.offsets[i + 1]);
  return g;
}

// Breadth-first levels from `root` over its component, written to `visit` from `head` on in
// Cuthill–McKee order (each vertex's unvisited neighbours by ascending degree, then index);
// marks them in `level` (−1: unvisited) and returns one past the last. The vertices of the
// last level are visit[last_level_begin, returned).
std::size_t cuthill_mckee(const Graph& g, std::int32_t root, std::vector<std::int32_t>& level,
                          std::vector<std::int32_t>& visit, std::size_t head, std::size_t& last_level_begin) {
  std::size_t tail = head;
  visit[tail++] = root;
  level[static_cast<std::size_t>(root)] = 0;
  last_level_begin = head;
  for (std::size_t q = head; q < tail; ++q) {
    const std::int32_t u = visit[q];
    const std::int32_t lu = level[static_cast<std::size_t>(u)];
    if (lu != level[static_cast<std::size_t>(visit[last_level_begin])]) last_level_begin = q;
    const std::size_t fresh = tail;
    for (std::int32_t e = g.offsets[static_cast<std::size_t>(u)]; e < g.offsets[static_cast<std::size_t>(u) + 1]; ++e) {
      const std::int32_t w = g.neighbors[static_cast<std::size_t>(e)];
      if (level[static_cast<std::size_t>(w)] >= 0) continue;
      level[static_cast<std::size_t>(w)] = lu + 1;
      visit[tail++] = w;
    }
    std::stable_sort(visit.begin() + std::ptrdiff_t(fresh), visit.begin() + std::ptrdiff_t(tail),
                     [&](std::int32_t a, std::int32_t b) { return g.degree(a) < g.degree(b); });
  }
  return tail;
}

} // namespace

double consecutive_column_fraction(const SpringAdjacency& adjacency) {
  std::size_t columns = 0, consecutive = 0;
  for (std::size_t s = 0; s < adjacency.slice_count(); ++s) {
    columns += std::size_t(adjacency.slice_offsets[s + 1] - adjacency.slice_offsets[s]) / CLOTH_SLICE_WIDTH;
    consecutive += std::size_t(std::popcount(adjacency.slice_consecutive_columns[s]));
  }
  return columns == 0 ? 0.0 : double(consecutive) / double(columns);
}

std::vector<std::int32_t> cloth_particle_order(std::size_t particle_count, const ClothSprings& springs) {
  const std::size_t n = particle_count;
  assert(n <= std::size_t(std::numeric_limits<std::int32_t>::max()) && "particle indices are 32-bit");
  std::vector<std::int32_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  if (consecutive_column_fraction(build_spring_adjacency(springs, n)) >= CLOTH_KEEP_NUMBERING_CONSECUTIVE) return order;
  // Each component (by its lowest vertex) from a pseudo-peripheral vertex (George and Liu): start
  // at the component's lowest vertex, restart from a vertex of least degree in the last level
  // while that makes the levels deeper (at most 8 times), then number in Cuthill–McKee order.
  const Graph g = spring_graph(springs, n);
  std::vector<std::int32_t> level(n, -1), scratch(n);
  std::size_t head = 0;
  for (std::size_t first = 0; first < n; ++first) {
    if (level[first] >= 0) continue;
    auto root = static_cast<std::int32_t>(first);
    std::int32_t depth = -1;
    for (int attempt = 0; attempt < 8; ++attempt) {
      std::size_t last_level = 0;
      const std::size_t tail = cuthill_mckee(g, root, level, scratch, head, last_level);
      const std::int32_t reached = level[static_cast<std::size_t>(scratch[tail - 1])];
      std::int32_t best = scratch[last_level];
      for (std::size_t q = last_level; q < tail; ++q)
        if (g.degree(scratch[q]) < g.degree(best)) best = scratch[q];
      for (std::size_t q = head; q < tail; ++q)
        level[static_cast<std::size_t>(scratch[q])] = -1;
      if (reached <= depth) break;
      depth = reached;
      root = best;
    }
    std::size_t last_level = 0;
    head = cuthill_mckee(g, root, level, order, head, last_level);
  }
  std::vector<std::int32_t> row_length(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    row_length[i] = g.degree(static_cast<std::int32_t>(i));
  for (std::size_t w = 0; w < n; w += CLOTH_ORDER_WINDOW) {
    const auto first = order.begin() + std::ptrdiff_t(w);
    const auto last = order.begin() + std::ptrdiff_t(std::min(n, w + CLOTH_ORDER_WINDOW));
    std::stable_sort(first, last, [&](std::int32_t a, std::int32_t b) {
      return row_length[static_cast<std::size_t>(a)] < row_length[static_cast<std::size_t>(b)];
    });
  }
  return order;
}

std::vector<std::int32_t> inverse_permutation(std::span<const std::int32_t> order) {
  std::vector<std::int32_t> rank(order.size(), -1);
  for (std::size_t k = 0; k < order.size(); ++k) {
    assert(order[k] >= 0 && static_cast<std::size_t>(order[k]) < order.size() && rank[order[k]] < 0 &&
           "not a permutation");
    rank[static_cast<std::size_t>(order[k])] = static_cast<std::int32_t>(k);
  }
  return rank;
}

ClothSprings renumber_cloth_springs(const ClothSprings& springs, std::span<const std::int32_t> rank) {
  ClothSprings out = springs;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t a = rank[static_cast<std::size_t>(springs.ends[2 * s])];
    const std::int32_t b = rank[static_cast<std::size_t>(springs.ends[2 * s + 1])];
    out.ends[2 * s] = std::min(a, b);
    out.ends[2 * s + 1] = std::max(a, b);
  }
  return out;
}

void gather_rows(std::span<const float> in, std::span<const std::int32_t> order, std::size_t width,
                 std::vector<float>& out) {
  out.resize(width * order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t from = width * static_cast<std::size_t>(order[k]);
    assert(from + width <= in.size() && "row out of range");
    std::copy_n(in.begin() + std::ptrdiff_t(from), width, out.begin() + std::ptrdiff_t(width * k));
  }
}

} // namespace vfit
