// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Area-weighted vertex normals on an OpenCL device (see vertex_normals.h for the math).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace vfit {

class OpenClContext;

/// Precompute/solve object: the constructor uploads the topology (triangles and the
/// vertex→triangle adjacency) once; compute() uploads positions, runs two kernels (per
/// triangle, then a per-vertex gather) and reads the normals back. Agrees with
/// vertex_normals_serial() within float tolerance (device sqrt/division may differ by ulps).
class OpenClVertexNormals {
public:
  /// triangles: #F × 3 indices in [0, vertex_count) (validated by the caller).
  OpenClVertexNormals(OpenClContext& context, std::span<const std::int32_t> triangles, std::size_t vertex_count);
  ~OpenClVertexNormals();
  OpenClVertexNormals(const OpenClVertexNormals&) = delete;
  OpenClVertexNormals& operator=(const OpenClVertexNormals&) = delete;

  /// positions: #V × 3 (m). normals (out, resized to #V × 3): unit or zero vectors.
  void compute(std::span<const float> positions, std::vector<float>& normals);

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
