// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Angle-weighted pseudo-normals of a triangle mesh (Bærentzen & Aanæs 2005, "Signed distance
/// computation using the angle weighted pseudonormal", eq. 1 and §3): for a point p whose
/// closest mesh point c lies on feature x (face, edge or vertex), sign((p − c)·n_x) is the side
/// of p, exactly, for a closed manifold mesh. Used by ProximityIndex (proximity.h) for
/// penetration detection (seed 000 eq. 18).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "vertex_normals.h"

namespace vfit {

/// The undirected edges of a triangle mesh, found by vertex index (two corners that share a
/// position but not an index make two different edges).
struct MeshEdges {
  /// #F × 3 edge ids: entry 3f + k is the edge joining corner k to corner (k + 1) mod 3 of f.
  std::vector<std::int32_t> triangle_edges;
  /// Edge → incident-triangle adjacency in compressed sparse rows: the triangles of edge e are
  /// `faces[offsets[e] .. offsets[e+1])`, ascending. Two for an interior manifold edge, one on
  /// a boundary, more at a non-manifold edge. offsets has #E + 1 entries, faces 3·#F.
  std::vector<std::int32_t> offsets;
  std::vector<std::int32_t> faces;

  /// #E, the number of distinct edges.
  std::size_t edge_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

/// Triangles, edges or vertices per TBB task when the pseudo-normals are (re)computed.
inline constexpr std::size_t PSEUDO_NORMALS_GRAIN = 4096;

/// Builds the edge table of `triangles` (#F × 3 indices in [0, vertex_count), validated by the
/// caller: assert only). Edge ids are ordered by (lower vertex, higher vertex). O(#F).
MeshEdges build_mesh_edges(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// Unit pseudo-normals of every face, edge and vertex.
struct PseudoNormals {
  std::vector<float> faces;         ///< #F × 3 unit face normals (right-hand rule); zero if degenerate
  std::vector<float> edges;         ///< #E × 3 normalise(Σ incident unit face normals)
  std::vector<float> vertices;      ///< #V × 3 normalise(Σ incident corner angle (rad) · unit face normal)
  std::vector<float> corner_angles; ///< #F × 3 scratch: the angle (rad) at each triangle corner
};

/// Computes all pseudo-normals, TBB-parallel (grain PSEUDO_NORMALS_GRAIN): a pass over the
/// triangles, then gathers over `edges` and `vertex_faces` (no atomics), so the result is the
/// same bit for bit as pseudo_normals_serial(). positions: #V × 3 (m). A zero-area triangle
/// contributes nothing; an edge or vertex whose sum is zero gets the zero vector.
void pseudo_normals_tbb(std::span<const float> positions, std::span<const std::int32_t> triangles,
                        const MeshEdges& edges, const VertexFaceAdjacency& vertex_faces, PseudoNormals& normals);

/// Serial reference of pseudo_normals_tbb(): the same range kernels over the whole range.
void pseudo_normals_serial(std::span<const float> positions, std::span<const std::int32_t> triangles,
                           const MeshEdges& edges, const VertexFaceAdjacency& vertex_faces, PseudoNormals& normals);

} // namespace vfit
