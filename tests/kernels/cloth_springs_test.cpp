// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/cloth_springs.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <random>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "test_support.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/cloth_ordering.h"
#include "vfit/kernels/cloth_rk4.h"

namespace vfit {
namespace {

// A grid with every vertex jittered (so no spring sits at its rest length after a second
// jitter) and random per-spring constants.
struct Fixture {
  Mesh mesh;
  ClothSprings springs;
  std::vector<float> x, v;
};

// Springs of f.mesh with random constants, and a state off their rest: positions jittered by up
// to ±`amplitude` (m), velocities up to ±1 m/s.
void randomise_springs_and_state(Fixture& f, std::mt19937& rng, float amplitude, bool damping) {
  std::uniform_real_distribution<float> jitter(-amplitude, amplitude), kd(50.0f, 500.0f), cd(0.0f, 0.5f),
      vel(-1.0f, 1.0f);
  f.springs = build_cloth_springs(f.mesh.position_view(), f.mesh.triangle_view());
  for (std::size_t s = 0; s < f.springs.size(); ++s) {
    f.springs.stiffness[s] = kd(rng);
    f.springs.damping[s] = damping ? cd(rng) : 0.0f;
  }
  f.x = f.mesh.positions;
  for (float& p : f.x)
    p += jitter(rng);
  f.v.resize(f.x.size());
  for (float& q : f.v)
    q = vel(rng);
}

Fixture jittered_cloth(int n, unsigned seed, bool damping) {
  Fixture f;
  f.mesh = make_grid(n, n, 1.0f, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
  for (float& p : f.mesh.positions)
    p += 0.5f * jitter(rng);
  randomise_springs_and_state(f, rng, 0.02f, damping);
  return f;
}

// 2 g particles with particle 0 pinned and some global damping: the RK4 parity tests' set-up.
ClothParticles pinned_first_particle(std::size_t count) {
  ClothParticles particles;
  particles.inverse_masses.assign(count, 1.0f / 2e-3f);
  particles.inverse_masses[0] = 0.0f;
  particles.global_damping = 0.3f;
  return particles;
}

// `steps` RK4 steps from f's state with rk4_step_tbb over `for_tbb` and rk4_step_serial over
// `for_serial` (pinned_first_particle() masses, h = 1e-4 s): the TBB state, then the serial one.
struct Rk4Pair {
  std::vector<float> x_tbb, v_tbb, x_serial, v_serial;
};
Rk4Pair rk4_tbb_and_serial(const Fixture& f, const SpringAdjacency& for_tbb, const SpringAdjacency& for_serial,
                           int steps) {
  const ClothParticles particles = pinned_first_particle(f.mesh.vertex_count());
  Rk4Pair r{f.x, f.v, f.x, f.v};
  Rk4Workspace wt, ws;
  for (int step = 0; step < steps; ++step) {
    rk4_step_tbb(r.x_tbb, r.v_tbb, for_tbb, particles, 1e-4f, wt);
    rk4_step_serial(r.x_serial, r.v_serial, for_serial, particles, 1e-4f, ws);
  }
  return r;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(ClothSprings, GridHasStructuralOnEveryEdgeAndBendingOnEveryInteriorEdge) {
  const int n = 6;
  const Mesh m = make_grid(n, n, 1.0f, 1.0f);
  const ClothSprings s = build_cloth_springs(m.position_view(), m.triangle_view());
  const std::size_t edges = 2 * n * (n - 1) + (n - 1) * (n - 1);
  const std::size_t boundary = 4 * (n - 1);
  std::size_t structural = 0, bending = 0;
  for (SpringKind k : s.kinds)
    (k == SpringKind::STRUCTURAL ? structural : bending)++;
  EXPECT_EQ(structural, edges);
  EXPECT_EQ(bending, edges - boundary);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const int a = s.ends[2 * i], b = s.ends[2 * i + 1];
    EXPECT_LT(a, b);
    double d2 = 0;
    for (int k = 0; k < 3; ++k)
      d2 += std::pow(double(m.positions[3 * a + k]) - m.positions[3 * b + k], 2);
    EXPECT_NEAR(s.rest_lengths[i], std::sqrt(d2), 1e-6) << "spring " << i;
  }
  const ClothSprings no_bend = build_cloth_springs(m.position_view(), m.triangle_view(), {false});
  EXPECT_EQ(no_bend.size(), edges);
}

// Forces are −∂E/∂x of E = Σ ½k(l − L)², checked by central differences in double. Step 2⁻¹²
// (exact in float for these coordinates): truncation O(ε²·E''') and the float rounding of the
// analytic force (~1e-6 relative) both stay far below the 1e-3 relative tolerance.
TEST(ClothSprings, HookeForcesAreMinusTheEnergyGradient) {
  Fixture f = jittered_cloth(5, 7u, false);
  std::vector<float> forces;
  spring_forces_scatter(f.x, f.v, f.springs, forces);
  const float eps = 1.0f / 4096.0f;
  double worst = 0, scale = 0;
  for (float q : forces)
    scale = std::max(scale, double(std::abs(q)));
  for (std::size_t c = 0; c < f.x.size(); ++c) {
    std::vector<float> p = f.x, q = f.x;
    p[c] += eps;
    q[c] -= eps;
    const double fd = -(spring_energy(p, f.springs) - spring_energy(q, f.springs)) / (double(p[c]) - q[c]);
    worst = std::max(worst, std::abs(fd - forces[c]));
  }
  EXPECT_LT(worst, 1e-3 * scale) << "largest force " << scale;
}

// Damping forces are −∂D/∂v of the Rayleigh function D = Σ ½c((v_j − v_i)·u)²; D is quadratic
// in v, so central differences are exact up to rounding (tolerance 1e-4 relative).
TEST(ClothSprings, DampingForcesAreMinusTheRayleighGradient) {
  Fixture f = jittered_cloth(5, 11u, true);
  for (float& k : f.springs.stiffness)
    k = 0.0f;
  auto rayleigh = [&](const std::vector<float>& v) {
    double d = 0;
    for (std::size_t s = 0; s < f.springs.size(); ++s) {
      const int i = f.springs.ends[2 * s], j = f.springs.ends[2 * s + 1];
      double u[3], len = 0, dot = 0;
      for (int k = 0; k < 3; ++k)
        len += std::pow(u[k] = double(f.x[3 * j + k]) - f.x[3 * i + k], 2);
      len = std::sqrt(len);
      for (int k = 0; k < 3; ++k)
        dot += (double(v[3 * j + k]) - v[3 * i + k]) * u[k] / len;
      d += 0.5 * f.springs.damping[s] * dot * dot;
    }
    return d;
  };
  std::vector<float> forces;
  spring_forces_scatter(f.x, f.v, f.springs, forces);
  double worst = 0, scale = 0;
  for (float q : forces)
    scale = std::max(scale, double(std::abs(q)));
  for (std::size_t c = 0; c < f.v.size(); ++c) {
    std::vector<float> p = f.v, q = f.v;
    p[c] += 1.0f / 1024.0f;
    q[c] -= 1.0f / 1024.0f;
    const double fd = -(rayleigh(p) - rayleigh(q)) / (double(p[c]) - q[c]);
    worst = std::max(worst, std::abs(fd - forces[c]));
  }
  EXPECT_LT(worst, 1e-4 * scale);
}

// A sliver edge (rest 0.1 mm) stretched to 1 mm reads as 10× against its own rest length but
// only 0.1× against a 1 cm floor; a NaN position always reads as runaway.
TEST(ClothSprings, MaxStretchMeasuresAgainstTheRestLengthFloor) {
  ClothSprings s;
  s.ends = {0, 1, 1, 2};
  s.rest_lengths = {1e-4f, 0.02f};
  s.stiffness = {1.0f, 1.0f};
  s.damping = {0.0f, 0.0f};
  s.kinds = {SpringKind::STRUCTURAL, SpringKind::STRUCTURAL};
  std::vector<float> x = {0, 0, 0, 1e-3f, 0, 0, 1e-3f + 0.03f, 0, 0};
  EXPECT_NEAR(max_spring_stretch(x, s), 10.0, 1e-3);
  EXPECT_NEAR(max_spring_stretch(x, s, 0.01f), 1.5, 1e-5); // now the 2 cm spring at 3 cm leads
  x[0] = NAN;
  EXPECT_TRUE(std::isinf(max_spring_stretch(x, s, 0.01f)));
}

// The parallel scan (blocks of SPRING_STRETCH_GRAIN springs) gives the serial maximum exactly,
// wherever in the springs the worst one lies, and reads a NaN in any block as runaway.
TEST(ClothSprings, ParallelMaxStretchEqualsTheSerialScan) {
  const std::size_t n = 5 * SPRING_STRETCH_GRAIN + 123; // several blocks and a partial one
  std::mt19937 rng(7u);
  std::uniform_real_distribution<float> jitter(0.9f, 1.1f);
  ClothSprings s;
  std::vector<float> x(3 * (n + 1), 0.0f);
  for (std::size_t k = 1; k <= n; ++k)
    x[3 * k] = x[3 * (k - 1)] + 0.01f * jitter(rng); // a chain along x, each link within ±10 % of its rest
  for (std::size_t k = 0; k < n; ++k) {
    s.ends.push_back(std::int32_t(k));
    s.ends.push_back(std::int32_t(k + 1));
    s.rest_lengths.push_back(0.01f);
    s.stiffness.push_back(1.0f);
    s.damping.push_back(0.0f);
    s.kinds.push_back(SpringKind::STRUCTURAL);
  }
  for (std::size_t worst : {std::size_t(0), SPRING_STRETCH_GRAIN - 1, 3 * SPRING_STRETCH_GRAIN + 5, n - 1}) {
    std::vector<float> y = x;
    for (std::size_t k = worst + 1; k <= n; ++k)
      y[3 * k] += 0.05f; // link `worst` stretched by 5 cm: the runaway one
    const double serial = max_spring_stretch(y, s, 0.0f, false);
    EXPECT_GT(serial, 5.0); // 5.9-6.1: the stretched link, far above the others' ≤ 1.1
    EXPECT_EQ(max_spring_stretch(y, s, 0.0f, true), serial) << "worst link " << worst;
  }
  x[3 * (4 * SPRING_STRETCH_GRAIN + 2) + 1] = NAN;
  EXPECT_TRUE(std::isinf(max_spring_stretch(x, s, 0.0f, true)));
}

TEST(ClothSprings, GatherEqualsScatterBitForBit) {
  const Fixture f = jittered_cloth(17, 3u, true);
  const SpringAdjacency adj = build_spring_adjacency(f.springs, f.mesh.vertex_count());
  std::vector<float> scatter, gather;
  spring_forces_scatter(f.x, f.v, f.springs, scatter);
  spring_forces_serial(f.x, f.v, adj, gather);
  EXPECT_TRUE(same_bits(scatter, gather));
  double net[3] = {0, 0, 0}; // internal forces sum to zero (Newton's third law)
  for (std::size_t i = 0; i < gather.size(); ++i)
    net[i % 3] += gather[i];
  for (double n : net)
    EXPECT_NEAR(n, 0.0, 1e-3);
}

// The gather runs 16 particles a slice, one per SIMD lane, each slice as wide as its longest
// row: a fan whose hub has 600 spring ends (300 rim vertices: one structural spring to each,
// bending springs across the spokes, and the rim springs) pads its 15 slice-mates' rows with
// hundreds of null entries, and 301 particles leave the last slice with one lane; short spokes
// below VFIT_SPRING_MIN_LENGTH are mixed in (zero force). Every lane must add its particle's
// springs in the scatter's order: the same bits.
TEST(ClothSprings, GatherEqualsScatterBitForBitWithARowLongerThanABlock) {
  const int rim = 300;
  std::mt19937 rng(11u);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), kd(50.0f, 500.0f), cd(0.0f, 0.5f);
  const Mesh fan = test::random_fan(rim, rng);
  std::vector<float> x = fan.positions;
  const std::vector<std::int32_t> tris = fan.triangles;
  ClothSprings springs = build_cloth_springs(x, tris);
  for (std::size_t s = 0; s < springs.size(); ++s) {
    springs.stiffness[s] = kd(rng);
    springs.damping[s] = cd(rng);
  }
  const std::size_t nv = x.size() / 3;
  const SpringAdjacency adj = build_spring_adjacency(springs, nv);
  ASSERT_GT(adj.offsets[1] - adj.offsets[0], 256) << "the hub's row must exceed a gather block";
  std::vector<float> v(x.size());
  for (float& q : v)
    q = u(rng);
  for (int k = 0; k < 3; ++k)
    x[3 * 7 + k] = x[k] + 1e-11f * float(k); // rim vertex 6 sits on the hub: a zero-length spoke
  std::vector<float> scatter, gather, tbb;
  spring_forces_scatter(x, v, springs, scatter);
  spring_forces_serial(x, v, adj, gather);
  spring_forces_tbb(x, v, adj, tbb);
  EXPECT_TRUE(same_bits(scatter, gather));
  EXPECT_TRUE(same_bits(gather, tbb));
  for (float q : gather)
    EXPECT_TRUE(std::isfinite(q));
}

// SpringAdjacency's sliced rows hold each CSR row in its lane, column by column, in order, and
// null entries (the particle itself, zero constants) past each row's end and past #V; the
// grid's 289 particles end in a slice of one particle.
TEST(ClothSprings, SlicedRowsHoldEachCsrRowInItsLane) {
  const Fixture f = jittered_cloth(17, 3u, true);
  const std::size_t nv = f.mesh.vertex_count();
  const SpringAdjacency adj = build_spring_adjacency(f.springs, nv);
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  ASSERT_EQ(adj.slice_count(), (nv + W - 1) / W);
  ASSERT_EQ(std::size_t(adj.slice_offsets.back()), adj.slice_neighbor_offsets.size());
  std::size_t real = 0;
  for (std::size_t s = 0; s < adj.slice_count(); ++s) {
    const auto first = std::size_t(adj.slice_offsets[s]), end = std::size_t(adj.slice_offsets[s + 1]);
    ASSERT_EQ((end - first) % W, 0u);
    std::int32_t longest = 0;
    for (std::size_t l = 0; l < W; ++l) {
      const std::size_t i = W * s + l;
      const std::int32_t row = i < nv ? adj.offsets[i + 1] - adj.offsets[i] : 0;
      longest = std::max(longest, row);
      for (std::size_t k = 0; first + W * k < end; ++k) {
        const std::size_t slot = first + W * k + l;
        if (std::int32_t(k) < row) {
          const auto e = std::size_t(adj.offsets[i]) + k;
          EXPECT_EQ(adj.slice_neighbor_offsets[slot], 3 * adj.neighbors[e]) << "particle " << i << ", entry " << k;
          EXPECT_EQ(adj.slice_rest_lengths[slot], adj.rest_lengths[e]);
          EXPECT_EQ(adj.slice_stiffness[slot], adj.stiffness[e]);
          EXPECT_EQ(adj.slice_damping[slot], adj.damping[e]);
          ++real;
        } else {
          EXPECT_EQ(adj.slice_neighbor_offsets[slot], 3 * std::int32_t(std::min(i, nv - 1))) << "null slot " << slot;
          EXPECT_EQ(adj.slice_rest_lengths[slot] + adj.slice_stiffness[slot] + adj.slice_damping[slot], 0.0f);
        }
      }
    }
    EXPECT_EQ(std::size_t(longest), (end - first) / W) << "slice " << s << " is as wide as its longest row";
    // The slices holding this slice's neighbours (null slots' particles included) span
    // [slice_neighbor_first, slice_neighbor_last], the slice itself inside.
    std::int32_t lowest = std::int32_t(s), highest = std::int32_t(s);
    for (std::size_t slot = first; slot < end; ++slot) {
      lowest = std::min(lowest, adj.slice_neighbor_offsets[slot] / 3 / std::int32_t(W));
      highest = std::max(highest, adj.slice_neighbor_offsets[slot] / 3 / std::int32_t(W));
    }
    EXPECT_EQ(adj.slice_neighbor_first[s], lowest) << "slice " << s;
    EXPECT_EQ(adj.slice_neighbor_last[s], highest) << "slice " << s;
    for (std::size_t k = 0; first + W * k < end; ++k) {
      bool consecutive = k < 32;
      for (std::size_t l = 1; l < W; ++l)
        consecutive = consecutive && adj.slice_neighbor_offsets[first + W * k + l] ==
                                         adj.slice_neighbor_offsets[first + W * k] + 3 * std::int32_t(l);
      EXPECT_EQ((adj.slice_consecutive_columns[s] >> k & 1u) != 0, consecutive) << "slice " << s << ", column " << k;
    }
  }
  EXPECT_EQ(real, adj.neighbors.size());
}

// A column whose 16 neighbours are consecutive particles is loaded as vectors
// (SpringAdjacency::slice_consecutive_columns), any other by a gather: the same values, so the
// forces and RK4 steps with the marks cleared (every column gathered) have the same bits. The
// 120 × 120 grid, numbered row by row, has both kinds.
TEST(ClothSprings, ConsecutiveColumnsGiveTheGatherBits) {
  const Fixture f = jittered_cloth(120, 9u, true);
  const SpringAdjacency adj = build_spring_adjacency(f.springs, f.mesh.vertex_count());
  std::size_t marked = 0, columns = 0;
  for (std::size_t s = 0; s < adj.slice_count(); ++s) {
    marked += std::size_t(std::popcount(adj.slice_consecutive_columns[s]));
    columns += std::size_t(adj.slice_offsets[s + 1] - adj.slice_offsets[s]) / CLOTH_SLICE_WIDTH;
  }
  ASSERT_GT(marked, columns / 2);
  ASSERT_LT(marked, columns);
  SpringAdjacency gathered = adj;
  std::fill(gathered.slice_consecutive_columns.begin(), gathered.slice_consecutive_columns.end(), 0u);
  std::vector<float> fast, slow, scatter;
  spring_forces_serial(f.x, f.v, adj, fast);
  spring_forces_serial(f.x, f.v, gathered, slow);
  spring_forces_scatter(f.x, f.v, f.springs, scatter);
  EXPECT_TRUE(same_bits(fast, slow));
  EXPECT_TRUE(same_bits(fast, scatter));

  const Rk4Pair r = rk4_tbb_and_serial(f, adj, gathered, 3);
  EXPECT_TRUE(same_bits(r.x_tbb, r.x_serial));
  EXPECT_TRUE(same_bits(r.v_tbb, r.v_serial));
}

TEST(ClothSprings, TbbEqualsSerialBitForBit) {
  const Fixture f = jittered_cloth(120, 5u, true); // 14,400 particles: several TBB chunks
  const SpringAdjacency adj = build_spring_adjacency(f.springs, f.mesh.vertex_count());
  std::vector<float> serial, tbb;
  spring_forces_serial(f.x, f.v, adj, serial);
  spring_forces_tbb(f.x, f.v, adj, tbb);
  EXPECT_TRUE(same_bits(serial, tbb));

  const Rk4Pair r = rk4_tbb_and_serial(f, adj, adj, 5);
  EXPECT_TRUE(same_bits(r.x_serial, r.x_tbb));
  EXPECT_TRUE(same_bits(r.v_serial, r.v_tbb));
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(r.x_serial[k], f.x[k]) << "pinned particle moved";
}

// f's cloth with its particles numbered at random (fixed seed): slice columns of scattered
// neighbours and rows of uneven length in every slice, as a garment's numbering gives them.
// order[k] = f's particle at position k.
struct Renumbered {
  std::vector<std::int32_t> order;
  ClothSprings springs;
  std::vector<float> x, v;
  ClothParticles particles;
};

Renumbered renumbered(const Fixture& f, std::vector<std::int32_t> order) {
  Renumbered r;
  r.order = std::move(order);
  r.springs = renumber_cloth_springs(f.springs, inverse_permutation(r.order));
  gather_rows(f.x, r.order, 3, r.x);
  gather_rows(f.v, r.order, 3, r.v);
  const ClothParticles p = pinned_first_particle(f.mesh.vertex_count());
  r.particles = p;
  gather_rows(p.inverse_masses, r.order, 1, r.particles.inverse_masses);
  return r;
}

Renumbered shuffled(const Fixture& f, unsigned seed) {
  std::vector<std::int32_t> order(f.mesh.vertex_count());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = std::int32_t(i);
  std::shuffle(order.begin(), order.end(), std::mt19937(seed));
  return renumbered(f, std::move(order));
}

double null_slots(const SpringAdjacency& adj) {
  return double(adj.slice_neighbor_offsets.size()) / double(adj.neighbors.size()) - 1.0;
}

// On a CPU with AVX-512 a column of scattered neighbours loads each neighbour's row with one
// masked vector load and transposes (cloth_gather.h, gather_rows16), elsewhere lane by lane:
// either way every lane must get the scatter's bits, the last particle (whose row ends the
// arrays: a full 16-byte load would read past them) included.
TEST(ClothOrdering, ScatteredColumnsGatherTheScatterBits) {
  const Fixture f = jittered_cloth(61, 21u, true); // 3,721 particles: a last slice of 9 lanes
  const Renumbered r = shuffled(f, 4u);
  const SpringAdjacency adj = build_spring_adjacency(r.springs, r.order.size());
  EXPECT_EQ(consecutive_column_fraction(adj), 0.0);
  std::vector<float> gather, gather_tbb, scatter;
  spring_forces_serial(r.x, r.v, adj, gather);
  spring_forces_tbb(r.x, r.v, adj, gather_tbb);
  spring_forces_scatter(r.x, r.v, r.springs, scatter);
  EXPECT_TRUE(same_bits(gather, scatter));
  EXPECT_TRUE(same_bits(gather_tbb, scatter));
}

// A grid numbered row by row keeps its numbering (its columns load as vectors); a scattered
// numbering is replaced by a permutation that brings the neighbours together (and pads no
// more).
TEST(ClothOrdering, OrderKeepsARowByRowGridAndRegroupsAScatteredOne) {
  const Fixture grid = jittered_cloth(120, 2u, false); // over half its columns consecutive
  const std::vector<std::int32_t> kept = cloth_particle_order(grid.x.size() / 3, grid.springs);
  for (std::size_t i = 0; i < kept.size(); ++i)
    ASSERT_EQ(kept[i], std::int32_t(i));

  const Fixture f = jittered_cloth(40, 2u, false);

  const Renumbered r = shuffled(f, 8u);
  const std::vector<std::int32_t> order = cloth_particle_order(r.order.size(), r.springs);
  std::vector<std::int32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i)
    ASSERT_EQ(sorted[i], std::int32_t(i)) << "not a permutation";
  const ClothSprings renamed = renumber_cloth_springs(r.springs, inverse_permutation(order));
  const SpringAdjacency before = build_spring_adjacency(r.springs, order.size());
  const SpringAdjacency after = build_spring_adjacency(renamed, order.size());
  EXPECT_LE(null_slots(after), null_slots(before)); // a grid's rows are nearly all of one length
  // Neighbours close in the order: the median |i − j| over the spring ends shrinks from about
  // #V/3 (random) to a few rows of the 40-wide grid.
  std::vector<std::int32_t> gaps;
  for (std::size_t s = 0; s < renamed.size(); ++s)
    gaps.push_back(std::abs(renamed.ends[2 * s] - renamed.ends[2 * s + 1]));
  std::nth_element(gaps.begin(), gaps.begin() + std::ptrdiff_t(gaps.size() / 2), gaps.end());
  EXPECT_LT(gaps[gaps.size() / 2], 200);
}

// The locality order (cloth_particle_order()) of a shuffled numbering, expressed over the
// fixture's own particles.
std::vector<std::int32_t> locality_order_of(const Renumbered& shuffled_numbering) {
  std::vector<std::int32_t> o = cloth_particle_order(shuffled_numbering.order.size(), shuffled_numbering.springs);
  for (std::int32_t& k : o)
    k = shuffled_numbering.order[std::size_t(k)];
  return o;
}

// The numbering renames particles only (springs keep their order): an RK4 step in it gives
// every particle the bits it gets in the input numbering, serial and TBB.
TEST(ClothOrdering, RenumberedRk4StepGivesEachParticleTheSameBits) {
  const Fixture f = jittered_cloth(90, 13u, true);
  const Renumbered scattered = shuffled(f, 6u);
  const Renumbered local = renumbered(f, locality_order_of(scattered));
  const SpringAdjacency adj_scattered = build_spring_adjacency(scattered.springs, scattered.order.size());
  const SpringAdjacency adj_local = build_spring_adjacency(local.springs, local.order.size());
  std::vector<float> xs = scattered.x, vs = scattered.v, xl = local.x, vl = local.v, xl_serial = local.x,
                     vl_serial = local.v;
  Rk4Workspace w1, w2, w3;
  for (int step = 0; step < 4; ++step) {
    rk4_step_tbb(xs, vs, adj_scattered, scattered.particles, 1e-4f, w1);
    rk4_step_tbb(xl, vl, adj_local, local.particles, 1e-4f, w2);
    rk4_step_serial(xl_serial, vl_serial, adj_local, local.particles, 1e-4f, w3);
  }
  EXPECT_TRUE(same_bits(xl, xl_serial));
  EXPECT_TRUE(same_bits(vl, vl_serial));
  // Back to f's numbering, both must agree bit for bit.
  std::vector<float> back_s, back_l;
  gather_rows(xs, inverse_permutation(scattered.order), 3, back_s);
  gather_rows(xl, inverse_permutation(local.order), 3, back_l);
  EXPECT_TRUE(same_bits(back_s, back_l));
  gather_rows(vs, inverse_permutation(scattered.order), 3, back_s);
  gather_rows(vl, inverse_permutation(local.order), 3, back_l);
  EXPECT_TRUE(same_bits(back_s, back_l));
}

// The catalogue tee in its own numbering pads its sliced rows by about a fifth; renumbered, by
// a few per cent.
TEST(ClothOrdering, TeeRowsPadLessRenumbered) {
  GarmentOptions go;
  go.type = GarmentType::TEE;
  go.target_vertices = 4000;
  const Mesh m = make_garment(go).mesh;
  const ClothSprings springs = build_cloth_springs(m.position_view(), m.triangle_view());
  const std::vector<std::int32_t> order = cloth_particle_order(m.vertex_count(), springs);
  const SpringAdjacency before = build_spring_adjacency(springs, m.vertex_count());
  const SpringAdjacency after =
      build_spring_adjacency(renumber_cloth_springs(springs, inverse_permutation(order)), m.vertex_count());
  EXPECT_GT(null_slots(before), 0.1);
  EXPECT_LT(null_slots(after), 0.1);
}

// The numbering keeps each particle's neighbours within a band: a 64 × 64 grid numbered at
// random has neighbours in every slice of its 256; in the order, a slice's neighbours lie
// within a few breadth-first levels (a level of the grid holds at most 2·64 particles, one
// spring spans at most two levels) plus the regrouping window on either side:
// 2·(2·2·64 + CLOTH_ORDER_WINDOW) / 16 = 48 slices.
TEST(ClothOrdering, OrderKeepsEachSlicesNeighboursWithinABand) {
  const Fixture f = jittered_cloth(64, 31u, false);
  const Renumbered r = shuffled(f, 12u);
  const SpringAdjacency before = build_spring_adjacency(r.springs, r.order.size());
  const SpringAdjacency after = build_spring_adjacency(
      renumber_cloth_springs(r.springs, inverse_permutation(cloth_particle_order(r.order.size(), r.springs))),
      r.order.size());
  const auto widest = [](const SpringAdjacency& adj) {
    std::int32_t w = 0;
    for (std::size_t s = 0; s < adj.slice_count(); ++s)
      w = std::max(w, adj.slice_neighbor_last[s] - adj.slice_neighbor_first[s]);
    return w;
  };
  EXPECT_GT(widest(before), 200);
  EXPECT_LE(widest(after), std::int32_t(2 * (2 * 2 * 64 + CLOTH_ORDER_WINDOW) / CLOTH_SLICE_WIDTH));
}

// One RK4 step in four whole-array stages from cloth_accelerations_serial(), in cloth_math.h's
// arithmetic (vfit_rk4_stage_update, pinned particles' position slope zero): the oracle of
// the drivers' fused stage passes and their schedule.
void rk4_reference_step(std::vector<float>& x, std::vector<float>& v, const SpringAdjacency& adj,
                        const ClothParticles& p, float h) {
  const std::size_t n = x.size();
  std::vector<float> xs = x, vs = v, a, acc_x(n), acc_v(n);
  for (int stage = 0; stage < 4; ++stage) {
    cloth_accelerations_serial(xs, vs, adj, p, a);
    const float w = stage == 0 || stage == 3 ? 1.0f : 2.0f;
    const float t = stage == 3 ? h / 6.0f : (stage == 2 ? 1.0f : 0.5f) * h;
    for (std::size_t k = 0; k < n; ++k) {
      const float slope_x = p.inverse_masses[k / 3] == 0.0f ? 0.0f : vs[k];
      acc_x[k] = stage == 0 ? slope_x : acc_x[k] + w * slope_x;
      acc_v[k] = stage == 0 ? a[k] : acc_v[k] + w * a[k];
      xs[k] = x[k] + t * (stage == 3 ? acc_x[k] : slope_x);
      vs[k] = v[k] + t * (stage == 3 ? acc_v[k] : a[k]);
    }
  }
  x = xs;
  v = vs;
}

// The drivers run the four stages as a wavefront swept from both ends of contiguous regions, or
// as four passes (cloth_rk4.h): each slice's stage arithmetic is the reference's, whatever the
// schedule, so every driver, schedule, chunk count and meeting point must give the reference's
// bits, on a strip numbered across (neighbours a slice or two apart: the ends run nearly all of
// it alone), the same strip numbered at random (every slice's neighbours in every region: the
// ends run stage 0 alone and leave the rest to the pass after) and renumbered by
// cloth_particle_order().
TEST(ClothRk4, StepsGiveTheStageByStageReferenceBitsForEveryChunkCount) {
  Fixture f;
  f.mesh = make_grid(6, 1500, 0.05f, 12.5f); // 9,000 particles, 563 slices, rows of 6
  std::mt19937 rng(17u);
  randomise_springs_and_state(f, rng, 2e-3f, true);
  const Renumbered across = renumbered(f, [&] {
    std::vector<std::int32_t> o(f.mesh.vertex_count());
    for (std::size_t i = 0; i < o.size(); ++i)
      o[i] = std::int32_t(i);
    return o;
  }());
  const Renumbered random = shuffled(f, 3u);
  const Renumbered ordered = renumbered(f, locality_order_of(random));
  const Renumbered* numberings[] = {&across, &random, &ordered};
  for (int numbering = 0; numbering < 3; ++numbering) {
    const Renumbered* r = numberings[numbering];
    const SpringAdjacency adj = build_spring_adjacency(r->springs, r->order.size());
    std::vector<float> x_ref = r->x, v_ref = r->v;
    for (int step = 0; step < 3; ++step)
      rk4_reference_step(x_ref, v_ref, adj, r->particles, 1e-4f);
    const auto check = [&](const char* what, const auto& step_once) {
      std::vector<float> x = r->x, v = r->v;
      Rk4Workspace w;
      for (int step = 0; step < 3; ++step)
        step_once(x, v, w);
      EXPECT_TRUE(same_bits(x, x_ref)) << what << ", numbering " << numbering;
      EXPECT_TRUE(same_bits(v, v_ref)) << what << ", numbering " << numbering;
    };
    check("serial", [&](std::vector<float>& x, std::vector<float>& v, Rk4Workspace& w) {
      rk4_step_serial(x, v, adj, r->particles, 1e-4f, w);
    });
    for (Rk4Schedule schedule : {Rk4Schedule::AUTO, Rk4Schedule::WAVEFRONT, Rk4Schedule::PASSES})
      check(("tbb, schedule " + std::to_string(int(schedule))).c_str(),
            [&](std::vector<float>& x, std::vector<float>& v, Rk4Workspace& w) {
              rk4_step_tbb(x, v, adj, r->particles, 1e-4f, w, schedule);
            });
    for (std::size_t chunks : {1, 2, 3, 7, 40, 1000})
      check(("chunks " + std::to_string(chunks)).c_str(),
            [&](std::vector<float>& x, std::vector<float>& v, Rk4Workspace& w) {
              rk4_step_chunked(x, v, adj, r->particles, 1e-4f, w, chunks);
            });
    // On one thread the ends run one after the other (TBB runs the lower index first): each
    // region's up end claims all of it and its down end nothing, the extreme meeting point.
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      for (std::size_t chunks : {2, 7})
        check(("one thread, chunks " + std::to_string(chunks)).c_str(),
              [&](std::vector<float>& x, std::vector<float>& v, Rk4Workspace& w) {
                rk4_step_chunked(x, v, adj, r->particles, 1e-4f, w, chunks);
              });
    }
  }
}

// One particle of mass m on a spring k to a pinned anchor, no gravity or damping: x(t) =
// L + A·cos(ωt), ω = √(k/m). RK4's global error is O(h⁴): halving h divides it by ~16. The
// coarsest step is t/12 (error ~1e-2), the finest t/48 (~5e-5), far above float rounding
// (~1e-6 here), so the measured ratios sit within [12, 20] of the asymptotic 16.
TEST(ClothRk4, GlobalErrorShrinksSixteenfoldWhenTheStepHalves) {
  ClothSprings s;
  s.ends = {0, 1};
  s.rest_lengths = {1.0f};
  s.stiffness = {4.0f};
  s.damping = {0.0f};
  s.kinds = {SpringKind::STRUCTURAL};
  const SpringAdjacency adj = build_spring_adjacency(s, 2);
  ClothParticles particles;
  particles.inverse_masses = {0.0f, 1.0f}; // m = 1 kg, ω = 2 rad/s
  particles.gravity[1] = 0.0f;
  // Phase-space error |(Δx, Δv/ω)| at a time where the phase error is not hidden by sin(ωt) = 0
  // (there only the O(h⁵)-per-period amplitude error shows, and ratios approach 32).
  const double amplitude = 0.3, omega = 2.0, t_end = 2.0 * M_PI + 0.75;
  std::vector<double> errors;
  for (int steps : {12, 24, 48}) {
    std::vector<float> x = {0, 0, 0, float(1.0 + amplitude), 0, 0}, v(6, 0.0f);
    Rk4Workspace w;
    for (int i = 0; i < steps; ++i)
      rk4_step_serial(x, v, adj, particles, float(t_end / steps), w);
    errors.push_back(std::hypot(x[3] - (1.0 + amplitude * std::cos(omega * t_end)),
                                (v[3] + amplitude * omega * std::sin(omega * t_end)) / omega));
    EXPECT_EQ(x[4], 0.0f);
  }
  EXPECT_GT(errors[0] / errors[1], 12.0) << errors[0] << " " << errors[1];
  EXPECT_LT(errors[0] / errors[1], 20.0) << errors[0] << " " << errors[1];
  EXPECT_GT(errors[1] / errors[2], 12.0) << errors[1] << " " << errors[2];
  EXPECT_LT(errors[1] / errors[2], 20.0) << errors[1] << " " << errors[2];
}

// Two free masses m on one spring k: the only oscillation has ω² = 2k/m, which Gershgorin gives
// exactly, so the bound is h = 2.5/ω. RK4 is stable up to 2√2/ω on the imaginary axis: at the
// bound the amplitude must not grow; at 1.2 × 2√2/ω it must explode.
TEST(ClothRk4, StableStepBoundIsTightForTwoMassesOnASpring) {
  ClothSprings s;
  s.ends = {0, 1};
  s.rest_lengths = {1.0f};
  s.stiffness = {200.0f};
  s.damping = {0.0f};
  s.kinds = {SpringKind::STRUCTURAL};
  const SpringAdjacency adj = build_spring_adjacency(s, 2);
  ClothParticles particles;
  particles.inverse_masses = {10.0f, 10.0f};
  particles.gravity[1] = 0.0f;
  const Rk4StepBound b = rk4_stable_step(adj, particles);
  EXPECT_NEAR(b.omega_max, std::sqrt(2.0 * 200.0 * 10.0), 1e-9);
  EXPECT_NEAR(b.max_step, 2.5 / b.omega_max, 1e-12);
  // 30 unstable steps grow the amplitude by |R(3.39i)|³⁰ ≈ 3.2³⁰: large but still finite.
  auto amplitude_after = [&](double h, int steps) {
    std::vector<float> x = {0, 0, 0, 1.1f, 0, 0}, v(6, 0.0f);
    Rk4Workspace w;
    for (int i = 0; i < steps; ++i)
      rk4_step_serial(x, v, adj, particles, float(h), w);
    return std::abs(x[3] - x[0] - 1.0);
  };
  EXPECT_LE(amplitude_after(b.max_step, 400), 0.1 + 1e-4);
  EXPECT_GT(amplitude_after(1.2 * 2.0 * std::sqrt(2.0) / b.omega_max, 30), 1.0);
}

// An elastic cable of rest length L pinned at both ends a distance L apart sags under its own
// weight until the stretch carries it. With w the weight per length and EA = k·l the axial
// stiffness of springs k of length l, a parabolic cable with small sag d has arc length
// L + 8d²/(3L) and horizontal tension wL²/(8d); equating the tension with EA·strain gives
// d = L·(3wL/(64·EA))^{1/3}. The chain's pinned end particles carry their weight directly, so
// w = (N − 1)·m·g/L. Parameters give d/L ≈ 0.05: the parabola and small-strain approximations
// are then good to ~0.5 %, and 40 segments add ~0.1 %; tolerance 2 %.
TEST(ClothRk4, ElasticCableSagsAsTheCableLawPredicts) {
  const int segments = 40;
  const double L = 1.0, l = L / segments, m = 1e-3, k = 5850.0, g = 9.81;
  ClothSprings s;
  for (int i = 0; i < segments; ++i) {
    s.ends.insert(s.ends.end(), {i, i + 1});
    s.rest_lengths.push_back(float(l));
    s.stiffness.push_back(float(k));
    s.damping.push_back(0.02f);
    s.kinds.push_back(SpringKind::STRUCTURAL);
  }
  const SpringAdjacency adj = build_spring_adjacency(s, segments + 1);
  ClothParticles particles;
  particles.inverse_masses.assign(segments + 1, float(1.0 / m));
  particles.inverse_masses.front() = particles.inverse_masses.back() = 0.0f;
  particles.global_damping = 30.0f; // ~ critical for the fundamental mode (ω₁ ≈ 16 rad/s)
  std::vector<float> x(3 * (segments + 1), 0.0f), v(x.size(), 0.0f);
  for (int i = 0; i <= segments; ++i)
    x[3 * i] = float(i * l);
  const double h = 0.8 * rk4_stable_step(adj, particles).max_step;
  Rk4Workspace w;
  for (double t = 0; t < 3.0; t += h)
    rk4_step_tbb(x, v, adj, particles, float(h), w);
  const double w_load = (segments - 1) * m * g / L;
  const double expected = L * std::cbrt(3.0 * w_load * L / (64.0 * k * l));
  const double sag = -x[3 * (segments / 2) + 1];
  EXPECT_NEAR(sag, expected, 0.02 * expected) << "expected sag " << expected;
}

} // namespace
} // namespace vfit
