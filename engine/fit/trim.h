// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Trim pieces of a garment: its connected pieces other than the largest (buttons, labels, a
/// pocket or collar modelled apart). No spring ties them to the garment, so free in the cloth
/// simulation they would fall off it; they are pinned in the simulation and then follow the
/// garment. Internal to engine/fit/.

#include <cstdint>
#include <span>
#include <vector>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit::fitting {

/// A garment's trim vertices and the triangles of its largest piece.
struct TrimPieces {
  std::vector<std::int32_t> vertices;       ///< ascending
  std::vector<std::int32_t> main_triangles; ///< the largest piece's triangles, #M × 3
};

/// The trim of `mesh` (empty when it is one piece). O(#V + #F).
TrimPieces trim_pieces(const Mesh& mesh);

/// Moves the trim vertices with the largest piece from `before` to `positions` (both #V × 3,
/// m): each moves as the point of the largest piece nearest to it in `before` (its closest
/// point's barycentric blend of its triangle's corner displacements). O(#trim log #M).
void carry_trim(const TrimPieces& trim, std::span<const float> before, std::span<float> positions);

} // namespace vfit::fitting
