// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to kernels/cloth_*.cpp: the shared C-subset math (cloth_math.h) brought into C++, the
// per-particle spring gather of the force and RK4 kernels (over sliced rows) and the row loop
// of the implicit solver's kernels (over CSR rows). Not a public header.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "spring_adjacency.h"

#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__)
#include <immintrin.h>
#endif

namespace vfit::cloth_detail {
using std::sqrt; // cloth_math.h calls sqrt(float) as OpenCL C does.
#include "cloth_math.h"

inline vfit_vec3 load3(const float* p, std::size_t i) { return vfit_vec3{p[3 * i], p[3 * i + 1], p[3 * i + 2]}; }

inline void store3(float* p, std::size_t i, vfit_vec3 v) {
  p[3 * i] = v.x;
  p[3 * i + 1] = v.y;
  p[3 * i + 2] = v.z;
}

// Marks a cloth kernel compiled also for AVX2 and AVX-512, picked at load time by the CPU
// (GCC/Clang function multiversioning on x86-64 ELF): its spring loops are gathers and
// square roots over 8 or 16 lanes instead of 4. Neither instruction set brings FMA, so the
// arithmetic (IEEE single precision, no contraction) and the bits are those of the default
// build. GCC only: Clang does not multiversion function templates.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__ELF__)
#define VFIT_CLOTH_MULTIVERSION __attribute__((target_clones("avx512f", "avx2", "default")))
#define VFIT_CLOTH_INLINE __attribute__((always_inline)) inline // into each clone
#else
#define VFIT_CLOTH_MULTIVERSION
#define VFIT_CLOTH_INLINE inline
#endif

// Marks a kernel compiled for AVX-512F alone, called only where avx512_available() says so:
// the RK4 pass's variant whose scattered neighbour loads are AVX-512 masked row loads
// (gather_rows16 below), written with intrinsics, which a target_clones default clone could not
// compile. VFIT_CLOTH_AVX512 is 1 where it exists.
#if defined(__x86_64__) && defined(__GNUC__) && defined(__ELF__)
#define VFIT_CLOTH_AVX512 1
#define VFIT_CLOTH_AVX512_TARGET __attribute__((target("avx512f")))
#else
#define VFIT_CLOTH_AVX512 0
#endif

// Marks a lambda to be inlined into its caller: the lambdas handed to the row loops below run
// inside a multiversioned kernel, and called instead they run in the default build, per row.
#if defined(__GNUC__)
#define VFIT_CLOTH_LAMBDA __attribute__((always_inline))
#else
#define VFIT_CLOTH_LAMBDA
#endif

// Σ of the spring forces on particle i (N) at the state (x, v), in adjacency order.
inline vfit_vec3 gather_spring_force(const float* x, const float* v, const SpringAdjacency& adj, std::size_t i) {
  const vfit_vec3 xi = load3(x, i), vi = load3(v, i);
  vfit_vec3 f{0.0f, 0.0f, 0.0f};
  for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
    const auto j = static_cast<std::size_t>(adj.neighbors[e]);
    const vfit_vec3 fs =
        vfit_spring_force(xi, load3(x, j), vi, load3(v, j), adj.rest_lengths[e], adj.stiffness[e], adj.damping[e]);
    f.x += fs.x;
    f.y += fs.y;
    f.z += fs.z;
  }
  return f;
}

// The spring forces (N) of one slice's particles, lane l for particle W·slice + l.
struct SliceForces {
  alignas(64) float f[3][CLOTH_SLICE_WIDTH];
};

#if VFIT_CLOTH_AVX512
// Whether this CPU (and OS) runs the VFIT_CLOTH_AVX512_TARGET kernels.
inline bool avx512_available() {
  static const bool available = __builtin_cpu_supports("avx512f");
  return available;
}

// outs[a][c][l] = arrays[a][offsets[l] + c] for the N arrays a, the 16 lanes l and c < 3: the
// rows of 16 scattered particles (offsets[l] = 3·j) of each array transposed into structure of
// arrays. Each row is one masked 16-byte load (x, y, z; the fourth float is masked off, so the
// last particle's row reads nothing past the array: a masked-off element is never accessed)
// straight into its 128-bit lane of a register: row 4q + r goes to lane q of register r. A
// 4 × 4 transpose inside the lanes (six unpacks per array) then gives x, y and z of the 16 lanes
// in order. 16 loads and 6 shuffles per array instead of 48 scalar loads and the inserts that
// assemble them: the same values. All arrays in one loop, so each offset is loaded once and the
// address is one base register per array, the offset scaled by 4 and a constant displacement
// (a lane's load starts 4q floats before its row: integer arithmetic, as that address may lie
// before the array).
template <int N>
VFIT_CLOTH_AVX512_TARGET inline void gather_rows16_of(const float* const (&arrays)[N], const std::int32_t* offsets,
                                                      float (*const (&outs)[N])[16]) {
  std::uintptr_t base[N];
  __m512 rows[N][4];
  for (int a = 0; a < N; ++a) {
    base[a] = reinterpret_cast<std::uintptr_t>(arrays[a]);
    for (int k = 0; k < 4; ++k)
      rows[a][k] = _mm512_setzero_ps();
  }
  // No lambdas: they would not inherit the target.
  for (int q = 0; q < 4; ++q)
    for (int k = 0; k < 4; ++k) {
      const auto bytes = static_cast<std::uintptr_t>(static_cast<std::intptr_t>(offsets[4 * q + k])) * sizeof(float) -
                         std::uintptr_t(16 * q);
      const auto mask = static_cast<__mmask16>(0x7u << (4 * q));
      for (int a = 0; a < N; ++a)
        rows[a][k] = _mm512_mask_loadu_ps(rows[a][k], mask, reinterpret_cast<const void*>(base[a] + bytes));
    }
  // The zero-masking forms with a full mask are the plain instructions; the unmasked
  // intrinsics start from _mm512_undefined_ps(), which GCC 12 warns of (-Wmaybe-uninitialized).
  constexpr __mmask16 ALL = 0xffff;
  constexpr __mmask8 ALL8 = 0xff;
  for (int a = 0; a < N; ++a) {
    const __m512* r = rows[a];
    const __m512d t0 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(ALL, r[0], r[1])); // x0 x1 y0 y1 a lane
    const __m512d t1 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(ALL, r[2], r[3])); // x2 x3 y2 y3
    const __m512d t2 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(ALL, r[0], r[1])); // z0 z1 · ·
    const __m512d t3 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(ALL, r[2], r[3])); // z2 z3 · ·
    _mm512_store_ps(outs[a][0], _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(ALL8, t0, t1)));
    _mm512_store_ps(outs[a][1], _mm512_castpd_ps(_mm512_maskz_unpackhi_pd(ALL8, t0, t1)));
    _mm512_store_ps(outs[a][2], _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(ALL8, t2, t3)));
  }
}

// xo[c][l] = x[offsets[l] + c] and vo[c][l] = v[offsets[l] + c] (gather_rows16_of): the rows
// x_j and v_j of the 16 neighbours of an RK4 column.
VFIT_CLOTH_AVX512_TARGET inline void gather_rows16(const float* x, const float* v, const std::int32_t* offsets,
                                                   float xo[3][16], float vo[3][16]) {
  gather_rows16_of<2>({x, v}, offsets, {xo, vo});
}

// po[c][l] = p[offsets[l] + c] (gather_rows16_of): the rows p_j of the 16 neighbours of a
// column of the implicit solver's product.
VFIT_CLOTH_AVX512_TARGET inline void gather_rows16(const float* p, const std::int32_t* offsets, float po[3][16]) {
  gather_rows16_of<1>({p}, offsets, {po});
}

// The permutation indices of load_rows16 / store_rows16: _mm512_permutex2var_ps picks element
// i & 15 of its first (i < 16) or second (i ≥ 16) operand.
struct TransposeIndices {
  alignas(64) std::int32_t load_first[3][16], load_second[3][16], store_first[3][16], store_second[3][16];
};

constexpr TransposeIndices make_transpose_indices() {
  TransposeIndices t{};
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 16; ++l) {
      // Loading component k of lane l, s[3l + k]: from the first two vectors, then the third.
      const int e = 3 * l + k;
      t.load_first[k][l] = e < 32 ? e : 0;
      t.load_second[k][l] = e < 32 ? l : 16 + e - 32;
      // Storing vector k (floats 16k … 16k + 15), element e = 16k + l = 3·lane + component:
      // components 0 and 1 from the x and y rows, then component 2 from the z row.
      const int f = 16 * k + l, lane = f / 3, component = f % 3;
      t.store_first[k][l] = component == 0 ? lane : component == 1 ? 16 + lane : 0;
      t.store_second[k][l] = component == 2 ? 16 + lane : l;
    }
  return t;
}

inline constexpr TransposeIndices TRANSPOSE = make_transpose_indices();

// out[c][l] = s[3l + c] for the 16 lanes: 16 particles' rows (48 consecutive floats) into
// structure of arrays, three loads and six two-source permutes (GCC compiles the scalar loop
// over 16 lanes into one float move per element for half the lanes or more).
VFIT_CLOTH_AVX512_TARGET inline void load_rows16(const float* s, float out[3][16]) {
  const __m512 a = _mm512_loadu_ps(s), b = _mm512_loadu_ps(s + 16), c = _mm512_loadu_ps(s + 32);
  for (int k = 0; k < 3; ++k) {
    const __m512 ab = _mm512_permutex2var_ps(a, _mm512_load_si512(TRANSPOSE.load_first[k]), b);
    _mm512_store_ps(out[k], _mm512_permutex2var_ps(ab, _mm512_load_si512(TRANSPOSE.load_second[k]), c));
  }
}

// out[c][l] = s[6l + c] for the 16 lanes and c < 6: 16 symmetric 3 × 3 blocks stored six
// floats each (xx, xy, xz, yy, yz, zz; ImplicitSystem::particle_blocks) into structure of
// arrays, one 16-lane gather per component (the full-mask form: the unmasked intrinsic starts
// from an undefined register, which GCC 12 warns of).
VFIT_CLOTH_AVX512_TARGET inline void load_sym_rows16(const float* s, float out[6][16]) {
  const __m512i six = _mm512_set_epi32(90, 84, 78, 72, 66, 60, 54, 48, 42, 36, 30, 24, 18, 12, 6, 0);
  for (int c = 0; c < 6; ++c)
    _mm512_store_ps(out[c], _mm512_mask_i32gather_ps(_mm512_setzero_ps(), 0xffff, six, s + c, 4));
}

// d[3l + c] = in[c][l] for the 16 lanes: load_rows16 backwards.
VFIT_CLOTH_AVX512_TARGET inline void store_rows16(float* d, const float in[3][16]) {
  const __m512 x = _mm512_load_ps(in[0]), y = _mm512_load_ps(in[1]), z = _mm512_load_ps(in[2]);
  for (int k = 0; k < 3; ++k) {
    const __m512 xy = _mm512_permutex2var_ps(x, _mm512_load_si512(TRANSPOSE.store_first[k]), y);
    _mm512_storeu_ps(d + 16 * k, _mm512_permutex2var_ps(xy, _mm512_load_si512(TRANSPOSE.store_second[k]), z));
  }
}

#endif

// Lane l of `out` = gather_spring_force(x, v, adj, W·slice + l), bit for bit (lanes past #V:
// garbage). One particle per lane: each column of the slice's sliced rows (SpringAdjacency::
// slice_offsets) evaluates one entry of every lane's row, gathering x_j and v_j, with the
// branch-free vfit_spring_force_relative, and adds it to the lane's running sum, so every
// lane sums its row in adjacency order from +0 (the padding adds ±0: no change).
//
// A column whose W neighbours are W consecutive particles (SpringAdjacency::
// slice_consecutive_columns; a mesh numbered row by row gives this in most columns) loads
// their states as three contiguous vectors per array, which the compiler deinterleaves with
// permutes, instead of 6·W scalar loads and inserts: the same values, so the same bits. The
// scalar loads of a general column bound the pass.
//
// ROW_LOADS (VFIT_CLOTH_AVX512_TARGET kernels only): a general column loads each neighbour's
// row of x and of v with one masked vector load (gather_rows16) instead of scalar loads.
template <bool ROW_LOADS = false>
VFIT_CLOTH_INLINE void slice_spring_forces(const float* x, const float* v, const SpringAdjacency& adj,
                                           std::size_t slice, SliceForces& out) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t n = adj.particle_count();
  alignas(64) float xi[3][W], vi[3][W];
  if (W * slice + W <= n) { // a full slice: its own states are contiguous too
    const float* xs = x + 3 * W * slice;
    const float* vs = v + 3 * W * slice;
#if VFIT_CLOTH_AVX512
    if constexpr (ROW_LOADS) {
      load_rows16(xs, xi);
      load_rows16(vs, vi);
    } else
#endif
      for (std::size_t l = 0; l < W; ++l)
        for (std::size_t c = 0; c < 3; ++c) {
          xi[c][l] = xs[3 * l + c];
          vi[c][l] = vs[3 * l + c];
        }
  } else {
    for (std::size_t l = 0; l < W; ++l) {
      const std::size_t i = std::min(W * slice + l, n - 1);
      for (std::size_t c = 0; c < 3; ++c) {
        xi[c][l] = x[3 * i + c];
        vi[c][l] = v[3 * i + c];
      }
    }
  }
  for (std::size_t c = 0; c < 3; ++c)
    for (std::size_t l = 0; l < W; ++l)
      out.f[c][l] = 0.0f;
  const auto first = static_cast<std::size_t>(adj.slice_offsets[slice]);
  const auto end = static_cast<std::size_t>(adj.slice_offsets[slice + 1]);
  std::uint32_t consecutive = adj.slice_consecutive_columns[slice];
  for (std::size_t column = first; column < end; column += W, consecutive >>= 1) {
    const std::int32_t* neighbors = adj.slice_neighbor_offsets.data() + column;
    const float* rest = adj.slice_rest_lengths.data() + column;
    const float* stiffness = adj.slice_stiffness.data() + column;
    const float* damping = adj.slice_damping.data() + column;
    const auto add = [&](std::size_t l, vfit_vec3 d, vfit_vec3 dv) VFIT_CLOTH_LAMBDA {
      const vfit_vec3 fs = vfit_spring_force_relative(d, dv, rest[l], stiffness[l], damping[l]);
      out.f[0][l] += fs.x;
      out.f[1][l] += fs.y;
      out.f[2][l] += fs.z;
    };
    if (consecutive & 1u) {
      const float* xj = x + neighbors[0];
      const float* vj = v + neighbors[0];
      for (std::size_t l = 0; l < W; ++l)
        add(l, vfit_vec3{xj[3 * l] - xi[0][l], xj[3 * l + 1] - xi[1][l], xj[3 * l + 2] - xi[2][l]},
            vfit_vec3{vj[3 * l] - vi[0][l], vj[3 * l + 1] - vi[1][l], vj[3 * l + 2] - vi[2][l]});
      continue;
    }
#if VFIT_CLOTH_AVX512
    if constexpr (ROW_LOADS) {
      static_assert(W == 16, "gather_rows16 fills 16 lanes");
      alignas(64) float xj[3][W], vj[3][W];
      gather_rows16(x, v, neighbors, xj, vj);
      for (std::size_t l = 0; l < W; ++l)
        add(l, vfit_vec3{xj[0][l] - xi[0][l], xj[1][l] - xi[1][l], xj[2][l] - xi[2][l]},
            vfit_vec3{vj[0][l] - vi[0][l], vj[1][l] - vi[1][l], vj[2][l] - vi[2][l]});
      continue;
    }
#endif
    for (std::size_t l = 0; l < W; ++l) {
      const std::int32_t j3 = neighbors[l]; // 3·j: a 32-bit gather index, unscaled
      add(l, vfit_vec3{x[j3] - xi[0][l], x[j3 + 1] - xi[1][l], x[j3 + 2] - xi[2][l]},
          vfit_vec3{v[j3] - vi[0][l], v[j3 + 1] - vi[1][l], v[j3 + 2] - vi[2][l]});
    }
  }
}

// Adjacency entries per block of for_each_row_block() in the implicit solver's kernels: their
// per-entry scratch (≤ 21 floats per entry) stays in the L1 cache.
inline constexpr std::size_t GATHER_BLOCK_ENTRIES = 256;

// Relative states of a block's entries, structure of arrays.
struct GatherBlock {
  alignas(64) float d[3][GATHER_BLOCK_ENTRIES];  // x_j − x_i
  alignas(64) float dv[3][GATHER_BLOCK_ENTRIES]; // v_j − v_i
  alignas(64) float f[3][GATHER_BLOCK_ENTRIES];  // the entry's spring force on its owner
};

// Copies x_j − x_i and v_j − v_i of the entries of particles [first, last) into s, from entry e0.
VFIT_CLOTH_INLINE void gather_relative_states(const float* x, const float* v, const SpringAdjacency& adj,
                                              std::size_t first, std::size_t last, std::int32_t e0, GatherBlock& s) {
  const std::int32_t* offsets = adj.offsets.data();
  const std::int32_t* neighbors = adj.neighbors.data();
  for (std::size_t p = first; p < last; ++p) {
    const vfit_vec3 xp = load3(x, p), vp = load3(v, p);
    for (std::int32_t e = offsets[p]; e < offsets[p + 1]; ++e) {
      const auto k = static_cast<std::size_t>(e - e0);
      const auto j = static_cast<std::size_t>(neighbors[e]);
      s.d[0][k] = x[3 * j] - xp.x;
      s.d[1][k] = x[3 * j + 1] - xp.y;
      s.d[2][k] = x[3 * j + 2] - xp.z;
      s.dv[0][k] = v[3 * j] - vp.x;
      s.dv[1][k] = v[3 * j + 1] - vp.y;
      s.dv[2][k] = v[3 * j + 2] - vp.z;
    }
  }
}

// The row loop of the CSR kernels: the rows [begin, end) in order, in blocks of consecutive
// rows holding at most `cap` entries in all, block(first, last, e0, count) for the rows
// [first, last) whose entries are [e0, e0 + count); a row longer than cap alone, by
// long_row(i). A block lets the caller evaluate its entries in one loop that vectorises, then
// sum each row's entries in adjacency order.
template <typename LongRow, typename Block>
VFIT_CLOTH_INLINE void for_each_row_block(const std::int32_t* offsets, std::size_t begin, std::size_t end,
                                          std::size_t cap, const LongRow& long_row, const Block& block) {
  const auto cap32 = static_cast<std::int32_t>(cap);
  std::size_t i = begin;
  while (i < end) {
    const std::int32_t e0 = offsets[i];
    if (offsets[i + 1] - e0 > cap32) {
      long_row(i);
      ++i;
      continue;
    }
    std::size_t last = i + 1;
    while (last < end && offsets[last + 1] - e0 <= cap32)
      ++last;
    block(i, last, e0, static_cast<std::size_t>(offsets[last] - e0));
    i = last;
  }
}
} // namespace vfit::cloth_detail
