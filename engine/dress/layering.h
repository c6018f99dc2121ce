// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Layering several garments on one body (seed 001 §6.3, eq. 7): garments are
/// resolved inner to outer, each against the body and then against the inner garments already
/// resolved, whose surfaces it must stay outside of by a clearance k. A penetrating vertex gets
/// the target v' = v + (k + d)·n of eq. 7 (d its depth under the inner surface, n that surface's
/// outward direction at its closest point), smoothed by remove_penetration()'s Laplacian solve.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "vfit/engine/dress/penetration.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

class ProximityIndex;
class EdgeCrossingIndex;

/// One resolved garment as a surface that outer garments must stay outside of. Keeps a copy of
/// the garment's triangles oriented away from the body (the whole garment is flipped when its
/// area-weighted face normals point towards the body on balance), a proximity index over it,
/// which of its edges and corners lie on its boundary (hems, cuffs, waistbands: closest
/// points there do not count, see LayerObstacle), and its edges, which must not pierce an
/// outer garment (engine/layer_piercing.h).
class InnerLayer {
public:
  /// garment: positions #V × 3 (m) and triangles #F × 3, already resolved against the body;
  /// body: the index the garment was resolved against (decides the orientation). clearance: k
  /// of seed 001 eq. 7 (m, ≥ 0); reach: how far (m, > 0) a layer point may be from a vertex and
  /// still count. A garment with no triangles gives a layer nothing is ever inside.
  InnerLayer(const Mesh& garment, const ProximityIndex& body, double clearance, double reach);
  ~InnerLayer();
  InnerLayer(InnerLayer&&) noexcept;
  InnerLayer& operator=(InnerLayer&&) noexcept;
  InnerLayer(const InnerLayer&) = delete;
  InnerLayer& operator=(const InnerLayer&) = delete;

  /// The view remove_penetration() takes; valid while this layer lives.
  LayerObstacle obstacle() const;
  /// Whether the garment's triangles were flipped to face away from the body.
  bool flipped() const { return m_flipped; }
  /// Boundary edges of the garment (edges used by one triangle).
  std::size_t boundary_edge_count() const { return m_boundary_edges; }

private:
  std::unique_ptr<ProximityIndex> m_index;
  std::vector<float> m_points;                              ///< #V × 3, as indexed
  std::vector<std::int32_t> m_triangles;                    ///< #F × 3, oriented away from the body
  std::vector<std::int32_t> m_edges;                        ///< #E × 2 distinct edges
  std::vector<std::int32_t> m_edge_offsets, m_vertex_edges; ///< CSR: each vertex's edges
  std::vector<std::uint8_t> m_boundary;
  std::size_t m_boundary_edges = 0;
  double m_clearance = 0, m_reach = 0;
  bool m_flipped = false;
};

struct LayeringOptions {
  PenetrationOptions penetration; ///< against the body (κ, smoothness, rounds)
  double layer_clearance = 0.003; ///< k of seed 001 eq. 7 (m): gap kept outside each inner garment
  double reach = 0.05;            ///< LayerObstacle::reach (m)
};

/// Resolves `garments` in place in layer order, inner to outer: garments[0] against the body,
/// garments[i] against the body and garments[0 … i − 1] as already resolved. Order matters: a
/// garment listed later ends outside the ones before it. `body` and `crossings` index the same
/// body mesh. Returns one report per garment, in the same order (before/after count vertices
/// inside inner layers in layer_inside_count). Null entries are an error (vfit::Error).
std::vector<PenetrationReport> resolve_layers(std::span<Mesh* const> garments, const ProximityIndex& body,
                                              const EdgeCrossingIndex& crossings, const LayeringOptions& options = {});

} // namespace vfit
