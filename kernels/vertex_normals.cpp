// SPDX-License-Identifier: Apache-2.0
#include "vertex_normals.h"

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

vfit_vec3 face_normal(std::span<const float> positions, std::span<const std::int32_t> tris, std::size_t f) {
  return vfit_triangle_area_normal(load(positions, tris[3 * f]), load(positions, tris[3 * f + 1]),
                                   load(positions, tris[3 * f + 2]));
}

void face_normals_range(std::span<const float> positions, std::span<const std::int32_t> tris, float* out,
                        std::size_t begin, std::size_t end) {
  for (std::size_t f = begin; f < end; ++f) {
    vfit_vec3 n = face_normal(positions, tris, f);
    out[3 * f] = n.x;
    out[3 * f + 1] = n.y;
    out[3 * f + 2] = n.z;
  }
}

void gather_range(const VertexFaceAdjacency& adj, const float* face_normals, float* out, std::size_t begin,
                  std::size_t end) {
  for (std::size_t v = begin; v < end; ++v) {
    vfit_vec3 s{0.0f, 0.0f, 0.0f};
    for (std::int32_t k = adj.offsets[v]; k < adj.offsets[v + 1]; ++k) {
      const float* n = face_normals + 3 * static_cast<std::size_t>(adj.faces[k]);
      s.x += n[0];
      s.y += n[1];
      s.z += n[2];
    }
    vfit_vec3 r = vfit_normalised_or_zero(s);
    out[3 * v] = r.x;
    out[3 * v + 1] = r.y;
    out[3 * v + 2] = r.z;
  }
}
} // namespace

VertexFaceAdjacency build_vertex_face_adjacency(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  VertexFaceAdjacency adj;
  adj.offsets.assign(vertex_count + 1, 0);
  for (std::int32_t v : triangles) {
    assert(v >= 0 && static_cast<std::size_t>(v) < vertex_count && "triangle index out of range");
    ++adj.offsets[static_cast<std::size_t>(v) + 1];
  }
  for (std::size_t v = 0; v < vertex_count; ++v)
    adj.offsets[v + 1] += adj.offsets[v];
  adj.faces.resize(triangles.size());
  std::vector<std::int32_t> cursor(adj.offsets.begin(), adj.offsets.end() - 1);
  // Counting sort in triangle order keeps each vertex's list ascending.
  for (std::size_t i = 0; i < triangles.size(); ++i)
    adj.faces[cursor[triangles[i]]++] = static_cast<std::int32_t>(i / 3);
  return adj;
}

void vertex_normals_serial(std::span<const float> positions, std::span<const std::int32_t> triangles,
                           std::vector<float>& normals) {
  const std::size_t nv = positions.size() / 3, nf = triangles.size() / 3;
  std::vector<float> sums(3 * nv, 0.0f);
  for (std::size_t f = 0; f < nf; ++f) {
    vfit_vec3 n = face_normal(positions, triangles, f);
    for (int k = 0; k < 3; ++k) {
      float* s = sums.data() + 3 * static_cast<std::size_t>(triangles[3 * f + k]);
      s[0] += n.x;
      s[1] += n.y;
      s[2] += n.z;
    }
  }
  normals.resize(3 * nv);
  for (std::size_t v = 0; v < nv; ++v) {
    vfit_vec3 r = vfit_normalised_or_zero(vfit_vec3{sums[3 * v], sums[3 * v + 1], sums[3 * v + 2]});
    normals[3 * v] = r.x;
    normals[3 * v + 1] = r.y;
    normals[3 * v + 2] = r.z;
  }
}

void vertex_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        const VertexFaceAdjacency& adjacency, std::vector<float>& face_normals,
                        std::vector<float>& normals) {
  const std::size_t nv = positions.size() / 3, nf = triangles.size() / 3;
  assert(adjacency.offsets.size() == nv + 1 && "adjacency built for another vertex count");
  face_normals.resize(3 * nf);
  normals.resize(3 * nv);
  float* fn = face_normals.data();
  parallel_for_range(nf, VERTEX_NORMALS_GRAIN,
                     [&](std::size_t b, std::size_t e) { face_normals_range(positions, triangles, fn, b, e); });
  float* out = normals.data();
  parallel_for_range(nv, VERTEX_NORMALS_GRAIN,
                     [&](std::size_t b, std::size_t e) { gather_range(adjacency, fn, out, b, e); });
}

void vertex_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        std::vector<float>& normals) {
  VertexFaceAdjacency adj = build_vertex_face_adjacency(triangles, positions.size() / 3);
  std::vector<float> scratch;
  vertex_normals_tbb(positions, triangles, adj, scratch, normals);
}

} // namespace vfit
