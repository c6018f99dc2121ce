// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Hole filling (seed 000 §5.1): a garment part (a sleeve tube open at both ends, a leg, a torso
/// with neck, waist and armholes) made watertight so that mean-curvature-flow skeletonisation
/// can run on it. Each boundary loop gets a dome-shaped cap of concentric rings.

#include <cstddef>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

struct HoleFillOptions {
  /// Height of each cap's dome above its loop's centroid, as a fraction of the loop's mean
  /// radius (distance of its vertices to their centroid). 1: a hemisphere, whose medial axis
  /// ends at the opening's centre, so a tube's curve skeleton reaches its openings; 0: flat.
  double dome_height = 1.0;
  /// A cap's rings have at most this many vertices, and it has at most a quarter as many
  /// rings (0: unbounded). Unbounded, a cap over a loop of n vertices has about n²/6 vertices,
  /// which on a 10^5-vertex tee was 1.7× the sleeves' own vertices, all of them input to the
  /// proxy that skeletonises them, while the proxy keeps ~one vertex per cm² of cap
  /// whatever its resolution. Loops of up to this many vertices (every corpus and Table-1
  /// garment's) get the same caps as unbounded.
  std::size_t max_ring_vertices = 128;
  /// Spacing of a cap's rings and of the vertices along them (mesh units); 0: the rim's own
  /// (about n vertices per ring for a loop of n). A spacing longer than the rim's thins the
  /// rings to about perimeter / edge_length vertices (at least 6) and their count to a
  /// quarter of that: a cap as coarse as the skeleton's proxy will be, where the rim's
  /// spacing would give it vertices that the proxy then collapses again
  /// (extract_part_skeleton()). A spacing at or below the rim's changes nothing.
  double edge_length = 0;
};

/// A watertight mesh made from an open one: the input's vertices first, in their order, then
/// the caps' vertices.
struct FilledMesh {
  Mesh mesh;                         ///< positions and triangles only (UVs, normals, labels dropped)
  std::size_t original_vertices = 0; ///< vertices [0, original_vertices) are the input's, unmoved
  std::size_t loops_filled = 0;      ///< boundary loops closed
};

/// Closes every boundary loop of `open_mesh` (#V × 3 positions, #F × 3 triangles; manifold,
/// consistently oriented) with a cap: rings at angles θ_k = k·90°/R between the loop and an
/// apex on the loop's outward normal (its vector area, oriented as the cap's triangles), each
/// ring the loop scaled by cos θ_k towards its centroid and lifted by sin θ_k·dome height;
/// rings thin out towards the apex (about n·cos θ_k vertices for a loop of n) and neighbouring
/// rings are zipped by arc-length parameter, so caps have no slivers. R ≈ n/4 (at least 1):
/// about square triangles; options.max_ring_vertices and options.edge_length bound both for
/// long or finely sampled loops (the rim is then zipped to a first ring with fewer vertices). The caps' triangles are
/// oriented like the input's, so an outward-oriented part gives an outward-oriented closed surface. A mesh without
/// boundary is returned unchanged. Throws vfit::Error("hole filling", …) naming the vertex where a boundary is not a
/// simple loop (a vertex with two outgoing boundary edges: non-manifold or inconsistently oriented input) and for a bad
/// index.
FilledMesh fill_holes(const Mesh& open_mesh, const HoleFillOptions& options = {});

} // namespace vfit
