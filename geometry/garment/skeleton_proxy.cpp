// SPDX-License-Identifier: Apache-2.0
#include "skeleton_proxy.h"

#include <algorithm>
#include <bit>
#include <numeric>
#include <queue>

#include <Eigen/Core>

#include "vfit/kernels/error.h"

namespace vfit {

namespace {

// Pre-coarsening (parts far above the target): a part with more than PRECOARSEN_ABOVE × target
// vertices is first reduced by rounds of independent collapses to about PRECOARSEN_TO × target,
// and the shortest-first collapses take it from there. Table-1 garments' parts (at most a few
// thousand vertices with caps, against 16 × 800) never reach it.
constexpr std::size_t PRECOARSEN_ABOVE = 16, PRECOARSEN_TO = 8;
// A round collapses edges up to this multiple of its lower-quartile edge length.
constexpr float ROUND_LENGTH_FACTOR = 1.5f;
// A round that merges fewer than this share of the vertices ends the pre-coarsening.
constexpr double PRECOARSEN_MIN_PROGRESS = 0.01;

// Clusters of input vertices: the running sum of their positions and their number, per vertex
// of the current mesh.
struct Clusters {
  std::vector<Eigen::Vector3d> sum;
  std::vector<double> count;
  Eigen::Vector3d position(std::size_t v) const { return sum[v] / count[v]; }
};

// One round of edge collapses, shortest edge first, on a closed manifold mesh (`tris` over the
// clusters' vertices), each vertex in at most one collapse per round (a matching), edges no
// longer than ROUND_LENGTH_FACTOR × the round's lower-quartile length: an edge a–b is
// collapsed when neither end was collapsed earlier in the round, a and b have valence > 3,
// they share exactly the two vertices across their edge (link condition) and those keep a
// valence ≥ 3, all on the mesh as the round's earlier collapses left it. Edge lengths are
// those at the start of the round (no edge of a collapsed vertex is tried again in it). Merges
// about a third of the vertices per round at a cost of a few passes over the mesh (plus the
// sort). Renumbers the clusters, `tris` and `input_vertex` (input vertex → vertex of the
// current mesh); returns the number of collapses.
std::size_t collapse_independent_edges(Clusters& clusters, std::vector<std::int32_t>& tris,
                                       std::vector<std::int32_t>& input_vertex) {
  const std::size_t nv = clusters.sum.size(), nf = tris.size() / 3;
  // Neighbours per vertex (CSR), from both other corners of each face, sorted and deduplicated.
  std::vector<std::int32_t> offset(nv + 1, 0);
  for (std::int32_t v : tris)
    offset[std::size_t(v) + 1] += 2;
  for (std::size_t v = 0; v < nv; ++v)
    offset[v + 1] += offset[v];
  std::vector<std::int32_t> all(static_cast<std::size_t>(offset[nv]));
  {
    std::vector<std::int32_t> fill(offset.begin(), offset.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (std::size_t k = 0; k < 3; ++k) {
        const auto v = std::size_t(tris[3 * f + k]);
        all[std::size_t(fill[v]++)] = tris[3 * f + (k + 1) % 3];
        all[std::size_t(fill[v]++)] = tris[3 * f + (k + 2) % 3];
      }
  }
  std::vector<std::int32_t> first(nv + 1, 0), neighbours;
  neighbours.reserve(all.size() / 2 + nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto begin = all.begin() + offset[v], end = all.begin() + offset[v + 1];
    std::sort(begin, end);
    neighbours.insert(neighbours.end(), begin, std::unique(begin, end));
    first[v + 1] = std::int32_t(neighbours.size());
  }
  std::vector<std::int32_t> valence(nv);
  for (std::size_t v = 0; v < nv; ++v)
    valence[v] = first[v + 1] - first[v];

  // Edges a < b keyed by (length as float bits, edge index): positive floats order as their bits.
  std::vector<std::pair<std::int32_t, std::int32_t>> edges;
  std::vector<std::uint64_t> keys;
  edges.reserve(neighbours.size() / 2);
  keys.reserve(neighbours.size() / 2);
  for (std::size_t a = 0; a < nv; ++a)
    for (std::int32_t i = first[a]; i < first[a + 1]; ++i) {
      const std::int32_t b = neighbours[std::size_t(i)];
      if (b <= std::int32_t(a)) continue;
      const auto length = float((clusters.position(a) - clusters.position(std::size_t(b))).norm());
      keys.push_back((std::uint64_t(std::bit_cast<std::uint32_t>(length)) << 32) | std::uint64_t(edges.size()));
      edges.emplace_back(std::int32_t(a), b);
    }
  std::sort(keys.begin(), keys.end());

  // Each vertex takes part in at most one collapse per round, so a vertex's current neighbours
  // are its neighbours at the start of the round, each replaced by the vertex it was merged into.
  std::vector<char> collapsed(nv, 0);
  std::vector<std::int32_t> merged_into(nv);
  std::iota(merged_into.begin(), merged_into.end(), 0);
  std::size_t collapses = 0;
  std::vector<std::int32_t> around_a, around_b;
  auto current_neighbours = [&](std::int32_t v, std::vector<std::int32_t>& out) {
    out.clear();
    for (std::int32_t i = first[std::size_t(v)]; i < first[std::size_t(v) + 1]; ++i)
      out.push_back(merged_into[std::size_t(neighbours[std::size_t(i)])]);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  };
  std::int32_t shared[2];
  // Only edges up to ROUND_LENGTH_FACTOR × the round's lower-quartile length: on an anisotropic
  // mesh the shortest-first order would not reach the long edges yet, and merging them anyway
  // leaves a pattern of low valences that the shortest-first collapses then cannot continue from.
  const std::uint64_t longest =
      keys.empty() ? 0
                   : std::uint64_t(std::bit_cast<std::uint32_t>(
                         ROUND_LENGTH_FACTOR * std::bit_cast<float>(std::uint32_t(keys[keys.size() / 4] >> 32))))
                             << 32 |
                         0xffffffffu;
  for (std::uint64_t key : keys) {
    if (key > longest) break;
    const auto [a, b] = edges[std::size_t(key & 0xffffffffu)];
    if (collapsed[std::size_t(a)] || collapsed[std::size_t(b)]) continue;
    if (valence[std::size_t(a)] <= 3 || valence[std::size_t(b)] <= 3) continue;
    current_neighbours(a, around_a);
    current_neighbours(b, around_b);
    // Link condition: exactly two common neighbours (the vertices across the edge).
    int common = 0;
    for (std::size_t i = 0, j = 0; i < around_a.size() && j < around_b.size() && common <= 2;) {
      if (around_a[i] < around_b[j]) {
        ++i;
      } else if (around_b[j] < around_a[i]) {
        ++j;
      } else {
        if (common < 2) shared[common] = around_a[i];
        ++common;
        ++i;
        ++j;
      }
    }
    if (common != 2 || valence[std::size_t(shared[0])] <= 3 || valence[std::size_t(shared[1])] <= 3) continue;
    --valence[std::size_t(shared[0])];
    --valence[std::size_t(shared[1])];
    valence[std::size_t(a)] += valence[std::size_t(b)] - 4;
    collapsed[std::size_t(a)] = collapsed[std::size_t(b)] = 1;
    merged_into[std::size_t(b)] = a;
    clusters.sum[std::size_t(a)] += clusters.sum[std::size_t(b)];
    clusters.count[std::size_t(a)] += clusters.count[std::size_t(b)];
    ++collapses;
  }

  // Renumber the surviving vertices in order; drop the two faces of each collapsed edge.
  std::vector<std::int32_t> renumber(nv, -1);
  Clusters kept;
  for (std::size_t v = 0; v < nv; ++v)
    if (merged_into[v] == std::int32_t(v)) {
      renumber[v] = std::int32_t(kept.sum.size());
      kept.sum.push_back(clusters.sum[v]);
      kept.count.push_back(clusters.count[v]);
    }
  for (std::size_t v = 0; v < nv; ++v)
    renumber[v] = renumber[std::size_t(merged_into[v])];
  std::size_t out = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t x = renumber[std::size_t(tris[3 * f])], y = renumber[std::size_t(tris[3 * f + 1])],
                       z = renumber[std::size_t(tris[3 * f + 2])];
    if (x == y || y == z || z == x) continue;
    tris[out++] = x;
    tris[out++] = y;
    tris[out++] = z;
  }
  tris.resize(out);
  for (std::int32_t& v : input_vertex)
    v = renumber[std::size_t(v)];
  clusters = std::move(kept);
  return collapses;
}

// Shortest-first collapses of the current mesh (`tris` over the clusters' vertices) down to
// `target_vertices`, as simplify_for_skeleton() describes: fills `proxy` with one vertex per
// surviving cluster (at its mean) and `vertex_proxy` with the proxy vertex of each current
// vertex.
void collapse_shortest_edges(Clusters clusters, std::vector<std::int32_t> tris, std::size_t target_vertices,
                             Mesh& proxy, std::vector<std::int32_t>& vertex_proxy) {
  const std::size_t nv = clusters.sum.size(), nf = tris.size() / 3;
  std::vector<Eigen::Vector3d>& sum = clusters.sum;
  std::vector<double>& count = clusters.count;
  std::vector<std::int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[std::size_t(x)] != x)
      x = parent[std::size_t(x)] = parent[std::size_t(parent[std::size_t(x)])];
    return x;
  };
  // Collapses are ordered by the distance between the means of the current vertices merged
  // (each counting once), not of the input vertices they stand for: a pre-coarsened vertex of
  // many input vertices would barely move when merged and keep absorbing its neighbours. Without
  // pre-coarsening both are the same numbers.
  std::vector<Eigen::Vector3d> guide_sum(nv);
  std::vector<double> guide_count(nv, 1.0);
  for (std::size_t v = 0; v < nv; ++v)
    guide_sum[v] = sum[v] / count[v];
  auto position = [&](std::int32_t r) -> Eigen::Vector3d {
    return guide_sum[std::size_t(r)] / guide_count[std::size_t(r)];
  };

  std::vector<char> alive(nf, 1);
  std::vector<std::vector<std::int32_t>> faces(nv), neighbours(nv);
  auto add_neighbour = [&](std::int32_t a, std::int32_t b) {
    auto& n = neighbours[std::size_t(a)];
    if (std::find(n.begin(), n.end(), b) == n.end()) n.push_back(b);
  };
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = tris[3 * f + std::size_t(k)], b = tris[3 * f + std::size_t(k + 1) % 3];
      faces[std::size_t(a)].push_back(std::int32_t(f));
      add_neighbour(a, b);
      add_neighbour(b, a);
    }

  struct Candidate {
    double length;
    std::int32_t a, b;
    bool operator>(const Candidate& o) const { return length > o.length; }
  };
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue;
  for (std::size_t a = 0; a < nv; ++a)
    for (std::int32_t b : neighbours[a])
      if (std::int32_t(a) < b) queue.push({(position(std::int32_t(a)) - position(b)).norm(), std::int32_t(a), b});

  std::size_t remaining = nv;
  std::vector<std::int32_t> shared;
  while (remaining > target_vertices && !queue.empty()) {
    const Candidate c = queue.top();
    queue.pop();
    std::int32_t a = find(c.a), b = find(c.b);
    if (a == b) continue;
    const double length = (position(a) - position(b)).norm();
    if (length > c.length * (1 + 1e-9)) {
      queue.push({length, a, b});
      continue;
    }
    auto& na = neighbours[std::size_t(a)];
    auto& nb = neighbours[std::size_t(b)];
    if (na.size() <= 3 || nb.size() <= 3) continue;
    // Link condition: a and b share exactly the two vertices across their edge.
    shared.clear();
    for (std::int32_t w : nb)
      if (w != a && std::find(na.begin(), na.end(), w) != na.end()) shared.push_back(w);
    if (shared.size() != 2) continue;
    if (faces[std::size_t(a)].size() < faces[std::size_t(b)].size())
      std::swap(a, b); // merge the smaller into the larger
    for (std::int32_t f : faces[std::size_t(b)]) {
      std::int32_t* t = &tris[3 * std::size_t(f)];
      if (t[0] == a || t[1] == a || t[2] == a) {
        alive[std::size_t(f)] = 0;
        continue;
      }
      for (int k = 0; k < 3; ++k)
        if (t[k] == b) t[k] = a;
      faces[std::size_t(a)].push_back(f);
    }
    std::erase_if(faces[std::size_t(a)], [&](std::int32_t f) { return !alive[std::size_t(f)]; });
    faces[std::size_t(b)].clear();
    for (std::int32_t w : neighbours[std::size_t(b)]) {
      if (w == a) continue;
      auto& nw = neighbours[std::size_t(w)];
      std::erase(nw, b);
      add_neighbour(w, a);
      add_neighbour(a, w);
    }
    std::erase(neighbours[std::size_t(a)], b);
    neighbours[std::size_t(b)].clear();
    parent[std::size_t(b)] = a;
    guide_sum[std::size_t(a)] += guide_sum[std::size_t(b)];
    guide_count[std::size_t(a)] += guide_count[std::size_t(b)];
    sum[std::size_t(a)] += sum[std::size_t(b)];
    count[std::size_t(a)] += count[std::size_t(b)];
    --remaining;
  }

  std::vector<std::int32_t> compact(nv, -1);
  vertex_proxy.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const std::int32_t r = find(std::int32_t(v));
    if (compact[std::size_t(r)] < 0) {
      compact[std::size_t(r)] = std::int32_t(proxy.positions.size() / 3);
      const Eigen::Vector3d p = sum[std::size_t(r)] / count[std::size_t(r)];
      proxy.positions.insert(proxy.positions.end(), {float(p.x()), float(p.y()), float(p.z())});
    }
    vertex_proxy[v] = compact[std::size_t(r)];
  }
  for (std::size_t f = 0; f < nf; ++f)
    if (alive[f])
      for (int k = 0; k < 3; ++k)
        proxy.triangles.push_back(compact[std::size_t(tris[3 * f + std::size_t(k)])]);
}

} // namespace

SkeletonProxy simplify_for_skeleton(const Mesh& mesh, std::size_t target_vertices) {
  const std::size_t nv = mesh.vertex_count();
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (mesh.triangles[i] < 0 || std::size_t(mesh.triangles[i]) >= nv)
      throw Error("skeleton proxy", 0, "face " + std::to_string(i / 3 + 1) + " has a vertex index out of range");
  SkeletonProxy proxy;
  if (nv <= target_vertices) {
    proxy.mesh.positions = mesh.positions;
    proxy.mesh.triangles = mesh.triangles;
    proxy.vertex_proxy.resize(nv);
    std::iota(proxy.vertex_proxy.begin(), proxy.vertex_proxy.end(), 0);
    return proxy;
  }
  Clusters clusters;
  clusters.sum.resize(nv);
  clusters.count.assign(nv, 1.0);
  for (std::size_t v = 0; v < nv; ++v)
    clusters.sum[v] = Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
  std::vector<std::int32_t> tris = mesh.triangles;
  std::vector<std::int32_t> input_vertex(nv);
  std::iota(input_vertex.begin(), input_vertex.end(), 0);
  if (nv > PRECOARSEN_ABOVE * target_vertices)
    while (clusters.sum.size() > PRECOARSEN_TO * target_vertices) {
      const std::size_t before = clusters.sum.size();
      if (double(collapse_independent_edges(clusters, tris, input_vertex)) < PRECOARSEN_MIN_PROGRESS * double(before))
        break;
    }
  std::vector<std::int32_t> vertex_proxy;
  collapse_shortest_edges(std::move(clusters), std::move(tris), target_vertices, proxy.mesh, vertex_proxy);
  proxy.vertex_proxy.resize(nv);
  for (std::size_t v = 0; v < nv; ++v)
    proxy.vertex_proxy[v] = vertex_proxy[std::size_t(input_vertex[v])];
  return proxy;
}

} // namespace vfit
