// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Points embedded in a triangle mesh (a coarse "carrier" surface) so that they follow it when
/// it moves: the fine garment carried by its simulated coarse proxy (seed 004 §3: simulate the
/// coarse garment, then reconstruct the fine one from it; here by a local frame per point rather
/// than the seed's learned per-triangle samples).
///
/// Each point p is tied to its closest carrier point q = (1−u−v)·a + u·b + v·c on triangle
/// (a, b, c) and keeps its offset d = p − q in a frame at q: N = the normalised blend
/// (1−u−v)·n_a + u·n_b + v·n_c of the carrier's area-weighted vertex normals, t₁ = the edge
/// b − a with its N component removed, normalised, and t₂ = N × t₁. Its coordinates are
/// (d·t₁, d·t₂, d·N). After the carrier moves, p' = q' + d₁·t₁' + d₂·t₂' + d_N·N' with q' and
/// the frame rebuilt from the moved triangle. Under a rigid motion of the carrier (rotation and
/// translation) every point moves by the same motion (to float rounding); a flat carrier
/// stretched in its plane keeps points that lay in its plane in it. Across a carrier edge the
/// normal blend and the closest point are continuous, so a bent carrier carries its points
/// without steps at its edges (only the small tangential offsets turn with their triangle).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vfit {

/// Where each embedded point sits relative to its carrier triangle.
struct SurfaceEmbedding {
  std::vector<std::int32_t> triangles; ///< #P carrier triangle of each point, or −1: not embedded (kept where it is)
  std::vector<float> barycentrics;     ///< #P × 2 (u, v) of the closest carrier point q on that triangle
  std::vector<float> offsets;          ///< #P × 3 (d·t₁, d·t₂, d·N) of d = p − q (m)

  std::size_t size() const { return triangles.size(); } ///< #P
};

/// Points per TBB task in embed_points() and carry_embedded_points().
inline constexpr std::size_t SURFACE_EMBEDDING_GRAIN = 1024;

/// Embeds `points` (#P × 3, m) in the carrier mesh (`carrier_positions` #C × 3 m, its rest
/// shape; `carrier_triangles` #T × 3 indices in [0, #C)): each point's closest carrier triangle
/// (kernels/proximity.h, any distance), barycentrics and frame offsets (file comment). `mask`,
/// when not empty (#P), embeds only the points whose entry is non-zero; the others get triangle
/// −1. A carrier with no triangles embeds nothing. Throws vfit::Error ("proximity mesh: …") for
/// a non-finite carrier position or an index out of range, ("proximity queries: …") for a
/// non-finite point, and for a mask of the wrong size.
void embed_points(std::span<const float> points, std::span<const float> carrier_positions,
                  std::span<const std::int32_t> carrier_triangles, std::span<const std::uint8_t> mask,
                  SurfaceEmbedding& embedding);

/// Moves the embedded points with the carrier: writes p' (file comment) into `points` (#P × 3,
/// the embedding's #P; rows of points whose triangle is −1 are left as they are) from the moved
/// `carrier_positions` (#C × 3, same topology `carrier_triangles` as at embed_points()).
/// Where a frame cannot be built (a zero normal blend, or an edge b − a along N: a degenerate
/// carrier triangle), at embedding or here, the world axes stand in for it. TBB-parallel over the points
/// (grain SURFACE_EMBEDDING_GRAIN); the same bits as a serial loop.
void carry_embedded_points(const SurfaceEmbedding& embedding, std::span<const float> carrier_positions,
                           std::span<const std::int32_t> carrier_triangles, std::span<float> points);

} // namespace vfit
