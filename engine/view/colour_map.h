// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Colour maps for false-colour pictures of a per-vertex scalar (strain, ease): a sequential
/// map for one-signed quantities and a diverging one centred on zero for signed ones.

#include <array>

namespace vfit {

/// RGB in [0, 1]³ (display-encoded, as written to the PNG).
using Rgb = std::array<float, 3>;

/// The colour maps colour_map() knows.
enum class ColourMap {
  SEQUENTIAL, ///< dark blue → teal → green → yellow (viridis-like), perceptually ordered
  DIVERGING,  ///< blue → light grey → red, for signed values with 0 at the middle
};

/// The colour of `t` ∈ [0, 1] under `map` (piecewise-linear between 5 stops); t is clamped
/// to [0, 1]; NaN gives mid grey (0.5, 0.5, 0.5).
Rgb colour_map(ColourMap map, float t);

} // namespace vfit
