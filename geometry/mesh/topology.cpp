// SPDX-License-Identifier: Apache-2.0
#include "topology.h"

#include <algorithm>
#include <cassert>
#include <numeric>
#include <vector>

#include <tbb/parallel_sort.h>

namespace vfit {
namespace {

class DisjointSets {
public:
  explicit DisjointSets(std::size_t n) : m_parent(n) { std::iota(m_parent.begin(), m_parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (m_parent[x] != x) {
      m_parent[x] = m_parent[m_parent[x]]; // path halving
      x = m_parent[x];
    }
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) m_parent[std::max(a, b)] = std::min(a, b);
  }

private:
  std::vector<std::uint32_t> m_parent;
};

// One directed half-edge: undirected key (min, max), whether it runs min→max, its face corner.
struct HalfEdge {
  std::uint64_t key;
  std::uint32_t corner; // 3·face + k: the edge from corner k to corner (k+1) mod 3
  bool operator<(const HalfEdge& o) const { return key < o.key || (key == o.key && corner < o.corner); }
};

} // namespace

TopologyReport analyse_topology(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  TopologyReport r;
  const std::size_t nf = triangles.size() / 3;
  r.vertices = vertex_count;
  r.faces = nf;

  std::vector<char> referenced(vertex_count, 0);
  for (std::int32_t v : triangles)
    referenced[v] = 1;
  const std::size_t nref = static_cast<std::size_t>(std::count(referenced.begin(), referenced.end(), 1));
  r.unreferenced_vertices = vertex_count - nref;

  std::vector<HalfEdge> half(3 * nf);
  for (std::size_t c = 0; c < 3 * nf; ++c) {
    const std::uint32_t a = static_cast<std::uint32_t>(triangles[c]);
    const std::uint32_t b = static_cast<std::uint32_t>(triangles[c % 3 == 2 ? c - 2 : c + 1]);
    half[c] = {(std::uint64_t{std::min(a, b)} << 32) | std::max(a, b), static_cast<std::uint32_t>(c)};
  }
  tbb::parallel_sort(half.begin(), half.end());

  auto from = [&](std::uint32_t c) { return static_cast<std::uint32_t>(triangles[c]); };
  auto to = [&](std::uint32_t c) { return static_cast<std::uint32_t>(triangles[c % 3 == 2 ? c - 2 : c + 1]); };

  DisjointSets vertex_sets(vertex_count);
  DisjointSets corner_sets(3 * nf);    // corners joined across manifold edges: fans around vertices
  std::vector<std::uint32_t> boundary; // corners whose outgoing edge is a boundary edge
  for (std::size_t i = 0; i < half.size();) {
    std::size_t j = i;
    while (j < half.size() && half[j].key == half[i].key)
      ++j;
    const std::size_t count = j - i;
    ++r.edges;
    vertex_sets.unite(from(half[i].corner), to(half[i].corner));
    if (count == 1) {
      ++r.boundary_edges;
      boundary.push_back(half[i].corner);
    } else if (count == 2) {
      const std::uint32_t c1 = half[i].corner, c2 = half[i + 1].corner;
      if (from(c1) == from(c2)) ++r.inconsistent_edges;
      // Join the two faces' corners at each end of the shared edge.
      auto corner_at = [&](std::uint32_t c, std::uint32_t v) {
        return from(c) == v ? c : (c % 3 == 2 ? c - 2 : c + 1);
      };
      for (std::uint32_t v : {from(c1), to(c1)})
        corner_sets.unite(corner_at(c1, v), corner_at(c2, v));
    } else {
      ++r.non_manifold_edges;
    }
    i = j;
  }

  // A vertex whose corners fall into more than one fan is non-manifold.
  std::vector<std::uint32_t> fan_root(vertex_count, UINT32_MAX);
  std::vector<char> flagged(vertex_count, 0);
  for (std::uint32_t c = 0; c < 3 * nf; ++c) {
    const std::uint32_t v = from(c), root = corner_sets.find(c);
    if (fan_root[v] == UINT32_MAX)
      fan_root[v] = root;
    else if (fan_root[v] != root && !flagged[v]) {
      flagged[v] = 1;
      ++r.non_manifold_vertices;
    }
  }

  for (std::size_t v = 0; v < vertex_count; ++v)
    if (referenced[v] && vertex_sets.find(static_cast<std::uint32_t>(v)) == v) ++r.components;

  // Chain boundary edges into loops. The walk ignores edge direction, so a garment whose
  // faces are not consistently oriented (common in real assets) still gets one loop per opening.
  std::vector<std::uint32_t> incident_offset(vertex_count + 1, 0);
  for (std::uint32_t c : boundary) {
    ++incident_offset[from(c) + 1];
    ++incident_offset[to(c) + 1];
  }
  for (std::size_t v = 0; v < vertex_count; ++v)
    incident_offset[v + 1] += incident_offset[v];
  std::vector<std::uint32_t> incident(2 * boundary.size()); // boundary edge numbers per vertex
  {
    std::vector<std::uint32_t> cursor(incident_offset.begin(), incident_offset.end() - 1);
    for (std::uint32_t e = 0; e < boundary.size(); ++e) {
      incident[cursor[from(boundary[e])]++] = e;
      incident[cursor[to(boundary[e])]++] = e;
    }
  }
  std::vector<char> used(boundary.size(), 0);
  std::vector<std::uint32_t> next_unused(incident_offset.begin(), incident_offset.end() - 1);
  for (std::uint32_t s = 0; s < boundary.size(); ++s) {
    if (used[s]) continue;
    ++r.boundary_loops;
    used[s] = 1;
    std::uint32_t v = to(boundary[s]);
    while (true) {
      std::uint32_t& k = next_unused[v];
      while (k < incident_offset[v + 1] && used[incident[k]])
        ++k;
      if (k >= incident_offset[v + 1]) break; // back at the start (or an open chain at a pinch)
      const std::uint32_t e = incident[k];
      used[e] = 1;
      v = from(boundary[e]) == v ? to(boundary[e]) : from(boundary[e]);
    }
  }

  r.euler_characteristic =
      static_cast<std::int64_t>(nref) - static_cast<std::int64_t>(r.edges) + static_cast<std::int64_t>(nf);
  return r;
}

std::vector<std::int32_t> vertex_piece_labels(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  std::vector<std::int32_t> parent(vertex_count);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](std::int32_t v) {
    while (parent[std::size_t(v)] != v)
      v = parent[std::size_t(v)] = parent[std::size_t(parent[std::size_t(v)])];
    return v;
  };
  for (std::size_t f = 0; 3 * f + 2 < triangles.size(); ++f)
    for (std::size_t k = 1; k < 3; ++k) {
      assert(std::size_t(triangles[3 * f + k]) < vertex_count && "triangle index out of range");
      const std::int32_t a = root(triangles[3 * f]), b = root(triangles[3 * f + k]);
      if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b); // the root stays the piece's smallest
    }
  for (std::size_t v = 0; v < vertex_count; ++v)
    parent[v] = root(std::int32_t(v));
  return parent;
}

} // namespace vfit
