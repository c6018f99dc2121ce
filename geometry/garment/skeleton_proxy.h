// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A coarse stand-in for a large watertight part, for skeleton extraction (seed 000 §5.1):
/// shortest-edge collapses that keep the surface a closed manifold and remember which
/// proxy vertex every input vertex went into, so that the skeleton's vertex → node map
/// (eq. 12) carries over to full resolution exactly.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// A simplified mesh and where each input vertex went.
struct SkeletonProxy {
  Mesh mesh;                              ///< positions and triangles; each vertex at the mean of its input vertices
  std::vector<std::int32_t> vertex_proxy; ///< #V input: the proxy vertex it was merged into
};

/// Collapses the currently shortest edge of a closed (watertight) triangle mesh (#V × 3
/// positions, #F × 3 triangles) until `target_vertices` remain, skipping collapses that
/// would break the link condition (two vertices sharing neighbours other than the two across
/// their edge: a pinched or non-manifold result) or leave a vertex of valence < 3; it may stop
/// above the target when no legal collapse is left. Geometry is not guarded (a fold is
/// harmless to the uniform-Laplacian contraction, which sees connectivity only). Far cheaper
/// than quadric decimation (geometry/mesh/decimate.h, which also rejected every collapse on a
/// tube of thin triangles). A mesh with at most `target_vertices` vertices is returned as is.
/// Throws vfit::Error for a bad index. A mesh of more than 16 × `target_vertices` vertices is
/// first brought to about 8 × the target by rounds of collapses in which each vertex takes part
/// at most once (shortest edge first within a round, only edges up to 1.5 × the round's
/// lower-quartile length, under the same link and valence rules), each round a few passes over
/// the mesh, so that the shortest-first queue only orders the last ~8 × target vertices. The
/// queue then takes it to the target, ordering collapses by the distance between the means of
/// the coarse vertices it merges; the output positions stay the means of the input vertices.
/// Smaller meshes (the Table-1 garments' parts) take the shortest-first collapses alone.
SkeletonProxy simplify_for_skeleton(const Mesh& closed_mesh, std::size_t target_vertices);

} // namespace vfit
