// SPDX-License-Identifier: Apache-2.0
#include "blend_weights.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "vfit/kernels/error.h"

namespace vfit {

double physical_weight(std::span<const double> distances, double cap) {
  if (!std::isfinite(cap) || cap < 0) throw Error("blend weights", 0, "cap must be finite and ≥ 0");
  if (distances.empty()) return 0;
  double lo = INFINITY, hi = -INFINITY, sum = 0;
  for (std::size_t i = 0; i < distances.size(); ++i) {
    const double d = distances[i];
    if (!std::isfinite(d) || d < 0)
      throw Error("blend weights", 0, "distance " + std::to_string(i) + " is negative or not finite");
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    sum += d;
  }
  if (!(hi > lo)) return 0;
  const double mean = sum / double(distances.size());
  return std::min((mean - lo) / (hi - lo), cap);
}

BlendWeights blend_weights(const ProximityIndex& body, const Mesh& garment, GarmentType type, double hip_height,
                           double band, double cap) {
  const std::size_t nv = garment.vertex_count();
  if (nv == 0) throw Error("blend weights", 0, "the garment has no vertices");
  if (!std::isfinite(band) || band < 0) throw Error("blend weights", 0, "band must be finite and ≥ 0");
  ClosestHits hits;
  body.closest_points(garment.positions, INFINITY, hits);
  BlendWeights out;
  out.split = type == GarmentType::SKIRT || type == GarmentType::DRESS;
  out.split_height = out.split ? hip_height : 0;
  std::vector<double> upper, lower;
  upper.reserve(nv);
  out.distances.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const double d = hits.triangles[v] < 0 ? 0.0 : std::max(0.0, double(hits.signed_distances[v]));
    out.distances[v] = float(d);
    (out.split && garment.positions[3 * v + 1] < hip_height ? lower : upper).push_back(d);
  }
  out.upper_vertices = upper.size();
  out.lower_vertices = lower.size();
  out.upper = physical_weight(upper, cap);
  out.lower = physical_weight(lower, cap);
  if (upper.empty()) out.upper = out.lower;
  if (lower.empty() || !out.split) out.lower = out.upper;
  out.per_vertex.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    double w = out.upper;
    if (out.split) {
      const double y = garment.positions[3 * v + 1];
      // 0 at or above the band's top, 1 at or below its bottom; a step when band = 0.
      const double s =
          band > 0 ? std::clamp((hip_height + band - y) / (2 * band), 0.0, 1.0) : (y < hip_height ? 1.0 : 0.0);
      w = (1 - s) * out.upper + s * out.lower;
    }
    out.per_vertex[v] = float(w);
  }
  return out;
}

} // namespace vfit
