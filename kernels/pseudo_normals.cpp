// SPDX-License-Identifier: Apache-2.0
#include "pseudo_normals.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "parallel.h"

namespace vfit {
namespace {
using std::sqrt; // vertex_normals_math.h calls sqrt(float) as OpenCL C does.
#include "vertex_normals_math.h"

vfit_vec3 load(std::span<const float> p, std::int32_t v) {
  const float* q = p.data() + 3 * static_cast<std::size_t>(v);
  return vfit_vec3{q[0], q[1], q[2]};
}

void store(float* out, std::size_t i, vfit_vec3 n) {
  out[3 * i] = n.x;
  out[3 * i + 1] = n.y;
  out[3 * i + 2] = n.z;
}

// The angle (rad) between u and v; atan2 of |u×v| and u·v stays accurate near 0 and π where
// acos of a normalised dot product loses half its digits.
float angle_between(vfit_vec3 u, vfit_vec3 v) {
  vfit_vec3 c = vfit_triangle_area_normal(vfit_vec3{0.0f, 0.0f, 0.0f}, u, v);
  return std::atan2(std::sqrt(c.x * c.x + c.y * c.y + c.z * c.z), u.x * v.x + u.y * v.y + u.z * v.z);
}

vfit_vec3 sub(vfit_vec3 a, vfit_vec3 b) { return vfit_vec3{a.x - b.x, a.y - b.y, a.z - b.z}; }

void faces_range(std::span<const float> positions, std::span<const std::int32_t> tris, float* normals, float* angles,
                 std::size_t begin, std::size_t end) {
  for (std::size_t f = begin; f < end; ++f) {
    const vfit_vec3 p[3] = {load(positions, tris[3 * f]), load(positions, tris[3 * f + 1]),
                            load(positions, tris[3 * f + 2])};
    store(normals, f, vfit_normalised_or_zero(vfit_triangle_area_normal(p[0], p[1], p[2])));
    for (int k = 0; k < 3; ++k)
      angles[3 * f + k] = angle_between(sub(p[(k + 1) % 3], p[k]), sub(p[(k + 2) % 3], p[k]));
  }
}

void edges_range(const MeshEdges& edges, const float* face_normals, float* out, std::size_t begin, std::size_t end) {
  for (std::size_t e = begin; e < end; ++e) {
    vfit_vec3 s{0.0f, 0.0f, 0.0f};
    for (std::int32_t i = edges.offsets[e]; i < edges.offsets[e + 1]; ++i) {
      const float* n = face_normals + 3 * static_cast<std::size_t>(edges.faces[i]);
      s.x += n[0];
      s.y += n[1];
      s.z += n[2];
    }
    store(out, e, vfit_normalised_or_zero(s));
  }
}

void vertices_range(std::span<const std::int32_t> tris, const VertexFaceAdjacency& adj, const float* face_normals,
                    const float* angles, float* out, std::size_t begin, std::size_t end) {
  for (std::size_t v = begin; v < end; ++v) {
    vfit_vec3 s{0.0f, 0.0f, 0.0f};
    for (std::int32_t i = adj.offsets[v]; i < adj.offsets[v + 1]; ++i) {
      const std::size_t f = static_cast<std::size_t>(adj.faces[i]);
      // A face lists v once per corner that uses it (twice only in a degenerate face).
      for (int k = 0; k < 3; ++k) {
        if (static_cast<std::size_t>(tris[3 * f + k]) != v) continue;
        const float w = angles[3 * f + k];
        s.x += w * face_normals[3 * f];
        s.y += w * face_normals[3 * f + 1];
        s.z += w * face_normals[3 * f + 2];
        break;
      }
    }
    store(out, v, vfit_normalised_or_zero(s));
  }
}

// Runs the three passes through `run(count, kernel)`: serially or through parallel_for_range.
template <typename Runner>
void compute(std::span<const float> positions, std::span<const std::int32_t> tris, const MeshEdges& edges,
             const VertexFaceAdjacency& adj, PseudoNormals& n, const Runner& run) {
  const std::size_t nv = positions.size() / 3, nf = tris.size() / 3, ne = edges.edge_count();
  assert(edges.triangle_edges.size() == tris.size() && "edge table built for another mesh");
  assert(adj.offsets.size() == nv + 1 && "adjacency built for another vertex count");
  n.faces.resize(3 * nf);
  n.corner_angles.resize(3 * nf);
  n.edges.resize(3 * ne);
  n.vertices.resize(3 * nv);
  float* fn = n.faces.data();
  float* angles = n.corner_angles.data();
  run(nf, [&](std::size_t b, std::size_t e) { faces_range(positions, tris, fn, angles, b, e); });
  float* en = n.edges.data();
  run(ne, [&](std::size_t b, std::size_t e) { edges_range(edges, fn, en, b, e); });
  float* vn = n.vertices.data();
  run(nv, [&](std::size_t b, std::size_t e) { vertices_range(tris, adj, fn, angles, vn, b, e); });
}
} // namespace

MeshEdges build_mesh_edges(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  const std::size_t corners = triangles.size();
  auto lo = [&](std::size_t h) {
    const std::size_t f = h / 3, k = h % 3;
    return std::min(triangles[3 * f + k], triangles[3 * f + (k + 1) % 3]);
  };
  auto hi = [&](std::size_t h) {
    const std::size_t f = h / 3, k = h % 3;
    return std::max(triangles[3 * f + k], triangles[3 * f + (k + 1) % 3]);
  };
  // Counting sort of the half-edges by their lower vertex, then a small sort per bucket by the
  // higher vertex (a bucket holds a vertex's few edges), keeps the build O(#F).
  std::vector<std::int32_t> start(vertex_count + 1, 0);
  for (std::size_t h = 0; h < corners; ++h) {
    assert(triangles[h] >= 0 && static_cast<std::size_t>(triangles[h]) < vertex_count && "index out of range");
    ++start[static_cast<std::size_t>(lo(h)) + 1];
  }
  for (std::size_t v = 0; v < vertex_count; ++v)
    start[v + 1] += start[v];
  std::vector<std::int32_t> sorted(corners);
  std::vector<std::int32_t> cursor(start.begin(), start.end() - 1);
  for (std::size_t h = 0; h < corners; ++h)
    sorted[cursor[lo(h)]++] = static_cast<std::int32_t>(h);
  for (std::size_t v = 0; v < vertex_count; ++v)
    std::sort(sorted.begin() + start[v], sorted.begin() + start[v + 1],
              [&](std::int32_t a, std::int32_t b) { return hi(a) != hi(b) ? hi(a) < hi(b) : a < b; });

  MeshEdges edges;
  edges.triangle_edges.resize(corners);
  edges.faces.resize(corners);
  edges.offsets.reserve(corners / 2 + 2);
  for (std::size_t i = 0; i < corners; ++i) {
    const std::size_t h = static_cast<std::size_t>(sorted[i]);
    const bool same_edge = i > 0 && lo(h) == lo(sorted[i - 1]) && hi(h) == hi(sorted[i - 1]);
    if (!same_edge) edges.offsets.push_back(static_cast<std::int32_t>(i));
    edges.triangle_edges[h] = static_cast<std::int32_t>(edges.offsets.size() - 1);
    edges.faces[i] = static_cast<std::int32_t>(h / 3);
  }
  edges.offsets.push_back(static_cast<std::int32_t>(corners));
  return edges;
}

void pseudo_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        const MeshEdges& edges, const VertexFaceAdjacency& vertex_faces, PseudoNormals& normals) {
  compute(positions, triangles, edges, vertex_faces, normals,
          [](std::size_t count, const auto& kernel) { parallel_for_range(count, PSEUDO_NORMALS_GRAIN, kernel); });
}

void pseudo_normals_serial(std::span<const float> positions, std::span<const std::int32_t> triangles,
                           const MeshEdges& edges, const VertexFaceAdjacency& vertex_faces, PseudoNormals& normals) {
  compute(positions, triangles, edges, vertex_faces, normals,
          [](std::size_t count, const auto& kernel) { kernel(std::size_t{0}, count); });
}

} // namespace vfit
