// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Geometric summary of a mesh: bounding box, extent, area, edge lengths, zero-area faces.

#include <array>
#include <cstddef>

#include "mesh.h"

namespace vfit {

struct MeshStats {
  /// The box of the vertices the faces use (every vertex when there are no faces: a point
  /// cloud); a vertex no face uses does not count here, nor in the extent and coordinate below.
  std::array<float, 3> bbox_min{0, 0, 0};
  std::array<float, 3> bbox_max{0, 0, 0};
  float largest_extent = 0;        ///< max over axes of bbox_max − bbox_min (file units)
  float max_abs_coordinate = 0;    ///< max over counted vertices and axes of |coordinate| (file units)
  double surface_area = 0;         ///< Σ triangle areas (file units²)
  double mean_edge_length = 0;     ///< over triangle corners' edges (shared edges counted twice)
  std::size_t zero_area_faces = 0; ///< faces of area below 1e-12 × extent² (collinear corners)
};

/// Computes the stats of a validated mesh. An empty mesh gives all zeros.
MeshStats mesh_stats(const Mesh& mesh);

} // namespace vfit
