// SPDX-License-Identifier: Apache-2.0
// compose_views() and compose_view() (declared in render.h): rendered views laid side by side
// with their titles and the false-colour legend.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "vfit/engine/view/bitmap_font.h"
#include "vfit/engine/view/render.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr Rgb8 PANEL_BACKGROUND = {246, 246, 246};
constexpr Rgb8 TEXT = {70, 70, 70};
constexpr Rgb8 SEPARATOR = {205, 205, 205};

// Everything is measured in font pixels of `scale` image pixels, so that labels stay legible
// at any view size.
struct Layout {
  int size = 0;  // view side (pixels)
  int scale = 1; // font pixel size
  int pad() const { return 6 * scale; }
};

std::string format_value(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", static_cast<double>(v));
  return text;
}

struct LegendText {
  std::string name;
  std::string labels[3]; // max, middle, min (top to bottom)
};

LegendText legend_text(const ScalarLegend& l) {
  return {l.name, {format_value(l.max), format_value(0.5f * (l.min + l.max)), format_value(l.min)}};
}

int legend_width(const Layout& layout, const ScalarLegend& l) {
  const LegendText t = legend_text(l);
  int label_width = 0;
  for (const auto& s : t.labels)
    label_width = std::max(label_width, text_width(s, layout.scale));
  const int bar_and_labels = 2 * layout.pad() + label_width;
  return 4 * layout.pad() + std::max(bar_and_labels, text_width(t.name, layout.scale));
}

void draw_legend(Image& out, int x0, const Layout& layout, const ScalarLegend& l) {
  const LegendText t = legend_text(l);
  const int pad = layout.pad(), scale = layout.scale;
  const int top = layout.size / 5, bottom = layout.size - layout.size / 5;
  const int bar_left = x0 + pad, bar_right = bar_left + 2 * pad;
  draw_text(out, bar_left, top - pad - GLYPH_HEIGHT * scale, t.name, scale, TEXT);
  for (int y = top; y < bottom; ++y) {
    const float u = static_cast<float>(bottom - 1 - y) / static_cast<float>(std::max(1, bottom - 1 - top));
    const Rgb c = colour_map(l.map, u);
    const Rgb8 c8 = {static_cast<std::uint8_t>(std::lround(255 * c[0])),
                     static_cast<std::uint8_t>(std::lround(255 * c[1])),
                     static_cast<std::uint8_t>(std::lround(255 * c[2]))};
    out.fill_rect(bar_left, y, bar_right, y + 1, c8);
  }
  // Frame, ticks and labels: max at the top, the middle value, min at the bottom.
  out.fill_rect(bar_left - 1, top - 1, bar_right + 1, top, TEXT);
  out.fill_rect(bar_left - 1, bottom, bar_right + 1, bottom + 1, TEXT);
  out.fill_rect(bar_left - 1, top, bar_left, bottom, TEXT);
  out.fill_rect(bar_right, top, bar_right + 1, bottom, TEXT);
  const int ticks[3] = {top, (top + bottom) / 2, bottom - 1};
  for (int k = 0; k < 3; ++k) {
    out.fill_rect(bar_right, ticks[k], bar_right + pad / 2, ticks[k] + std::max(1, scale / 2), TEXT);
    draw_text(out, bar_right + pad, ticks[k] - GLYPH_HEIGHT * scale / 2, t.labels[k], scale, TEXT);
  }
}

Image compose(const Rendering& r, const std::vector<std::size_t>& which) {
  if (r.views.empty()) throw Error("render", 0, "nothing was rendered");
  Layout layout;
  layout.size = r.views.front().image.width;
  layout.scale = std::max(1, (layout.size + 128) / 256); // 2 font pixels per image pixel from 384 px up
  const int legend = r.legend ? legend_width(layout, *r.legend) : 0;
  Image out(static_cast<int>(which.size()) * layout.size + legend, layout.size, PANEL_BACKGROUND);
  for (std::size_t k = 0; k < which.size(); ++k) {
    const ViewImage& v = r.views[which[k]];
    const int x0 = static_cast<int>(k) * layout.size;
    out.paste(v.image, x0, 0);
    if (k > 0) out.fill_rect(x0, 0, x0 + 1, layout.size, SEPARATOR);
    draw_text(out, x0 + layout.pad(), layout.pad(), render_view_name(v.view), layout.scale, TEXT);
  }
  if (r.legend) {
    const int x0 = static_cast<int>(which.size()) * layout.size;
    out.fill_rect(x0, 0, x0 + 1, layout.size, SEPARATOR);
    draw_legend(out, x0, layout, *r.legend);
  }
  return out;
}

} // namespace

Image compose_views(const Rendering& rendering) {
  std::vector<std::size_t> all(rendering.views.size());
  for (std::size_t k = 0; k < all.size(); ++k)
    all[k] = k;
  return compose(rendering, all);
}

Image compose_view(const Rendering& rendering, std::size_t index) {
  if (index >= rendering.views.size())
    throw Error("render", 0,
                "view " + std::to_string(index) + " out of range (" + std::to_string(rendering.views.size()) +
                    " views)");
  return compose(rendering, {index});
}

} // namespace vfit
