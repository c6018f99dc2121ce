// SPDX-License-Identifier: Apache-2.0
#include "clip.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "topology.h"

namespace vfit {
namespace {

// Drops vertices no face uses and renumbers.
Mesh compact(const std::vector<float>& positions, const std::vector<std::int32_t>& triangles) {
  std::vector<std::int32_t> remap(positions.size() / 3, -1);
  Mesh out;
  out.triangles.reserve(triangles.size());
  for (std::int32_t v : triangles) {
    if (remap[v] < 0) {
      remap[v] = static_cast<std::int32_t>(out.positions.size() / 3);
      out.positions.insert(out.positions.end(), positions.begin() + 3 * v, positions.begin() + 3 * v + 3);
    }
    out.triangles.push_back(remap[v]);
  }
  return out;
}

} // namespace

Mesh clip_mesh(const Mesh& mesh, const KeepFunction& keep, double snap) {
  std::vector<float> pos = mesh.positions;
  const std::size_t nv = mesh.vertex_count();
  std::vector<double> k(nv);
  for (std::size_t v = 0; v < nv; ++v)
    k[v] = keep(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]);
  // Snap: a vertex close to the cut slides onto it along the edge towards its neighbour on the
  // other side (staying on the surface), so the split never makes a sliver.
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int e = 0; e < 3; ++e) {
      const std::int32_t a = mesh.triangles[3 * f + e], b = mesh.triangles[3 * f + (e + 1) % 3];
      if ((k[a] >= 0) == (k[b] >= 0) || k[a] == 0 || k[b] == 0) continue;
      const double t = k[a] / (k[a] - k[b]);
      double len = 0;
      for (int c = 0; c < 3; ++c)
        len += double(pos[3 * b + c] - pos[3 * a + c]) * (pos[3 * b + c] - pos[3 * a + c]);
      len = std::sqrt(len);
      const std::int32_t near = t < 0.5 ? a : b;
      const double dist = (t < 0.5 ? t : 1 - t) * len;
      if (dist > snap || dist > 0.3 * len) continue;
      for (int c = 0; c < 3; ++c)
        pos[3 * near + c] = static_cast<float>(pos[3 * a + c] + t * (pos[3 * b + c] - pos[3 * a + c]));
      k[near] = 0;
    }
  // Split. Crossing points are shared through an edge-keyed map.
  std::unordered_map<std::uint64_t, std::int32_t> cut_vertex;
  auto crossing = [&](std::int32_t a, std::int32_t b) {
    const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::uint32_t(std::max(a, b));
    auto it = cut_vertex.find(key);
    if (it != cut_vertex.end()) return it->second;
    const double t = k[a] / (k[a] - k[b]);
    const auto id = static_cast<std::int32_t>(pos.size() / 3);
    for (int c = 0; c < 3; ++c)
      pos.push_back(static_cast<float>(pos[3 * a + c] + t * (pos[3 * b + c] - pos[3 * a + c])));
    k.push_back(0);
    cut_vertex.emplace(key, id);
    return id;
  };
  std::vector<std::int32_t> tris;
  tris.reserve(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t v[3] = {mesh.triangles[3 * f], mesh.triangles[3 * f + 1], mesh.triangles[3 * f + 2]};
    int pos_count = 0, neg_count = 0;
    for (std::int32_t x : v) {
      if (k[x] > 0)
        ++pos_count;
      else if (k[x] < 0)
        ++neg_count;
    }
    if (neg_count == 0) {
      if (pos_count > 0) tris.insert(tris.end(), {v[0], v[1], v[2]}); // all on the cut: dropped
      continue;
    }
    if (pos_count == 0) continue;
    // Walk the corners in order, emitting the kept polygon (corners ≥ 0 and crossings).
    std::int32_t poly[4];
    int n = 0;
    for (int e = 0; e < 3; ++e) {
      const std::int32_t a = v[e], b = v[(e + 1) % 3];
      if (k[a] >= 0) poly[n++] = a;
      if ((k[a] > 0 && k[b] < 0) || (k[a] < 0 && k[b] > 0)) poly[n++] = crossing(a, b);
    }
    for (int i = 1; i + 1 < n; ++i)
      tris.insert(tris.end(), {poly[0], poly[i], poly[i + 1]});
  }
  return compact(pos, tris);
}

Mesh largest_component(const Mesh& mesh) {
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<std::int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[x] != x)
      x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t f = 0; f < nf; ++f)
    for (int e = 1; e < 3; ++e) {
      const std::int32_t a = find(mesh.triangles[3 * f]), b = find(mesh.triangles[3 * f + e]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::unordered_map<std::int32_t, std::size_t> faces_of;
  for (std::size_t f = 0; f < nf; ++f)
    ++faces_of[find(mesh.triangles[3 * f])];
  std::int32_t best = -1;
  std::size_t best_count = 0;
  for (const auto& [root, count] : faces_of)
    if (count > best_count || (count == best_count && root < best)) {
      best = root;
      best_count = count;
    }
  std::vector<std::int32_t> tris;
  for (std::size_t f = 0; f < nf; ++f)
    if (find(mesh.triangles[3 * f]) == best)
      tris.insert(tris.end(), mesh.triangles.begin() + 3 * f, mesh.triangles.begin() + 3 * f + 3);
  return compact(mesh.positions, tris);
}

} // namespace vfit
