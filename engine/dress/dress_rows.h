// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// One vertex of a packed #V × 3 float array as an Eigen row in double, the unit of the
/// dressing room's geometry (pushes, chords, layer normals).

#include <cstddef>
#include <span>

#include <Eigen/Core>

namespace vfit::dress {

using Row = Eigen::RowVector3d;

/// Row i of `p` (#V × 3, any unit), i < #V.
inline Row row_of(std::span<const float> p, std::size_t i) { return Row(p[3 * i], p[3 * i + 1], p[3 * i + 2]); }

} // namespace vfit::dress
