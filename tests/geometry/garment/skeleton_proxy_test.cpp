// SPDX-License-Identifier: Apache-2.0
// The skeleton proxy (skeleton_proxy.h): a closed manifold of the requested size whose every
// vertex stands for a disjoint set of input vertices and sits at their mean.
#include "vfit/geometry/garment/skeleton_proxy.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include <gtest/gtest.h>

#include "vfit/geometry/garment/hole_fill.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// A closed tube (caps from hole filling) and its proxy at `target` vertices.
struct ProxyCase {
  Mesh closed;
  SkeletonProxy proxy;
};

ProxyCase tube_proxy(int rings, int segments, std::size_t target) {
  ProxyCase c;
  c.closed = fill_holes(make_tube(rings, segments, 0.05f, 0.6f)).mesh;
  c.proxy = simplify_for_skeleton(c.closed, target);
  return c;
}

// The proxy is a closed sphere of `target` vertices over disjoint, even clusters of the input.
void expect_proxy_of_target_size(const ProxyCase& c, std::size_t target) {
  const Mesh& p = c.proxy.mesh;
  // A tube of about square quads has legal collapses down to a few dozen vertices.
  EXPECT_EQ(p.vertex_count(), target);
  const TopologyReport t = analyse_topology(p.triangle_view(), p.vertex_count());
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
  EXPECT_EQ(t.euler_characteristic, 2); // collapses under the link condition keep the genus
  for (std::size_t f = 0; f < p.face_count(); ++f) {
    const std::int32_t* tri = &p.triangles[3 * f];
    EXPECT_TRUE(tri[0] != tri[1] && tri[1] != tri[2] && tri[2] != tri[0]) << "face " << f;
  }
  // Each proxy vertex is the mean of the input vertices mapped to it (float rounding: the
  // means are of coordinates below 1 m, so 1e-6 m is many ulps).
  ASSERT_EQ(c.proxy.vertex_proxy.size(), c.closed.vertex_count());
  std::vector<Eigen::Vector3d> sum(p.vertex_count(), Eigen::Vector3d::Zero());
  std::vector<double> count(p.vertex_count(), 0.0);
  for (std::size_t v = 0; v < c.closed.vertex_count(); ++v) {
    const std::int32_t q = c.proxy.vertex_proxy[v];
    ASSERT_GE(q, 0);
    ASSERT_LT(std::size_t(q), p.vertex_count());
    sum[std::size_t(q)] +=
        Eigen::Vector3d(c.closed.positions[3 * v], c.closed.positions[3 * v + 1], c.closed.positions[3 * v + 2]);
    count[std::size_t(q)] += 1;
  }
  for (std::size_t q = 0; q < p.vertex_count(); ++q) {
    ASSERT_GT(count[q], 0) << "proxy vertex " << q << " stands for no input vertex";
    const Eigen::Vector3d mean = sum[q] / count[q];
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(p.positions[3 * q + std::size_t(k)], mean[k], 1e-6) << q;
  }
  // Shortest-first collapses keep the clusters even: no proxy vertex stands for more than a
  // few times its share (a bar with room; a chain of merges into one vertex would give tens).
  const double mean_cluster = double(c.closed.vertex_count()) / double(p.vertex_count());
  EXPECT_LT(*std::max_element(count.begin(), count.end()), 6 * mean_cluster);
}

// (tube rings, segments, target). 6,000 vertices (plus caps) at 800: shortest-first collapses
// alone; at 200, and 24,000–70,000 vertices at 800, above 16 × the target: rounds of
// collapses first (skeleton_proxy.h). The tubes' triangles are long and thin (ring spacing
// 0.6–2.4 mm against 6.5–13 mm around), the case where rounds that merged long edges too left
// the shortest-first collapses stuck at 5 × the target with clusters of 15 × the mean.
struct ProxySize {
  int rings, segments;
  std::size_t target;
};

class SkeletonProxySizes : public ::testing::TestWithParam<ProxySize> {};

TEST_P(SkeletonProxySizes, IsAClosedSphereOfTheTargetSizeOverDisjointClusters) {
  const ProxySize size = GetParam();
  expect_proxy_of_target_size(tube_proxy(size.rings, size.segments, size.target), size.target);
}

INSTANTIATE_TEST_SUITE_P(SkeletonProxy, SkeletonProxySizes,
                         ::testing::Values(ProxySize{250, 24, 200}, ProxySize{250, 24, 800}, ProxySize{500, 48, 800},
                                           ProxySize{1000, 48, 800}, ProxySize{700, 100, 800}),
                         [](const auto& param_info) {
                           return std::to_string(param_info.param.rings * param_info.param.segments) + "_to_" +
                                  std::to_string(param_info.param.target);
                         });

TEST(SkeletonProxy, ReturnsASmallMeshAsItIsAndRejectsBadIndices) {
  const Mesh closed = fill_holes(make_tube(4, 8, 0.05f, 0.1f)).mesh;
  const SkeletonProxy same = simplify_for_skeleton(closed, closed.vertex_count());
  EXPECT_EQ(same.mesh.positions, closed.positions);
  EXPECT_EQ(same.mesh.triangles, closed.triangles);
  for (std::size_t v = 0; v < closed.vertex_count(); ++v)
    EXPECT_EQ(same.vertex_proxy[v], std::int32_t(v));
  Mesh bad = closed;
  bad.triangles[4] = std::int32_t(closed.vertex_count());
  EXPECT_THROW(simplify_for_skeleton(bad, 10), Error);
}

} // namespace
} // namespace vfit
