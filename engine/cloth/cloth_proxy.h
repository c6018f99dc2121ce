// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A coarse simulation proxy of a high-resolution garment (seed 004 §3: simulate the coarse
/// garment, reconstruct the fine one from it, then fix its penetration, §3.2.2). The proxy is
/// the fine garment decimated by half-edge collapses, short edges first (even edge lengths, as
/// the mass-spring cloth wants: geometry/mesh/even_decimate.h), so its vertices are fine vertices at their fine
/// positions and its boundary loops (hems, cuffs, the neckline, a waistband's opening) are loops of fine boundary
/// vertices. Every fine vertex is embedded in it (kernels/surface_embedding.h: closest proxy triangle, barycentrics and
/// the offset in a frame of blended vertex normals), so the fine garment follows the simulated proxy by a local
/// rigid-ish transform: rigid motions of the proxy move it exactly, a rotated sleeve keeps its shape.
///
/// Per-vertex inputs of the simulation carry over by the proxy vertex's fine vertex
/// (proxy_vertex_values(): fabrics; proxy_pins(): pins). The waistband auto-pins of
/// ClothOptions need nothing: the proxy keeps the waist opening, and waistband_vertices() finds
/// the band on it.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "vfit/kernels/surface_embedding.h"

namespace vfit {

/// The proxy and the fine garment's embedding in it.
struct ClothProxy {
  std::vector<float> positions;              ///< #P × 3 (m): the proxy at rest (its fine vertices' positions)
  std::vector<std::int32_t> triangles;       ///< #Q × 3 indices in [0, #P)
  std::vector<std::int32_t> source_vertices; ///< #P: the fine vertex each proxy vertex is, ascending
  /// #V (the fine garment's vertices): each fine vertex in its closest proxy triangle; vertices
  /// in none of the simulated triangles have triangle −1.
  SurfaceEmbedding embedding;

  std::size_t vertex_count() const { return positions.size() / 3; } ///< #P
};

/// Builds the proxy of the fine garment (`positions` #V × 3 m, after the geometric fit, before
/// simulation) over its triangles `simulated_triangles` (#F' × 3 indices in [0, #V): the
/// garment's largest piece, say, without its trim; fit_pipeline.cpp) decimated to about
/// `target_vertices` vertices (decimate_evenly(), geometry/mesh/even_decimate.h; it may stop
/// above the target where its guards reject every collapse), and embeds in it every
/// fine vertex of those triangles. A surface of at most `target_vertices` vertices is its own
/// proxy (the fine vertices of the triangles, each embedded at its own place). Throws
/// vfit::Error for an index out of range; the surface must be manifold and consistently
/// oriented (the pipeline's garments are: read_garment() welds and orients them).
ClothProxy build_cloth_proxy(std::span<const float> positions, std::span<const std::int32_t> simulated_triangles,
                             std::size_t target_vertices);

/// The fine garment from the proxy moved to `proxy_positions` (#P × 3 m, the proxy's topology):
/// every embedded fine vertex carried by carry_embedded_points(), the proxy's own fine vertices
/// exactly at their proxy positions; vertices not embedded are left as they are in
/// `positions` (#V × 3 m, written in place).
void reconstruct_from_proxy(const ClothProxy& proxy, std::span<const float> proxy_positions,
                            std::span<float> positions);

/// A per-vertex value of the fine garment (#V: ClothOptions::vertex_fabric's fabric indices,
/// say) for each proxy vertex: its fine vertex's value (#P). An empty input gives an empty output.
std::vector<std::int32_t> proxy_vertex_values(const ClothProxy& proxy, std::span<const std::int32_t> fine_values);

/// The proxy vertices that stand for pinned fine vertices (`fine_pins`: indices in [0, #V)),
/// ascending; proxy indices. Fine pinned vertices that are not proxy vertices follow the proxy
/// like any other; a caller that needs them fixed puts them back after reconstruct_from_proxy().
std::vector<std::int32_t> proxy_pins(const ClothProxy& proxy, std::span<const std::int32_t> fine_pins);

} // namespace vfit
