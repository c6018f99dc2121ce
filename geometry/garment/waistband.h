// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The waistband of a bottom garment (trousers, shorts, skirt): the band of cloth along its
/// waist opening, which the cloth simulator pins to the body (ClothOptions::waistband_pins in
/// engine/cloth/cloth_sim.h) so the garment cannot slide down.

#include <cstdint>
#include <span>
#include <vector>

namespace vfit {

/// The vertices whose distance along the mesh's edges from the waist opening is at most
/// band_width, the opening's own vertices included. The distance is the shortest path over the
/// triangles' sides (Dijkstra, edge lengths in m, in double); the waist opening is the topmost
/// boundary loop, the one of highest mean Y (Y up).
///
/// positions: #V × 3 (m); triangles: #F × 3 indices; band_width (m). Returns ascending vertex
/// indices; empty when the mesh has no boundary (a closed mesh). Throws vfit::Error
/// ("waistband: …") for a negative or non-finite band_width or a triangle index outside [0, #V).
/// Positions are not checked for finiteness. O(#V + #F log #F): the boundary loops
/// (build_hole_caps(), kernels/hole_caps.h) and the edge lists, then a search that visits only
/// the band.
std::vector<std::int32_t> waistband_vertices(std::span<const float> positions, std::span<const std::int32_t> triangles,
                                             double band_width);

} // namespace vfit
