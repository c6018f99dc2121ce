#include "penetration.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>
#include <tuple>
#include <type_traits>

#include "engine/layer_piercing.h"
#include "kernels/edge_crossings.h"
#include "kernels/laplacian.h"
#include <Eigen/SparseCholesky>

#include "kernels/error.h"
#include "kernels/parallel.h"
#include "kernels/proximity.h"

#include <tbb/parallel_invoke.h>

namespace vfit {
namespace {

// measure_penetration(positions, body)'s reach (m): a vertex with no body point this close is
// queried again without a limit (it has no crossing index for a ray: resolve_far_vertices()).
constexpr float NEAR_SEARCH = 0.05f;

// Removal's reach (m): queries stop at max(NEAR_REACH, NEAR_REACH_PER_CLEARANCE·κ), beyond
// which a vertex cannot be near (it only needs its side: one ray per piece of such vertices,
// resolve_far_vertices()). A short reach makes the queries far cheaper: Embree prunes at once
// the BVH nodes beyond it. Measured on the Table-1 garments after the coarse move (medians 3–20 mm
// from the body), one thread: Shorts 1's 8,196 queries take 6.1 ms within 5 cm, 3.5 within 2 cm
// and 2.8 within 1 cm; Shirt 2's 3,550 take 3.2, 2.3 and 1.2 ms.
constexpr float NEAR_REACH = 0.01f;
constexpr double NEAR_REACH_PER_CLEARANCE = 3.0;
float near_reach(double clearance) { return float(std::max(double(NEAR_REACH), NEAR_REACH_PER_CLEARANCE * clearance)); }

using Row = Eigen::RowVector3d;

// The garment's edges (lower end first, in (lower, higher) order: mesh_edge_endpoints()'s
// order) and their reverses, so crossings can be found from either end. Read off the garment's
// uniform Laplacian, which removal builds anyway: row v's off-diagonal columns above v are the
// edges from v (sorted), a fifth of the time of a separate edge table (Table-1 Shorts 1: 1.4 ms).
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

Row row_of(std::span<const float> p, std::size_t i) { return Row(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

// Per-vertex displacement wanted this round; a vertex keeps the largest one proposed.
struct Pushes {
  std::vector<Row> displacement;
  std::vector<char> flagged;
  explicit Pushes(std::size_t n) : displacement(n, Row::Zero()), flagged(n, 0) {}
  void propose(std::size_t v, const Row& d) {
    if (flagged[v] && displacement[v].squaredNorm() >= d.squaredNorm()) return;
    displacement[v] = d;
    flagged[v] = 1;
  }
  bool any() const {
    return std::any_of(flagged.begin(), flagged.end(), [](char f) { return f != 0; });
  }
};

// Vertex targets: κ outside the closest body point, along the side (seed 000 eq. 18–19), for
// vertices whose signed distance is below `threshold`.
void push_vertices(std::span<const float> positions, const ClosestHits& hits, double clearance, double threshold,
                   Pushes& pushes) {
  for (std::size_t v = 0; v < hits.size(); ++v) {
    const double d = hits.triangles[v] >= 0 ? hits.signed_distances[v] : INFINITY;
    if (!(d < threshold)) continue;
    const Row y = row_of(positions, v), h = row_of(hits.points, v);
    const Row dir = y - h;
    const double len = dir.norm();
    if (len <= 1e-9) continue; // on the surface: no side to push towards
    // Outward: from the closest point towards the vertex when outside, away from it when inside.
    pushes.propose(v, h + clearance * dir * ((d < 0 ? -1.0 : 1.0) / len) - y);
  }
}

// How far outside the body a crossing edge's chord is pushed: half of κ, since both of its ends
// are already outside (a smaller margin took up to 22 rounds on the corpus outfits, for the
// same stretch), and a floor so a zero κ (seed 004) still clears the surface.
double crossing_margin(double clearance) { return std::max(0.5 * clearance, 1e-4); }

// Whether a closest hit on a layer lies on the layer's boundary (hem, cuff, waistband).
bool on_layer_boundary(const LayerObstacle& layer, std::int32_t triangle, std::int8_t feature) {
  const std::uint8_t mask = layer.boundary[std::size_t(triangle)];
  const auto f = static_cast<TriangleFeature>(feature);
  if (f >= TriangleFeature::EDGE_0 && f <= TriangleFeature::EDGE_2)
    return (mask >> (int(feature) - int(TriangleFeature::EDGE_0))) & 1u;
  if (f >= TriangleFeature::VERTEX_0 && f <= TriangleFeature::VERTEX_2)
    return (mask >> (3 + int(feature) - int(TriangleFeature::VERTEX_0))) & 1u;
  return false;
}

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

// How far a direct round's crossing push may stretch the garment (see limit_stretch()): an edge
// may grow to STRETCH_LIMIT times its length where the direct rounds began, or by κ when that is
// more.
constexpr double STRETCH_LIMIT = 1.5;

// Scales down the crossing pushes `proposed` (their ends' displacements) so that no edge at a
// pushed vertex grows past STRETCH_LIMIT times its length in d.reference (or by κ, when that
// is more). The direct rounds move each vertex by its push as it is, with no Laplacian term
// holding it to its neighbours, round after round, so pushes that trade an edge's crossing
// back and forth walk a vertex far out: measured (stop 26) on the 63 corpus fits of the corpus
// test's three poses without the simulation, the worksuit's tee on arms_down had a sleeve
// vertex squeezed between arm and torso carried 25 cm out in front (80 edge sides torn, up to
// 317 mm), a skirt's hem on knee_bent 280 mm, a shirt 146 mm; with `vfit fit`'s own rig a
// shirt's collar point was drawn 44 cm out. With the limit: at most 105 mm (the solved rounds'
// pushes of vertices deep inside, which this does not touch), and the edges the limit leaves
// crossing (412 against 232 over the 63) are resolved by the simulation and the cleanup after
// it (0 left after the fit, as before). An edge the push shortens, or keeps within the limit,
// leaves the push as it is; one already past the limit stops a push that lengthens it. A
// neighbour's own push counts as proposed.
void limit_stretch(std::span<const float> positions, const Detection& d, double clearance, Pushes& proposed) {
  if (d.reference.empty() || !d.adjacency) return;
  const SparseMatrix& L = *d.adjacency;
  std::vector<double> scale(proposed.flagged.size(), 1.0);
  for (std::size_t v = 0; v < proposed.flagged.size(); ++v) {
    if (!proposed.flagged[v]) continue;
    const Row dv = proposed.displacement[v];
    const double a = dv.squaredNorm();
    if (a <= 0) continue;
    double t = 1.0;
    for (SparseMatrix::InnerIterator it(L, Eigen::Index(v)); it; ++it) {
      const auto u = std::size_t(it.col());
      if (u == v) continue;
      const Row du = proposed.flagged[u] ? proposed.displacement[u] : Row::Zero();
      const Row c = row_of(positions, v) - row_of(positions, u) - du;
      const double rest = (row_of(d.reference, v) - row_of(d.reference, u)).norm();
      const double limit = std::max(STRETCH_LIMIT * rest, rest + clearance);
      const double after = (c + dv).norm();
      if (after <= limit || after <= c.norm()) continue; // within the limit, or shortened
      if (c.norm() >= limit) {
        t = 0;
        break;
      }
      // |c + t·dv| = limit for the t in (0, 1): c is inside the ball of that radius, c + dv out.
      const double b = c.dot(dv), cc = c.squaredNorm() - limit * limit;
      t = std::min(t, (-b + std::sqrt(std::max(0.0, b * b - a * cc))) / a);
    }
    scale[v] = std::clamp(t, 0.0, 1.0);
  }
  for (std::size_t v = 0; v < scale.size(); ++v) {
    if (!proposed.flagged[v] || scale[v] >= 1.0) continue;
    proposed.displacement[v] *= scale[v];
    if (scale[v] <= 0) proposed.flagged[v] = 0;
  }
}

// Closest points of the vertices `moved` (all when null), written into their rows of `all`.
void closest_points_of(const ProximityIndex& index, std::span<const float> positions, float reach,
                       const std::vector<std::size_t>* moved, ClosestHits& all) {
  if (!moved) {
    index.closest_points(positions, reach, all);
    return;
  }
  // The previous closest point lies on the surface, so the new distance is at most the
  // vertex's distance to it: searching within that radius (plus float slack: the stored point
  // carries ~1e-7 m of rounding) finds the same closest distance (ties between equally close
  // triangles may go to another one) while Embree prunes more of its traversal than with the
  // full reach.
  std::vector<float> queries, radii;
  queries.reserve(3 * moved->size());
  radii.reserve(moved->size());
  for (std::size_t v : *moved) {
    queries.insert(queries.end(), {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
    float radius = reach;
    if (all.triangles[v] >= 0) {
      const float bound = float((row_of(positions, v) - row_of(all.points, v)).norm());
      radius = std::min(reach, bound * (1.0f + 1e-5f) + 1e-6f);
    }
    radii.push_back(radius);
  }
  ClosestHits part;
  index.closest_points(queries, radii, part);
  for (std::size_t k = 0; k < moved->size(); ++k)
    all.copy_row((*moved)[k], part, k);
}

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
// (slower: ~5 µs each). Those inside are queried again without a limit, so every vertex inside
// has a hit and its depth; those outside get f = +reach, a lower bound of their distance.
// `subset`: the vertices just queried (null: all).
constexpr float FAR_RAY_LENGTH = 1000.0f; // m: beyond any body
void resolve_far_vertices(std::span<const float> positions, const ProximityIndex& body,
                          const EdgeCrossingIndex* crossings, const std::vector<std::size_t>* subset, float reach,
                          const SparseMatrix* adjacency, ClosestHits& all) {
  std::vector<std::size_t> far;
  if (subset) {
    for (std::size_t v : *subset)
      if (all.triangles[v] < 0) far.push_back(v);
  } else {
    for (std::size_t v = 0; v < all.size(); ++v)
      if (all.triangles[v] < 0) far.push_back(v);
  }
  if (far.empty()) return;
  // Per far vertex (by its index in `far`), the representative whose ray decides its side.
  std::vector<std::size_t> decided_by(far.size());
  std::vector<std::size_t> unreached; // the representatives
  if (adjacency && body.hole_count() == 0) {
    // Slack for the float rounding of Embree's pruning at the reach (~1e-7 relative).
    const double joined = 2.0 * (double(reach) * (1.0 - 1e-5) - 1e-7);
    std::vector<std::int32_t> slot(all.size(), -1); // far vertex → its index in `far`
    for (std::size_t k = 0; k < far.size(); ++k)
      slot[far[k]] = std::int32_t(k);
    std::vector<char> seen(far.size(), 0);
    const auto* outer = adjacency->outerIndexPtr();
    const auto* inner = adjacency->innerIndexPtr();
    std::vector<std::size_t> queue;
    for (std::size_t k0 = 0; k0 < far.size(); ++k0) {
      if (seen[k0]) continue;
      seen[k0] = 1;
      decided_by[k0] = unreached.size();
      unreached.push_back(far[k0]);
      queue.assign(1, far[k0]);
      for (std::size_t head = 0; head < queue.size(); ++head) {
        const std::size_t u = queue[head];
        for (auto k = outer[u]; k < outer[u + 1]; ++k) {
          const std::int32_t w = slot[std::size_t(inner[k])];
          if (w < 0 || seen[std::size_t(w)] ||
              (row_of(positions, u) - row_of(positions, far[std::size_t(w)])).norm() >= joined)
            continue;
          seen[std::size_t(w)] = 1;
          decided_by[std::size_t(w)] = decided_by[k0];
          queue.push_back(far[std::size_t(w)]);
        }
      }
    }
  } else {
    unreached = far;
    for (std::size_t k = 0; k < far.size(); ++k)
      decided_by[k] = k;
  }
  // Per representative: inside.
  std::vector<char> in(unreached.size(), 1);
  if (crossings) {
    // Not along an axis or a diagonal, so rays rarely run along a body's edges (the robust
    // intersection mode counts such a ray once anyway).
    const Row dir = Row(0.267, 0.535, 0.802).normalized();
    std::vector<float> points;
    std::vector<std::int32_t> rays;
    points.reserve(6 * unreached.size());
    rays.reserve(2 * unreached.size());
    for (std::size_t k = 0; k < unreached.size(); ++k) {
      const Row a = row_of(positions, unreached[k]), b = a + double(FAR_RAY_LENGTH) * dir;
      points.insert(points.end(), {float(a.x()), float(a.y()), float(a.z()), float(b.x()), float(b.y()), float(b.z())});
      rays.insert(rays.end(), {std::int32_t(2 * k), std::int32_t(2 * k + 1)});
    }
    SegmentCrossings first;
    crossings->first_crossings(points, rays, first);
    for (std::size_t k = 0; k < unreached.size(); ++k) {
      in[k] = 0;
      if (first.triangles[k] < 0) continue;
      float n[3];
      crossings->face_normal(first.triangles[k], n);
      in[k] = n[0] * dir.x() + n[1] * dir.y() + n[2] * dir.z() > 0;
    }
  }
  std::vector<std::size_t> inside;
  for (std::size_t k = 0; k < far.size(); ++k) {
    if (in[decided_by[k]])
      inside.push_back(far[k]);
    else
      all.signed_distances[far[k]] = reach; // outside, at least this far
  }
  if (inside.empty()) return;
  std::vector<float> queries;
  queries.reserve(3 * inside.size());
  for (std::size_t v : inside)
    queries.insert(queries.end(), {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
  ClosestHits part;
  body.closest_points(queries, INFINITY, part);
  for (std::size_t k = 0; k < inside.size(); ++k)
    all.copy_row(inside[k], part, k);
}

// Signed distance of each vertex to a layer, +∞ where the layer does not count (out of reach,
// or the closest point on its boundary).
void detect_layer(std::span<const float> positions, const LayerObstacle& layer, const std::vector<std::size_t>* moved,
                  ClosestHits& hits, std::vector<double>& f) {
  closest_points_of(*layer.surface, positions, float(layer.reach), moved, hits);
  f.resize(hits.size());
  auto update = [&](std::size_t v) {
    const bool counts = hits.triangles[v] >= 0 && !on_layer_boundary(layer, hits.triangles[v], hits.features[v]);
    f[v] = counts ? double(hits.signed_distances[v]) : double(INFINITY);
  };
  if (moved)
    for (std::size_t v : *moved)
      update(v);
  else
    for (std::size_t v = 0; v < hits.size(); ++v)
      update(v);
}

// Edges crossing the body. An edge a–b of length ℓ crossing the surface at p has
// |a − p| + |p − b| = ℓ, and |a − p| ≥ d(a), |p − b| ≥ d(b) for the ends' distances to the
// body, so d(a) + d(b) ≤ ℓ: edges with a larger sum are skipped without a ray (most of a loose
// garment, and on a tight one the edges whose ends both keep about half their length off the
// body), which leaves the count exact. With `moved_flags`, only edges with a moved end are
// looked at again.
void detect_crossings(std::span<const float> positions, const ClosestHits& hits, std::span<const float> drift,
                      const EdgeCrossingIndex& crossings, const GarmentEdges& edges,
                      const std::vector<char>* moved_flags, Detection& d) {
  const std::size_t ne = edges.forward.size() / 2;
  if (!moved_flags) {
    d.edge_triangles.assign(ne, -1);
    d.edge_parameters.assign(ne, INFINITY);
  }
  std::vector<std::size_t> candidates;
  std::vector<std::int32_t> rows;
  for (std::size_t e = 0; e < ne; ++e) {
    const auto a = std::size_t(edges.forward[2 * e]), b = std::size_t(edges.forward[2 * e + 1]);
    if (moved_flags && !(*moved_flags)[a] && !(*moved_flags)[b]) continue;
    d.edge_triangles[e] = -1;
    d.edge_parameters[e] = INFINITY;
    auto distance = [&](std::size_t v) { // a lower bound of the vertex's distance to the body
      return std::fabs(double(hits.signed_distances[v])) - double(drift[v]);
    };
    const double length = (row_of(positions, a) - row_of(positions, b)).norm() + 2e-6; // + float slack
    if (distance(a) + distance(b) > length) continue;
    candidates.push_back(e);
    rows.insert(rows.end(), {edges.forward[2 * e], edges.forward[2 * e + 1]});
  }
  SegmentCrossings found;
  crossings.first_crossings(positions, rows, found);
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    d.edge_triangles[candidates[k]] = found.triangles[k];
    d.edge_parameters[candidates[k]] = found.parameters[k];
  }
  d.crossing.clear();
  for (std::size_t e = 0; e < ne; ++e)
    if (d.edge_triangles[e] >= 0) d.crossing.push_back(e);
  d.crossings_checked = true;
}

// Detects everything (moved = null) or again for the vertices in `moved` only (moved_flags:
// the same set as per-vertex flags).
// `requery` (when `moved` is given): the moved vertices whose body hit must be queried again.
void detect(std::span<const float> positions, const ProximityIndex& body, const EdgeCrossingIndex* crossings,
            const GarmentEdges* edges, std::span<const LayerObstacle> layers, const std::vector<std::size_t>* moved,
            const std::vector<char>* moved_flags, const std::vector<std::size_t>* requery, Detection& d) {
  if (moved || !d.body_queried) closest_points_of(body, positions, d.reach, moved ? requery : nullptr, d.body);
  d.body_queried = false;
  resolve_far_vertices(positions, body, crossings, moved ? requery : nullptr, d.reach, d.adjacency, d.body);
  if (!moved)
    d.drift.assign(positions.size() / 3, 0.0f);
  else
    for (std::size_t v : *requery)
      d.drift[v] = 0.0f;
  if (crossings) detect_crossings(positions, d.body, d.drift, *crossings, *edges, moved ? moved_flags : nullptr, d);
  d.layer_hits.resize(layers.size());
  d.layer_f.resize(layers.size());
  d.layer_piercings.resize(layers.size());
  for (std::size_t l = 0; l < layers.size(); ++l) {
    detect_layer(positions, layers[l], moved, d.layer_hits[l], d.layer_f[l]);
    // Found afresh every time: a solve moves triangles that vertices it did not move share.
    find_layer_piercings(positions, d.triangles, layers[l], d.layer_hits[l], d.layer_piercings[l]);
  }
}

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
bool may_have_changed(const Detection& d, std::size_t v, float moved, double clearance) {
  const float bound = d.body.signed_distances[v] - d.drift[v];
  return !(double(bound - moved) >= clearance && bound > 0);
}

PenetrationStats vertex_stats(const ClosestHits& hits, double clearance) {
  PenetrationStats s;
  double depth_sum = 0;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (hits.triangles[i] < 0) continue;
    const double d = hits.signed_distances[i];
    if (d < clearance) ++s.near_count;
    if (d < 0) {
      ++s.inside_count;
      depth_sum += -d;
      s.max_depth = std::max(s.max_depth, -d);
    }
  }
  if (s.inside_count) s.mean_depth = depth_sum / double(s.inside_count);
  return s;
}

PenetrationStats stats_of(const Detection& d, double clearance) {
  PenetrationStats s = vertex_stats(d.body, clearance);
  s.crossings_checked = d.crossings_checked;
  s.crossing_edges = d.crossing.size();
  std::vector<char> inside(d.body.size(), 0);
  for (const std::vector<double>& f : d.layer_f)
    for (std::size_t v = 0; v < f.size(); ++v)
      if (f[v] < 0) {
        inside[v] = 1;
        s.layer_max_depth = std::max(s.layer_max_depth, -f[v]);
      }
  s.layer_inside_count = std::size_t(std::count(inside.begin(), inside.end(), char(1)));
  for (const std::vector<LayerPiercing>& p : d.layer_piercings)
    s.layer_crossing_edges += p.size();
  return s;
}

// Crossing edges whose ends are both outside (an end inside is the vertex push's job, and
// moving it out often ends the crossing): the inside chord [t₁, t₂] must leave the body. Its
// midpoint at parameter s needs a displacement δ; moving the ends by δ_a, δ_b moves it by
// (1 − s)·δ_a + s·δ_b, and the smallest such pair is δ_a = δ(1 − s)/w, δ_b = δ·s/w with
// w = (1 − s)² + s²: the end nearer the chord moves more, the far end little.
void push_crossing_edges(std::span<const float> positions, const ProximityIndex& body,
                         const EdgeCrossingIndex& crossings, const GarmentEdges& edges, const Detection& d,
                         double clearance, Pushes& pushes) {
  auto inside = [&](std::int32_t v) {
    return d.body.triangles[std::size_t(v)] >= 0 && d.body.signed_distances[std::size_t(v)] < 0;
  };
  // Outward direction at a vertex's closest body point (both ends are outside), from a hit
  // taken where the vertex is now (no drift); zero otherwise.
  auto outward = [&](std::size_t v) -> Row {
    if (d.body.triangles[v] < 0 || d.drift[v] > 0) return Row::Zero();
    const Row dir = row_of(positions, v) - row_of(d.body.points, v);
    const double len = dir.norm();
    return len > 1e-9 ? Row(dir / len) : Row::Zero();
  };
  auto opposite_sides = [&](std::size_t a, std::size_t b) { return outward(a).dot(outward(b)) < 0; };
  // Whether the faces a chord enters (from a) and leaves (first crossed from b) through face
  // away from each other; a chord with no second crossing counts as a sheet (the old rule).
  auto opposed_faces = [&](std::int32_t enter, std::int32_t leave) {
    if (enter < 0 || leave < 0) return true;
    float n[3], m[3];
    crossings.face_normal(enter, n);
    crossings.face_normal(leave, m);
    return n[0] * m[0] + n[1] * m[1] + n[2] * m[2] < 0;
  };
  std::vector<std::size_t> rows; // indices into d.crossing of the edges with both ends outside
  std::vector<std::int32_t> reversed;
  for (std::size_t k = 0; k < d.crossing.size(); ++k) {
    const std::size_t e = d.crossing[k];
    if (inside(edges.forward[2 * e]) || inside(edges.forward[2 * e + 1])) continue;
    rows.push_back(k);
    reversed.insert(reversed.end(), {edges.backward[2 * e], edges.backward[2 * e + 1]});
  }
  if (rows.empty()) return;
  SegmentCrossings from_b;
  crossings.first_crossings(positions, reversed, from_b);
  std::vector<float> midpoints;
  std::vector<double> at(rows.size()), leave_at(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::size_t e = d.crossing[rows[i]];
    const Row a = row_of(positions, std::size_t(edges.forward[2 * e]));
    const Row b = row_of(positions, std::size_t(edges.forward[2 * e + 1]));
    const double enter = d.edge_parameters[e];
    const double leave = from_b.triangles[i] >= 0 ? 1.0 - from_b.parameters[i] : enter;
    at[i] = 0.5 * (enter + std::max(enter, leave));
    leave_at[i] = leave;
    const Row m = a + at[i] * (b - a);
    midpoints.insert(midpoints.end(), {float(m.x()), float(m.y()), float(m.z())});
  }
  ClosestHits hits;
  body.closest_points(midpoints, INFINITY, hits);
  const double margin = crossing_margin(clearance);
  Pushes proposed(pushes.flagged.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::size_t e = d.crossing[rows[i]];
    const Row m = row_of(midpoints, i), h = row_of(hits.points, i);
    const Row a_end = row_of(positions, std::size_t(edges.forward[2 * e]));
    const Row b_end = row_of(positions, std::size_t(edges.forward[2 * e + 1]));
    // A chord deeper than its edge is long is a garment passing through a limb, not grazing
    // the body: no local push fixes it, and pushing toward the nearest surface can carry the
    // ends through the limb. Left alone (and counted).
    if (hits.triangles[i] >= 0 && hits.signed_distances[i] < 0 && (h - m).norm() > (b_end - a_end).norm()) continue;
    // An edge whose ends lie on opposite sides of the body (outward directions at their closest
    // points more than 90° apart) with an inside chord shorter than κ passes through a sheet of
    // body thinner than the clearance: a fold of the body's skin (linear blend skinning
    // squeezes an armpit or the back of a bent knee into a thin web), not anatomy. Pushing it
    // to one side pushes its neighbours through the web (measured on the Table-1 shirts: the
    // same ~20 edges crossed for 15 rounds). Left alone (and counted).
    // A sheet is told from a graze by the faces the chord enters and leaves through: a sheet's
    // two sides face away from each other, while an edge grazing a convex bulge (between two
    // ends on opposite sides of a limb, e.g. across an armpit) enters and leaves through faces
    // that face nearly the same way, and is pushed (corpus blazer and overalls after
    // simulation: chords of 1.5 mm, 0.05–0.1 mm deep, left by the sheet rule alone).
    if (const double chord = std::max(0.0, leave_at[i] - d.edge_parameters[e]) * (b_end - a_end).norm();
        chord < clearance && opposite_sides(std::size_t(edges.forward[2 * e]), std::size_t(edges.forward[2 * e + 1])) &&
        opposed_faces(d.edge_triangles[e], from_b.triangles[i]))
      continue;
    Row push;
    if (hits.triangles[i] >= 0 && hits.signed_distances[i] < 0 && (h - m).norm() > 1e-9) {
      push = (h - m) * (((h - m).norm() + margin) / (h - m).norm());
    } else {
      // The chord's midpoint is outside (the edge enters and leaves twice): push along the
      // first crossed face's normal until the deeper end is the margin in front of that face.
      float n[3];
      crossings.face_normal(d.edge_triangles[e], n);
      const Row normal(n[0], n[1], n[2]);
      const Row a = row_of(positions, std::size_t(edges.forward[2 * e]));
      const Row b = row_of(positions, std::size_t(edges.forward[2 * e + 1]));
      const Row c = a + double(d.edge_parameters[e]) * (b - a);
      const double behind = std::max({0.0, -(a - c).dot(normal), -(b - c).dot(normal)});
      push = normal * (behind + margin);
    }
    const double s = std::clamp(at[i], 0.0, 1.0), w = (1 - s) * (1 - s) + s * s;
    proposed.propose(std::size_t(edges.forward[2 * e]), push * ((1 - s) / w));
    proposed.propose(std::size_t(edges.forward[2 * e + 1]), push * (s / w));
  }
  limit_stretch(positions, d, clearance, proposed);
  for (std::size_t v = 0; v < proposed.flagged.size(); ++v)
    if (proposed.flagged[v]) pushes.propose(v, proposed.displacement[v]);
}

// Seed 001 eq. 7: v' = v + (k − f)·n, n the layer's outward direction at the closest point.
// With `piercings`, also the corners of garment triangles that a layer's edge passes through.
void push_out_of_layers(std::span<const float> positions, std::span<const LayerObstacle> layers, const Detection& d,
                        bool first_round, bool piercings, Pushes& pushes) {
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const std::vector<double>& f = d.layer_f[l];
    const ClosestHits& hits = d.layer_hits[l];
    const double threshold = first_round ? layers[l].clearance : 0.0;
    for (std::size_t v = 0; v < f.size(); ++v) {
      if (!(f[v] < threshold)) continue;
      const Row y = row_of(positions, v), h = row_of(hits.points, v);
      const double len = (y - h).norm();
      if (len <= 1e-9) continue; // on the layer: no side to push towards
      const Row n = (y - h) * ((f[v] < 0 ? -1.0 : 1.0) / len);
      pushes.propose(v, (layers[l].clearance - f[v]) * n);
    }
    // A layer edge through a garment triangle: its corners move out past the edge's outer end.
    if (!piercings) continue;
    for (const LayerPiercing& p : d.layer_piercings[l])
      for (int k = 0; k < 3; ++k)
        if (p.push.squaredNorm() > 0)
          pushes.propose(std::size_t(d.triangles[3 * std::size_t(p.triangle) + std::size_t(k)]), p.push);
  }
}

// Rings of neighbours around the pushed vertices that a solve may move; the rest of the garment
// is the fixed region and keeps its place exactly. With λ2/λ1 = 1 on the uniform Laplacian a
// push decays by about half per ring, so 6 rings leave under 2 % of it at the region's edge
// (a 4 mm push: a 0.06 mm step there, which the next round's solve smooths if it matters),
// and the solve covers a few thousand vertices instead of the whole garment. Measured against
// 8 rings (< 0.5 %) on the Table-1 twins: the same rounds and end states, mean edge change
// within 0.01 % (slightly lower), regions ~40 % smaller, removal ~10–15 % faster.
constexpr int REGION_RINGS = 6;
// Push gains. A push p on one vertex moves it by only part of p: the Laplacian term spreads
// the push over the neighbours (alone on a mesh of valence 6 with λ2/λ1 = 1, a vertex moves by
// well under a fifth of its push), so a vertex still inside after a round crept out by a
// fraction of its depth per round (the Table-1 Pant 1 (P3): one vertex, 1.7 → 0.4 mm over six
// rounds). The solve is linear, so a vertex pushed again is pushed by the displacement it
// wants divided by the fraction of its previous push that it achieved (its response), at most
// PUSH_GAIN_INSIDE times for a vertex inside the body and PUSH_GAIN_OTHER times for the ends
// of crossing edges and layer pushes, whose neighbours' pushes overlap theirs (a gain of 4
// there overshoots: corpus jeans 1.96 % mean edge change against 1.89 %). Measured: Table-1
// rows from 1–16 rounds to 1–5, corpus outfits from 16–19 to 4–9, the same offences at the
// end, mean edge change within 0.07 % of before.
constexpr double PUSH_GAIN_INSIDE = 4.0;
constexpr double PUSH_GAIN_OTHER = 2.0;

// Regions of at least this many unknowns are rebuilt around a later round's pushes when those
// are under an eighth of the pushes the region was grown from (see remove()).
constexpr std::size_t SHRINK_REGION_FROM = 2000;

// The unknowns of the solve: the vertices within REGION_RINGS rings of a pushed vertex (R),
// and the Laplacian rows that touch them (R and one ring more).
struct Region {
  std::vector<std::int32_t> column;  // per vertex: its unknown index in R, or −1 when fixed
  std::vector<std::size_t> vertices; // unknown index → vertex
  std::vector<std::size_t> rows;     // Laplacian rows (vertices) whose stencil touches R
  std::vector<char> moves;           // per vertex: in R
  bool covers(const Pushes& p) const {
    for (std::size_t v = 0; v < p.flagged.size(); ++v)
      if (p.flagged[v] && column[v] < 0) return false;
    return true;
  }
};

// Grows `seeds` (per vertex, non-zero = in) by `rings` rings over L's stencil; returns the
// vertices reached with their ring (0 = seed), −1 for the others.
std::vector<int> rings_around(const SparseMatrix& L, std::vector<int> ring, int rings) {
  std::vector<std::size_t> front;
  for (std::size_t v = 0; v < ring.size(); ++v)
    if (ring[v] == 0) front.push_back(v);
  for (int k = 1; k <= rings && !front.empty(); ++k) {
    std::vector<std::size_t> next;
    for (std::size_t v : front)
      for (SparseMatrix::InnerIterator it(L, Eigen::Index(v)); it; ++it)
        if (ring[std::size_t(it.col())] < 0) {
          ring[std::size_t(it.col())] = k;
          next.push_back(std::size_t(it.col()));
        }
    front.swap(next);
  }
  return ring;
}

Region make_region(const SparseMatrix& L, const std::vector<char>& seeds) {
  std::vector<int> ring(seeds.size(), -1);
  for (std::size_t v = 0; v < seeds.size(); ++v)
    if (seeds[v]) ring[v] = 0;
  ring = rings_around(L, std::move(ring), REGION_RINGS + 1);
  Region r;
  r.column.assign(seeds.size(), -1);
  r.moves.assign(seeds.size(), 0);
  for (std::size_t v = 0; v < seeds.size(); ++v) {
    if (ring[v] < 0) continue;
    r.rows.push_back(v);
    if (ring[v] <= REGION_RINGS) {
      r.moves[v] = 1;
      r.column[v] = std::int32_t(r.vertices.size());
      r.vertices.push_back(v);
    }
  }
  return r;
}

// The normal equations of a round's least squares, in displacements δ = y − y⁰ of the region's
// vertices (the fixed ones keep δ = 0):
//   seed 000: min ‖δ − p‖² + λ‖L_R δ‖²                      → (I + λ L_RᵀL_R) δ = p,
//   seed 004: min ‖δ − p‖² + ω_s‖L_R δ − g‖² + ω_d‖δ‖²       → ((1 + ω_d) I + ω_s L_RᵀL_R) δ = p + ω_s L_Rᵀ g,
// p the pushes (0 for vertices not pushed), g = L y⁰_start − L y the region rows' drift of the
// Laplacian coordinates from the start (seed 004 keeps the start's wrinkles). L_R holds L's
// region rows and its columns in R. The matrix c·I + w·L_RᵀL_R is symmetric positive definite;
// its eigenvalues lie in [c, c + w·(2·max degree)²] (Gershgorin on the graph Laplacian), so its
// condition number reaches ~150 for λ = 1 on a triangle mesh and CG needs ~75 iterations to a
// 1e-7 residual, ~35 to the default 1e-3; the LDLᵀ factorisation, reused over the rounds, is
// faster below ~2,000 unknowns (PenetrationSolver::AUTO).
class RegionSystem {
public:
  RegionSystem(const SparseMatrix& L, const Region& region, double c, double w, bool cholesky, double cg_tolerance)
      : m_c(c), m_w(w), m_cg_tolerance(cg_tolerance) {
    const auto n = static_cast<Eigen::Index>(region.vertices.size());
    const auto m = static_cast<Eigen::Index>(region.rows.size());
    // L_R written straight into compressed row storage: a region row keeps L's entries in the
    // region's columns, already in column order (unknowns are numbered in vertex order).
    const auto* outer = L.outerIndexPtr();
    const auto* inner = L.innerIndexPtr();
    const double* value = L.valuePtr();
    Eigen::Index nonzeros = 0;
    for (const std::size_t v : region.rows)
      for (auto k = outer[v]; k < outer[v + 1]; ++k)
        nonzeros += region.column[std::size_t(inner[k])] >= 0;
    m_L.resize(m, n);
    m_L.resizeNonZeros(nonzeros);
    auto* out_outer = m_L.outerIndexPtr();
    auto* out_inner = m_L.innerIndexPtr();
    double* out_value = m_L.valuePtr();
    Eigen::Index written = 0;
    out_outer[0] = 0;
    for (std::size_t r = 0; r < region.rows.size(); ++r) {
      const std::size_t v = region.rows[r];
      for (auto k = outer[v]; k < outer[v + 1]; ++k)
        if (const std::int32_t col = region.column[std::size_t(inner[k])]; col >= 0) {
          out_inner[written] = col;
          out_value[written++] = value[k];
        }
      out_outer[r + 1] = static_cast<std::remove_pointer_t<decltype(out_outer)>>(written);
    }
    m_Lt = m_L.transpose();
    m_inverse_diagonal = Eigen::VectorXd::Constant(n, c);
    for (Eigen::Index r = 0; r < m; ++r)
      for (SparseMatrix::InnerIterator it(m_L, r); it; ++it)
        m_inverse_diagonal[it.col()] += w * it.value() * it.value();
    m_inverse_diagonal = m_inverse_diagonal.cwiseInverse();
    if (cholesky) {
      Eigen::SparseMatrix<double> M = (m_w * (m_Lt * m_L)).eval();
      for (Eigen::Index v = 0; v < n; ++v)
        M.coeffRef(v, v) += m_c;
      m_cholesky.emplace(M);
      if (m_cholesky->info() != Eigen::Success)
        throw Error("remove_penetration", 0, "the region's system is not positive definite");
    }
  }
  Eigen::Index rows() const { return m_L.rows(); }
  // w·L_Rᵀ g for g with one row per region row.
  Eigen::MatrixXd transpose_times(const Eigen::MatrixXd& g) const { return m_w * (m_Lt * g); }
  // Solves (c I + w L_RᵀL_R) δ = rhs (n × 3) by Jacobi-preconditioned conjugate gradients, the
  // three columns together; stops at ‖r‖ ≤ cg_tolerance·‖rhs‖ per column or after 200 iterations. The
  // products run over the rows in parallel (each row a gather, no atomics) and the dot products
  // are summed in fixed chunks in a fixed order, so the result does not depend on the threads.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs, int& iterations) const {
    iterations = 0;
    if (m_cholesky) return solve_factored(rhs);
    const auto n = static_cast<std::size_t>(rhs.rows());
    // Vectors are n × 3, row-major (x, y, z of one vertex together).
    std::vector<double> x(3 * n, 0.0), r(3 * n), z(3 * n), d(3 * n), q(3 * n), t(3 * std::size_t(m_L.rows()));
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        r[3 * i + std::size_t(c)] = rhs(Eigen::Index(i), c);
    // Per-chunk partial dot products (CG_GRAIN rows a chunk), summed in chunk order: the same
    // bits for any thread count. Each pass over the vectors does all the work of one CG step
    // that reads those vectors, and the dot products it needs, in one sweep.
    const std::size_t chunks = (n + CG_GRAIN - 1) / CG_GRAIN;
    std::vector<std::array<double, 6>> partial(chunks);
    auto sweep = [&](const auto& body) {
      parallel_for_range(chunks, 1, [&](std::size_t cb, std::size_t ce) {
        for (std::size_t ch = cb; ch < ce; ++ch) {
          std::array<double, 6> s{};
          body(3 * ch * CG_GRAIN, 3 * std::min(n, (ch + 1) * CG_GRAIN), s);
          partial[ch] = s;
        }
      });
      std::array<double, 6> total{};
      for (const auto& s : partial)
        for (std::size_t k = 0; k < 6; ++k)
          total[k] += s[k];
      return total;
    };
    // z = M⁻¹r (Jacobi), and r·z, r·r per column.
    auto precondition = [&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
      for (std::size_t k = b; k < e; ++k) {
        z[k] = m_inverse_diagonal[Eigen::Index(k / 3)] * r[k];
        s[k % 3] += r[k] * z[k];
        s[3 + k % 3] += r[k] * r[k];
      }
    };
    std::array<double, 6> sums = sweep(precondition);
    d = z;
    std::array<double, 3> rz{sums[0], sums[1], sums[2]}, stop{sums[3], sums[4], sums[5]};
    for (double& s : stop)
      s *= m_cg_tolerance * m_cg_tolerance;
    for (; iterations < 200; ++iterations) {
      if (sums[3] <= stop[0] && sums[4] <= stop[1] && sums[5] <= stop[2]) break;
      multiply(m_L, d, t);
      multiply(m_Lt, t, q);
      // q = c·d + w·L_Rᵀ(L_R d), and d·q per column.
      const std::array<double, 6> dq = sweep([&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
        for (std::size_t k = b; k < e; ++k) {
          q[k] = m_c * d[k] + m_w * q[k];
          s[k % 3] += d[k] * q[k];
        }
      });
      std::array<double, 3> alpha{};
      for (std::size_t c = 0; c < 3; ++c)
        alpha[c] = dq[c] > 0 ? rz[c] / dq[c] : 0.0; // 0: converged (d = 0)
      sums = sweep([&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
        for (std::size_t k = b; k < e; ++k) {
          x[k] += alpha[k % 3] * d[k];
          r[k] -= alpha[k % 3] * q[k];
        }
        precondition(b, e, s);
      });
      std::array<double, 3> beta{};
      for (std::size_t c = 0; c < 3; ++c) {
        beta[c] = rz[c] > 0 ? sums[c] / rz[c] : 0.0;
        rz[c] = sums[c];
      }
      parallel_for_range(n, CG_GRAIN, [&](std::size_t b, std::size_t e) {
        for (std::size_t k = 3 * b; k < 3 * e; ++k)
          d[k] = z[k] + beta[k % 3] * d[k];
      });
    }
    Eigen::MatrixXd out(Eigen::Index(n), 3);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        out(Eigen::Index(i), c) = x[3 * i + std::size_t(c)];
    return out;
  }

private:
  static constexpr std::size_t CG_GRAIN = 4096; // rows per task of the CG's loops

  // The factorisation's solve, P M Pᵀ = L D Lᵀ (L unit lower, stored below its diagonal by
  // columns), with the three columns of rhs carried together through one sweep of L per
  // triangle: twice as fast as Eigen's solve(), which sweeps L once per column (measured on a
  // Table-1 Shirt 1 region of 1,966 unknowns: 0.13 against 0.26 ms). Same operations per
  // column in the same order (1/d multiplied, as Eigen does), so the same bits as its solve.
  Eigen::MatrixXd solve_factored(const Eigen::MatrixXd& rhs) const {
    const auto& factor = m_cholesky->matrixL().nestedExpression();
    const auto* outer = factor.outerIndexPtr();
    const auto* inner = factor.innerIndexPtr();
    const double* value = factor.valuePtr();
    const auto& diagonal = m_cholesky->vectorD();
    const auto& to = m_cholesky->permutationP().indices(); // row i of rhs is row to[i] of P·rhs
    const auto n = static_cast<std::size_t>(rhs.rows());
    std::vector<double> y(3 * n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        y[3 * std::size_t(to[Eigen::Index(i)]) + std::size_t(c)] = rhs(Eigen::Index(i), c);
    for (std::size_t j = 0; j < n; ++j) { // L y = P·rhs
      const double y0 = y[3 * j], y1 = y[3 * j + 1], y2 = y[3 * j + 2];
      for (auto k = outer[j]; k < outer[j + 1]; ++k) {
        double* yi = y.data() + 3 * std::size_t(inner[k]);
        yi[0] -= value[k] * y0;
        yi[1] -= value[k] * y1;
        yi[2] -= value[k] * y2;
      }
    }
    for (std::size_t j = 0; j < n; ++j) { // times 1/d, as Eigen does
      const double inverse = 1.0 / diagonal[Eigen::Index(j)];
      for (std::size_t c = 0; c < 3; ++c)
        y[3 * j + c] *= inverse;
    }
    for (std::size_t j = n; j-- > 0;) { // Lᵀ x = D⁻¹ y
      double s0 = y[3 * j], s1 = y[3 * j + 1], s2 = y[3 * j + 2];
      for (auto k = outer[j]; k < outer[j + 1]; ++k) {
        const double* xi = y.data() + 3 * std::size_t(inner[k]);
        s0 -= value[k] * xi[0];
        s1 -= value[k] * xi[1];
        s2 -= value[k] * xi[2];
      }
      y[3 * j] = s0;
      y[3 * j + 1] = s1;
      y[3 * j + 2] = s2;
    }
    Eigen::MatrixXd out(Eigen::Index(n), 3);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        out(Eigen::Index(i), c) = y[3 * std::size_t(to[Eigen::Index(i)]) + std::size_t(c)];
    return out;
  }

  // y = A·v for a row-major CSR A and n × 3 row-major v, y (rows of A × 3), rows in parallel.
  template <class Matrix> static void multiply(const Matrix& A, const std::vector<double>& v, std::vector<double>& y) {
    const auto* outer = A.outerIndexPtr();
    const auto* inner = A.innerIndexPtr();
    const double* value = A.valuePtr();
    parallel_for_range(std::size_t(A.rows()), CG_GRAIN, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        double s0 = 0, s1 = 0, s2 = 0;
        for (auto k = outer[i]; k < outer[i + 1]; ++k) {
          const double* vj = v.data() + 3 * std::size_t(inner[k]);
          s0 += value[k] * vj[0];
          s1 += value[k] * vj[1];
          s2 += value[k] * vj[2];
        }
        y[3 * i] = s0;
        y[3 * i + 1] = s1;
        y[3 * i + 2] = s2;
      }
    });
  }

  double m_c, m_w, m_cg_tolerance;
  SparseMatrix m_L;                                  // region rows × R
  Eigen::SparseMatrix<double, Eigen::RowMajor> m_Lt; // R × region rows
  Eigen::VectorXd m_inverse_diagonal;
  std::optional<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> m_cholesky;
};

Eigen::MatrixXd as_matrix(std::span<const float> p) {
  Eigen::MatrixXd y(static_cast<Eigen::Index>(p.size() / 3), 3);
  for (Eigen::Index v = 0; v < y.rows(); ++v)
    for (int k = 0; k < 3; ++k)
      y(v, k) = p[3 * std::size_t(v) + std::size_t(k)];
  return y;
}

// Adds the wall time of f() to `total` (ms) and returns f()'s result.
template <class F> auto timed(double& total, F&& f) {
  struct Add {
    double& total;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    ~Add() { total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(); }
  } add{total};
  return f();
}

bool resolved(const PenetrationStats& s) {
  return s.inside_count == 0 && s.crossing_edges == 0 && s.layer_inside_count == 0 && s.layer_crossing_edges == 0;
}

// The direct rounds (PenetrationOptions::direct_rounds): from a state with no vertex deeper
// than the tolerance and edges still crossing, each round moves every crossing edge's ends and
// every vertex inside by its push (push_crossing_edges(), push_vertices()) and detects them
// again; the best state over the rounds is kept, so the result is never worse than the solved
// rounds'. They stop after 2 × stall_rounds rounds in a row without improvement (a push that
// moves a chord along a curved limb gains a little per round: measured on the corpus outfits
// after simulation, a long-sleeve cuff's last 6 crossing edges went in 4 rounds where 100
// solved rounds left 1; the overalls' hem over a foot needed 57).
template <class Badness>
void push_directly(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                   const GarmentEdges& edges, std::span<const LayerObstacle> layers, double clearance,
                   const PenetrationOptions& o, const Badness& badness, Detection& detection,
                   PenetrationReport& report) {
  const std::size_t nv = garment.vertex_count();
  const std::vector<float> reference = garment.positions;
  detection.reference = reference;
  timed(report.detection_ms,
        [&] { detect(garment.positions, body, &crossings, &edges, layers, nullptr, nullptr, nullptr, detection); });
  report.after = stats_of(detection, o.clearance);
  PenetrationStats best = report.after;
  std::vector<float> best_positions = garment.positions;
  std::vector<std::size_t> moved;
  int last_improvement = -1;
  for (int round = 0; round < o.direct_rounds && !resolved(report.after); ++round) {
    Pushes pushes(nv);
    push_vertices(garment.positions, detection.body, clearance, 0.0, pushes);
    push_crossing_edges(garment.positions, body, crossings, edges, detection, clearance, pushes);
    if (!pushes.any()) break;
    moved.clear();
    for (std::size_t v = 0; v < nv; ++v)
      if (pushes.flagged[v]) {
        moved.push_back(v);
        for (int c = 0; c < 3; ++c)
          garment.positions[3 * v + std::size_t(c)] += static_cast<float>(pushes.displacement[v][c]);
      }
    // Only the moved vertices and their edges can have changed (the body is static): detected
    // again, every one of them queried afresh, so the statistics stay exact.
    timed(report.detection_ms, [&] {
      detect(garment.positions, body, &crossings, &edges, layers, &moved, &pushes.flagged, &moved, detection);
    });
    report.after = stats_of(detection, o.clearance);
    ++report.direct_rounds;
    if (badness(report.after) < badness(best)) {
      best = report.after;
      best_positions = garment.positions;
      last_improvement = round;
    } else if (o.stall_rounds > 0 && round - last_improvement >= 2 * o.stall_rounds) {
      break;
    }
  }
  detection.reference = {};
  if (badness(best) < badness(report.after)) {
    garment.positions = std::move(best_positions);
    report.after = best;
  }
}

PenetrationReport remove(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex* crossings,
                         std::span<const LayerObstacle> layers, const PenetrationOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool seed004 = o.method == PenetrationMethod::SEED_004;
  const std::size_t nv = garment.vertex_count();
  SparseMatrix L;
  std::optional<GarmentEdges> edges;
  const double clearance = seed004 ? 0.0 : o.clearance; // seed 004 projects onto the face
  Detection detection;
  detection.reach = near_reach(o.clearance);
  detection.triangles = garment.triangles;
  PenetrationReport report;
  timed(report.detection_ms, [&] {
    // The garment's Laplacian and edges (serial) are built while the body is queried for
    // every vertex (parallel): neither needs the other, and the rest of the detection needs
    // both. Table-1 Shorts 1 (8,196 vertices), 2 cores: ~0.3 ms less than one after the other.
    tbb::parallel_invoke(
        [&] {
          L = uniform_laplacian(garment.triangle_view(), nv);
          if (crossings) edges.emplace(L);
        },
        [&] { closest_points_of(body, garment.positions, detection.reach, nullptr, detection.body); });
    detection.adjacency = &L;
    detection.body_queried = true;
    detect(garment.positions, body, crossings, edges ? &*edges : nullptr, layers, nullptr, nullptr, nullptr, detection);
  });
  const GarmentEdges* edge_list = edges ? &*edges : nullptr;
  report.before = stats_of(detection, o.clearance);
  report.after = report.before;
  Pushes pushes(nv);
  // Vertices merely closer than κ (or a layer's k) are pushed in the first round only;
  // afterwards only those inside are. The solve leaves a pushed vertex a little short of κ (the
  // Laplacian pulls it back), and re-pushing all of those every round inflates the garment
  // round after round (corpus outfits: 2.2 % mean edge change against 1.9 % this way).
  // Crossing edges are pushed once no vertex is deeper than the tolerance: where a garment passes through a
  // limb (a T-pose sleeve on an arms-down body), chord pushes toward the nearest surface fight
  // the vertex pushes and can carry vertices deep inside.
  auto propose = [&](bool first_round) {
    pushes = Pushes(nv);
    push_vertices(garment.positions, detection.body, clearance, first_round ? clearance : 0.0, pushes);
    const bool deep_inside = vertex_stats(detection.body, 0.0).max_depth > o.tolerance;
    if (crossings && !deep_inside)
      push_crossing_edges(garment.positions, body, *crossings, *edges, detection, clearance, pushes);
    // Like crossing edges, layer edges through the garment wait until no vertex is deep inside
    // the body: their pushes fought the body's on the worksuit's tee (dressed over overalls
    // whose bib covers it), which ended with 27 vertices inside the body instead of 8.
    push_out_of_layers(garment.positions, layers, detection, first_round, !deep_inside, pushes);
    return pushes.any();
  };
  if (!timed(report.detection_ms, [&] { return propose(true); })) {
    report.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return report;
  }

  const std::vector<float> start_positions = garment.positions;
  const Eigen::MatrixXd rest_laplacian =
      seed004 ? Eigen::MatrixXd(L * as_matrix(garment.positions)) : Eigen::MatrixXd();
  const int rounds = seed004 ? std::min(o.max_iterations, o.seed004_iterations) : o.max_iterations;

  // The best state seen, returned when the rounds run out unresolved: never worse than that.
  // Depth beyond the tolerance weighs most (it is what the quality bars and the simulation's
  // contact handling care about), then the offences against the body, then those against inner
  // layers (a garment that cannot get out of a layer it is dressed under, e.g. a tee under the
  // bib of overalls, keeps the state best for the body: the worksuit's tee ended with 24
  // vertices inside the body and 122 crossing edges when layer offences counted as much), then
  // the depth.
  auto badness = [&o](const PenetrationStats& st) {
    return std::make_tuple(st.max_depth > o.tolerance, st.inside_count + st.crossing_edges,
                           st.layer_inside_count + st.layer_crossing_edges, st.max_depth);
  };
  std::vector<float> best_positions;
  PenetrationStats best = report.before;
  Region region;
  std::optional<RegionSystem> system;
  std::vector<char> seeds; // the pushed vertices the region was grown from
  std::size_t seed_count = 0;
  int last_improvement = -1;
  std::vector<std::size_t> requery;
  std::vector<double> response(nv, 1.0);                      // per vertex: see PUSH_GAIN_INSIDE; 1 until pushed
  std::vector<char> crossings_pending(crossings ? nv : 0, 0); // moved since their edges' last check
  auto check_pending_crossings = [&] {
    detect_crossings(garment.positions, detection.body, detection.drift, *crossings, *edge_list, &crossings_pending,
                     detection);
    std::fill(crossings_pending.begin(), crossings_pending.end(), char(0));
  };
  // Queries again the vertices skipped since their last query (may_have_changed()) and takes
  // the statistics afresh. The skip is exact where the body's signed distance is continuous; a
  // posed body that intersects itself (skin folded at an armpit) makes the side jump, so a
  // skipped vertex can be found inside here: before the rounds end, and before they stop as
  // resolved, every vertex is queried again, and the report is exact on any body.
  auto refresh_skipped = [&] {
    requery.clear();
    for (std::size_t v = 0; v < nv; ++v)
      if (detection.drift[v] > 0) requery.push_back(v);
    if (requery.empty()) return;
    timed(report.detection_ms, [&] {
      closest_points_of(body, garment.positions, detection.reach, &requery, detection.body);
      resolve_far_vertices(garment.positions, body, crossings, &requery, detection.reach, detection.adjacency,
                           detection.body);
    });
    for (std::size_t v : requery)
      detection.drift[v] = 0.0f;
    report.after = stats_of(detection, o.clearance);
  };
  for (int iter = 0; iter < rounds; ++iter) {
    if (iter > 0 && !timed(report.detection_ms, [&] { return propose(false); })) break;
    // The region: REGION_RINGS rings around the pushed vertices. A push outside it (a later
    // round finds a new spot) grows it. When a later round pushes far fewer vertices than the
    // region was grown from (the first round pushes thousands, the next ones tens), a region
    // around those alone is rebuilt once it is large: factoring a few hundred unknowns costs
    // less than two solves over thousands (measured on the Table-1 shorts: 6,216 unknowns,
    // 1.5 ms per solve, then ~600).
    const std::size_t pushed_now = std::size_t(std::count(pushes.flagged.begin(), pushes.flagged.end(), char(1)));
    const bool shrink = system && region.vertices.size() >= SHRINK_REGION_FROM && 8 * pushed_now < seed_count;
    if (!system || shrink || !region.covers(pushes)) {
      if (!system || shrink)
        seeds = pushes.flagged;
      else
        for (std::size_t v = 0; v < nv; ++v)
          seeds[v] |= pushes.flagged[v];
      seed_count = std::size_t(std::count(seeds.begin(), seeds.end(), char(1)));
      region = make_region(L, seeds);
      // AUTO factors only the first round's region: a region rebuilt later (shrunk around a
      // few remaining pushes, or grown to a new spot) is mostly solved once or twice, where
      // the factorisation's ordering and elimination cost more than CG on its few hundred
      // unknowns (see PenetrationSolver::AUTO).
      const bool direct = o.solver == PenetrationSolver::CHOLESKY || (o.solver == PenetrationSolver::AUTO && !system &&
                                                                      region.vertices.size() < o.direct_solve_limit);
      timed(report.system_ms, [&] {
        system.emplace(L, region, seed004 ? 1.0 + o.seed004_damping : 1.0, seed004 ? o.seed004_smoothing : o.smoothness,
                       direct, o.cg_tolerance);
      });
      ++report.region_builds;
    }
    for (std::size_t v = 0; v < nv; ++v)
      if (pushes.flagged[v] && response[v] < 1.0) {
        const bool inside = detection.body.triangles[v] >= 0 && detection.body.signed_distances[v] < 0;
        pushes.displacement[v] *= std::min(1.0 / response[v], inside ? PUSH_GAIN_INSIDE : PUSH_GAIN_OTHER);
      }
    const auto n = static_cast<Eigen::Index>(region.vertices.size());
    Eigen::MatrixXd rhs(n, 3);
    for (Eigen::Index k = 0; k < n; ++k)
      rhs.row(k) = pushes.displacement[region.vertices[std::size_t(k)]];
    if (seed004) {
      const Eigen::MatrixXd drift = rest_laplacian - L * as_matrix(garment.positions);
      Eigen::MatrixXd g(system->rows(), 3);
      for (Eigen::Index r = 0; r < g.rows(); ++r)
        g.row(r) = drift.row(Eigen::Index(region.rows[std::size_t(r)]));
      rhs += system->transpose_times(g);
    }
    int cg_iterations = 0;
    const Eigen::MatrixXd delta = timed(report.solve_ms, [&] { return system->solve(rhs, cg_iterations); });
    report.solver_iterations += cg_iterations;
    for (Eigen::Index k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c)
        garment.positions[3 * region.vertices[std::size_t(k)] + std::size_t(c)] += static_cast<float>(delta(k, c));
    report.iterations = iter + 1;
    for (Eigen::Index k = 0; k < n; ++k) // each pushed vertex's response (see PUSH_GAIN_INSIDE)
      if (const std::size_t v = region.vertices[std::size_t(k)]; pushes.flagged[v])
        if (const double pushed2 = pushes.displacement[v].squaredNorm(); pushed2 > 0)
          response[v] = std::clamp(delta.row(k).dot(pushes.displacement[v]) / pushed2, 0.0, 1.0);
    requery.clear();
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::size_t v = region.vertices[std::size_t(k)];
      const float moved = float(delta.row(k).norm()) + 1e-6f; // + float rounding of the positions
      if (may_have_changed(detection, v, moved, o.clearance))
        requery.push_back(v);
      else
        detection.drift[v] += moved;
    }
    timed(report.detection_ms, [&] {
      detect(garment.positions, body, nullptr, edge_list, layers, &region.vertices, &region.moves, &requery, detection);
      if (!crossings) return;
      // While a vertex is deeper than the tolerance the next round pushes no crossing edge
      // (propose()), so the edges' check waits: the vertices moved meanwhile are remembered
      // and their edges checked once it is needed (Table-1 Shorts 1: two rounds of ~18k edge
      // checks saved). Meanwhile the statistics carry the last crossing count.
      for (std::size_t v : region.vertices)
        crossings_pending[v] = 1;
      if (vertex_stats(detection.body, 0.0).max_depth > o.tolerance) return;
      check_pending_crossings();
    });
    report.after = stats_of(detection, o.clearance);
    // clearance is a target, not a requirement
    if (resolved(report.after) && (refresh_skipped(), resolved(report.after))) break;
    if (badness(report.after) < badness(best)) {
      best = report.after;
      best_positions = garment.positions;
      last_improvement = iter;
    } else if (o.stall_rounds > 0 && iter - last_improvement >= o.stall_rounds) {
      break;
    }
  }
  if (std::find(crossings_pending.begin(), crossings_pending.end(), char(1)) != crossings_pending.end()) {
    timed(report.detection_ms, check_pending_crossings);
    report.after = stats_of(detection, o.clearance);
  }
  if (!resolved(report.after) && badness(best) < badness(report.after)) {
    if (!best_positions.empty()) {
      garment.positions = best_positions;
      // best's statistics were taken with skipped vertices: measure the state returned afresh.
      timed(report.detection_ms, [&] {
        detect(garment.positions, body, crossings, edge_list, layers, nullptr, nullptr, nullptr, detection);
      });
      report.after = stats_of(detection, o.clearance);
    } else {
      garment.positions = start_positions; // the start was best
      report.after = best;
    }
  } else if (!resolved(report.after)) {
    refresh_skipped();
  }
  if (crossings && !seed004 && report.after.crossing_edges > 0 && report.after.max_depth <= o.tolerance)
    push_directly(garment, body, *crossings, *edge_list, layers, clearance, o, badness, detection, report);
  report.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

PenetrationStats measure(const Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                         std::span<const LayerObstacle> layers, double clearance) {
  const SparseMatrix L = uniform_laplacian(garment.triangle_view(), garment.vertex_count());
  const GarmentEdges edges(L);
  Detection d;
  d.reach = near_reach(clearance);
  d.adjacency = &L;
  d.triangles = garment.triangles;
  detect(garment.positions, body, &crossings, &edges, layers, nullptr, nullptr, nullptr, d);
  return stats_of(d, clearance);
}

} // namespace

PenetrationStats measure_penetration(std::span<const float> garment_positions, const ProximityIndex& body,
                                     double clearance) {
  ClosestHits hits;
  body.closest_points(garment_positions, NEAR_SEARCH, hits);
  resolve_far_vertices(garment_positions, body, nullptr, nullptr, NEAR_SEARCH, nullptr, hits);
  return vertex_stats(hits, clearance);
}

PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, double clearance) {
  return measure(garment, body, crossings, {}, clearance);
}

PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, std::span<const LayerObstacle> layers,
                                     double clearance) {
  return measure(garment, body, crossings, layers, clearance);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const PenetrationOptions& o) {
  return remove(garment, body, nullptr, {}, o);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     const PenetrationOptions& o) {
  return remove(garment, body, &crossings, {}, o);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     std::span<const LayerObstacle> layers, const PenetrationOptions& o) {
  return remove(garment, body, &crossings, layers, o);
}

} // namespace vfit
