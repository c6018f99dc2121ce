// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/pushes.h"

#include <cmath>

#include "vfit/kernels/edge_crossings.h"

namespace vfit::dress {

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

} // namespace vfit::dress
