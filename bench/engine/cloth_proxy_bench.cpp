// SPDX-License-Identifier: Apache-2.0
// The coarse simulation proxy of a high-resolution garment (engine/cloth/cloth_proxy.h).
//  - BM_BuildClothProxy/S/P: build_cloth_proxy() (decimation and embedding) of the catalogue
//    T-pose tee M of 5,000 vertices midpoint-subdivided S times (S = 2, 3, 4: about 8·10^4,
//    3.2·10^5, 1.3·10^6 vertices; subdividing is far quicker than generating the catalogue
//    garment at that count, and the triangles keep the catalogue's quality) down to 15,000
//    proxy vertices. Second argument: 0 = OpenMesh's quadric decimater alone
//    (decimate_to_vertex_count(), the catalogue's; no embedding), the baseline; 1 = the proxy
//    (decimate_evenly() and the embedding). Counters: fine and proxy vertices, vertices_per_s (fine), the proxy's edge
//    length spread (max / median) and worst triangle aspect ratio (longest edge / height).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "vfit/engine/cloth/cloth_proxy.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/decimate.h"

namespace {

const vfit::Mesh& subdivided_tee(int times) {
  static std::vector<vfit::Mesh> cache;
  if (cache.empty()) {
    vfit::GarmentOptions o;
    o.type = vfit::GarmentType::TEE;
    o.target_vertices = 5000;
    cache.push_back(vfit::make_garment(o).mesh);
  }
  while (static_cast<int>(cache.size()) <= times)
    cache.push_back(vfit::subdivide_midpoints(cache.back()));
  return cache[static_cast<std::size_t>(times)];
}

// (max edge / median edge, worst longest-edge / height) of a triangle mesh.
std::pair<double, double> quality(const std::vector<float>& p, const std::vector<std::int32_t>& t) {
  std::vector<double> lengths;
  double worst = 0;
  auto at = [&](std::int32_t v, int c) { return double(p[3 * std::size_t(v) + std::size_t(c)]); };
  for (std::size_t f = 0; f < t.size() / 3; ++f) {
    double e[3][3], len[3];
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < 3; ++c)
        e[k][c] = at(t[3 * f + std::size_t((k + 1) % 3)], c) - at(t[3 * f + std::size_t(k)], c);
      len[k] = std::sqrt(e[k][0] * e[k][0] + e[k][1] * e[k][1] + e[k][2] * e[k][2]);
      lengths.push_back(len[k]);
    }
    const double cx = e[0][1] * e[1][2] - e[0][2] * e[1][1], cy = e[0][2] * e[1][0] - e[0][0] * e[1][2],
                 cz = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    const double area2 = std::sqrt(cx * cx + cy * cy + cz * cz);
    const double longest = std::max({len[0], len[1], len[2]});
    if (area2 > 0) worst = std::max(worst, longest * longest / area2);
  }
  std::nth_element(lengths.begin(), lengths.begin() + std::ptrdiff_t(lengths.size() / 2), lengths.end());
  const double median = lengths[lengths.size() / 2];
  return {*std::max_element(lengths.begin(), lengths.end()) / median, worst};
}

void BM_BuildClothProxy(benchmark::State& state) {
  const vfit::Mesh& fine = subdivided_tee(static_cast<int>(state.range(0)));
  const bool proxy_order = state.range(1) == 1;
  constexpr std::size_t TARGET = 15000;
  std::vector<float> positions;
  std::vector<std::int32_t> triangles;
  for (auto _ : state) {
    if (proxy_order) {
      vfit::ClothProxy proxy = vfit::build_cloth_proxy(fine.positions, fine.triangles, TARGET);
      positions = std::move(proxy.positions);
      triangles = std::move(proxy.triangles);
    } else {
      vfit::Mesh coarse = vfit::decimate_to_vertex_count(fine, TARGET);
      positions = std::move(coarse.positions);
      triangles = std::move(coarse.triangles);
    }
  }
  const auto [spread, aspect] = quality(positions, triangles);
  state.counters["fine_vertices"] = double(fine.vertex_count());
  state.counters["proxy_vertices"] = double(positions.size() / 3);
  state.counters["edge_spread"] = spread;
  state.counters["worst_aspect"] = aspect;
  state.counters["vertices_per_s"] =
      benchmark::Counter(double(fine.vertex_count()) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BuildClothProxy)->ArgsProduct({{2, 3, 4}, {0, 1}})->Unit(benchmark::kMillisecond)->Iterations(1);

} // namespace

BENCHMARK_MAIN();
