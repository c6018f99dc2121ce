// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Discrete Reeb graph of a scalar function on a garment's surface (seed 000 §4.1, after
/// Werghi, Xiao and Siebert 2006), and the merge tree of the same function at vertex
/// resolution, which locates the saddles (armpits, crotch) where branches meet the trunk.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "surface_graph.h"

namespace vfit {

/// A node: one connected component of the vertices whose value lies in one band.
struct ReebNode {
  int band = 0;         ///< band index, 0 at the source
  double level_min = 0; ///< the band's range of function values [level_min, level_max)
  double level_max = 0;
  std::size_t vertex_count = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(); ///< mean position of its vertices
};

/// An arc: the two nodes are joined by at least one mesh edge (nodes of different bands).
struct ReebArc {
  std::int32_t from = 0, to = 0; ///< node indices, band(from) < band(to)
  std::size_t edge_count = 0;    ///< mesh edges between them
};

struct ReebGraph {
  std::vector<double> levels;  ///< K + 1 band boundaries, ascending
  std::vector<ReebNode> nodes; ///< ordered by band
  std::vector<ReebArc> arcs;
  std::vector<std::int32_t> vertex_node; ///< #V node of each vertex; −1 where the value is not finite

  /// Nodes of the band after `node` joined to it (its successors towards larger values).
  std::vector<std::int32_t> children(std::int32_t node) const;
};

/// Splits [min f, max f] into `bands` equal bands (≥ 1) and builds the graph: components per band
/// by union-find over edges inside the band, arcs between components of different bands that
/// share an edge. `f` is #V values; vertices with non-finite values are left out.
ReebGraph build_reeb_graph(const SurfaceGraph& graph, const std::vector<double>& f, int bands);

/// A superlevel-set component of f just before it merges into another at a saddle.
struct MergeBranch {
  std::int32_t birth_vertex = -1; ///< where the component appeared: its largest value of f
  double birth_value = 0;
  std::size_t vertex_count = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double min_y = 0;                      ///< lowest height of its vertices
  std::vector<std::uint32_t> tag_counts; ///< per tag: how many of its vertices carry it (see merge_tree)
};

/// Two or more significant components of {f > value} that join at `saddle`.
struct MergeEvent {
  std::int32_t saddle = -1; ///< the vertex whose addition joins them
  double value = 0;         ///< f(saddle)
  std::vector<MergeBranch> branches;
};

/// Merge tree of the superlevel sets of f (a sweep from the largest value down, union-find
/// over edges). A component is significant when it spans at least `min_persistence` in f
/// (birth value − merge value) and holds at least `min_vertices` vertices; smaller ones are
/// absorbed silently (boundary noise). `tags` (#V, values in [0, tag_count) or −1; may be
/// empty) labels vertices, e.g. by the opening they lie on, and each branch reports how many
/// of each it holds. Events are returned in sweep order (decreasing value).
std::vector<MergeEvent> merge_tree(const SurfaceGraph& graph, const std::vector<double>& f, double min_persistence,
                                   std::size_t min_vertices, const std::vector<std::int32_t>& tags = {},
                                   int tag_count = 0);

/// The vertices of the component of {u : f(u) > value} that contains `seed` (flood fill).
std::vector<std::int32_t> superlevel_component(const SurfaceGraph& graph, const std::vector<double>& f,
                                               std::int32_t seed, double value);

} // namespace vfit
