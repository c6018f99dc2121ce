// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/garment/waistband.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <string>
#include <utility>

#include "vfit/kernels/error.h"
#include "vfit/kernels/hole_caps.h"

namespace vfit {

std::vector<std::int32_t> waistband_vertices(std::span<const float> positions, std::span<const std::int32_t> triangles,
                                             double band_width) {
  const std::size_t nv = positions.size() / 3;
  if (!(band_width >= 0) || !std::isfinite(band_width))
    throw Error("waistband", 0, "band_width must be finite and ≥ 0, got " + std::to_string(band_width));
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nv)
      throw Error("waistband", 0,
                  "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(nv) + ")");
  const HoleCaps loops = build_hole_caps(triangles, nv);
  if (loops.loop_count() == 0) return {};
  std::size_t top = 0;
  double top_y = -INFINITY;
  for (std::size_t l = 0; l < loops.loop_count(); ++l) {
    double y = 0;
    const std::int32_t b = loops.loop_offsets[l], e = loops.loop_offsets[l + 1];
    for (std::int32_t k = b; k < e; ++k)
      y += positions[3 * static_cast<std::size_t>(loops.loop_vertices[k]) + 1];
    y /= std::max(1, e - b);
    if (y > top_y) {
      top_y = y;
      top = l;
    }
  }
  // Dijkstra from the waist loop over the mesh edges (each triangle side, both directions).
  std::vector<std::vector<std::int32_t>> neighbours(nv);
  for (std::size_t f = 0; f < triangles.size() / 3; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = triangles[3 * f + k], b = triangles[3 * f + (k + 1) % 3];
      neighbours[static_cast<std::size_t>(a)].push_back(b);
      neighbours[static_cast<std::size_t>(b)].push_back(a);
    }
  std::vector<double> distance(nv, INFINITY);
  using Entry = std::pair<double, std::int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (std::int32_t k = loops.loop_offsets[top]; k < loops.loop_offsets[top + 1]; ++k) {
    distance[static_cast<std::size_t>(loops.loop_vertices[k])] = 0;
    queue.emplace(0.0, loops.loop_vertices[k]);
  }
  while (!queue.empty()) {
    const auto [d, a] = queue.top();
    queue.pop();
    if (d > distance[static_cast<std::size_t>(a)]) continue;
    for (std::int32_t b : neighbours[static_cast<std::size_t>(a)]) {
      double len2 = 0;
      for (int k = 0; k < 3; ++k) {
        const double e = double(positions[3 * std::size_t(b) + k]) - positions[3 * std::size_t(a) + k];
        len2 += e * e;
      }
      const double db = d + std::sqrt(len2);
      if (db > band_width || db >= distance[static_cast<std::size_t>(b)]) continue;
      distance[static_cast<std::size_t>(b)] = db;
      queue.emplace(db, b);
    }
  }
  std::vector<std::int32_t> band;
  for (std::size_t i = 0; i < nv; ++i)
    if (distance[i] <= band_width) band.push_back(static_cast<std::int32_t>(i));
  return band;
}

} // namespace vfit
