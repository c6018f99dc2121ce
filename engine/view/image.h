// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// RGB images and PNG files: what the renderer draws into and writes (8-bit sRGB-encoded
/// colour, no alpha), encoded and decoded with libpng.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace vfit {

/// An 8-bit RGB colour.
using Rgb8 = std::array<std::uint8_t, 3>;

/// A width × height RGB image, rows top to bottom, pixels left to right, 3 bytes per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb; ///< height × width × 3

  /// An image of the given size filled with `fill`. Sizes must be ≥ 0.
  Image(int w, int h, Rgb8 fill = {255, 255, 255});
  Image() = default;

  /// The pixel at column x, row y (0 ≤ x < width, 0 ≤ y < height; assert only).
  Rgb8 at(int x, int y) const;
  /// Sets the pixel at (x, y); does nothing outside the image (so drawing may clip).
  void set(int x, int y, Rgb8 colour);
  /// Fills the rectangle [x0, x1) × [y0, y1), clipped to the image.
  void fill_rect(int x0, int y0, int x1, int y1, Rgb8 colour);
  /// Copies `other` with its top-left corner at (x, y), clipped to this image.
  void paste(const Image& other, int x, int y);
};

/// The PNG encoding (8-bit RGB, non-interlaced) of `image`. Throws vfit::Error for an empty
/// image (width or height 0).
std::string encode_png(const Image& image);

/// Writes `image` as a PNG file, atomically (a temporary file beside it, renamed). Throws
/// vfit::Error naming `path` when it cannot be written.
void write_png(const std::filesystem::path& path, const Image& image);

/// Decodes PNG bytes (any bit depth and colour type; alpha composited onto white, grey expanded
/// to RGB, 16-bit channels reduced to 8) into an RGB image. `source` names the input in messages.
/// Throws vfit::Error "<source>: not a PNG file" or "<source>: corrupt PNG: <why>".
Image decode_png(std::string_view bytes, const std::string& source);

/// Reads and decodes a PNG file (decode_png()); throws vfit::Error naming `path`.
Image read_png(const std::filesystem::path& path);

} // namespace vfit
