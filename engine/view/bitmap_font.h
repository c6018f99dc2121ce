// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A tiny built-in 5 × 7 bitmap font (our own glyphs) for the labels of rendered pictures:
/// view names, legend values and titles. Digits, A–Z (lower case is drawn as upper case),
/// space and . , - + % : / ( ) _ = ; any other character is drawn as '?'.

#include <string_view>

#include "vfit/engine/view/image.h"

namespace vfit {

inline constexpr int GLYPH_WIDTH = 5;   ///< glyph columns (font pixels)
inline constexpr int GLYPH_HEIGHT = 7;  ///< glyph rows (font pixels)
inline constexpr int GLYPH_ADVANCE = 6; ///< columns from one character to the next (1 blank)

/// Whether font pixel (column, row) of `c` is ink; column in [0, 5), row in [0, 7) from the top.
/// False outside the glyph cell.
bool glyph_ink(char c, int column, int row);

/// Width in image pixels of `text` drawn at integer `scale` ≥ 1 (each font pixel a
/// scale × scale square): (6·n − 1)·scale for n > 0 characters, 0 for empty text.
int text_width(std::string_view text, int scale);

/// Draws `text` with its top-left corner at image pixel (x, y), each font pixel a
/// scale × scale square of `colour`, clipped to the image. No background is drawn.
void draw_text(Image& image, int x, int y, std::string_view text, int scale, Rgb8 colour);

} // namespace vfit
