// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/opencl_cloth.h"

#include "vfit/engine/cloth/cloth_sim.h"
#include "vfit/kernels/error.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/cloth_implicit.h"
#include "vfit/kernels/cloth_rk4.h"
#include "vfit/kernels/cloth_springs.h"
#include "vfit/kernels/opencl_context.h"

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
// The grid's slices have both kinds of columns (SpringAdjacency::slice_consecutive_columns),
// so a CPU device's per-slice kernel runs both its vector loads and its gathers here.
TEST(OpenClCloth, Rk4StepsAgreeWithTheSerialReferenceAfterNSteps) {
  REQUIRE_OPENCL_DEVICE();
  Cloth c = make_cloth();
  const float h = 1e-4f;
  ASSERT_LT(h, rk4_stable_step(c.adjacency, c.particles).max_step);
  std::size_t columns = 0, consecutive = 0;
  for (std::size_t s = 0; s < c.adjacency.slice_count(); ++s) {
    columns += std::size_t(c.adjacency.slice_offsets[s + 1] - c.adjacency.slice_offsets[s]) / CLOTH_SLICE_WIDTH;
    consecutive += std::size_t(std::popcount(c.adjacency.slice_consecutive_columns[s]));
  }
  ASSERT_GT(consecutive, 0u);
  ASSERT_LT(consecutive, columns);
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

// The implicit Euler system's product on the device against implicit_system_multiply(): the
// same blocks (each particle's own block D_i and the sliced springs in rank-one form, applied
// to differences p_i − p_j), the same order of operations and no FMA contraction, so only the device's
// float arithmetic could differ (it is IEEE for + and ×, which is all the product uses):
// agreement to 1e-6 of the largest entry covers a device that reassociates nothing but rounds
// differently in the last bit. Pinned rows are zero on both.
TEST(OpenClCloth, ImplicitSystemProductAgreesWithTheSerialReference) {
  REQUIRE_OPENCL_DEVICE();
  Cloth c = make_cloth();
  std::mt19937 rng(23u);
  std::normal_distribution<float> normal(0.0f, 0.1f);
  for (float& v : c.v)
    v = normal(rng);
  ImplicitSystem system;
  assemble_implicit_system(c.x, c.v, c.adjacency, c.particles, 1.0f / 60.0f, system, false);
  std::vector<float> p(c.x.size());
  for (float& q : p)
    q = normal(rng);
  std::vector<float> expected, got;
  implicit_system_multiply(system, c.adjacency, p, expected);
  OpenClContext ctx;
  OpenClImplicitMultiply device(ctx, c.adjacency);
  device.set_system(system);
  device.multiply(p, got);
  ASSERT_EQ(got.size(), expected.size());
  double worst = 0, largest = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    worst = std::max(worst, double(std::abs(got[i] - expected[i])));
    largest = std::max(largest, double(std::abs(expected[i])));
  }
  RecordProperty("max_product_difference", std::to_string(worst));
  EXPECT_GT(largest, 0.0);
  EXPECT_LE(worst, 1e-6 * largest);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(got[k], 0.0f) << "pinned row 0";
    EXPECT_EQ(got[3 * 39 + k], 0.0f) << "pinned row 39";
  }
}

// ClothSim with the OpenCL backend against the TBB backend, RK4 both: a square of cloth
// (21 × 21) pinned at two corners swings for `frames` frames of 1/60 s, optionally dropped on a
// sphere (contacts resolved on the host between device windows). Returns the largest
// coordinate difference (m) and the largest motion (m).
struct Parity {
  double worst = 0, moved = 0;
  std::size_t contacts[2] = {0, 0};
};

std::string scientific(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

Parity opencl_tbb_parity(int frames, bool sphere) {
  Mesh cloth = make_grid(21, 21, 0.6f, 0.6f);
  for (std::size_t i = 0; i < cloth.vertex_count(); ++i)
    cloth.positions[3 * i + 1] = sphere ? 0.30f : 0.0f;
  const Mesh ball = make_uv_sphere(24, 48, 0.25f);
  std::vector<float> out[2];
  Parity p;
  for (int run = 0; run < 2; ++run) {
    ClothOptions o;
    o.integrator = ClothIntegrator::RK4;
    o.backend = run == 0 ? Backend::TBB : Backend::OPENCL;
    o.fabrics[0].stretch_stiffness = 200.0;
    o.fabrics[0].bend_stiffness = 2.0;
    o.global_damping = 1.0;
    ClothSim sim(cloth.position_view(), cloth.triangle_view(), o);
    if (sphere)
      sim.set_body(ball.position_view(), ball.triangle_view());
    else
      sim.pin(std::vector<std::int32_t>{0, 20});
    for (int f = 0; f < frames; ++f) {
      const ClothStepReport r = sim.step(1.0 / 60.0);
      EXPECT_EQ(r.status, ClothStatus::OK) << "backend " << run << ", frame " << f;
      p.contacts[run] += r.contacts;
    }
    out[run].assign(sim.positions().begin(), sim.positions().end());
  }
  for (std::size_t i = 0; i < out[0].size(); ++i) {
    p.worst = std::max(p.worst, double(std::abs(out[0][i] - out[1][i])));
    p.moved = std::max(p.moved, double(std::abs(out[0][i] - cloth.positions[i])));
  }
  return p;
}

// Free swinging, no contacts: after N = 30 frames (0.5 s, ~250 RK4 substeps) the two backends
// agree to 1e-4 m. Per substep the device differs from the host by ulps (sqrt, division);
// a stable, damped integration keeps those from growing faster than the motion itself, which
// is ~1 m here, so 1e-4 m is ~1e-4 of the motion. Measured on PoCL (CPU): 0, the same bits,
// since its sqrt and division are correctly rounded and the kernels contract no FMAs; the
// bound is for devices that use OpenCL's allowance of 3 ulp (sqrt) and 2.5 ulp (division).
TEST(OpenClClothSim, Rk4BackendAgreesWithTbbAfterNFrames) {
  REQUIRE_OPENCL_DEVICE();
  const Parity p = opencl_tbb_parity(30, false);
  RecordProperty("max_position_difference_m", scientific(p.worst));
  RecordProperty("max_motion_m", scientific(p.moved));
  EXPECT_GT(p.moved, 0.1);
  EXPECT_LT(p.worst, 1e-4);
}

// Dropped on a sphere: contacts on the host between device windows. A contact is a threshold
// (signed distance < τ), so an ulp-level difference can decide whether a particle is pushed
// out this window or the next; the pushed particle then differs by up to what it moves in one
// window (~1 mm). 30 frames (0.5 s) of draping end within 2 mm, and the contact counts agree
// to 2 % (measured on PoCL: the same bits and counts, as above).
TEST(OpenClClothSim, Rk4BackendWithBodyContactsAgreesWithTbb) {
  REQUIRE_OPENCL_DEVICE();
  const Parity p = opencl_tbb_parity(30, true);
  RecordProperty("max_position_difference_m", scientific(p.worst));
  RecordProperty("max_motion_m", scientific(p.moved));
  EXPECT_GT(p.contacts[0], 0u);
  EXPECT_NEAR(double(p.contacts[1]), double(p.contacts[0]), 0.02 * double(p.contacts[0]));
  EXPECT_LT(p.worst, 2e-3);
}

TEST(OpenClClothSim, ImplicitEulerOnOpenClIsRefused) {
  const Mesh cloth = make_grid(5, 5, 0.2f, 0.2f);
  ClothOptions o;
  o.integrator = ClothIntegrator::IMPLICIT_EULER;
  o.backend = Backend::OPENCL;
  EXPECT_THROW(ClothSim(cloth.position_view(), cloth.triangle_view(), o), Error);
}

} // namespace
} // namespace vfit
