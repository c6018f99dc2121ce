// SPDX-License-Identifier: Apache-2.0
#include "surface_graph.h"

#include <algorithm>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
}

// Normal of a loop: its area vector (Newell) when the loop is a simple cycle, which follows a
// tube's axis even when the cut that made the opening is not planar; else the direction of
// least spread of its edge midpoints.
Eigen::Vector3d loop_normal(const SurfaceGraph& g, const std::vector<std::pair<std::int32_t, std::int32_t>>& edges,
                            const Eigen::Vector3d& centroid) {
  std::unordered_map<std::int32_t, std::vector<std::int32_t>> next;
  for (auto [a, b] : edges) {
    next[a].push_back(b);
    next[b].push_back(a);
  }
  const bool simple = std::all_of(next.begin(), next.end(), [](const auto& kv) { return kv.second.size() == 2; });
  if (simple && edges.size() >= 3) {
    Eigen::Vector3d area = Eigen::Vector3d::Zero();
    std::int32_t prev = edges.front().first, cur = edges.front().second;
    for (std::size_t i = 0; i < edges.size(); ++i) {
      area += (g.points[prev] - centroid).cross(g.points[cur] - centroid);
      const auto& n = next[cur];
      const std::int32_t after = n[0] == prev ? n[1] : n[0];
      prev = cur;
      cur = after;
    }
    if (area.norm() > 0) return area.normalized();
  }
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (auto [a, b] : edges) {
    const Eigen::Vector3d m = 0.5 * (g.points[a] + g.points[b]) - centroid;
    cov += (g.points[a] - g.points[b]).norm() * m * m.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  return eig.eigenvectors().col(0).normalized();
}

} // namespace

SurfaceGraph build_surface_graph(const Mesh& mesh) {
  SurfaceGraph g;
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  g.points.resize(nv);
  for (std::size_t v = 0; v < nv; ++v)
    g.points[v] = Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);

  // Every face side, filed under its smaller vertex; a side filed once is a boundary edge.
  // Orientation is ignored on purpose: real garments come with flipped faces.
  std::vector<std::int32_t> first(nv + 1, 0), other(3 * nf);
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      if (a < 0 || b < 0 || std::size_t(a) >= nv || std::size_t(b) >= nv)
        throw Error("garment", 0,
                    "face " + std::to_string(f) + " has a vertex index outside [0, " + std::to_string(nv) + ")");
      if (a != b) ++first[std::min(a, b) + 1];
    }
  for (std::size_t v = 0; v < nv; ++v)
    first[v + 1] += first[v];
  {
    std::vector<std::int32_t> fill(first.begin(), first.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
        if (a != b) other[fill[std::min(a, b)]++] = std::max(a, b);
      }
  }
  std::vector<std::uint64_t> edges;
  std::vector<std::pair<std::int32_t, std::int32_t>> boundary;
  for (std::size_t v = 0; v < nv; ++v) {
    const auto begin = other.begin() + first[v], end = other.begin() + first[v + 1];
    std::sort(begin, end);
    for (auto i = begin; i != end;) {
      auto j = i;
      while (j != end && *j == *i)
        ++j;
      edges.push_back(edge_key(std::uint32_t(v), std::uint32_t(*i)));
      if (j - i == 1) boundary.push_back({std::int32_t(v), *i});
      i = j;
    }
  }

  g.offsets.assign(nv + 1, 0);
  for (std::uint64_t e : edges) {
    ++g.offsets[(e >> 32) + 1];
    ++g.offsets[(e & 0xffffffffu) + 1];
  }
  for (std::size_t v = 0; v < nv; ++v)
    g.offsets[v + 1] += g.offsets[v];
  g.neighbours.resize(2 * edges.size());
  g.lengths.resize(2 * edges.size());
  std::vector<std::int32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  double total = 0;
  UnionFind sets(nv);
  for (std::uint64_t e : edges) {
    const std::int32_t a = std::int32_t(e >> 32), b = std::int32_t(e & 0xffffffffu);
    const float len = float((g.points[a] - g.points[b]).norm());
    total += len;
    g.neighbours[fill[a]] = b;
    g.lengths[fill[a]++] = len;
    g.neighbours[fill[b]] = a;
    g.lengths[fill[b]++] = len;
    sets.unite(std::uint32_t(a), std::uint32_t(b));
  }
  g.mean_edge = edges.empty() ? 0.0 : total / double(edges.size());

  // Components, numbered by decreasing size; isolated vertices are unreferenced (−1).
  std::vector<std::size_t> size(nv, 0);
  for (std::size_t v = 0; v < nv; ++v)
    if (g.offsets[v + 1] > g.offsets[v]) ++size[sets.find(std::uint32_t(v))];
  std::vector<std::uint32_t> roots;
  for (std::size_t v = 0; v < nv; ++v)
    if (size[v] > 0) roots.push_back(std::uint32_t(v));
  std::stable_sort(roots.begin(), roots.end(), [&](auto a, auto b) { return size[a] > size[b]; });
  std::vector<std::int32_t> index_of_root(nv, -1);
  for (std::size_t i = 0; i < roots.size(); ++i) {
    index_of_root[roots[i]] = std::int32_t(i);
    g.component_sizes.push_back(size[roots[i]]);
  }
  g.component_count = roots.size();
  g.component.assign(nv, -1);
  for (std::size_t v = 0; v < nv; ++v)
    if (g.offsets[v + 1] > g.offsets[v]) g.component[v] = index_of_root[sets.find(std::uint32_t(v))];

  // Boundary loops: connected sets of boundary edges (robust to pinched, non-manifold loops).
  UnionFind loop_sets(nv);
  for (auto [a, b] : boundary)
    loop_sets.unite(std::uint32_t(a), std::uint32_t(b));
  std::vector<std::int32_t> loop_of(nv, -1);
  std::vector<std::vector<std::pair<std::int32_t, std::int32_t>>> loop_edges;
  for (auto [a, b] : boundary) {
    const std::uint32_t r = loop_sets.find(std::uint32_t(a));
    if (loop_of[r] < 0) {
      loop_of[r] = std::int32_t(loop_edges.size());
      loop_edges.emplace_back();
    }
    loop_edges[loop_of[r]].push_back({a, b});
  }
  for (const auto& le : loop_edges) {
    BoundaryLoop loop;
    std::vector<std::int32_t> verts;
    for (auto [a, b] : le) {
      const double len = (g.points[a] - g.points[b]).norm();
      loop.perimeter += len;
      loop.centroid += len * 0.5 * (g.points[a] + g.points[b]);
      verts.push_back(a);
      verts.push_back(b);
    }
    loop.centroid /= std::max(loop.perimeter, 1e-300);
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    loop.vertices = std::move(verts);
    loop.min_y = loop.max_y = g.points[loop.vertices.front()].y();
    for (std::int32_t v : loop.vertices) {
      loop.min_y = std::min(loop.min_y, g.points[v].y());
      loop.max_y = std::max(loop.max_y, g.points[v].y());
    }
    loop.normal = loop_normal(g, le, loop.centroid);
    g.loops.push_back(std::move(loop));
  }
  std::stable_sort(g.loops.begin(), g.loops.end(),
                   [](const auto& a, const auto& b) { return a.perimeter > b.perimeter; });
  return g;
}

} // namespace vfit
