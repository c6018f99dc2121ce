// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Topological summary of a triangle mesh: components, boundary loops, manifoldness,
/// orientation, Euler characteristic. Works on any index soup, non-manifold included.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vfit {

struct TopologyReport {
  std::size_t vertices = 0;              ///< #V (all, referenced or not)
  std::size_t unreferenced_vertices = 0; ///< vertices used by no face
  std::size_t faces = 0;                 ///< #F
  std::size_t edges = 0;                 ///< distinct undirected edges
  std::size_t components = 0;            ///< face-connected components (through shared vertices)
  std::size_t boundary_edges = 0;        ///< edges used by exactly one face
  std::size_t boundary_loops = 0;        ///< closed chains of boundary edges (holes, openings)
  std::size_t non_manifold_edges = 0;    ///< edges used by more than two faces
  std::size_t non_manifold_vertices = 0; ///< vertices whose faces form more than one fan
  std::size_t inconsistent_edges = 0;    ///< manifold edges whose two faces traverse it the same way
  std::int64_t euler_characteristic = 0; ///< V − E + F over referenced vertices

  bool manifold() const { return non_manifold_edges == 0 && non_manifold_vertices == 0; }
  bool oriented() const { return inconsistent_edges == 0; }
  /// Closed (no boundary), manifold and consistently oriented.
  bool watertight() const { return boundary_edges == 0 && manifold() && oriented(); }
};

/// Analyses `triangles` (#F × 3 indices in [0, vertex_count)). O(F log F).
TopologyReport analyse_topology(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// The connected pieces of a triangle mesh by shared vertices: per vertex (#V = vertex_count),
/// the smallest vertex index of its piece (a vertex in no triangle is its own piece), so two
/// vertices are in one piece exactly when their labels are equal. `triangles`: #F × 3 indices
/// in [0, vertex_count) (assert only). Union–find, O(F α(V)).
std::vector<std::int32_t> vertex_piece_labels(std::span<const std::int32_t> triangles, std::size_t vertex_count);

} // namespace vfit
