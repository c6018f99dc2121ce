#include "kernels/opencl_cloth.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "geometry/mesh/primitives.h"
#include "kernels/cloth_rk4.h"
#include "kernels/cloth_springs.h"
#include "kernels/opencl_context.h"

namespace vfit {
namespace {

#define REQUIRE_OPENCL_DEVICE()                                                                                        \
  if (list_opencl_devices().empty()) GTEST_SKIP() << "no OpenCL device installed (apt-get install pocl-opencl-icd)"

// A 40 × 40 cloth (1 m², 1,600 particles) with jittered positions, two pinned corners, a
// jersey-like spring constant and lumped masses, at rest.
struct Cloth {
  std::vector<float> x, v;
  ClothSprings springs;
  SpringAdjacency adjacency;
  ClothParticles particles;
};

Cloth make_cloth() {
  Cloth c;
  Mesh m = make_grid(40, 40, 1.0f, 1.0f);
  std::mt19937 rng(17u);
  std::uniform_real_distribution<float> jitter(-0.002f, 0.002f);
  c.springs = build_cloth_springs(m.position_view(), m.triangle_view());
  for (std::size_t s = 0; s < c.springs.size(); ++s) {
    const bool bend = c.springs.kinds[s] == SpringKind::BENDING;
    c.springs.stiffness[s] = bend ? 4.0f : 400.0f;
    c.springs.damping[s] = 0.002f;
  }
  c.adjacency = build_spring_adjacency(c.springs, m.vertex_count());
  c.particles.inverse_masses.assign(m.vertex_count(), 1.0f / (0.15f / m.vertex_count()));
  c.particles.inverse_masses[0] = c.particles.inverse_masses[39] = 0.0f;
  c.particles.global_damping = 0.5f;
  c.x = m.positions;
  for (float& p : c.x)
    p += jitter(rng);
  c.v.assign(c.x.size(), 0.0f);
  return c;
}

TEST(OpenClCloth, SpringForcesAgreeWithTheSerialGather) {
  REQUIRE_OPENCL_DEVICE();
  const Cloth c = make_cloth();
  OpenClContext ctx;
  OpenClClothRk4 device(ctx, c.adjacency, c.particles);
  device.set_state(c.x, c.v);
  std::vector<float> expected, got;
  spring_forces_serial(c.x, c.v, c.adjacency, expected);
  device.spring_forces(got);
  ASSERT_EQ(got.size(), expected.size());
  // Same formula and order; only the device's sqrt and division may differ by an ulp or so,
  // which the sum over ~12 springs of forces up to ~1 N magnifies to ~1e-6 N.
  double worst = 0;
  for (std::size_t i = 0; i < got.size(); ++i)
    worst = std::max(worst, double(std::abs(got[i] - expected[i])));
  RecordProperty("max_force_difference_N", std::to_string(worst));
  EXPECT_LT(worst, 1e-5);
}

// After N = 200 RK4 steps of 0.1 ms (the cloth falling and swinging for 20 ms) the device and
// the serial reference agree to 1e-5 m, about 10 ulps of a coordinate near 1 m: per-operation
// differences of an ulp in sqrt/division are damped, not amplified, by a stable integration at
// this step (the positions move by ~2 mm in that time, so this is ~0.5 % of the motion).
TEST(OpenClCloth, Rk4StepsAgreeWithTheSerialReferenceAfterNSteps) {
  REQUIRE_OPENCL_DEVICE();
  Cloth c = make_cloth();
  const float h = 1e-4f;
  ASSERT_LT(h, rk4_stable_step(c.adjacency, c.particles).max_step);
  OpenClContext ctx;
  OpenClClothRk4 device(ctx, c.adjacency, c.particles);
  device.set_state(c.x, c.v);
  const int steps = 200;
  device.step(h, steps);
  std::vector<float> dx, dv;
  device.get_state(dx, dv);
  const std::vector<float> x0 = c.x;
  Rk4Workspace w;
  for (int s = 0; s < steps; ++s)
    rk4_step_serial(c.x, c.v, c.adjacency, c.particles, h, w);
  double worst = 0, moved = 0;
  for (std::size_t i = 0; i < c.x.size(); ++i) {
    worst = std::max(worst, double(std::abs(dx[i] - c.x[i])));
    moved = std::max(moved, double(std::abs(c.x[i] - x0[i])));
  }
  RecordProperty("max_position_difference_m", std::to_string(worst));
  RecordProperty("max_motion_m", std::to_string(moved));
  EXPECT_GT(moved, 1e-3); // the comparison is of a cloth that moved
  EXPECT_LT(worst, 1e-5) << "largest motion " << moved;
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(dx[k], x0[k]) << "pinned particle moved on the device";
}

} // namespace
} // namespace vfit
