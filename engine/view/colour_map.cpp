// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/view/colour_map.h"

#include <algorithm>
#include <cmath>

namespace vfit {
namespace {

constexpr int STOP_COUNT = 5;
using Stops = std::array<Rgb, STOP_COUNT>;

// Evenly spaced stops, in 0–255 units.
constexpr Stops SEQUENTIAL_STOPS = {{{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}}};
constexpr Stops DIVERGING_STOPS = {{{59, 76, 192}, {141, 176, 254}, {221, 221, 221}, {244, 154, 123}, {180, 4, 38}}};

} // namespace

Rgb colour_map(ColourMap map, float t) {
  if (std::isnan(t)) return {0.5f, 0.5f, 0.5f};
  const Stops& stops = map == ColourMap::SEQUENTIAL ? SEQUENTIAL_STOPS : DIVERGING_STOPS;
  const float x = std::clamp(t, 0.0f, 1.0f) * (STOP_COUNT - 1);
  const int k = std::min(static_cast<int>(x), STOP_COUNT - 2);
  const float f = x - static_cast<float>(k);
  Rgb c;
  for (int i = 0; i < 3; ++i)
    c[i] = ((1.0f - f) * stops[k][i] + f * stops[k + 1][i]) / 255.0f;
  return c;
}

} // namespace vfit
