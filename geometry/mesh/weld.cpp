// SPDX-License-Identifier: Apache-2.0
#include "weld.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "vfit/kernels/pseudo_normals.h"

namespace vfit {

namespace {

std::uint32_t key_bits(float x) { return std::bit_cast<std::uint32_t>(x == 0.0f ? 0.0f : x); }

std::uint64_t mix(std::uint64_t h) { // splitmix64's finaliser: every key bit reaches the slot
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

} // namespace

WeldReport weld_coincident_vertices(Mesh& mesh) {
  WeldReport report;
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<char> used(nv, 0);
  for (std::int32_t v : mesh.triangles)
    if (v >= 0 && std::size_t(v) < nv) used[std::size_t(v)] = 1;
  // Each used vertex → the first used vertex at its position: open addressing (linear
  // probing) over a power-of-two table at most half full, keyed by the coordinates' bits.
  std::vector<std::int32_t> first(nv, -1);
  std::size_t slots = 16;
  while (slots < 2 * nv)
    slots *= 2;
  std::vector<std::int32_t> table(slots, -1);
  const float* p = mesh.positions.data();
  auto same = [&](std::size_t a, std::size_t b) {
    for (std::size_t c = 0; c < 3; ++c)
      if (key_bits(p[3 * a + c]) != key_bits(p[3 * b + c])) return false;
    return true;
  };
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) {
      ++report.unreferenced;
      continue;
    }
    const std::uint64_t h = mix((std::uint64_t(key_bits(p[3 * v])) << 32 | key_bits(p[3 * v + 1])) ^
                                (std::uint64_t(key_bits(p[3 * v + 2])) * 0x9e3779b97f4a7c15ull));
    for (std::size_t slot = h & (slots - 1);; slot = (slot + 1) & (slots - 1)) {
      if (table[slot] < 0) {
        table[slot] = std::int32_t(v);
        first[v] = std::int32_t(v);
        break;
      }
      if (same(std::size_t(table[slot]), v)) {
        first[v] = table[slot];
        ++report.welded;
        break;
      }
    }
  }
  if (report.welded == 0 && report.unreferenced == 0) return report;

  // New numbering: the surviving vertices in their order.
  std::vector<std::int32_t> renumber(nv, -1);
  std::vector<float> positions;
  positions.reserve(3 * (nv - report.welded - report.unreferenced));
  for (std::size_t v = 0; v < nv; ++v)
    if (first[v] == std::int32_t(v)) {
      renumber[v] = std::int32_t(positions.size() / 3);
      positions.insert(positions.end(), mesh.positions.begin() + std::ptrdiff_t(3 * v),
                       mesh.positions.begin() + std::ptrdiff_t(3 * v + 3));
    }
  std::size_t out = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    std::int32_t t[3];
    for (int k = 0; k < 3; ++k)
      t[k] = renumber[std::size_t(first[std::size_t(mesh.triangles[3 * f + std::size_t(k)])])];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++report.collapsed;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      mesh.triangles[3 * out + std::size_t(k)] = t[k];
      if (mesh.has_uvs()) mesh.uv_triangles[3 * out + std::size_t(k)] = mesh.uv_triangles[3 * f + std::size_t(k)];
      if (mesh.has_normals())
        mesh.normal_triangles[3 * out + std::size_t(k)] = mesh.normal_triangles[3 * f + std::size_t(k)];
    }
    if (mesh.has_labels()) mesh.face_labels[out] = mesh.face_labels[f];
    ++out;
  }
  mesh.triangles.resize(3 * out);
  if (mesh.has_uvs()) mesh.uv_triangles.resize(3 * out);
  if (mesh.has_normals()) mesh.normal_triangles.resize(3 * out);
  if (mesh.has_labels()) mesh.face_labels.resize(out);
  mesh.positions = std::move(positions);
  return report;
}

WeldReport weld_seams(Mesh& mesh, float relative_tolerance) {
  WeldReport report = weld_coincident_vertices(mesh);
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nf == 0) return report;
  // Boundary vertices: those of edges one triangle uses.
  const MeshEdges edges = build_mesh_edges(mesh.triangles, nv);
  std::vector<char> boundary(nv, 0);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const auto e = std::size_t(edges.triangle_edges[3 * f + k]);
      if (edges.offsets[e + 1] - edges.offsets[e] != 1) continue;
      boundary[std::size_t(mesh.triangles[3 * f + k])] = 1;
      boundary[std::size_t(mesh.triangles[3 * f + (k + 1) % 3])] = 1;
    }
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::int32_t v : mesh.triangles)
    for (std::size_t c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], mesh.positions[3 * std::size_t(v) + c]);
      hi[c] = std::max(hi[c], mesh.positions[3 * std::size_t(v) + c]);
    }
  const double diagonal = std::sqrt(double(hi[0] - lo[0]) * (hi[0] - lo[0]) + double(hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                    double(hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double tol = double(relative_tolerance) * diagonal;
  if (!(tol > 0)) return report;
  // A grid of cells of the tolerance: a vertex's earlier neighbours within it lie in the 27
  // cells around its own.
  auto cell = [&](std::size_t v, int c) {
    return std::int64_t(std::floor(double(mesh.positions[3 * v + std::size_t(c)]) / tol));
  };
  auto cell_key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return std::uint64_t(x) * 0x9e3779b97f4a7c15ull ^ std::uint64_t(y) * 0xc2b2ae3d27d4eb4full ^
           std::uint64_t(z) * 0x165667b19e3779f9ull;
  };
  std::unordered_map<std::uint64_t, std::vector<std::int32_t>> grid;
  std::size_t snapped = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!boundary[v]) continue;
    const std::int64_t cx = cell(v, 0), cy = cell(v, 1), cz = cell(v, 2);
    std::int32_t target = -1;
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(cell_key(cx + dx, cy + dy, cz + dz));
          if (it == grid.end()) continue;
          for (std::int32_t u : it->second) { // earlier, in index order
            double d2 = 0;
            for (std::size_t c = 0; c < 3; ++c) {
              const double e = double(mesh.positions[3 * v + c]) - mesh.positions[3 * std::size_t(u) + c];
              d2 += e * e;
            }
            if (d2 <= tol * tol && (target < 0 || u < target)) target = u;
          }
        }
    if (target >= 0) {
      for (std::size_t c = 0; c < 3; ++c)
        mesh.positions[3 * v + c] = mesh.positions[3 * std::size_t(target) + c];
      ++snapped;
    } else {
      grid[cell_key(cx, cy, cz)].push_back(std::int32_t(v));
    }
  }
  if (snapped == 0) return report;
  const WeldReport more = weld_coincident_vertices(mesh);
  report.welded += more.welded;
  report.unreferenced += more.unreferenced;
  report.collapsed += more.collapsed;
  return report;
}

} // namespace vfit
