// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Area-weighted vertex normals of a triangle mesh: n_v = normalise(Σ_{f ∋ v} (b−a)×(c−a)),
/// the first data-parallel primitive, with serial, TBB and OpenCL implementations that agree
/// (serial and TBB bit for bit; OpenCL within float tolerance, see tests/opencl).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vfit {

/// Vertex → incident-triangle adjacency in compressed sparse rows: the triangles of vertex v
/// are `faces[offsets[v] .. offsets[v+1])`, in ascending triangle order (so a gather visits
/// them in the order a serial scatter would).
struct VertexFaceAdjacency {
  std::vector<std::int32_t> offsets; ///< #V + 1
  std::vector<std::int32_t> faces;   ///< 3·#F
};

/// Builds the adjacency of `triangles` (#F × 3 vertex indices, each in [0, vertex_count)).
/// Indices must already be validated (assert only).
VertexFaceAdjacency build_vertex_face_adjacency(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// Grain size of the TBB drivers below, in triangles or vertices per task.
inline constexpr std::size_t VERTEX_NORMALS_GRAIN = 4096;

/// Serial reference. positions: #V × 3 (m); triangles: #F × 3; normals (out, resized to
/// #V × 3): unit vectors, or zero for a vertex with no non-degenerate incident triangle.
void vertex_normals_serial(std::span<const float> positions, std::span<const std::int32_t> triangles,
                           std::vector<float>& normals);

/// TBB version: triangle normals in parallel over triangles, then a gather per vertex over
/// `adjacency` (no atomics). Same result as the serial reference, bit for bit.
/// `face_normals` is scratch (#F × 3), resized by the callee, reusable across calls.
void vertex_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        const VertexFaceAdjacency& adjacency, std::vector<float>& face_normals,
                        std::vector<float>& normals);

/// One-call TBB wrapper that builds the adjacency itself.
void vertex_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        std::vector<float>& normals);

} // namespace vfit
