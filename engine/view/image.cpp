// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/view/image.h"

#include <algorithm>
#include <cassert>

#include <png.h>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit {

Image::Image(int w, int h, Rgb8 fill) : width(w), height(h) {
  assert(w >= 0 && h >= 0 && "image sizes must be ≥ 0");
  rgb.resize(3 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (std::size_t i = 0; i < rgb.size(); i += 3)
    std::copy(fill.begin(), fill.end(), rgb.begin() + i);
}

Rgb8 Image::at(int x, int y) const {
  assert(x >= 0 && x < width && y >= 0 && y < height && "pixel outside the image");
  const std::size_t i = 3 * (static_cast<std::size_t>(y) * width + x);
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

void Image::set(int x, int y, Rgb8 colour) {
  if (x < 0 || x >= width || y < 0 || y >= height) return;
  const std::size_t i = 3 * (static_cast<std::size_t>(y) * width + x);
  rgb[i] = colour[0];
  rgb[i + 1] = colour[1];
  rgb[i + 2] = colour[2];
}

void Image::fill_rect(int x0, int y0, int x1, int y1, Rgb8 colour) {
  for (int y = std::max(y0, 0); y < std::min(y1, height); ++y)
    for (int x = std::max(x0, 0); x < std::min(x1, width); ++x)
      set(x, y, colour);
}

void Image::paste(const Image& other, int x, int y) {
  for (int r = 0; r < other.height; ++r)
    for (int c = 0; c < other.width; ++c)
      set(x + c, y + r, other.at(c, r));
}

// libpng's simplified API (1.6): no setjmp/longjmp across C++ frames; failures come back as
// a flag and a message in the png_image.
std::string encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0)
    throw Error("image", 0,
                "cannot encode an empty image (" + std::to_string(image.width) + " × " + std::to_string(image.height) +
                    ") as PNG");
  png_image info{};
  info.version = PNG_IMAGE_VERSION;
  info.width = static_cast<png_uint_32>(image.width);
  info.height = static_cast<png_uint_32>(image.height);
  info.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_get_memory_size(info, size, 0, image.rgb.data(), 0, nullptr))
    throw Error("image", 0, std::string("PNG encoding failed: ") + info.message);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&info, bytes.data(), &size, 0, image.rgb.data(), 0, nullptr))
    throw Error("image", 0, std::string("PNG encoding failed: ") + info.message);
  bytes.resize(size);
  return bytes;
}

void write_png(const std::filesystem::path& path, const Image& image) {
  write_file_atomically(path, encode_png(image));
}

Image decode_png(std::string_view bytes, const std::string& source) {
  static constexpr unsigned char SIGNATURE[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 8 || !std::equal(SIGNATURE, SIGNATURE + 8, reinterpret_cast<const unsigned char*>(bytes.data())))
    throw Error(source, 0, "not a PNG file");
  png_image info{};
  info.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&info, bytes.data(), bytes.size()))
    throw Error(source, 0, std::string("corrupt PNG: ") + info.message);
  info.format = PNG_FORMAT_RGB;
  Image image(static_cast<int>(info.width), static_cast<int>(info.height));
  const png_color white{255, 255, 255};
  if (!png_image_finish_read(&info, &white, image.rgb.data(), 0, nullptr))
    throw Error(source, 0, std::string("corrupt PNG: ") + info.message);
  return image;
}

Image read_png(const std::filesystem::path& path) { return decode_png(read_file_bytes(path), path.string()); }

} // namespace vfit
