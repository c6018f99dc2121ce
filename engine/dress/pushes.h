// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The pushes of penetration removal (seed 000 eq. 18–19; seed 001 eq. 7): per vertex, the
/// displacement a round wants, from vertices inside or near the body, edges crossing it and
/// inner layers' vertices and edges. Internal to engine/dress/ (penetration.cpp).

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "vfit/engine/dress/detection.h"
#include "vfit/engine/dress/dress_rows.h"

namespace vfit {

class EdgeCrossingIndex;

namespace dress {

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
                   Pushes& pushes);

// How far outside the body a crossing edge's chord is pushed: half of κ, since both of its ends
// are already outside (a smaller margin took up to 22 rounds on the corpus outfits, for the
// same stretch), and a floor so a zero κ (seed 004) still clears the surface.
inline double crossing_margin(double clearance) { return std::max(0.5 * clearance, 1e-4); }

// How far a direct round's crossing push may stretch the garment (see limit_stretch()): an edge
// may grow to STRETCH_LIMIT times its length where the direct rounds began, or by κ when that is
// more.
inline constexpr double STRETCH_LIMIT = 1.5;

// Scales down the crossing pushes `proposed` (their ends' displacements) so that no edge at a
// pushed vertex grows past STRETCH_LIMIT times its length in d.reference (or by κ, when that
// is more). The direct rounds move each vertex by its push as it is, with no Laplacian term
// holding it to its neighbours, round after round, so pushes that trade an edge's crossing
// back and forth walk a vertex far out (on the corpus fits, a sleeve vertex squeezed between
// arm and torso was carried 25 cm out in front without the limit: docs/benchmarks.md). The
// edges the limit leaves crossing are resolved by the simulation and the clean-up after
// it. An edge the push shortens, or keeps within the limit,
// leaves the push as it is; one already past the limit stops a push that lengthens it. A
// neighbour's own push counts as proposed.
void limit_stretch(std::span<const float> positions, const Detection& d, double clearance, Pushes& proposed);

// Crossing edges whose ends are both outside (an end inside is the vertex push's job, and
// moving it out often ends the crossing): the inside chord [t₁, t₂] must leave the body. Its
// midpoint at parameter s needs a displacement δ; moving the ends by δ_a, δ_b moves it by
// (1 − s)·δ_a + s·δ_b, and the smallest such pair is δ_a = δ(1 − s)/w, δ_b = δ·s/w with
// w = (1 − s)² + s²: the end nearer the chord moves more, the far end little.
void push_crossing_edges(std::span<const float> positions, const ProximityIndex& body,
                         const EdgeCrossingIndex& crossings, const GarmentEdges& edges, const Detection& d,
                         double clearance, Pushes& pushes);

// Seed 001 eq. 7: v' = v + (k − f)·n, n the layer's outward direction at the closest point.
// With `piercings`, also the corners of garment triangles that a layer's edge passes through.
void push_out_of_layers(std::span<const float> positions, std::span<const LayerObstacle> layers, const Detection& d,
                        bool first_round, bool piercings, Pushes& pushes);

} // namespace dress
} // namespace vfit
