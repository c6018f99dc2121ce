// SPDX-License-Identifier: Apache-2.0
#include "geodesic.h"

#include <limits>
#include <queue>

namespace vfit {

std::vector<double> geodesic_distance(const SurfaceGraph& graph, const std::vector<GeodesicSeed>& seeds,
                                      std::int32_t stop) {
  std::vector<double> dist(graph.vertex_count(), std::numeric_limits<double>::infinity());
  using Entry = std::pair<double, std::int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (const GeodesicSeed& s : seeds)
    if (s.distance < dist[s.vertex]) {
      dist[s.vertex] = s.distance;
      queue.push({s.distance, s.vertex});
    }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue; // a stale entry: v was settled closer
    if (v == stop) break;
    for (std::int32_t i = graph.offsets[v]; i < graph.offsets[v + 1]; ++i) {
      const std::int32_t u = graph.neighbours[i];
      const double du = d + graph.lengths[i];
      if (du < dist[u]) {
        dist[u] = du;
        queue.push({du, u});
      }
    }
  }
  return dist;
}

} // namespace vfit
