// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/layer_piercing.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "vfit/engine/dress/dress_rows.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

using dress::Row;
using dress::row_of;

// Unit normal of layer triangle t (oriented away from the body), or zero when degenerate.
Row layer_normal(const LayerObstacle& layer, std::int32_t t) {
  const auto f = 3 * std::size_t(t);
  const Row a = row_of(layer.points, std::size_t(layer.triangles[f]));
  const Row n = (row_of(layer.points, std::size_t(layer.triangles[f + 1])) - a)
                    .cross(row_of(layer.points, std::size_t(layer.triangles[f + 2])) - a);
  const double len = n.norm();
  return len > 0 ? Row(n / len) : Row(Row::Zero());
}

// Rings of layer vertices grown from the flagged ones over the layer's edges.
void grow_rings(const LayerObstacle& layer, int rings, std::vector<char>& in) {
  std::vector<std::int32_t> front;
  for (std::size_t v = 0; v < in.size(); ++v)
    if (in[v]) front.push_back(std::int32_t(v));
  for (int r = 0; r < rings && !front.empty(); ++r) {
    std::vector<std::int32_t> next;
    for (const std::int32_t v : front)
      for (auto k = layer.edge_offsets[std::size_t(v)]; k < layer.edge_offsets[std::size_t(v) + 1]; ++k) {
        const auto e = 2 * std::size_t(layer.vertex_edges[std::size_t(k)]);
        const std::int32_t w = layer.edges[e] == v ? layer.edges[e + 1] : layer.edges[e];
        if (!in[std::size_t(w)]) {
          in[std::size_t(w)] = 1;
          next.push_back(w);
        }
      }
    front = std::move(next);
  }
}

// How many rings of layer vertices around the closest layer points of a triangle's corners may
// hold the vertex that pokes through it. Corners are outside the layer and the vertex lies
// beyond the triangle, so it is within about one garment edge of a corner's closest point;
// two rings cover layer edges up to about half as long as the garment's.
constexpr int CANDIDATE_RINGS = 2;

} // namespace

void find_layer_piercings(std::span<const float> positions, std::span<const std::int32_t> triangles,
                          const LayerObstacle& layer, const ClosestHits& hits, std::vector<LayerPiercing>& out) {
  out.clear();
  if (layer.points.empty() || layer.edges.empty() || layer.edge_offsets.empty() || triangles.empty()) return;
  const std::size_t nf = triangles.size() / 3, nl = layer.points.size() / 3;

  // Garment triangles near enough to the layer to be pierced, and the layer vertices their
  // corners are closest to. A corner closest to the layer's boundary counts too: a waistband's
  // rim is what pokes through most often.
  std::vector<std::int32_t> candidates, candidate_triangles;
  std::vector<char> near(nl, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t* c = &triangles[3 * f];
    const Row a = row_of(positions, std::size_t(c[0])), b = row_of(positions, std::size_t(c[1])),
              d = row_of(positions, std::size_t(c[2]));
    const double longest = std::max({(b - a).norm(), (d - b).norm(), (a - d).norm()});
    double nearest = INFINITY;
    for (int k = 0; k < 3; ++k)
      if (const auto v = std::size_t(c[k]); hits.triangles[v] >= 0)
        nearest = std::min(nearest, double(std::fabs(hits.signed_distances[v])));
    if (!(nearest <= longest + layer.clearance)) continue;
    candidates.push_back(std::int32_t(f));
    candidate_triangles.insert(candidate_triangles.end(), {c[0], c[1], c[2]});
    for (int k = 0; k < 3; ++k)
      if (const std::int32_t t = hits.triangles[std::size_t(c[k])]; t >= 0)
        for (int j = 0; j < 3; ++j)
          near[std::size_t(layer.triangles[3 * std::size_t(t) + std::size_t(j)])] = 1;
  }
  if (candidates.empty()) return;
  grow_rings(layer, CANDIDATE_RINGS, near);

  std::vector<char> taken(layer.edges.size() / 2, 0);
  std::vector<std::int32_t> segments, segment_edges;
  for (std::size_t v = 0; v < nl; ++v) {
    if (!near[v]) continue;
    for (auto k = layer.edge_offsets[v]; k < layer.edge_offsets[v + 1]; ++k) {
      const auto e = std::size_t(layer.vertex_edges[std::size_t(k)]);
      if (taken[e]) continue;
      taken[e] = 1;
      segments.insert(segments.end(), {layer.edges[2 * e], layer.edges[2 * e + 1]});
      segment_edges.push_back(std::int32_t(e));
    }
  }
  if (segments.empty()) return;

  const EdgeCrossingIndex garment(positions, candidate_triangles);
  SegmentCrossings found;
  garment.first_crossings(layer.points, segments, found);
  for (std::size_t k = 0; k < found.size(); ++k) {
    if (found.triangles[k] < 0) continue;
    const std::int32_t f = candidates[std::size_t(found.triangles[k])];
    Row n = Row::Zero();
    for (int j = 0; j < 3; ++j)
      if (const std::int32_t t = hits.triangles[std::size_t(triangles[3 * std::size_t(f) + std::size_t(j)])]; t >= 0)
        n += layer_normal(layer, t);
    const double len = n.norm();
    LayerPiercing p;
    p.edge = segment_edges[k];
    p.triangle = f;
    if (len > 1e-9) { // else counted, but there is no outward direction to push along
      n /= len;
      const Row from = row_of(layer.points, std::size_t(segments[2 * k])),
                to = row_of(layer.points, std::size_t(segments[2 * k + 1]));
      const Row at = from + double(found.parameters[k]) * (to - from);
      const double beyond = std::max({(from - at).dot(n), (to - at).dot(n), 0.0});
      p.push = (beyond + layer.clearance) * n;
    }
    out.push_back(p);
  }
}

} // namespace vfit
