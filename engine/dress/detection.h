// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Detection for penetration removal (seed 000 §6.2, eq. 18; seed 001 §6.3): where a garment
/// stands against the body and its inner layers, detected once per round and then again only
/// for the vertices a solve moved. Internal to engine/dress/ (penetration.cpp and pushes.cpp).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "vfit/engine/dress/layer_piercing.h"
#include "vfit/engine/dress/penetration_types.h"
#include "vfit/kernels/laplacian.h"
#include "vfit/kernels/proximity.h"

namespace vfit {

class EdgeCrossingIndex;

namespace dress {

// measure_penetration(positions, body)'s reach (m): a vertex with no body point this close is
// queried again without a limit (it has no crossing index for a ray: resolve_far_vertices()).
inline constexpr float NEAR_SEARCH = 0.05f;

// Removal's reach (m): queries stop at max(NEAR_REACH, NEAR_REACH_PER_CLEARANCE·κ), beyond
// which a vertex cannot be near (it only needs its side: one ray per piece of such vertices,
// resolve_far_vertices()). A short reach makes the queries far cheaper: Embree prunes at once
// the BVH nodes beyond it (on the Table-1 garments after the coarse move, a 1 cm reach takes
// about half the time of 5 cm: docs/benchmarks.md).
inline constexpr float NEAR_REACH = 0.01f;
inline constexpr double NEAR_REACH_PER_CLEARANCE = 3.0;
inline float near_reach(double clearance) {
  return float(std::max(double(NEAR_REACH), NEAR_REACH_PER_CLEARANCE * clearance));
}

// The garment's edges (lower end first, in (lower, higher) order: mesh_edge_endpoints()'s
// order) and their reverses, so crossings can be found from either end. Read off the garment's
// uniform Laplacian, which removal builds anyway: row v's off-diagonal columns above v are the
// edges from v (sorted), a fifth of the time of a separate edge table.
// An edge of a degenerate triangle joining a vertex to itself has no Laplacian entry; it has
// no length and crosses nothing.
struct GarmentEdges {
  std::vector<std::int32_t> forward, backward;
  explicit GarmentEdges(const SparseMatrix& laplacian) {
    const auto* outer = laplacian.outerIndexPtr();
    const auto* inner = laplacian.innerIndexPtr();
    std::size_t count = 0;
    for (Eigen::Index v = 0; v < laplacian.rows(); ++v)
      for (auto k = outer[v]; k < outer[v + 1]; ++k)
        count += inner[k] > v;
    forward.reserve(2 * count);
    backward.reserve(2 * count);
    for (Eigen::Index v = 0; v < laplacian.rows(); ++v)
      for (auto k = outer[v]; k < outer[v + 1]; ++k)
        if (inner[k] > v) {
          forward.insert(forward.end(), {std::int32_t(v), std::int32_t(inner[k])});
          backward.insert(backward.end(), {std::int32_t(inner[k]), std::int32_t(v)});
        }
  }
};

// Whether a closest hit on a layer lies on the layer's boundary (hem, cuff, waistband).
bool on_layer_boundary(const LayerObstacle& layer, std::int32_t triangle, std::int8_t feature);

// Where the garment stands, detected once per round: the statistics of that round and the
// pushes of the next both come from it. After a solve only the vertices it moved (and the
// edges touching them) are detected again; the fixed region's answers stand.
struct Detection {
  // How far body queries reach (m; see NEAR_REACH), and the garment's vertex adjacency (its
  // uniform Laplacian: row v's other columns are v's neighbours) along which
  // resolve_far_vertices() joins far vertices into pieces that one ray decides; null: a ray
  // per far vertex.
  float reach = NEAR_SEARCH;
  const SparseMatrix* adjacency = nullptr;
  // Set when `body` already holds every vertex's query within `reach`: the next full detect()
  // takes it as it is (once).
  bool body_queried = false;
  // Per vertex, within `reach`. A vertex with none there is outside: triangle −1 and signed
  // distance +reach, a lower bound of its distance (those inside are queried without limit).
  ClosestHits body;
  // Per vertex: how far it moved since `body` was queried for it (m). A vertex that stays at
  // least κ outside the body (its distance minus its drift) is not queried again: its side
  // and whether it is near cannot have changed, and its distance minus the drift bounds its
  // distance from below (see may_have_changed()).
  std::vector<float> drift;
  bool crossings_checked = false;
  std::vector<std::int32_t> edge_triangles; // per edge: first body triangle crossed from its first end, or −1
  std::vector<float> edge_parameters;       // per edge: that crossing's parameter t ∈ [0, 1]
  std::vector<std::size_t> crossing;        // the edges with edge_triangles ≥ 0, ascending
  std::vector<ClosestHits> layer_hits;      // per layer, per vertex
  std::vector<std::vector<double>> layer_f; // per layer, per vertex signed distance; +∞ = does not count
  // The garment's triangles (#F × 3), for the layer edges piercing them; empty: not checked.
  std::span<const std::int32_t> triangles;
  std::vector<std::vector<LayerPiercing>> layer_piercings; // per layer
  // The garment's positions where the direct rounds began (#V × 3), against which
  // limit_stretch() measures the stretch of their crossing pushes; empty (the solved rounds):
  // not limited.
  std::span<const float> reference;
};

// Closest points of the vertices `moved` (all when null), written into their rows of `all`.
void closest_points_of(const ProximityIndex& index, std::span<const float> positions, float reach,
                       const std::vector<std::size_t>* moved, ClosestHits& all);

// A vertex with no body point within the reach is far outside, or deeper inside than that
// (a driven garment's crotch through a thigh: corpus shorts, 55–64 mm; before this they went
// uncounted and unpushed). A ray to far away decides which on a closed body: it starts inside
// iff the first face it crosses faces along it (it leaves through that face). One ray serves a
// whole piece of such vertices (`adjacency` given, body without holes): each is the centre of a
// ball of radius `reach` free of the body's surface, and two neighbours whose balls overlap
// (closer than twice the reach) are joined by an edge that crosses no surface, so they lie on
// the same side. (Sides are not spread from the vertices with hits: on a posed body that
// intersects itself, an arm pressed into the torso, the closest sheet's pseudo-normal can call
// a point outside that lies inside the other sheet; measured on the corpus overalls, that left a
// vertex 11 mm inside.) Without a crossing index every far vertex is taken as possibly inside
// (slower: a full query each). Those inside are queried again without a limit, so every vertex inside
// has a hit and its depth; those outside get f = +reach, a lower bound of their distance.
// `subset`: the vertices just queried (null: all).
inline constexpr float FAR_RAY_LENGTH = 1000.0f; // m: beyond any body
void resolve_far_vertices(std::span<const float> positions, const ProximityIndex& body,
                          const EdgeCrossingIndex* crossings, const std::vector<std::size_t>* subset, float reach,
                          const SparseMatrix* adjacency, ClosestHits& all);

// Signed distance of each vertex to a layer, +∞ where the layer does not count (out of reach,
// or the closest point on its boundary).
void detect_layer(std::span<const float> positions, const LayerObstacle& layer, const std::vector<std::size_t>* moved,
                  ClosestHits& hits, std::vector<double>& f);

// Edges crossing the body. An edge a–b of length ℓ crossing the surface at p has
// |a − p| + |p − b| = ℓ, and |a − p| ≥ d(a), |p − b| ≥ d(b) for the ends' distances to the
// body, so d(a) + d(b) ≤ ℓ: edges with a larger sum are skipped without a ray (most of a loose
// garment, and on a tight one the edges whose ends both keep about half their length off the
// body), which leaves the count exact. With `moved_flags`, only edges with a moved end are
// looked at again.
void detect_crossings(std::span<const float> positions, const ClosestHits& hits, std::span<const float> drift,
                      const EdgeCrossingIndex& crossings, const GarmentEdges& edges,
                      const std::vector<char>* moved_flags, Detection& d);

// Detects everything (moved = null) or again for the vertices in `moved` only (moved_flags:
// the same set as per-vertex flags).
// `requery` (when `moved` is given): the moved vertices whose body hit must be queried again.
void detect(std::span<const float> positions, const ProximityIndex& body, const EdgeCrossingIndex* crossings,
            const GarmentEdges* edges, std::span<const LayerObstacle> layers, const std::vector<std::size_t>* moved,
            const std::vector<char>* moved_flags, const std::vector<std::size_t>* requery, Detection& d);

// Whether a vertex that moved by `moved` (m) may have changed side or come within κ of the body,
// so that its body hit must be queried again: unless it was outside and its distance bound
// minus the move stays at least κ. A vertex that stays ≥ κ outside is neither inside nor near in
// the statistics (its stale signed distance is larger still), is pushed by no vertex rule, and
// the crossing filter uses the bound, so every count stays exact on a body whose signed
// distance is continuous (a closed body that does not intersect itself: ProximityIndex's
// contract; see refresh_skipped() in remove() for the others). A vertex with no hit within the
// reach is outside (those inside have hits: resolve_far_vertices()), and the reach is its
// bound. (Skipping every vertex that stays outside, near or not, saves little more — the near
// ones are few — and lets more side flips of self-intersecting posed bodies go unseen between
// refreshes.)
bool may_have_changed(const Detection& d, std::size_t v, float moved, double clearance);

PenetrationStats vertex_stats(const ClosestHits& hits, double clearance);

PenetrationStats stats_of(const Detection& d, double clearance);

} // namespace dress
} // namespace vfit
