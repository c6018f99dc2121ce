// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Penetration detection and removal between a garment and a body (seed 000 §6.2, eq. 18–21;
/// seed 004 §3.2.2): garment vertices inside the body, or closer to it than a clearance κ, are
/// pushed out to κ along the side of their closest body point while a Laplacian term keeps the
/// garment's shape; garment edges that cross the body surface with both ends outside (a sleeve
/// edge through a thin wrist) are pushed out by the depth of their inside chord; inner garment
/// layers, when given, are kept out of too (seed 001 eq. 7; engine/layering.h); detection and
/// solve repeat until nothing is inside and nothing crosses.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "vfit/engine/dress/penetration_types.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

class ProximityIndex;
class EdgeCrossingIndex;

/// Measures a garment (positions #V × 3, m) against a body index (a closed, outward-oriented
/// mesh), with `clearance` κ (m) for near_count. Every vertex inside counts, however deep:
/// vertices with no body point within 5 cm are queried again without a limit (slower;
/// the overloads with an EdgeCrossingIndex, and remove_penetration(), first cast one ray from
/// each to tell those outside, which are most, from those deep inside).
PenetrationStats measure_penetration(std::span<const float> garment_positions, const ProximityIndex& body,
                                     double clearance);

/// As above, and also counts the garment's edges (from its triangles) that cross the body
/// surface; `crossings` indexes the same body mesh as `body`.
PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, double clearance);

/// Removes penetration in place. garment: positions and triangles (its uniform Laplacian keeps
/// the shape: argmin_y Σ_i ‖y_i − t_i‖² + λ ‖L (y − y⁰)‖², y⁰ the round's start, t_i = closest
/// body point + κ·outward for vertices inside (or, in the first round only, within κ), t_i = y⁰_i
/// elsewhere). Only the vertices within 6 rings of a pushed vertex are unknowns; the rest of
/// the garment is the fixed region and does not move. The matrix I + λ L_RᵀL_R of that region is
/// factored once and reused every round, as seed 004 does (a later round pushing a vertex
/// outside the region grows it, and a large region is rebuilt around a much smaller later push
/// set; either factors again: PenetrationReport::region_builds, PenetrationSolver). A vertex
/// pushed again in a later round has its push divided by the fraction of its previous push the
/// solve delivered (the Laplacian term spreads a push over the neighbours), at most 4× for a
/// vertex inside the body and 2× for other pushes, so a lone vertex does not creep out over
/// many rounds. After a solve only the moved vertices are detected again. Returns the
/// statistics before and after.
/// Vertex tests only: edges crossing the body are neither found nor counted.
PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const PenetrationOptions& options = {});

/// As above, and edges crossing the body are resolved too: for an edge a→b with both ends
/// outside whose first crossing from a is at t₁ and from b at t₂ (so the chord [t₁, 1 − t₂] lies
/// inside), the chord's midpoint m = a + s·(b − a) must move by δ = (‖h − m‖ + κ/2)·(h − m)/‖h − m‖
/// to lie κ/2 outside its closest body point h; the ends move by the smallest pair that does
/// it, δ·(1 − s)/w and δ·s/w with w = (1 − s)² + s² (the end nearer the chord moves more). A
/// vertex proposed several displacements keeps the largest. Edges with an end inside are left
/// to that end's vertex push for the round; crossing pushes wait until no vertex is deeper
/// than `tolerance`; a chord deeper than its edge is long (the garment passes through a limb,
/// e.g. a T-pose sleeve on an arms-down body) is not pushed, only counted. When the rounds run
/// out unresolved, the best state seen is returned (least depth beyond `tolerance`, then
/// fewest vertices inside + crossing edges, then fewest layer offences, then least depth).
/// Rounds repeat until no vertex is inside and no edge crosses (at most max_iterations).
/// `crossings` indexes the same body mesh as `body`.
PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     const PenetrationOptions& options = {});

/// As above, and the garment is also kept outside inner garment layers (seed 001 §6.3): a
/// vertex whose signed distance f to a layer is below 0 (or, in the first round, below the
/// layer's clearance k) gets the target of seed 001 eq. 7, v' = v + (k − f)·n = v + (k + d)·n
/// with d = −f its depth and n the layer's outward direction at its closest point, smoothed
/// by the same Laplacian solve as the body targets. Rounds repeat until nothing is inside the
/// body or a layer, no edge crosses the body and no layer edge pierces the garment: a layer
/// edge through garment triangle T (the layer poking out between T's corners, which are all
/// outside it) pushes T's corners out along the layer's outward normal by how far the edge's
/// outer end lies beyond T, plus k (engine/layer_piercing.h; like crossing edges, only once no
/// vertex is deeper in the body than `tolerance`); the pushes are smoothed by the same solve. The statistics count
/// layer_inside_count / layer_max_depth / layer_crossing_edges too.
PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     std::span<const LayerObstacle> layers, const PenetrationOptions& options = {});

/// measure_penetration() with crossings, plus the vertices inside each of `layers`.
PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, std::span<const LayerObstacle> layers,
                                     double clearance);

} // namespace vfit
