// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/detection.h"

#include <algorithm>
#include <cmath>

#include "vfit/engine/dress/dress_rows.h"
#include "vfit/kernels/edge_crossings.h"

namespace vfit::dress {

bool on_layer_boundary(const LayerObstacle& layer, std::int32_t triangle, std::int8_t feature) {
  const std::uint8_t mask = layer.boundary[std::size_t(triangle)];
  const auto f = static_cast<TriangleFeature>(feature);
  if (f >= TriangleFeature::EDGE_0 && f <= TriangleFeature::EDGE_2)
    return (mask >> (int(feature) - int(TriangleFeature::EDGE_0))) & 1u;
  if (f >= TriangleFeature::VERTEX_0 && f <= TriangleFeature::VERTEX_2)
    return (mask >> (3 + int(feature) - int(TriangleFeature::VERTEX_0))) & 1u;
  return false;
}

void closest_points_of(const ProximityIndex& index, std::span<const float> positions, float reach,
                       const std::vector<std::size_t>* moved, ClosestHits& all) {
  if (!moved) {
    index.closest_points(positions, reach, all);
    return;
  }
  // Each vertex searches only as far as its previous closest point (requery_radius()).
  std::vector<float> queries, radii;
  queries.reserve(3 * moved->size());
  radii.reserve(moved->size());
  for (std::size_t v : *moved) {
    queries.insert(queries.end(), {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
    float radius = reach;
    if (all.triangles[v] >= 0) radius = std::min(reach, requery_radius(&positions[3 * v], &all.points[3 * v]));
    radii.push_back(radius);
  }
  ClosestHits part;
  index.closest_points(queries, radii, part);
  for (std::size_t k = 0; k < moved->size(); ++k)
    all.copy_row((*moved)[k], part, k);
}

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

} // namespace vfit::dress
