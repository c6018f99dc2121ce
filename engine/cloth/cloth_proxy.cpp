// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/cloth/cloth_proxy.h"

#include <algorithm>
#include <string>

#include "vfit/geometry/mesh/even_decimate.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/error.h"

namespace vfit {

ClothProxy build_cloth_proxy(std::span<const float> positions, std::span<const std::int32_t> simulated_triangles,
                             std::size_t target_vertices) {
  const std::size_t nv = positions.size() / 3;
  // The simulated surface alone, its vertices in fine order.
  std::vector<std::int32_t> local(nv, -1);
  std::vector<std::int32_t> fine_of;
  std::vector<std::uint8_t> simulated(nv, 0);
  for (std::size_t k = 0; k < simulated_triangles.size(); ++k) {
    const std::int32_t v = simulated_triangles[k];
    if (v < 0 || std::size_t(v) >= nv)
      throw Error("cloth proxy", 0,
                  "triangle " + std::to_string(k / 3 + 1) + " has vertex index " + std::to_string(v) + " outside [0, " +
                      std::to_string(nv) + ")");
    simulated[std::size_t(v)] = 1;
  }
  Mesh surface;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!simulated[v]) continue;
    local[v] = static_cast<std::int32_t>(fine_of.size());
    fine_of.push_back(static_cast<std::int32_t>(v));
    surface.positions.insert(surface.positions.end(), positions.begin() + std::ptrdiff_t(3 * v),
                             positions.begin() + std::ptrdiff_t(3 * v + 3));
  }
  surface.triangles.reserve(simulated_triangles.size());
  for (const std::int32_t v : simulated_triangles)
    surface.triangles.push_back(local[std::size_t(v)]);

  ClothProxy proxy;
  std::vector<std::int32_t> kept;
  Mesh coarse = decimate_evenly(surface, target_vertices, kept);
  proxy.positions = std::move(coarse.positions);
  proxy.triangles = std::move(coarse.triangles);
  proxy.source_vertices.resize(kept.size());
  for (std::size_t p = 0; p < kept.size(); ++p)
    proxy.source_vertices[p] = fine_of[std::size_t(kept[p])];
  embed_points(positions, proxy.positions, proxy.triangles, simulated, proxy.embedding);
  return proxy;
}

void reconstruct_from_proxy(const ClothProxy& proxy, std::span<const float> proxy_positions,
                            std::span<float> positions) {
  carry_embedded_points(proxy.embedding, proxy_positions, proxy.triangles, positions);
  // The proxy's own vertices exactly where the simulation left them (the embedding gives them
  // back to float rounding only).
  for (std::size_t p = 0; p < proxy.source_vertices.size(); ++p)
    std::copy_n(proxy_positions.begin() + std::ptrdiff_t(3 * p), 3,
                positions.begin() + std::ptrdiff_t(3 * std::size_t(proxy.source_vertices[p])));
}

std::vector<std::int32_t> proxy_vertex_values(const ClothProxy& proxy, std::span<const std::int32_t> fine_values) {
  std::vector<std::int32_t> out;
  if (fine_values.empty()) return out;
  out.reserve(proxy.source_vertices.size());
  for (const std::int32_t v : proxy.source_vertices)
    out.push_back(fine_values[std::size_t(v)]);
  return out;
}

std::vector<std::int32_t> proxy_pins(const ClothProxy& proxy, std::span<const std::int32_t> fine_pins) {
  std::vector<std::int32_t> out;
  for (const std::int32_t v : fine_pins) {
    // source_vertices is ascending: a binary search finds the proxy vertex of a fine one.
    const auto it = std::lower_bound(proxy.source_vertices.begin(), proxy.source_vertices.end(), v);
    if (it != proxy.source_vertices.end() && *it == v)
      out.push_back(static_cast<std::int32_t>(it - proxy.source_vertices.begin()));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

} // namespace vfit
