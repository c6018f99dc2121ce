// SPDX-License-Identifier: Apache-2.0
#include "reeb_graph.h"

#include <algorithm>
#include <cmath>

namespace vfit {

std::vector<std::int32_t> ReebGraph::children(std::int32_t node) const {
  std::vector<std::int32_t> out;
  for (const ReebArc& a : arcs)
    if (a.from == node && nodes[a.to].band == nodes[node].band + 1) out.push_back(a.to);
  return out;
}

ReebGraph build_reeb_graph(const SurfaceGraph& graph, const std::vector<double>& f, int bands) {
  ReebGraph rg;
  bands = std::max(bands, 1);
  const std::size_t nv = graph.vertex_count();
  double bottom = INFINITY, top = -INFINITY;
  for (double v : f)
    if (std::isfinite(v)) {
      bottom = std::min(bottom, v);
      top = std::max(top, v);
    }
  if (!(top > bottom)) top = bottom + 1; // constant or empty: one band holds everything
  const double width = (top - bottom) / bands;
  for (int b = 0; b <= bands; ++b)
    rg.levels.push_back(bottom + b * width);
  std::vector<int> band(nv, -1);
  for (std::size_t v = 0; v < nv; ++v)
    if (std::isfinite(f[v])) band[v] = std::clamp(int((f[v] - bottom) / width), 0, bands - 1);

  UnionFind sets(nv);
  for (std::size_t v = 0; v < nv; ++v)
    for (std::int32_t i = graph.offsets[v]; i < graph.offsets[v + 1]; ++i)
      if (band[v] >= 0 && band[v] == band[graph.neighbours[i]])
        sets.unite(std::uint32_t(v), std::uint32_t(graph.neighbours[i]));

  // Nodes ordered by band, then by their root vertex.
  std::vector<std::pair<int, std::uint32_t>> keys;
  for (std::size_t v = 0; v < nv; ++v)
    if (band[v] >= 0 && sets.find(std::uint32_t(v)) == v) keys.push_back({band[v], std::uint32_t(v)});
  std::sort(keys.begin(), keys.end());
  std::vector<std::int32_t> node_of_root(nv, -1);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    node_of_root[keys[i].second] = std::int32_t(i);
    ReebNode n;
    n.band = keys[i].first;
    n.level_min = rg.levels[n.band];
    n.level_max = rg.levels[n.band + 1];
    rg.nodes.push_back(n);
  }
  rg.vertex_node.assign(nv, -1);
  for (std::size_t v = 0; v < nv; ++v) {
    if (band[v] < 0) continue;
    const std::int32_t n = node_of_root[sets.find(std::uint32_t(v))];
    rg.vertex_node[v] = n;
    ++rg.nodes[n].vertex_count;
    rg.nodes[n].centroid += graph.points[v];
  }
  for (ReebNode& n : rg.nodes)
    n.centroid /= double(std::max<std::size_t>(n.vertex_count, 1));

  std::vector<std::uint64_t> pairs;
  for (std::size_t v = 0; v < nv; ++v)
    for (std::int32_t i = graph.offsets[v]; i < graph.offsets[v + 1]; ++i) {
      const std::int32_t a = rg.vertex_node[v], b = rg.vertex_node[graph.neighbours[i]];
      if (a >= 0 && b >= 0 && rg.nodes[a].band < rg.nodes[b].band)
        pairs.push_back((std::uint64_t(a) << 32) | std::uint32_t(b));
    }
  std::sort(pairs.begin(), pairs.end());
  for (std::size_t i = 0; i < pairs.size();) {
    std::size_t j = i;
    while (j < pairs.size() && pairs[j] == pairs[i])
      ++j;
    rg.arcs.push_back({std::int32_t(pairs[i] >> 32), std::int32_t(pairs[i] & 0xffffffffu), j - i});
    i = j;
  }
  return rg;
}

namespace {

struct Component {
  std::int32_t birth = -1;
  std::size_t count = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double min_y = 0;
  std::vector<std::uint32_t> tags; // empty until the component holds a tagged vertex
};

} // namespace

std::vector<MergeEvent> merge_tree(const SurfaceGraph& graph, const std::vector<double>& f, double min_persistence,
                                   std::size_t min_vertices, const std::vector<std::int32_t>& tags, int tag_count) {
  const std::size_t nv = graph.vertex_count();
  std::vector<std::int32_t> order;
  for (std::size_t v = 0; v < nv; ++v)
    if (std::isfinite(f[v])) order.push_back(std::int32_t(v));
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return f[a] > f[b] || (f[a] == f[b] && a < b); });

  UnionFind sets(nv);
  std::vector<char> active(nv, 0);
  std::vector<Component> comp(nv); // indexed by root
  std::vector<MergeEvent> events;
  std::vector<std::uint32_t> roots;
  for (std::int32_t v : order) {
    roots.clear();
    for (std::int32_t i = graph.offsets[v]; i < graph.offsets[v + 1]; ++i) {
      const std::int32_t u = graph.neighbours[i];
      if (!active[u]) continue;
      const std::uint32_t r = sets.find(std::uint32_t(u));
      if (std::find(roots.begin(), roots.end(), r) == roots.end()) roots.push_back(r);
    }
    active[v] = 1;
    const Eigen::Vector3d& p = graph.points[v];
    if (roots.size() >= 2) {
      MergeEvent e;
      e.saddle = v;
      e.value = f[v];
      for (std::uint32_t r : roots) {
        const Component& c = comp[r];
        if (f[c.birth] - f[v] >= min_persistence && c.count >= min_vertices) {
          MergeBranch b{c.birth, f[c.birth], c.count, c.sum / double(c.count), c.min_y, c.tags};
          b.tag_counts.resize(std::size_t(tag_count), 0);
          e.branches.push_back(std::move(b));
        }
      }
      if (e.branches.size() >= 2) events.push_back(std::move(e));
    }
    // Elder rule: the merged component keeps the oldest birth (largest value).
    Component merged{v, 1, p, p.y(), {}};
    if (!tags.empty() && tags[v] >= 0) {
      merged.tags.assign(std::size_t(tag_count), 0);
      ++merged.tags[tags[v]];
    }
    for (std::uint32_t r : roots) {
      Component& c = comp[r];
      if (f[c.birth] > f[merged.birth]) merged.birth = c.birth;
      merged.count += c.count;
      merged.sum += c.sum;
      merged.min_y = std::min(merged.min_y, c.min_y);
      if (merged.tags.empty())
        merged.tags.swap(c.tags);
      else
        for (std::size_t k = 0; k < c.tags.size(); ++k)
          merged.tags[k] += c.tags[k];
      std::vector<std::uint32_t>().swap(c.tags);
    }
    std::uint32_t root = std::uint32_t(v);
    for (std::uint32_t r : roots)
      root = sets.unite(root, r);
    comp[root] = std::move(merged);
  }
  return events;
}

std::vector<std::int32_t> superlevel_component(const SurfaceGraph& graph, const std::vector<double>& f,
                                               std::int32_t seed, double value) {
  std::vector<std::int32_t> out;
  if (!(f[seed] > value)) return out;
  std::vector<char> seen(graph.vertex_count(), 0);
  seen[seed] = 1;
  out.push_back(seed);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::int32_t v = out[i];
    for (std::int32_t k = graph.offsets[v]; k < graph.offsets[v + 1]; ++k) {
      const std::int32_t u = graph.neighbours[k];
      if (!seen[u] && f[u] > value) {
        seen[u] = 1;
        out.push_back(u);
      }
    }
  }
  return out;
}

} // namespace vfit
