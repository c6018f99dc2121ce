// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// An inner garment layer poking out through an outer garment (seed 001 §6.3): the outer
/// garment's vertices all lie outside the layer, yet a layer vertex sticks out through one of
/// its triangles between them (trousers' waistband through a tee's front after the tee has
/// settled). No vertex test of the outer garment sees it; the layer's edges crossing the
/// garment's triangles do. remove_penetration() counts them (PenetrationStats::
/// layer_crossing_edges) and pushes the pierced triangles out; this is its detection.

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "vfit/engine/dress/penetration_types.h"

namespace vfit {

struct ClosestHits;

/// One layer edge through a garment triangle, and what moves that triangle clear of it.
struct LayerPiercing {
  std::int32_t edge = -1;     ///< the layer's edge (row of LayerObstacle::edges)
  std::int32_t triangle = -1; ///< the garment triangle it passes through
  /// Displacement (m) for each corner of `triangle`: along the layer's outward normal there
  /// (the mean of its corners' closest layer faces' normals), by how far the edge's outer end
  /// lies beyond the triangle plus the layer's clearance k.
  Eigen::RowVector3d push = Eigen::RowVector3d::Zero();
};

/// Garment triangles within reach of the layer whose rings a layer edge may pierce, found
/// through the garment vertices' closest layer points (`hits`: one row per garment vertex, as
/// remove_penetration() queries them within the layer's reach; a row with no hit is out of
/// reach). Candidates: triangles with a corner closer to the layer than the triangle's
/// longest edge plus k; layer edges within two rings of the layer triangles their corners are
/// closest to. Each candidate edge is cast against the candidate triangles (an Embree
/// segment query, kernels/edge_crossings.h) and counted once (its first crossing). positions:
/// #V × 3 (m); triangles: #F × 3. A layer without points or edges (LayerObstacle built
/// without them) pierces nothing. `out` is cleared first.
void find_layer_piercings(std::span<const float> positions, std::span<const std::int32_t> triangles,
                          const LayerObstacle& layer, const ClosestHits& hits, std::vector<LayerPiercing>& out);

} // namespace vfit
