// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The edge graph of a triangle mesh as garment segmentation reads it (seed 000 §4): vertex
/// adjacency with edge lengths, connected components and boundary loops (the garment's
/// openings). Built from the index soup alone, so flipped faces, non-manifold edges and
/// unreferenced vertices are all accepted.

#include <cstdint>
#include <numeric>
#include <vector>

#include <Eigen/Core>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Union-find over [0, n) with path halving; the smaller index becomes the root.
class UnionFind {
public:
  explicit UnionFind(std::size_t n) : m_parent(n) { std::iota(m_parent.begin(), m_parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (m_parent[x] != x) {
      m_parent[x] = m_parent[m_parent[x]];
      x = m_parent[x];
    }
    return x;
  }
  /// Joins the sets of a and b; returns the new root.
  std::uint32_t unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return a;
    if (b < a) std::swap(a, b);
    m_parent[b] = a;
    return a;
  }

private:
  std::vector<std::uint32_t> m_parent;
};

/// One opening of a garment: a connected set of boundary edges (edges used by one face).
struct BoundaryLoop {
  std::vector<std::int32_t> vertices;                 ///< the loop's vertices (unordered)
  double perimeter = 0;                               ///< total length of its edges (mesh units)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(); ///< length-weighted centre of its edges
  Eigen::Vector3d normal =
      Eigen::Vector3d::UnitY(); ///< unit area vector (Newell; best-fit plane normal for a pinched loop); sign arbitrary
  double min_y = 0, max_y = 0;  ///< height range
};

/// Undirected edge graph of a mesh in CSR form.
struct SurfaceGraph {
  std::vector<Eigen::Vector3d> points;  ///< #V positions
  std::vector<std::int32_t> offsets;    ///< #V + 1: neighbours of v are [offsets[v], offsets[v+1])
  std::vector<std::int32_t> neighbours; ///< 2·#E neighbour indices
  std::vector<float> lengths;           ///< 2·#E edge lengths, parallel to `neighbours`
  std::vector<std::int32_t> component;  ///< #V component index (0 = largest); −1: unreferenced
  std::size_t component_count = 0;
  std::vector<std::size_t> component_sizes; ///< vertices per component, largest first
  std::vector<BoundaryLoop> loops;          ///< every boundary loop, largest perimeter first
  double mean_edge = 0;                     ///< mean edge length

  std::size_t vertex_count() const { return points.size(); }
};

/// Builds the graph of `mesh` (#V × 3 positions, #F × 3 triangles). Throws vfit::Error naming
/// the face for an index outside [0, #V).
SurfaceGraph build_surface_graph(const Mesh& mesh);

} // namespace vfit
