// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Penetration removal and measurement with the garment's topology built beforehand: the entry
/// points behind penetration.h's functions, for a caller that removes and measures one garment
/// many times (Dresser). Internal to engine/dress/.

#include <span>

#include "vfit/engine/dress/detection.h"
#include "vfit/engine/dress/penetration_types.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/laplacian.h"

namespace vfit {

class EdgeCrossingIndex;
class ProximityIndex;

namespace dress {

/// What removal needs of a garment's connectivity: its uniform Laplacian (#V × #V) and its
/// edges (GarmentEdges), built once from its triangles. Valid for any positions of the same
/// triangles.
struct GarmentTopology {
  explicit GarmentTopology(const Mesh& garment);
  SparseMatrix laplacian;
  GarmentEdges edges;
};

/// remove_penetration() (penetration.h); `crossings` null: vertex tests only. `topology`:
/// the garment's, built beforehand, or null to build it here.
PenetrationReport remove(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex* crossings,
                         std::span<const LayerObstacle> layers, const PenetrationOptions& options,
                         const GarmentTopology* topology);

/// measure_penetration() with crossings and layers (penetration.h); `topology` as for remove().
PenetrationStats measure(const Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                         std::span<const LayerObstacle> layers, double clearance, const GarmentTopology* topology);

} // namespace dress
} // namespace vfit
