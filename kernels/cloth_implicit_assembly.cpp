// SPDX-License-Identifier: Apache-2.0
// The assembly of the implicit Euler system (cloth_implicit.h's assemble_implicit_system):
// per spring entry its force, K·dv and system block S_e (cloth_math.h), per row the diagonal
// block, its inverse (the preconditioner) and the right-hand side, and the off-diagonal blocks
// in both the CSR and the sliced layout the solver's product reads.
#include "cloth_implicit.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "cloth_gather.h"
#include "cloth_implicit_blocks.h"

namespace vfit {
namespace {
using namespace cloth_detail;

void add_sym(vfit_sym3& a, vfit_sym3 b) {
  a.xx += b.xx;
  a.xy += b.xy;
  a.xz += b.xz;
  a.yy += b.yy;
  a.yz += b.yz;
  a.zz += b.zz;
}

// Per-entry results of the assembly of a block of rows (structure of arrays).
struct AssemblyBlock {
  GatherBlock states;                               // d, dv of each entry; f: its spring force
  alignas(64) float kv[3][GATHER_BLOCK_ENTRIES];    // K·dv of each entry
  alignas(64) float block[6][GATHER_BLOCK_ENTRIES]; // S_e of each entry, as off_diagonal
  alignas(64) float rank[5][GATHER_BLOCK_ENTRIES];  // u, a, t of each entry, as sliced_springs
};

// Evaluates entry e (block slot k) from its relative state: force, K·dv and S_e into the slot.
inline void assemble_entry(const float* rest, const float* stiffness, const float* damping, float h, std::size_t e,
                           vfit_vec3 d, vfit_vec3 dv, AssemblyBlock& b, std::size_t k) {
  vfit_vec3 fs, ks;
  vfit_sym3 block;
  vfit_spring_implicit_terms_relative(d, dv, rest[e], stiffness[e], damping[e], h, &fs, &ks, &block);
  b.states.f[0][k] = fs.x;
  b.states.f[1][k] = fs.y;
  b.states.f[2][k] = fs.z;
  b.kv[0][k] = ks.x;
  b.kv[1][k] = ks.y;
  b.kv[2][k] = ks.z;
  b.block[0][k] = block.xx;
  b.block[1][k] = block.xy;
  b.block[2][k] = block.xz;
  b.block[3][k] = block.yy;
  b.block[4][k] = block.yz;
  b.block[5][k] = block.zz;
  // S_e = a·u·uᵀ + t·I: vfit_spring_implicit_terms_relative's u, a and t, the same formulas.
  const float l = std::sqrt(vfit_v3_dot(d, d));
  const float live = (float)(l > VFIT_SPRING_MIN_LENGTH);
  const float w = 1.0f / (live * l + (1.0f - live));
  float transverse = live * (stiffness[e] * (1.0f - rest[e] * w));
  transverse = transverse < 0.0f ? 0.0f : transverse;
  b.rank[0][k] = live * (d.x * w);
  b.rank[1][k] = live * (d.y * w);
  b.rank[2][k] = live * (d.z * w);
  b.rank[3][k] = h * damping[e] + h * h * (stiffness[e] - transverse);
  b.rank[4][k] = h * h * transverse;
}

// Copies the S_e of `count` slots from slot 0 into off_diagonal from entry e0.
inline void store_blocks(const AssemblyBlock& b, float* off_diagonal, std::size_t entries, std::size_t e0,
                         std::size_t count) {
  for (std::size_t c = 0; c < 6; ++c)
    std::copy_n(b.block[c], count, off_diagonal + c * entries + e0);
}

// Row i of the system from its entries' results: the diagonal block, its inverse and the
// right-hand side, summed in adjacency order, its own block D_i, and the row's springs (u, a,
// t) copied into its lane of the sliced springs (zero past its end). entry(e) returns the slot
// of b holding entry e's force, K·dv, S_e and (u, a, t).
template <typename EntrySlot>
inline void assemble_row(const float* v, const SpringAdjacency& adj, const ClothParticles& particles, float h,
                         ImplicitSystem& s, std::size_t i, const AssemblyBlock& b, const EntrySlot& entry) {
  const float* inv_mass = particles.inverse_masses.data();
  const bool is_free = inv_mass[i] != 0.0f;
  s.free[i] = is_free ? 1 : 0;
  const float m = is_free ? 1.0f / inv_mass[i] : 0.0f;
  const float md = m * (1.0f + h * particles.global_damping);
  vfit_sym3 diag{md, 0.0f, 0.0f, md, 0.0f, md};
  vfit_vec3 f{0.0f, 0.0f, 0.0f}, kv{0.0f, 0.0f, 0.0f}; // spring force, ∂f/∂x·v
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t slots = adj.slice_neighbor_offsets.size();
  const auto slice_first = static_cast<std::size_t>(adj.slice_offsets[i / W]);
  const auto slice_end = static_cast<std::size_t>(adj.slice_offsets[i / W + 1]);
  std::size_t slot = slice_first + i % W; // entry k's: slice_first + W·k + lane
  for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e, slot += W) {
    const std::size_t k = entry(std::size_t(e));
    f.x += b.states.f[0][k];
    f.y += b.states.f[1][k];
    f.z += b.states.f[2][k];
    kv.x += b.kv[0][k];
    kv.y += b.kv[1][k];
    kv.z += b.kv[2][k];
    add_sym(diag, vfit_sym3{b.block[0][k], b.block[1][k], b.block[2][k], b.block[3][k], b.block[4][k], b.block[5][k]});
    for (std::size_t c = 0; c < 5; ++c)
      s.sliced_springs[c * slots + slot] = b.rank[c][k];
  }
  for (; slot < slice_end; slot += W)
    for (std::size_t c = 0; c < 5; ++c)
      s.sliced_springs[c * slots + slot] = 0.0f;
  store_sym(s.diagonal.data(), i, diag);
  store_sym(s.particle_blocks.data(), i, vfit_sym3{md, 0.0f, 0.0f, md, 0.0f, md});
  s.inertia[i] = md;
  if (!is_free) {
    store_sliced_sym(s.preconditioner.data(), i, vfit_sym3{0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f});
    store3(s.rhs.data(), i, vfit_vec3{0.0f, 0.0f, 0.0f});
    return;
  }
  store_sliced_sym(s.preconditioner.data(), i, preconditioner_block(diag, md));
  // b = h·(f + m·g − μ·m·v + h·∂f/∂x·v)
  const vfit_vec3 vi = load3(v, i);
  const float g[3] = {particles.gravity[0], particles.gravity[1], particles.gravity[2]};
  const float mu = particles.global_damping;
  store3(s.rhs.data(), i,
         vfit_vec3{h * (f.x + m * g[0] - mu * m * vi.x + h * kv.x), h * (f.y + m * g[1] - mu * m * vi.y + h * kv.y),
                   h * (f.z + m * g[2] - mu * m * vi.z + h * kv.z)});
}

// Assembles the rows [begin, end). The springs of a block of consecutive rows are evaluated in
// one loop over their entries (vectorised; cloth_gather.h's for_each_row_block), then each
// row sums its entries in adjacency order; a row longer than a block evaluates each entry just
// before adding it (the same function, so the same bits).
VFIT_CLOTH_MULTIVERSION void assemble_range(const float* x, const float* v, const SpringAdjacency& adj,
                                            const ClothParticles& particles, float h, ImplicitSystem& s,
                                            bool with_off_diagonal, std::size_t begin, std::size_t end) {
  const float* rest = adj.rest_lengths.data();
  const float* stiffness = adj.stiffness.data();
  const float* damping = adj.damping.data();
  float* off_diagonal = s.off_diagonal.data();
  const std::size_t entries = adj.neighbors.size();
  AssemblyBlock b;
  const auto long_row = [&](std::size_t i) VFIT_CLOTH_LAMBDA {
    const vfit_vec3 xi = load3(x, i), vi = load3(v, i);
    assemble_row(v, adj, particles, h, s, i, b, [&](std::size_t e) VFIT_CLOTH_LAMBDA {
      const auto j = static_cast<std::size_t>(adj.neighbors[e]);
      assemble_entry(rest, stiffness, damping, h, e, vfit_v3_sub(load3(x, j), xi), vfit_v3_sub(load3(v, j), vi), b, 0);
      if (with_off_diagonal) store_blocks(b, off_diagonal, entries, e, 1);
      return std::size_t{0};
    });
  };
  const auto block = [&](std::size_t first, std::size_t last, std::int32_t e0, std::size_t count) VFIT_CLOTH_LAMBDA {
    gather_relative_states(x, v, adj, first, last, e0, b.states);
    for (std::size_t k = 0; k < count; ++k)
      assemble_entry(rest, stiffness, damping, h, std::size_t(e0) + k,
                     vfit_vec3{b.states.d[0][k], b.states.d[1][k], b.states.d[2][k]},
                     vfit_vec3{b.states.dv[0][k], b.states.dv[1][k], b.states.dv[2][k]}, b, k);
    if (with_off_diagonal) store_blocks(b, off_diagonal, entries, std::size_t(e0), count);
    for (std::size_t row = first; row < last; ++row)
      assemble_row(v, adj, particles, h, s, row, b,
                   [e0](std::size_t e) VFIT_CLOTH_LAMBDA { return e - std::size_t(e0); });
  };
  for_each_row_block(adj.offsets.data(), begin, end, GATHER_BLOCK_ENTRIES, long_row, block);
}

void resize_system(ImplicitSystem& s, std::size_t nv, std::size_t entries, std::size_t slots, bool with_off_diagonal) {
  if (with_off_diagonal)
    s.off_diagonal.resize(6 * entries);
  else
    s.off_diagonal.clear(); // not left stale

  s.sliced_springs.resize(5 * slots);
  s.diagonal.resize(6 * nv);
  s.particle_blocks.resize(6 * nv);
  s.inertia.resize(nv);
  s.preconditioner.resize(6 * CLOTH_SLICE_WIDTH * ((nv + CLOTH_SLICE_WIDTH - 1) / CLOTH_SLICE_WIDTH));
  s.rhs.resize(3 * nv);
  s.free.resize(nv);
}
} // namespace

namespace cloth_detail {
void assemble_implicit_system(std::span<const float> positions, std::span<const float> velocities,
                              const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                              ImplicitSystem& system, const ImplicitPasses& passes, bool with_off_diagonal) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && velocities.size() == 3 * nv && "state and adjacency sizes differ");
  assert(particles.inverse_masses.size() == nv && "one inverse mass per particle");
  resize_system(system, nv, adjacency.neighbors.size(), adjacency.slice_neighbor_offsets.size(), with_off_diagonal);
  passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
    assemble_range(positions.data(), velocities.data(), adjacency, particles, h, system, with_off_diagonal, b, e);
  });
}
} // namespace cloth_detail

void assemble_implicit_system(std::span<const float> positions, std::span<const float> velocities,
                              const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                              ImplicitSystem& system, bool parallel, bool with_off_diagonal) {
  cloth_detail::assemble_implicit_system(positions, velocities, adjacency, particles, h, system,
                                         cloth_detail::ImplicitPasses{parallel, nullptr}, with_off_diagonal);
}

} // namespace vfit
