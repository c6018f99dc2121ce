// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/dresser.h"

#include <gtest/gtest.h>

#include "vfit/engine/dress/penetration.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/hole_caps.h"

namespace vfit {
namespace {

// A tube cutting into a sphere (its near side up to 2.9 cm inside), as penetration_test's.
Mesh tube_into_sphere() {
  Mesh tube = make_tube(40, 48, 0.10f, 0.6f);
  for (std::size_t v = 0; v < tube.vertex_count(); ++v) {
    tube.positions[3 * v] += 0.27f;
    tube.positions[3 * v + 1] -= 0.3f;
  }
  return tube;
}

// The Dresser reuses the garment's Laplacian and edges between calls; its answers are those of
// remove_penetration() and measure_penetration() with the same body, layers and options, bit
// for bit (the topology built once is the same matrix as the one built per call).
TEST(Dresser, RemovesAndMeasuresAsThePenetrationFunctions) {
  const Mesh sphere = make_uv_sphere(40, 80, 0.20f);
  const DressingBody body(sphere, 0.003, 0.05);
  DressOptions options;
  options.removal.clearance = 0.003;
  options.clearance = 0.003;
  const Mesh start = tube_into_sphere();
  Mesh by_dresser = start, by_function = start;
  const Dresser dresser(body, start, options);
  const PenetrationReport a = dresser.remove(by_dresser);
  const PenetrationReport b = remove_penetration(by_function, body.index(), body.crossings(), {}, options.removal);
  EXPECT_GT(a.before.inside_count, 50u);
  EXPECT_EQ(a.after.inside_count, 0u);
  EXPECT_EQ(by_dresser.positions, by_function.positions);
  EXPECT_EQ(a.iterations, b.iterations);
  const PenetrationStats m = dresser.measure(start);
  const PenetrationStats n = measure_penetration(start, body.index(), body.crossings(), {}, options.clearance);
  EXPECT_EQ(m.inside_count, n.inside_count);
  EXPECT_EQ(m.crossing_edges, n.crossing_edges);
  EXPECT_EQ(m.max_depth, n.max_depth);
  EXPECT_EQ(m.inside_count, a.before.inside_count);
}

// After the simulation: nothing simulated (no positions before it) is a measurement only; a
// "simulated" garment left inside the body is cleaned; one whose clean-up cannot get back to
// where removal had it is given its positions before the simulation back, with a warning.
TEST(Dresser, AfterTheSimulationCleansUpOrDiscards) {
  const Mesh sphere = make_uv_sphere(40, 80, 0.20f);
  const DressingBody body(sphere, 0.003, 0.05);
  DressOptions options;
  Mesh garment = tube_into_sphere();
  const Dresser dresser(body, garment, options);
  const PenetrationReport removal = dresser.remove(garment);
  ASSERT_EQ(removal.after.inside_count, 0u);

  Mesh same = garment;
  const SettledReport measured = dresser.after_simulation(same, {}, removal.after);
  EXPECT_FALSE(measured.cleaned);
  EXPECT_FALSE(measured.discarded);
  EXPECT_EQ(same.positions, garment.positions);
  EXPECT_EQ(measured.after.inside_count, 0u);

  Mesh simulated = tube_into_sphere(); // the "simulation" put it back into the sphere
  const SettledReport cleaned = dresser.after_simulation(simulated, garment.positions, removal.after);
  EXPECT_GT(cleaned.simulated.inside_count, 50u);
  EXPECT_TRUE(cleaned.cleaned);
  EXPECT_FALSE(cleaned.discarded) << cleaned.warning;
  EXPECT_EQ(cleaned.after.inside_count, 0u);

  DressOptions none = options;
  none.removal.max_iterations = 0; // removal cannot clean anything: the simulated shape goes
  none.removal.direct_rounds = 0;
  const Dresser idle(body, garment, none);
  Mesh stuck = tube_into_sphere();
  const SettledReport discarded = idle.after_simulation(stuck, garment.positions, removal.after);
  EXPECT_TRUE(discarded.cleaned);
  EXPECT_TRUE(discarded.discarded);
  EXPECT_FALSE(discarded.warning.empty());
  EXPECT_EQ(stuck.positions, garment.positions);
  EXPECT_EQ(discarded.after.inside_count, 0u);
}

// A dressed garment becomes an inner layer; the collision surface is the body, then each layer's
// vertices with its triangles and the fans closing its openings.
TEST(Dresser, LayersJoinTheCollisionSurface) {
  const Mesh sphere = make_uv_sphere(20, 40, 0.20f);
  DressingBody body(sphere, 0.003, 0.05);
  EXPECT_TRUE(body.layers().empty());
  Mesh tube = make_tube(10, 16, 0.25f, 0.3f); // around the sphere, open at both ends
  body.add_layer(tube);
  ASSERT_EQ(body.layers().size(), 1u);
  std::vector<float> positions;
  std::vector<std::int32_t> triangles;
  body.collision_surface(positions, triangles);
  const HoleCaps caps = build_hole_caps(tube.triangles, tube.vertex_count());
  EXPECT_FALSE(caps.triangles.empty());
  EXPECT_EQ(triangles.size(), sphere.triangles.size() + tube.triangles.size() + caps.triangles.size());
  EXPECT_GE(positions.size(), sphere.positions.size() + tube.positions.size());
  // A garment between the body and the layer (radius 0.22 m: under it, within its reach) is
  // inside the layer; one outside it (0.27 m) is not.
  const Mesh under = make_tube(10, 16, 0.22f, 0.2f);
  const Dresser dresser(body, under, DressOptions{});
  EXPECT_GT(dresser.measure(under).layer_inside_count, under.vertex_count() / 2); // all but near the rims
  const Mesh over = make_tube(10, 16, 0.27f, 0.2f);
  EXPECT_EQ(dresser.measure(over).layer_inside_count, 0u);
}

} // namespace
} // namespace vfit
