// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The per-frame clean-up of a dressed character (seed 001 §6.3 eq. 7 and §7): after the blend
/// of a frame, each garment, inner first, is
/// 1. pushed out of the posed body: a vertex inside it (signed distance < 0, at any depth: the
///    query searches as far as last frame's closest point, carried onto this frame's body,
///    bounds the distance, without limit on the first frame) moves onto its closest body point
///    plus `body_gap` along the outward direction;
/// 2. cleared of edges through the body: an edge whose two ends are outside but whose middle
///    crosses a limb (an armpit pinched by the skinning, a thigh through a skirt's panel) is
///    found by a segment test (only edges no longer than their ends' distances to the body
///    summed can cross, the distance being 1-Lipschitz), and both ends are moved along the
///    outward direction at the middle of the chord inside by that point's depth plus
///    `body_gap` (for a convex cross-section this carries the whole chord out); repeated for the
///    edges around moved vertices, up to `crossing_rounds` times;
/// 3. layered (eq. 7): a vertex inside a garment under it (its signed distance to that garment,
///    oriented away from the body, below 0; a closest point on the inner garment's hem, cuff or
///    waistband does not count, as in the fit) moves to that garment's surface plus the
///    clearance k: v' = v + (k + d)·n, innermost garment first; then the inner garment's edges
///    that still pierce this garment's triangles (find_layer_piercings(), as the fit finds
///    them) move those triangles' corners clear, up to `crossing_rounds` times.
/// What is left is counted, never hidden: vertices still more than 1 mm inside, edges still
/// through the body. The clean-up moves vertices only (no solve, no smoothing), so it costs
/// O((#V + #E_candidates) · log #F) per garment per frame; its buffers are reused from frame to
/// frame (the layer-piercing test, find_layer_piercings(), allocates its own).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "vfit/engine/dress/layer_piercing.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/proximity.h"

namespace vfit {

struct FrameCleanupOptions {
  double body_gap = 0.001;        ///< m: where a vertex pushed out of the body ends, outside it
  double layer_clearance = 0.003; ///< k of eq. 7 (m): where a vertex pushed out of a layer ends
  float reach = 0.05f;            ///< m: the layer queries' radius, and the moved vertices' body queries
  int crossing_rounds = 8;        ///< rounds of the edge test and push
};

/// What one garment's clean-up did and left.
struct FrameCleanupCounts {
  std::size_t body_pushed = 0;            ///< vertices pushed out of the body
  std::size_t crossings_pushed = 0;       ///< edges through the body whose ends were moved
  std::size_t layer_pushed = 0;           ///< vertices pushed out of a garment under them
  std::size_t layer_piercings_pushed = 0; ///< inner garments' edges through this one, moved clear
  std::size_t left_inside_1mm = 0;        ///< vertices more than 1 mm inside the body afterwards
  std::size_t left_crossing = 0;          ///< edges still through the body afterwards
  double body_ms = 0;                     ///< wall time of steps 1–2 (ms)
  double layering_ms = 0;                 ///< wall time of step 3 and the layer's refit (ms)
};

/// The body (indexed once, refitted per frame) and the garments as layers (each indexed once
/// over its oriented triangles, refitted per frame once it is clean).
class FrameCleanup {
public:
  /// body: the naked body at rest (#B × 3 m, closed and outward, or with holes capped as the
  /// proximity core does); garments: each garment at rest, inner first, in the same pose. Their
  /// orientation as layers (away from the body) is decided here, at rest. Throws vfit::Error for
  /// a mesh the indices refuse.
  FrameCleanup(const Mesh& body, std::span<const Mesh* const> garments, const FrameCleanupOptions& options = {});

  /// Moves the body to this frame's positions (#B × 3, m). Call before clean().
  void refit_body(std::span<const float> positions);
  /// The body's index, as last refitted, shared with whoever else queries the posed body (the
  /// cloths: ClothSim::set_body(index, …)), so it is refitted once per frame.
  const std::shared_ptr<ProximityIndex>& body() const { return m_body; }

  /// Cleans garment g's `positions` (#V_g × 3, m) in place against the body and the garments
  /// 0 … g − 1 as last cleaned, then makes them garment g's layer for the garments after it
  /// (the outermost garment's layer is not refitted: nothing lies outside it).
  /// Call for g = 0, 1, … in order each frame.
  FrameCleanupCounts clean(std::size_t g, std::span<float> positions);

private:
  struct Layer {
    std::vector<std::int32_t> triangles_as_given;         // the garment's own
    std::vector<std::int32_t> triangles;                  // oriented away from the body
    std::vector<std::uint8_t> boundary;                   // LayerObstacle::boundary
    std::vector<std::int32_t> edges;                      // #E × 2
    std::vector<std::int32_t> edge_offsets, vertex_edges; // CSR: each vertex's edge rows
    ProximityIndex index;
  };
  // One round of the edge test over m_edge_rows; pushes (when `push`) and returns the edges
  // found crossing.
  std::size_t crossing_round(const Layer& layer, std::span<float> x, bool push);

  // Per garment, last frame's closest body and layer triangles and barycentrics: carried onto
  // this frame's surface they bound each vertex's closest distance, so a query searches only
  // that far (an exact bound: the carried point lies on the surface) instead of without limit.
  struct Previous {
    std::vector<std::int32_t> triangles;
    std::vector<float> barycentrics;
  };
  // Closest points of x on `index` (positions `surface`, triangles `triangles`) within `cap`
  // (m, or +∞), searched within the bound `previous` gives; `previous` updated to the answers.
  void query(const ProximityIndex& index, std::span<const float> surface, std::span<const std::int32_t> triangles,
             std::span<const float> x, float cap, Previous& previous, ClosestHits& hits);

  FrameCleanupOptions m_options;
  std::vector<std::int32_t> m_body_triangles;
  std::vector<float> m_body_positions;
  std::vector<std::vector<float>> m_layer_positions;
  std::vector<Previous> m_previous_body;
  std::vector<std::vector<Previous>> m_previous_layer; // [garment][inner layer]
  std::vector<float> m_radii;
  std::shared_ptr<ProximityIndex> m_body;
  std::vector<Layer> m_layers;
  // Scratch, sized on the first frame.
  ClosestHits m_hits, m_sub_hits;
  SegmentHits m_forward, m_backward;
  std::vector<float> m_points, m_from, m_to, m_push, m_distance;
  std::vector<std::int32_t> m_rows, m_edge_rows, m_moved;
  std::vector<char> m_moved_flag, m_edge_flag;
  std::vector<LayerPiercing> m_piercings;
};

} // namespace vfit
