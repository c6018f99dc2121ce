// SPDX-License-Identifier: Apache-2.0
// The coarse simulation proxy (engine/cloth/cloth_proxy.h) of a catalogue tee: its vertices are the
// tee's, its openings the tee's, every tee vertex is embedded and comes back at rest, and the
// per-vertex inputs map through the proxy's vertices.
#include "vfit/engine/cloth/cloth_proxy.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

const Mesh& tee() {
  static const Mesh m = [] {
    GarmentOptions o;
    o.type = GarmentType::TEE;
    o.target_vertices = 4000;
    return make_garment(o).mesh;
  }();
  return m;
}

TEST(ClothProxy, IsTheGarmentDecimatedWithItsOpeningsAndCarriesItBackAtRest) {
  const Mesh& fine = tee();
  const ClothProxy proxy = build_cloth_proxy(fine.positions, fine.triangles, 800);
  EXPECT_EQ(proxy.vertex_count(), 800u);
  const TopologyReport fine_topology = analyse_topology(fine.triangles, fine.vertex_count());
  const TopologyReport topology = analyse_topology(proxy.triangles, proxy.vertex_count());
  EXPECT_TRUE(topology.manifold());
  EXPECT_TRUE(topology.oriented());
  EXPECT_EQ(topology.boundary_loops, fine_topology.boundary_loops); // hem, neckline, two cuffs
  EXPECT_EQ(topology.euler_characteristic, fine_topology.euler_characteristic);
  ASSERT_EQ(proxy.source_vertices.size(), 800u);
  for (std::size_t p = 0; p < 800; ++p)
    for (int c = 0; c < 3; ++c)
      ASSERT_EQ(proxy.positions[3 * p + std::size_t(c)],
                fine.positions[3 * std::size_t(proxy.source_vertices[p]) + std::size_t(c)]);
  ASSERT_EQ(proxy.embedding.size(), fine.vertex_count());
  for (std::int32_t t : proxy.embedding.triangles)
    ASSERT_GE(t, 0);

  std::vector<float> rebuilt(fine.positions.size(), 0.0f);
  reconstruct_from_proxy(proxy, proxy.positions, rebuilt);
  // Float rounding of coordinates of ~1.5 m through the frame.
  for (std::size_t i = 0; i < rebuilt.size(); ++i)
    EXPECT_NEAR(rebuilt[i], fine.positions[i], 2e-6) << i;
  for (std::int32_t v : proxy.source_vertices)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(rebuilt[3 * std::size_t(v) + std::size_t(c)], fine.positions[3 * std::size_t(v) + std::size_t(c)]);
}

TEST(ClothProxy, VerticesOutsideTheSimulatedTrianglesAreNotEmbedded) {
  const Mesh& fine = tee();
  // The first half of the triangles only.
  const std::vector<std::int32_t> half(fine.triangles.begin(),
                                       fine.triangles.begin() + std::ptrdiff_t(3 * (fine.face_count() / 2)));
  const ClothProxy proxy = build_cloth_proxy(fine.positions, half, 500);
  std::vector<char> used(fine.vertex_count(), 0);
  for (std::int32_t v : half)
    used[std::size_t(v)] = 1;
  for (std::size_t v = 0; v < fine.vertex_count(); ++v)
    EXPECT_EQ(proxy.embedding.triangles[v] >= 0, used[v] != 0) << v;
  for (std::int32_t v : proxy.source_vertices)
    EXPECT_TRUE(used[std::size_t(v)]);
  const std::vector<std::int32_t> bad = {0, 1, std::int32_t(fine.vertex_count())};
  EXPECT_THROW(build_cloth_proxy(fine.positions, bad, 10), Error);
}

TEST(ClothProxy, PinsAndPerVertexValuesMapThroughTheProxysVertices) {
  const Mesh& fine = tee();
  const ClothProxy proxy = build_cloth_proxy(fine.positions, fine.triangles, 600);
  std::vector<std::int32_t> fabric(fine.vertex_count());
  for (std::size_t v = 0; v < fabric.size(); ++v)
    fabric[v] = std::int32_t(v % 7);
  const std::vector<std::int32_t> mapped = proxy_vertex_values(proxy, fabric);
  ASSERT_EQ(mapped.size(), proxy.vertex_count());
  for (std::size_t p = 0; p < mapped.size(); ++p)
    EXPECT_EQ(mapped[p], proxy.source_vertices[p] % 7);
  EXPECT_TRUE(proxy_vertex_values(proxy, {}).empty());
  // Every fine vertex pinned: every proxy vertex pinned, once each; a fine vertex that is no
  // proxy vertex pins nothing.
  std::vector<std::int32_t> all(fine.vertex_count());
  for (std::size_t v = 0; v < all.size(); ++v)
    all[v] = std::int32_t(v);
  all.push_back(proxy.source_vertices[3]); // twice
  const std::vector<std::int32_t> pins = proxy_pins(proxy, all);
  ASSERT_EQ(pins.size(), proxy.vertex_count());
  for (std::size_t p = 0; p < pins.size(); ++p)
    EXPECT_EQ(pins[p], std::int32_t(p));
  std::int32_t not_kept = 0;
  while (std::binary_search(proxy.source_vertices.begin(), proxy.source_vertices.end(), not_kept))
    ++not_kept;
  EXPECT_TRUE(proxy_pins(proxy, std::vector<std::int32_t>{not_kept}).empty());
}

} // namespace
} // namespace vfit
