// SPDX-License-Identifier: Apache-2.0
#include "mesh_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace vfit {

MeshStats mesh_stats(const Mesh& mesh) {
  MeshStats s;
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv == 0) return s;
  // The surface's box: a vertex no face uses (an exporter's stray point, a deleted part's
  // leftovers) would otherwise set the extent, and with it the detected units. A point cloud
  // (no faces) is all vertices.
  std::vector<char> counted(nv, nf == 0);
  for (const std::int32_t v : mesh.triangles)
    counted[static_cast<std::size_t>(v)] = 1;
  s.bbox_min = {INFINITY, INFINITY, INFINITY};
  s.bbox_max = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t v = 0; v < nv; ++v)
    if (counted[v])
      for (int k = 0; k < 3; ++k) {
        s.bbox_min[k] = std::min(s.bbox_min[k], mesh.positions[3 * v + k]);
        s.bbox_max[k] = std::max(s.bbox_max[k], mesh.positions[3 * v + k]);
      }
  for (int k = 0; k < 3; ++k) {
    s.largest_extent = std::max(s.largest_extent, s.bbox_max[k] - s.bbox_min[k]);
    s.max_abs_coordinate = std::max({s.max_abs_coordinate, std::abs(s.bbox_min[k]), std::abs(s.bbox_max[k])});
  }
  const double zero_area = 1e-12 * double(s.largest_extent) * s.largest_extent;
  double edge_sum = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const float* p[3];
    for (int k = 0; k < 3; ++k)
      p[k] = &mesh.positions[3 * static_cast<std::size_t>(mesh.triangles[3 * f + k])];
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = double(p[1][k]) - p[0][k];
      w[k] = double(p[2][k]) - p[0][k];
    }
    const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
    const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
    s.surface_area += area;
    if (area <= zero_area) ++s.zero_area_faces;
    for (int k = 0; k < 3; ++k) {
      const float* a = p[k];
      const float* b = p[(k + 1) % 3];
      edge_sum += std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                            double(a[2] - b[2]) * (a[2] - b[2]));
    }
  }
  if (nf > 0) s.mean_edge_length = edge_sum / double(3 * nf);
  return s;
}

} // namespace vfit
