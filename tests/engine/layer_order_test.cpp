// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/layer_order.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// An open tube along Y (radius r m, from y0 to y0 + length), wound outward, shifted by x.
Mesh band(float r, float y0, float length, float x = 0) {
  Mesh m = make_tube(12, 48, r, length);
  m.uvs.clear();
  m.uv_triangles.clear();
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    m.positions[3 * v] += x;
    m.positions[3 * v + 1] += y0;
  }
  return m;
}

// Several bands as one mesh (one garment of several pieces).
Mesh bands(const std::vector<Mesh>& parts) {
  Mesh m;
  for (const Mesh& p : parts) {
    const auto offset = static_cast<std::int32_t>(m.vertex_count());
    m.positions.insert(m.positions.end(), p.positions.begin(), p.positions.end());
    for (std::int32_t v : p.triangles)
      m.triangles.push_back(v + offset);
  }
  return m;
}

Mesh turned_over(Mesh m) {
  for (std::size_t f = 0; f < m.face_count(); ++f)
    std::swap(m.triangles[3 * f + 1], m.triangles[3 * f + 2]);
  return m;
}

std::vector<std::size_t> inferred(const std::vector<Mesh>& garments, std::vector<std::size_t> default_order,
                                  const LayerOrderOptions& options = {}) {
  std::vector<const Mesh*> p;
  for (const Mesh& g : garments)
    p.push_back(&g);
  return infer_layer_order(p, default_order, {}, options).order;
}

// A sleeve 2 cm inside another (a tee's under a jacket's): inner first whatever the default
// order and whichever way each file winds its triangles (the side is read on each garment
// turned outward by its capped volume).
TEST(LayerOrder, PutsTheInnerOfTwoCoaxialTubesFirstWhateverTheWinding) {
  const Mesh inner = band(0.15f, -0.05f, 0.7f), outer = band(0.17f, 0, 0.6f); // the inner one longer at both ends
  for (bool flip_inner : {false, true})
    for (bool flip_outer : {false, true}) {
      const std::vector<Mesh> g = {flip_outer ? turned_over(outer) : outer, flip_inner ? turned_over(inner) : inner};
      SCOPED_TRACE(testing::Message() << "flip inner " << flip_inner << ", outer " << flip_outer);
      EXPECT_EQ(inferred(g, {0, 1}), (std::vector<std::size_t>{1, 0}));
      EXPECT_EQ(inferred(g, {1, 0}), (std::vector<std::size_t>{1, 0}));
    }
  std::vector<const Mesh*> p = {&outer, &inner};
  const std::vector<std::size_t> order = {0, 1};
  const LayerOrder found = infer_layer_order(p, order);
  ASSERT_EQ(found.relations.size(), 1u);
  EXPECT_EQ(found.relations[0].under, 1u);
  EXPECT_EQ(found.relations[0].over, 0u);
  // Every vertex within reach faces the other sheet 2 cm away along its normal (the inner
  // one's rims lie beyond the reach of the outer's): unanimous.
  EXPECT_EQ(found.relations[0].agree, found.relations[0].total);
  EXPECT_GT(found.relations[0].total, 1000u);
}

// A shirt tucked into trousers: the overlap is a band of each; only it votes, and the rest
// (beyond the outer one's rim, farther than the reach) says nothing.
TEST(LayerOrder, ReadsAPartialOverlapAndIgnoresPointsBeyondTheRim) {
  const Mesh shirt = band(0.15f, 0.3f, 0.6f), trousers = band(0.165f, -0.5f, 1.0f);
  EXPECT_EQ(inferred({trousers, shirt}, {0, 1}), (std::vector<std::size_t>{1, 0}));
  // The same shirt over the trousers' band (wider than them where they meet).
  const Mesh loose = band(0.18f, 0.3f, 0.6f);
  EXPECT_EQ(inferred({loose, trousers}, {0, 1}), (std::vector<std::size_t>{1, 0}));
}

// Garments that do not meet, or pairs the caller rules out: the default order.
TEST(LayerOrder, KeepsTheDefaultOrderWhereTheGeometrySaysNothing) {
  const Mesh a = band(0.15f, 0, 0.6f), b = band(0.17f, 0, 0.6f, 1.0f); // 1 m apart
  EXPECT_EQ(inferred({b, a}, {0, 1}), (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(inferred({b, a}, {1, 0}), (std::vector<std::size_t>{1, 0}));
  const Mesh c = band(0.17f, 0, 0.6f);
  std::vector<const Mesh*> p = {&c, &a};
  const std::vector<std::size_t> order = {0, 1};
  const LayerOrder ruled_out = infer_layer_order(p, order, [](std::size_t, std::size_t) { return false; });
  EXPECT_EQ(ruled_out.order, order);
  EXPECT_TRUE(ruled_out.votes.empty());
  // A garment without triangles neither votes nor is voted on.
  const Mesh empty;
  EXPECT_EQ(inferred({c, empty, a}, {0, 1, 2}), (std::vector<std::size_t>{1, 2, 0}));
}

// Three garments, each inside the next where they meet, round in a circle: the relations
// contradict one another, so none is kept.
TEST(LayerOrder, DropsContradictoryRelations) {
  LayerOrderOptions o;
  o.reach = 0.03; // below the 4 cm between a and c on [0.5, 1]
  const Mesh a = bands({band(0.15f, 0, 1.0f), band(0.20f, 1.05f, 1.0f)});
  const Mesh b = band(0.17f, 0, 1.0f);
  const Mesh c = band(0.19f, 0.5f, 0.5f);
  const Mesh c2 = bands({band(0.19f, 0.5f, 0.5f), band(0.18f, 1.05f, 1.0f)});
  // Without c's upper band: a under b under c, a chain.
  EXPECT_EQ(inferred({c, b, a}, {0, 1, 2}, o), (std::vector<std::size_t>{2, 1, 0}));
  // With it, c is under a on [1.05, 2.05]: a < b < c < a.
  std::vector<const Mesh*> p = {&a, &b, &c2};
  const std::vector<std::size_t> order = {1, 2, 0};
  const LayerOrder found = infer_layer_order(p, order, {}, o);
  EXPECT_TRUE(found.contradictory);
  EXPECT_TRUE(found.relations.empty());
  EXPECT_EQ(found.order, order);
}

// Sampling every k-th vertex decides as all of them do; too few votes decide nothing.
TEST(LayerOrder, SamplesLargeGarmentsAndNeedsEnoughVotes) {
  const Mesh inner = band(0.15f, 0, 0.6f), outer = band(0.17f, 0, 0.6f);
  LayerOrderOptions few;
  few.max_samples = 40;
  EXPECT_EQ(inferred({outer, inner}, {0, 1}, few), (std::vector<std::size_t>{1, 0}));
  few.max_samples = 10;
  few.min_votes = 30; // 2 × 10 samples cannot reach it
  EXPECT_EQ(inferred({outer, inner}, {0, 1}, few), (std::vector<std::size_t>{0, 1}));
}

TEST(LayerOrder, RejectsADefaultOrderThatIsNotAPermutation) {
  const Mesh a = band(0.15f, 0, 0.6f), b = band(0.17f, 0, 0.6f);
  std::vector<const Mesh*> p = {&a, &b};
  const std::vector<std::size_t> twice = {0, 0}, short_one = {0}, out_of_range = {0, 2};
  EXPECT_THROW(infer_layer_order(p, twice), Error);
  EXPECT_THROW(infer_layer_order(p, short_one), Error);
  EXPECT_THROW(infer_layer_order(p, out_of_range), Error);
}

} // namespace
} // namespace vfit
