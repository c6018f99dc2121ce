// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Internal caps over the holes of an open triangle mesh, for deciding inside/outside only.
/// A scanned body is rarely closed (neck, soles, eyes); the pseudo-normal side test
/// (Bærentzen & Aanæs 2005) is exact only on a closed mesh. Each boundary loop gets one new
/// vertex, its loop's centroid, and a fan of triangles from that vertex to the loop's edges,
/// oriented so the capped mesh is consistently oriented. ProximityIndex (proximity.h) decides
/// the side on the capped mesh and reports closest points on the original one.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vfit {

/// The boundary loops of a mesh and the fan caps that close them.
struct HoleCaps {
  /// Loop → vertex-index adjacency in compressed sparse rows: loop l walks the vertices
  /// `loop_vertices[loop_offsets[l] .. loop_offsets[l+1])` along its boundary edges, in the
  /// direction the edges have in their triangles. loop_offsets has #L + 1 entries.
  std::vector<std::int32_t> loop_offsets;
  std::vector<std::int32_t> loop_vertices;
  /// #C × 3 cap triangles over the capped vertex set: indices < #V are mesh vertices, index
  /// #V + l is the centroid of loop l. A boundary edge a→b of a mesh triangle gets the cap
  /// triangle (b, a, #V + l), so each capped edge is used once in each direction.
  std::vector<std::int32_t> triangles;

  /// #L, the number of holes.
  std::size_t loop_count() const { return loop_offsets.empty() ? 0 : loop_offsets.size() - 1; }
};

/// Finds the boundary edges of `triangles` (#F × 3 indices in [0, vertex_count), validated by
/// the caller: assert only) — edges with exactly one incident triangle, matched by vertex
/// index — chains them into loops and fans a cap over each. A closed mesh gives no loops.
/// Where two loops touch at one vertex the chaining takes the first unused continuation, which
/// still yields loops that together cover every boundary edge once. O(#F log #F).
HoleCaps build_hole_caps(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// Writes the capped vertex positions: the #V × 3 `positions` (m) followed by the #L loop
/// centroids (mean of each loop's vertices). `capped` is resized to (#V + #L) × 3.
void capped_positions(std::span<const float> positions, const HoleCaps& caps, std::vector<float>& capped);

} // namespace vfit
