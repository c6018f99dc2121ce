// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to kernels/cloth_implicit*.cpp: how ImplicitSystem stores its 3×3 blocks, and the
// fixed-chunk driver every pass of the implicit step runs through (the assembly in
// cloth_implicit_assembly.cpp, the solve in cloth_implicit.cpp). Not a public header.

#include <algorithm>
#include <cstddef>
#include <span>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "chunk_team.h"
#include "cloth_gather.h"
#include "cloth_implicit_system.h"
#include "cloth_rk4.h"
#include "parallel.h"

namespace vfit::cloth_detail {

// Block i of ImplicitSystem::diagonal: six floats from 6·i (xx, xy, xz, yy, yz, zz).
inline vfit_sym3 load_sym(const float* p, std::size_t i) {
  const float* s = p + 6 * i;
  return vfit_sym3{s[0], s[1], s[2], s[3], s[4], s[5]};
}

inline void store_sym(float* p, std::size_t i, vfit_sym3 s) {
  float* d = p + 6 * i;
  d[0] = s.xx;
  d[1] = s.xy;
  d[2] = s.xz;
  d[3] = s.yy;
  d[4] = s.yz;
  d[5] = s.zz;
}

// Block i of ImplicitSystem::preconditioner, stored by slices: component c of particle i at
// 6·W·(i / W) + W·c + i % W.
inline std::size_t sliced_sym_index(std::size_t i) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  return 6 * (i - i % W) + i % W;
}

inline vfit_sym3 load_sliced_sym(const float* p, std::size_t i) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const float* s = p + sliced_sym_index(i);
  return vfit_sym3{s[0], s[W], s[2 * W], s[3 * W], s[4 * W], s[5 * W]};
}

inline void store_sliced_sym(float* p, std::size_t i, vfit_sym3 s) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  float* d = p + sliced_sym_index(i);
  d[0] = s.xx;
  d[W] = s.xy;
  d[2 * W] = s.xz;
  d[3 * W] = s.yy;
  d[4 * W] = s.yz;
  d[5 * W] = s.zz;
}

// The preconditioner block of a row: the inverse of its diagonal block A_ii (mass part md, kg)
// with 2⁻¹⁸·tr(A_ii − md·I) added along the diagonal. A_ii summed in float carries ≈ 2⁻²⁴ of
// its springs' h²·k per entry and addition, which may exceed the mass term of a light particle
// (a sliver's): its rounded inverse may then be indefinite and CG breaks. The shift (16× the
// rounding of a dozen additions) keeps the inverse's condition below 2¹⁸, so its float entries
// stay positive definite; it changes CG's convergence only, never the answer.
inline vfit_sym3 preconditioner_block(vfit_sym3 diag, float md) {
  const float shift = 0x1p-18f * (diag.xx + diag.yy + diag.zz - 3.0f * md);
  diag.xx += shift;
  diag.yy += shift;
  diag.zz += shift;
  return vfit_sym3_inverse(diag);
}

// Fixed chunks of the implicit passes: the count covering n particles.
inline std::size_t chunk_count(std::size_t n) { return (n + CLOTH_IMPLICIT_CHUNK - 1) / CLOTH_IMPLICIT_CHUNK; }

// Runs kernel(chunk, begin, end) over the fixed chunks of [0, n): in order, or in parallel.
// With `affinity`, the passes that share it hand each chunk to the thread that ran it last,
// where it can (the CG's passes: a thread's part of the system then stays in its own cache
// from pass to pass, as far as it fits).
template <typename Kernel>
void run_chunks(std::size_t n, bool parallel, const Kernel& kernel, tbb::affinity_partitioner* affinity = nullptr) {
  const std::size_t chunks = chunk_count(n);
  const auto body = [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      kernel(c, c * CLOTH_IMPLICIT_CHUNK, std::min(n, (c + 1) * CLOTH_IMPLICIT_CHUNK));
  };
  if (!parallel)
    body(0, chunks);
  else if (affinity == nullptr)
    parallel_for_range(chunks, 1, body);
  else
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, chunks, 1),
        [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); }, *affinity);
}
// The team an implicit step holds for its passes (chunk_team.h), over the same fixed chunks.
using ImplicitTeam = ChunkTeam<CLOTH_IMPLICIT_CHUNK>;

// How the passes of an implicit step run: in order, by TBB pass by pass (`parallel`), or by a
// team held for the step. Every way gives the same bits (fixed chunks, sums in chunk order).
struct ImplicitPasses {
  bool parallel = false;
  ImplicitTeam* team = nullptr;

  template <typename Kernel>
  void run(std::size_t n, const Kernel& kernel, tbb::affinity_partitioner* affinity = nullptr) const {
    if (team != nullptr)
      team->run(n, kernel);
    else
      run_chunks(n, parallel, kernel, affinity);
  }
  // Whether other TBB loops (the coarse level's) may run in parallel: not while a team holds
  // the threads, whose followers would leave them to the leader alone.
  bool tbb() const { return parallel && team == nullptr; }
};

// assemble_implicit_system() with its passes run by `passes`.
void assemble_implicit_system(std::span<const float> positions, std::span<const float> velocities,
                              const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                              ImplicitSystem& system, const ImplicitPasses& passes, bool with_off_diagonal);

} // namespace vfit::cloth_detail
