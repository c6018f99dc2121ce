#pragma once
/// \file
/// Penetration detection and removal between a garment and a body (seed 000 §6.2, eq. 18–21;
/// seed 004 §3.2.2): garment vertices inside the body, or closer to it than a clearance κ, are
/// pushed out to κ along the side of their closest body point while a Laplacian term keeps the
/// garment's shape; detection and solve repeat until nothing is inside.

#include <cstddef>
#include <span>
#include <vector>

#include "geometry/mesh/mesh.h"

namespace vfit {

class ProximityIndex;

/// Where a garment stands against a body. Depths are in metres (positive = inside).
struct PenetrationStats {
  std::size_t inside_count = 0; ///< vertices inside the body (seed 000 eq. 18: f < 0)
  std::size_t near_count = 0;   ///< vertices inside or closer than the clearance κ
  double max_depth = 0;         ///< deepest vertex inside (0 when none)
  double mean_depth = 0;        ///< mean depth over the vertices inside (0 when none)
};

struct PenetrationOptions {
  double clearance = 0.002;   ///< κ (m): the gap left between a pushed vertex and the body
  double smoothness = 1.0;    ///< λ2/λ1: weight of keeping the garment's Laplacian coordinates
  int max_iterations = 25;    ///< detection → solve rounds at most
  double tolerance = 0.0005;  ///< stop when no vertex is deeper than this (m)
};

struct PenetrationReport {
  PenetrationStats before, after;
  int iterations = 0;
  double milliseconds = 0;
};

/// Measures a garment (positions #V × 3, m) against a body index (a closed, outward-oriented
/// mesh), with `clearance` κ (m) for near_count.
PenetrationStats measure_penetration(std::span<const float> garment_positions, const ProximityIndex& body,
                                     double clearance);

/// Removes penetration in place. garment: positions and triangles (its uniform Laplacian keeps
/// the shape: argmin_y Σ_i ‖y_i − t_i‖² + λ ‖L (y − y⁰)‖², t_i = closest body point + κ·outward
/// for vertices inside or within κ, t_i = y⁰_i elsewhere; the matrix I + λ LᵀL is factored once
/// and reused every round, as seed 004 does). Returns the statistics before and after.
PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const PenetrationOptions& options = {});

} // namespace vfit
