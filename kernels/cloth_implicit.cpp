// SPDX-License-Identifier: Apache-2.0
#include "cloth_implicit.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include <tbb/partitioner.h>

#include "cloth_gather.h"
#include "cloth_implicit_blocks.h"
#include "cloth_implicit_coarse.h"
#include "parallel.h"

namespace vfit {
namespace {
using namespace cloth_detail;

// Σ over chunks, in chunk order, of partials[stride·c + k].
double chunk_sum(const std::vector<double>& partials, std::size_t chunks, std::size_t stride, std::size_t k) {
  double s = 0;
  for (std::size_t c = 0; c < chunks; ++c)
    s += partials[stride * c + k];
  return s;
}

double dot3(vfit_vec3 a, vfit_vec3 b) { return double(a.x) * b.x + double(a.y) * b.y + double(a.z) * b.z; }

// S_e·d = a·u·(u·d) + t·d for the spring in slot k of the sliced springs (ImplicitSystem::
// sliced_springs, `slots` per component).
inline vfit_vec3 spring_times(const float* springs, std::size_t slots, std::size_t k, vfit_vec3 d) {
  const vfit_vec3 u{springs[k], springs[slots + k], springs[2 * slots + k]};
  return vfit_spring_rank_one_apply(u, springs[3 * slots + k], springs[4 * slots + k], d);
}

// (A·p)_i for a free particle i: D_i·p_i + Σ_e S_e·(p_i − p_j) (pinned p_j are zero by the
// filter), A_ii·p_i − Σ_e S_e·p_j without the cancellation (ImplicitSystem::particle_blocks),
// each S_e applied in its rank-one form (ImplicitSystem::sliced_springs), as the CG's product.
vfit_vec3 row_times(const ImplicitSystem& s, const SpringAdjacency& adj, const float* p, std::size_t i) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t slots = adj.slice_neighbor_offsets.size();
  const vfit_vec3 pi = load3(p, i);
  vfit_vec3 r = vfit_sym3_apply(load_sym(s.particle_blocks.data(), i), pi);
  std::size_t slot = static_cast<std::size_t>(adj.slice_offsets[i / W]) + i % W;
  for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e, slot += W) {
    const vfit_vec3 t = spring_times(s.sliced_springs.data(), slots, slot,
                                     vfit_v3_sub(pi, load3(p, static_cast<std::size_t>(adj.neighbors[e]))));
    r.x += t.x;
    r.y += t.y;
    r.z += t.z;
  }
  return r;
}

// Row i of (A·p) for the particles of one slice, lane l for particle W·slice + l (lanes past
// #V: garbage): D_i·p_i + Σ_e S_e·(p_i − p_j) in adjacency order, as row_times, from the
// sliced springs (rank-one form), one particle per SIMD lane (as cloth_gather.h's
// slice_spring_forces). The null slots' blocks are zero and name the particle itself, so
// their S·(p_i − p_i) is +0, which changes no sum: the values of row_times, a zero's sign aside.
struct SliceProduct {
  alignas(64) float r[3][CLOTH_SLICE_WIDTH];
  alignas(64) float p[3][CLOTH_SLICE_WIDTH]; // p_i of each lane
};

//
// ROW_LOADS (VFIT_CLOTH_AVX512_TARGET kernels only): each column's 16 neighbour rows p_j are
// loaded by one masked vector load each (gather_rows16) instead of 48 scalar loads and their
// inserts, which bound the pass: the same values, so the same bits.
template <bool ROW_LOADS = false>
VFIT_CLOTH_INLINE void slice_product(const ImplicitSystem& s, const SpringAdjacency& adj, const float* p,
                                     std::size_t slice, SliceProduct& out) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t last = adj.particle_count() - 1;
#if VFIT_CLOTH_AVX512
  if constexpr (ROW_LOADS) {
    if (W * slice + W <= last + 1) { // a full slice: its rows of p and D are contiguous
      load_rows16(p + 3 * W * slice, out.p);
      alignas(64) float d[6][W];
      load_sym_rows16(s.particle_blocks.data() + 6 * W * slice, d);
      for (std::size_t l = 0; l < W; ++l) {
        const vfit_vec3 r = vfit_sym3_apply(vfit_sym3{d[0][l], d[1][l], d[2][l], d[3][l], d[4][l], d[5][l]},
                                            vfit_vec3{out.p[0][l], out.p[1][l], out.p[2][l]});
        out.r[0][l] = r.x;
        out.r[1][l] = r.y;
        out.r[2][l] = r.z;
      }
    }
  }
  if (!ROW_LOADS || W * slice + W > last + 1)
#endif
    for (std::size_t l = 0; l < W; ++l) {
      const std::size_t i = std::min(W * slice + l, last);
      const vfit_vec3 pi = load3(p, i);
      const vfit_vec3 r = vfit_sym3_apply(load_sym(s.particle_blocks.data(), i), pi);
      out.r[0][l] = r.x;
      out.r[1][l] = r.y;
      out.r[2][l] = r.z;
      out.p[0][l] = pi.x;
      out.p[1][l] = pi.y;
      out.p[2][l] = pi.z;
    }
  const std::size_t slots = adj.slice_neighbor_offsets.size();
  const auto first = static_cast<std::size_t>(adj.slice_offsets[slice]);
  const auto end = static_cast<std::size_t>(adj.slice_offsets[slice + 1]);
  for (std::size_t column = first; column < end; column += W) {
    const std::int32_t* neighbors = adj.slice_neighbor_offsets.data() + column;
    const float* springs = s.sliced_springs.data() + column;
#if VFIT_CLOTH_AVX512
    if constexpr (ROW_LOADS) {
      static_assert(W == 16, "gather_rows16 fills 16 lanes");
      alignas(64) float pj[3][W];
      gather_rows16(p, neighbors, pj);
      for (std::size_t l = 0; l < W; ++l) {
        const vfit_vec3 d{out.p[0][l] - pj[0][l], out.p[1][l] - pj[1][l], out.p[2][l] - pj[2][l]};
        const vfit_vec3 t = spring_times(springs, slots, l, d);
        out.r[0][l] += t.x;
        out.r[1][l] += t.y;
        out.r[2][l] += t.z;
      }
      continue;
    }
#endif
    for (std::size_t l = 0; l < W; ++l) {
      const std::int32_t j3 = neighbors[l];
      const vfit_vec3 d{out.p[0][l] - p[j3], out.p[1][l] - p[j3 + 1], out.p[2][l] - p[j3 + 2]};
      const vfit_vec3 t = spring_times(springs, slots, l, d);
      out.r[0][l] += t.x;
      out.r[1][l] += t.y;
      out.r[2][l] += t.z;
    }
  }
}

// B&W's filter S_i applied to a: 0 for a pinned particle, (I − n·nᵀ)·a for a constrained one
// (normals non-null, row i nonzero), a otherwise.
inline vfit_vec3 filter_row(const ImplicitSystem& s, const float* normals, std::size_t i, vfit_vec3 a) {
  if (!s.free[i]) return vfit_vec3{0.0f, 0.0f, 0.0f};
  if (normals == nullptr) return a;
  const vfit_vec3 n = load3(normals, i);
  const float an = vfit_v3_dot(a, n);
  return vfit_vec3{a.x - an * n.x, a.y - an * n.y, a.z - an * n.z};
}

// Σ of a pass's per-lane partial sums, in lane order. A pass over a range sums each lane's
// particles (the range's W·s + l) in particle order, one running sum per lane, so the W sums
// run in parallel (a single running sum over the particles is a chain of dependent additions
// that bounds the pass); the order depends on the range only, never on the thread count.
double lane_sum(const double (&lanes)[CLOTH_SLICE_WIDTH]) {
  double s = 0;
  for (double x : lanes)
    s += x;
  return s;
}

// Per-particle results of one slice in a CG pass, lane l for particle W·slice + l.
struct SliceDots {
  alignas(64) float a[3][CLOTH_SLICE_WIDTH]; // the filtered S·A·z (first pass) or S·P⁻¹·r (second)
  alignas(64) double first[CLOTH_SLICE_WIDTH], second[CLOTH_SLICE_WIDTH];
};

// Lane l of `out` = filter_row(s, normals, i, a_l) for the `count` particles from `first`, a in
// out.a (in place). Without contact normals the filter is a select (pinned rows → +0), which
// vectorises; with them, the projection row by row.
VFIT_CLOTH_INLINE void filter_slice(const ImplicitSystem& s, const float* normals, std::size_t first, std::size_t count,
                                    SliceDots& out) {
  const unsigned char* is_free = s.free.data() + first;
  if (normals == nullptr) {
    for (std::size_t c = 0; c < 3; ++c)
      for (std::size_t l = 0; l < count; ++l)
        out.a[c][l] = is_free[l] ? out.a[c][l] : 0.0f;
    return;
  }
  for (std::size_t l = 0; l < count; ++l) {
    const vfit_vec3 f = filter_row(s, normals, first + l, vfit_vec3{out.a[0][l], out.a[1][l], out.a[2][l]});
    out.a[0][l] = f.x;
    out.a[1][l] = f.y;
    out.a[2][l] = f.z;
  }
}

// The first pass of a CG iteration over the particles [begin, end) (whole slices, or up to
// #V): p = z + β·p and q = S·A·z + β·q in place; returns Σ p·q over the range (double, in
// lane_sum's order). The per-particle work of a slice runs lane-parallel (it vectorises).
// ROW_LOADS: slice_product's row loads (the AVX-512 kernel direction_range_rows).
template <bool ROW_LOADS>
VFIT_CLOTH_INLINE double direction_slices(const ImplicitSystem& s, const SpringAdjacency& adj, const float* normals,
                                          const float* z, float beta, float* p, float* q, std::size_t begin,
                                          std::size_t end) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  assert(begin % W == 0 && "a range of whole slices");
  alignas(64) double pq_lanes[W] = {};
  SliceProduct product;
  SliceDots lanes;
  for (std::size_t first = begin; first < end; first += W) {
    const std::size_t count = std::min(W, end - first);
    slice_product<ROW_LOADS>(s, adj, z, first / W, product);
    for (std::size_t c = 0; c < 3; ++c)
      std::copy_n(product.r[c], W, lanes.a[c]);
    filter_slice(s, normals, first, count, lanes); // zero for a pinned row
    float* pb = p + 3 * first;
    float* qb = q + 3 * first;
    const float* zb = z + 3 * first;
#if VFIT_CLOTH_AVX512
    if constexpr (ROW_LOADS) {
      if (count == W) { // the same operations on the rows transposed (load_rows16, store_rows16)
        alignas(64) float zs[3][W], ps[3][W], qs[3][W];
        load_rows16(zb, zs);
        load_rows16(pb, ps);
        load_rows16(qb, qs);
        for (std::size_t l = 0; l < W; ++l) {
          const vfit_vec3 pn{zs[0][l] + beta * ps[0][l], zs[1][l] + beta * ps[1][l], zs[2][l] + beta * ps[2][l]};
          const vfit_vec3 qn{lanes.a[0][l] + beta * qs[0][l], lanes.a[1][l] + beta * qs[1][l],
                             lanes.a[2][l] + beta * qs[2][l]};
          ps[0][l] = pn.x;
          ps[1][l] = pn.y;
          ps[2][l] = pn.z;
          qs[0][l] = qn.x;
          qs[1][l] = qn.y;
          qs[2][l] = qn.z;
          lanes.first[l] = dot3(pn, qn);
        }
        store_rows16(pb, ps);
        store_rows16(qb, qs);
        for (std::size_t l = 0; l < W; ++l)
          pq_lanes[l] += lanes.first[l];
        continue;
      }
    }
#endif
    for (std::size_t l = 0; l < count; ++l) {
      const vfit_vec3 pn{zb[3 * l] + beta * pb[3 * l], zb[3 * l + 1] + beta * pb[3 * l + 1],
                         zb[3 * l + 2] + beta * pb[3 * l + 2]};
      const vfit_vec3 qn{lanes.a[0][l] + beta * qb[3 * l], lanes.a[1][l] + beta * qb[3 * l + 1],
                         lanes.a[2][l] + beta * qb[3 * l + 2]};
      store3(pb, l, pn);
      store3(qb, l, qn);
      lanes.first[l] = dot3(pn, qn);
    }
    for (std::size_t l = 0; l < count; ++l)
      pq_lanes[l] += lanes.first[l];
  }
  return lane_sum(pq_lanes);
}

VFIT_CLOTH_MULTIVERSION double direction_range_lanes(const ImplicitSystem& s, const SpringAdjacency& adj,
                                                     const float* normals, const float* z, float beta, float* p,
                                                     float* q, std::size_t begin, std::size_t end) {
  return direction_slices<false>(s, adj, normals, z, beta, p, q, begin, end);
}

#if VFIT_CLOTH_AVX512
VFIT_CLOTH_AVX512_TARGET double direction_range_rows(const ImplicitSystem& s, const SpringAdjacency& adj,
                                                     const float* normals, const float* z, float beta, float* p,
                                                     float* q, std::size_t begin, std::size_t end) {
  return direction_slices<true>(s, adj, normals, z, beta, p, q, begin, end);
}
#endif

// direction_slices() in the variant this CPU runs fastest: row loads where AVX-512 is there.
double direction_range(const ImplicitSystem& s, const SpringAdjacency& adj, const float* normals, const float* z,
                       float beta, float* p, float* q, std::size_t begin, std::size_t end) {
#if VFIT_CLOTH_AVX512
  if (avx512_available()) return direction_range_rows(s, adj, normals, z, beta, p, q, begin, end);
#endif
  return direction_range_lanes(s, adj, normals, z, beta, p, q, begin, end);
}

// The second pass of a CG iteration over the particles [begin, end): Δv += α·p, r −= α·q,
// z = S·P⁻¹·r; writes r·r and r·z over the range to rr and rz (double, in lane_sum's order),
// lane-parallel per slice as direction_range. ROW_LOADS (the AVX-512 kernel update_range_rows):
// a full slice's rows of r and z are transposed by load_rows16 and store_rows16 instead of
// strided scalar loads and stores: the same operations, so the same bits.
template <bool ROW_LOADS>
VFIT_CLOTH_INLINE void update_slices(const ImplicitSystem& s, const float* normals, float alpha, const float* p,
                                     const float* q, float* dv, float* r, float* z, std::size_t begin, std::size_t end,
                                     double& rr, double& rz) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const float* precond = s.preconditioner.data();
  SliceDots lanes;
  alignas(64) double rr_lanes[W] = {}, rz_lanes[W] = {};
  for (std::size_t first = begin; first < end; first += W) {
    const std::size_t count = std::min(W, end - first);
    for (std::size_t k = 3 * first; k < 3 * (first + count); ++k) {
      dv[k] += alpha * p[k];
      r[k] -= alpha * q[k];
    }
#if VFIT_CLOTH_AVX512
    if constexpr (ROW_LOADS) {
      if (count == W) {
        alignas(64) float rs[3][W];
        load_rows16(r + 3 * first, rs);
        const float* pc = precond + sliced_sym_index(first); // the slice's 6 × W components
        for (std::size_t l = 0; l < W; ++l) {
          const vfit_vec3 zi =
              vfit_sym3_apply(vfit_sym3{pc[l], pc[W + l], pc[2 * W + l], pc[3 * W + l], pc[4 * W + l], pc[5 * W + l]},
                              vfit_vec3{rs[0][l], rs[1][l], rs[2][l]});
          lanes.a[0][l] = zi.x;
          lanes.a[1][l] = zi.y;
          lanes.a[2][l] = zi.z;
        }
        filter_slice(s, normals, first, count, lanes);
        store_rows16(z + 3 * first, lanes.a);
        for (std::size_t l = 0; l < W; ++l) {
          const vfit_vec3 ri{rs[0][l], rs[1][l], rs[2][l]}, zi{lanes.a[0][l], lanes.a[1][l], lanes.a[2][l]};
          lanes.first[l] = dot3(ri, ri);
          lanes.second[l] = dot3(ri, zi);
        }
        for (std::size_t l = 0; l < W; ++l) {
          rr_lanes[l] += lanes.first[l];
          rz_lanes[l] += lanes.second[l];
        }
        continue;
      }
    }
#endif
    for (std::size_t l = 0; l < count; ++l) {
      const vfit_vec3 zi = vfit_sym3_apply(load_sliced_sym(precond, first + l), load3(r, first + l));
      lanes.a[0][l] = zi.x;
      lanes.a[1][l] = zi.y;
      lanes.a[2][l] = zi.z;
    }
    filter_slice(s, normals, first, count, lanes);
    for (std::size_t l = 0; l < count; ++l) {
      const vfit_vec3 ri = load3(r, first + l), zi{lanes.a[0][l], lanes.a[1][l], lanes.a[2][l]};
      store3(z, first + l, zi);
      lanes.first[l] = dot3(ri, ri);
      lanes.second[l] = dot3(ri, zi);
    }
    for (std::size_t l = 0; l < count; ++l) {
      rr_lanes[l] += lanes.first[l];
      rz_lanes[l] += lanes.second[l];
    }
  }
  rr = lane_sum(rr_lanes);
  rz = lane_sum(rz_lanes);
}

VFIT_CLOTH_MULTIVERSION void update_range_lanes(const ImplicitSystem& s, const float* normals, float alpha,
                                                const float* p, const float* q, float* dv, float* r, float* z,
                                                std::size_t begin, std::size_t end, double& rr, double& rz) {
  update_slices<false>(s, normals, alpha, p, q, dv, r, z, begin, end, rr, rz);
}

#if VFIT_CLOTH_AVX512
VFIT_CLOTH_AVX512_TARGET void update_range_rows(const ImplicitSystem& s, const float* normals, float alpha,
                                                const float* p, const float* q, float* dv, float* r, float* z,
                                                std::size_t begin, std::size_t end, double& rr, double& rz) {
  update_slices<true>(s, normals, alpha, p, q, dv, r, z, begin, end, rr, rz);
}
#endif

// update_slices() in the variant this CPU runs fastest (as direction_range).
void update_range(const ImplicitSystem& s, const float* normals, float alpha, const float* p, const float* q, float* dv,
                  float* r, float* z, std::size_t begin, std::size_t end, double& rr, double& rz) {
#if VFIT_CLOTH_AVX512
  if (avx512_available()) {
    update_range_rows(s, normals, alpha, p, q, dv, r, z, begin, end, rr, rz);
    return;
  }
#endif
  update_range_lanes(s, normals, alpha, p, q, dv, r, z, begin, end, rr, rz);
}

bool contact_row(const ImplicitContactSprings& c, std::size_t i) {
  const vfit_vec3 n = load3(c.normals.data(), i);
  return vfit_v3_dot(n, n) > 0.0f;
}

// Adds (sign = 1) or removes (sign = −1) particle i's contact spring: h²·k·n·nᵀ on its diagonal
// block and its own block D_i (and its preconditioner block) and (−h·k·g₀ − h²·k·n·v₀)·n on its right-hand side.
void add_contact_spring(ImplicitSystem& s, const ImplicitContactSprings& c, const float* v, float h, std::size_t i,
                        float sign) {
  const vfit_vec3 n = load3(c.normals.data(), i);
  const float k = c.stiffness[i];
  const float a = sign * h * h * k;
  vfit_sym3 d = load_sym(s.diagonal.data(), i);
  d.xx += a * n.x * n.x;
  d.xy += a * n.x * n.y;
  d.xz += a * n.x * n.z;
  d.yy += a * n.y * n.y;
  d.yz += a * n.y * n.z;
  d.zz += a * n.z * n.z;
  store_sym(s.diagonal.data(), i, d);
  store_sliced_sym(s.preconditioner.data(), i, preconditioner_block(d, s.inertia[i]));
  // D_i: the inertia plus the spring, or (removed) the inertia again exactly, as the rounding
  // of a subtraction would leave ≈ 2⁻²⁴·h²·k (κ·m_i: 20 times the mass term's own rounding).
  const float in = s.inertia[i];
  vfit_sym3 own{in, 0.0f, 0.0f, in, 0.0f, in};
  if (sign > 0.0f) {
    own.xx += a * n.x * n.x;
    own.xy = a * n.x * n.y;
    own.xz = a * n.x * n.z;
    own.yy += a * n.y * n.y;
    own.yz = a * n.y * n.z;
    own.zz += a * n.z * n.z;
  }
  store_sym(s.particle_blocks.data(), i, own);
  const float along = sign * (-h * k * c.gaps[i]) - a * vfit_v3_dot(n, load3(v, i));
  const vfit_vec3 b = load3(s.rhs.data(), i);
  store3(s.rhs.data(), i, vfit_vec3{b.x + along * n.x, b.y + along * n.y, b.z + along * n.z});
}

// λ = −h·k·(g₀ + h·n·v₁) (N·s), v₁ = v₀ + Δv: the contact spring's impulse over the step.
float contact_impulse(const ImplicitContactSprings& c, const float* v, const float* dv, float h, std::size_t i) {
  const vfit_vec3 n = load3(c.normals.data(), i), v0 = load3(v, i), d = load3(dv, i);
  const vfit_vec3 v1{v0.x + d.x, v0.y + d.y, v0.z + d.z};
  return -h * c.stiffness[i] * (c.gaps[i] + h * vfit_v3_dot(n, v1));
}

ImplicitSolveReport solve_system(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                 ImplicitWorkspace& w, const ImplicitPasses& passes,
                                 const ImplicitConstraints* constraints, bool reuse_coarse);

ImplicitSolveReport implicit_step(std::span<float> positions, std::span<float> velocities,
                                  const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                                  const ImplicitSolveOptions& options, ImplicitWorkspace& w,
                                  const ImplicitPasses& passes, const ImplicitConstraints* constraints,
                                  const ImplicitContactSprings* contact_springs) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && velocities.size() == 3 * nv && "state and adjacency sizes differ");
  // The CSR blocks only for the coarse level (AUTO may engage it in this solve).
  cloth_detail::assemble_implicit_system(positions, velocities, adjacency, particles, h, w.system, passes,
                                         options.preconditioner != ImplicitPreconditioner::BLOCK_JACOBI);
  const bool springs = contact_springs != nullptr && !contact_springs->empty();
  if (springs) {
    assert(contact_springs->normals.size() == 3 * nv && contact_springs->gaps.size() == nv &&
           contact_springs->stiffness.size() == nv && "one contact spring row per particle");
    w.contact_active.assign(nv, 0);
    passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        if (w.system.free[i] && contact_springs->stiffness[i] > 0.0f && contact_row(*contact_springs, i)) {
          w.contact_active[i] = 1;
          add_contact_spring(w.system, *contact_springs, velocities.data(), h, i, 1.0f);
        }
    });
  }
  ImplicitSolveReport report = solve_system(adjacency, options, w, passes, constraints, false);
  if (springs) {
    // One-sided: remove the springs that pulled and solve again from this answer.
    const std::size_t chunks = chunk_count(nv);
    w.partials.assign(chunks, 0.0);
    w.normal_impulses.assign(nv, 0.0f);
    passes.run(nv, [&](std::size_t c, std::size_t b, std::size_t e) {
      double removed = 0;
      for (std::size_t i = b; i < e; ++i) {
        if (!w.contact_active[i]) continue;
        const float impulse = contact_impulse(*contact_springs, velocities.data(), w.dv.data(), h, i);
        if (impulse < 0.0f) {
          w.contact_active[i] = 0;
          add_contact_spring(w.system, *contact_springs, velocities.data(), h, i, -1.0f);
          removed += 1;
        } else {
          w.normal_impulses[i] = impulse; // final unless the springs left are solved again
        }
      }
      w.partials[c] = removed;
    });
    if (chunk_sum(w.partials, chunks, 1, 0) > 0 && contact_springs->release_iterations > 0) {
      ImplicitSolveOptions again = options;
      again.warm_start = true;
      again.max_iterations = contact_springs->release_iterations;
      // The coarse level factored for the first solve still serves (a preconditioner need not
      // match A, only be SPD): the removed springs changed a few diagonal blocks.
      report.iterations += solve_system(adjacency, again, w, passes, constraints, true).iterations;
      // Δv changed: the kept springs' impulses are taken again.
      passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i)
          if (w.contact_active[i])
            w.normal_impulses[i] = contact_impulse(*contact_springs, velocities.data(), w.dv.data(), h, i);
      });
    }
  }
  float* x = positions.data();
  float* v = velocities.data();
  const float* dv = w.dv.data();
  const unsigned char* is_free = w.system.free.data();
  passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      if (!is_free[i]) continue;
      for (std::size_t k = 3 * i; k < 3 * i + 3; ++k) {
        v[k] += dv[k];
        x[k] += h * v[k];
      }
    }
  });
  return report;
}
} // namespace

void implicit_system_multiply(const ImplicitSystem& system, const SpringAdjacency& adjacency, std::span<const float> p,
                              std::vector<float>& out) {
  const std::size_t nv = adjacency.particle_count();
  assert(p.size() == 3 * nv && "one 3-vector per particle");
  // The filter: pinned entries of p read as zero.
  std::vector<float> filtered(p.begin(), p.end());
  for (std::size_t i = 0; i < nv; ++i)
    if (!system.free[i]) store3(filtered.data(), i, vfit_vec3{0.0f, 0.0f, 0.0f});
  out.assign(3 * nv, 0.0f);
  for (std::size_t i = 0; i < nv; ++i)
    if (system.free[i]) store3(out.data(), i, row_times(system, adjacency, filtered.data(), i));
}

namespace {
// The coarse level for a solve of w.system with `options`: null for block Jacobi (or when the
// coarse factorisation failed, which falls back to it); factored anew unless `reuse` and the
// last factorisation still stands.
ImplicitCoarseSpace* coarse_level(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                  ImplicitWorkspace& w, const float* normals, bool parallel, bool reuse) {
  const std::size_t nv = adjacency.particle_count();
  if (options.preconditioner == ImplicitPreconditioner::BLOCK_JACOBI) return nullptr; // no coarse level made
  ImplicitCoarseSpace& c = w.coarse.get();
  if (!use_two_level(options, nv, c)) return nullptr;
  prepare_coarse_space(c, adjacency, options);
  if (reuse && c.factored) return &c;
  return factor_coarse_space(c, w.system, adjacency, normals, parallel) ? &c : nullptr;
}

// ImplicitSolveOptions::translation_start: w.dv = P·c on the free rows, c = (Pᵀ·A·P)⁻¹·Pᵀ·b
// (P: a common translation of the free particles). Row i of A·P·c is D_i·c plus S_e·c for each
// spring to a pinned neighbour (the springs between free particles see no relative motion), so
// Pᵀ·A·P = Σ_free (D_i + Σ_{e: j pinned} S_e). Sums per chunk in double, added in chunk order
// (the same bits for any thread count). False, and w.dv left zero, when no row is free or
// Pᵀ·A·P is not safely positive definite. Writes c and whether any free particle has a pinned
// neighbour (translated_row() then has springs to add).
bool translation_start(const ImplicitSystem& s, const SpringAdjacency& adj, ImplicitWorkspace& w,
                       const ImplicitPasses& passes, vfit_vec3& c_out, bool& pinned_neighbours) {
  const std::size_t nv = adj.particle_count();
  const std::size_t chunks = chunk_count(nv);
  constexpr std::size_t K = 10; // Pᵀ·b (3), Pᵀ·A·P (xx, xy, xz, yy, yz, zz), springs to pinned rows
  std::vector<double> part(K * chunks, 0.0);
  const std::size_t slots = adj.slice_neighbor_offsets.size();
  passes.run(nv, [&](std::size_t c, std::size_t b, std::size_t e) {
    double* q = part.data() + K * c;
    for (std::size_t i = b; i < e; ++i) {
      if (!s.free[i]) continue;
      const vfit_vec3 bi = load3(s.rhs.data(), i);
      q[0] += bi.x;
      q[1] += bi.y;
      q[2] += bi.z;
      vfit_sym3 m = load_sym(s.particle_blocks.data(), i);
      std::size_t slot = static_cast<std::size_t>(adj.slice_offsets[i / CLOTH_SLICE_WIDTH]) + i % CLOTH_SLICE_WIDTH;
      for (std::int32_t k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k, slot += CLOTH_SLICE_WIDTH) {
        if (s.free[static_cast<std::size_t>(adj.neighbors[k])]) continue;
        q[9] += 1;
        const float* sp = s.sliced_springs.data();
        const vfit_vec3 u{sp[slot], sp[slots + slot], sp[2 * slots + slot]};
        const float a = sp[3 * slots + slot], t = sp[4 * slots + slot];
        m.xx += a * u.x * u.x + t;
        m.xy += a * u.x * u.y;
        m.xz += a * u.x * u.z;
        m.yy += a * u.y * u.y + t;
        m.yz += a * u.y * u.z;
        m.zz += a * u.z * u.z + t;
      }
      q[3] += m.xx;
      q[4] += m.xy;
      q[5] += m.xz;
      q[6] += m.yy;
      q[7] += m.yz;
      q[8] += m.zz;
    }
  });
  double t[K] = {};
  for (std::size_t c = 0; c < chunks; ++c)
    for (std::size_t k = 0; k < K; ++k)
      t[k] += part[K * c + k];
  // c = M⁻¹·(Pᵀ·b) by the adjugate of the symmetric M (double).
  const double xx = t[3], xy = t[4], xz = t[5], yy = t[6], yz = t[7], zz = t[8];
  const double cxx = yy * zz - yz * yz, cxy = xz * yz - xy * zz, cxz = xy * yz - xz * yy;
  const double det = xx * cxx + xy * cxy + xz * cxz;
  if (!(xx > 0) || !(det > 1e-12 * xx * xx * xx)) return false; // nothing free, or not safely definite
  const double cyy = xx * zz - xz * xz, cyz = xy * xz - xx * yz, czz = xx * yy - xy * xy;
  const double c[3] = {(cxx * t[0] + cxy * t[1] + cxz * t[2]) / det, (cxy * t[0] + cyy * t[1] + cyz * t[2]) / det,
                       (cxz * t[0] + cyz * t[1] + czz * t[2]) / det};
  if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || !std::isfinite(c[2])) return false;
  const vfit_vec3 cf{static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2])};
  passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      if (s.free[i]) store3(w.dv.data(), i, cf);
  });
  c_out = cf;
  pinned_neighbours = t[9] > 0;
  return true;
}

ImplicitSolveReport solve_system(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                 ImplicitWorkspace& w, const ImplicitPasses& passes,
                                 const ImplicitConstraints* constraints, bool reuse_coarse) {
  const std::size_t nv = adjacency.particle_count();
  const std::size_t chunks = chunk_count(nv);
  const ImplicitSystem& s = w.system;
  const bool constrained = constraints != nullptr && !constraints->empty();
  assert((!constrained || (constraints->normals.size() == 3 * nv && constraints->targets.size() == nv)) &&
         "one constraint row per particle");
  const float* normals = constrained ? constraints->normals.data() : nullptr;
  const bool warm = options.warm_start && w.dv.size() == 3 * nv && !constrained;
  // r and z are written whole by the initial pass below; p, q and (unless warm) Δv start at
  // zero, cleared chunk by chunk by the passes' own threads.
  for (auto* buf : {&w.dv, &w.r, &w.z, &w.p, &w.q})
    buf->resize(3 * nv);
  passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
    for (auto* buf : {&w.dv, &w.p, &w.q})
      if (!warm || buf != &w.dv)
        std::fill(buf->begin() + std::ptrdiff_t(3 * b), buf->begin() + std::ptrdiff_t(3 * e), 0.0f);
  });
  vfit_vec3 translation{0.0f, 0.0f, 0.0f};
  bool pinned_neighbours = false;
  bool translated = options.translation_start && !warm && !constrained &&
                    translation_start(s, adjacency, w, passes, translation, pinned_neighbours);
  // Row i of A·Δv₀ for the translation start Δv₀ = c on the free rows: row_times()'s sum with
  // the springs between free particles left out, as their p_i − p_j = c − c is exactly zero
  // and adds ±0 (the same values, a zero's sign aside), so only D_i·c and the springs to pinned
  // neighbours remain, in adjacency order; without pinned neighbours, D_i·c alone.
  const auto translated_row = [&](std::size_t i) {
    vfit_vec3 row = vfit_sym3_apply(load_sym(s.particle_blocks.data(), i), translation);
    if (!pinned_neighbours) return row;
    const std::size_t slots = adjacency.slice_neighbor_offsets.size();
    std::size_t slot = static_cast<std::size_t>(adjacency.slice_offsets[i / CLOTH_SLICE_WIDTH]) + i % CLOTH_SLICE_WIDTH;
    for (std::int32_t e = adjacency.offsets[i]; e < adjacency.offsets[i + 1]; ++e, slot += CLOTH_SLICE_WIDTH) {
      if (s.free[static_cast<std::size_t>(adjacency.neighbors[e])]) continue;
      const vfit_vec3 t = spring_times(s.sliced_springs.data(), slots, slot, translation);
      row.x += t.x;
      row.y += t.y;
      row.z += t.z;
    }
    return row;
  };
  w.partials.assign(2 * chunks, 0.0);
  w.patches.assign(2 * chunks, 0.0);
  float* dv = w.dv.data();
  float* r = w.r.data();
  float* z = w.z.data();
  float* p = w.p.data();
  float* q = w.q.data();
  double* part = w.partials.data();
  const float* precond = s.preconditioner.data();
  // B&W's filter S_i: 0 for a pinned particle, I − n·nᵀ for a contact, I otherwise.
  const auto filter = [&](std::size_t i, vfit_vec3 a) { return filter_row(s, normals, i, a); };
  // TWO_LEVEL: z = S·D⁻¹·r + P·Ac⁻¹·Pᵀ·r, the coarse term added after each pass forming r.
  ImplicitCoarseSpace* coarse = coarse_level(adjacency, options, w, normals, passes.tbb(), reuse_coarse);

  // Δv₀ = the constrained components, or the previous answer with a warm start (zero otherwise),
  // so r₀ = S·(b − A·Δv₀).
  if (constrained) {
    passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 n = load3(normals, i);
        const float t = s.free[i] ? constraints->targets[i] : 0.0f;
        store3(dv, i, vfit_vec3{t * n.x, t * n.y, t * n.z});
      }
    });
  }
  // A warm start without constraints: q = S·A·Δv₀ by the CG's own product pass (p, zero, as
  // scratch: p = Δv₀ + 0·p), the values of row_times() (a zero's sign aside) at the cost of one
  // vectorised pass instead of a scalar one per row; the initial pass reads it and clears p and
  // q again. (With constraints the filter does not commute with the subtraction, so those rows
  // keep row_times().)
  const bool product_start = warm && !constrained;
  if (product_start)
    passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
      direction_range(s, adjacency, normals, dv, 0.0f, p, q, b, e);
    });
  // r = S·(b − A·Δv₀), z = S·P⁻¹·r; partials: |S·b|², r·z; patches: each chunk's free
  // particles (turned into its bound below) and |r|².
  double* patch = w.patches.data();
  const auto initial_pass = [&] {
    passes.run(nv, [&](std::size_t c, std::size_t b, std::size_t e) {
      double bb = 0, rz = 0, rr_c = 0, free_c = 0;
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 bi = filter(i, load3(s.rhs.data(), i));
        vfit_vec3 ri = bi;
        if (translated && s.free[i]) {
          ri = filter(i, vfit_v3_sub(load3(s.rhs.data(), i), translated_row(i)));
        } else if (product_start) {
          if (s.free[i]) ri = vfit_v3_sub(bi, load3(q, i)); // the filter is the identity on free rows
          store3(p, i, vfit_vec3{0.0f, 0.0f, 0.0f});
          store3(q, i, vfit_vec3{0.0f, 0.0f, 0.0f});
        } else if (constrained && s.free[i])
          ri = filter(i, vfit_v3_sub(load3(s.rhs.data(), i), row_times(s, adjacency, dv, i)));
        const vfit_vec3 zi = filter(i, vfit_sym3_apply(load_sliced_sym(precond, i), ri));
        store3(r, i, ri);
        store3(z, i, zi);
        bb += dot3(bi, bi);
        rz += dot3(ri, zi);
        rr_c += dot3(ri, ri);
        free_c += s.free[i] ? 1.0 : 0.0;
      }
      part[2 * c] = bb;
      part[2 * c + 1] = rz;
      patch[2 * c] = free_c;
      patch[2 * c + 1] = rr_c;
    });
  };
  initial_pass();
  double rr = 0;
  for (std::size_t k = 0; k < 3 * nv; ++k)
    rr += double(r[k]) * r[k];
  if (translated) {
    // Kept only where it answers most of the step (see ImplicitSolveOptions::translation_keep).
    const double keep = options.translation_keep;
    if (rr > keep * keep * chunk_sum(w.partials, chunks, 2, 0)) {
      translated = false;
      w.dv.assign(3 * nv, 0.0f);
      initial_pass();
      rr = 0;
      for (std::size_t k = 0; k < 3 * nv; ++k)
        rr += double(r[k]) * r[k];
    }
  }
  const double bb = chunk_sum(w.partials, chunks, 2, 0);
  double rz = chunk_sum(w.partials, chunks, 2, 1);
  if (coarse != nullptr) rz += coarse_correct(*coarse, s, normals, r, z, passes.tbb());
  ImplicitSolveReport report;
  // The scale of the relative test: |S·b| (the impulse the free directions must balance; |b|
  // instead, which includes the weight the contacts carry, lets the 6,000-vertex tee drape
  // diverge at steps of 1/60 s), or |r₀| when only the constraints drive the solve; with a warm
  // start |r₀| alone (see ImplicitSolveOptions::warm_start).
  const double scale = warm ? rr : std::max(bb, rr);
  const double stop = options.tolerance * options.tolerance * scale;
  // Per patch (ImplicitSolveOptions::per_patch): its share n_P / n of the global bound.
  const double free_total = chunk_sum(w.patches, chunks, 2, 0);
  for (std::size_t c = 0; c < chunks; ++c)
    patch[2 * c] = free_total > 0 ? stop * patch[2 * c] / free_total : 0.0;
  // max over patches of ‖r_P‖² / bound_P.
  const auto worst_patch = [&] {
    double worst = 0;
    for (std::size_t c = 0; c < chunks; ++c)
      if (patch[2 * c] > 0) worst = std::max(worst, patch[2 * c + 1] / patch[2 * c]);
    return worst;
  };
  const auto met = [&] { return rr <= stop && (!options.per_patch || worst_patch() <= 1.0); };
  bool done = met();
  // Two passes over the particles per iteration instead of three: the new search direction
  // p = z + β·p and its product q = S·A·p are formed together, q as S·A·z + β·q (the product is
  // linear), so the product gathers z, which is complete before the pass, and p and q are
  // updated in place row by row. p and q start at zero, so β = 0 gives p = z, q = S·A·z.
  float beta = 0.0f;
  tbb::affinity_partitioner affinity;
  while (scale > 0 && report.iterations < options.max_iterations && !done) {
    // p = z + β·p, q = S·A·z + β·q; partial p·q.
    passes.run(
        nv,
        [&](std::size_t c, std::size_t b, std::size_t e) {
          part[2 * c] = direction_range(s, adjacency, normals, z, beta, p, q, b, e);
        },
        &affinity);
    const double pq = chunk_sum(w.partials, chunks, 2, 0);
    if (!(pq > 0)) break; // A is positive definite on the free rows: only a zero p gets here
    const auto alpha = static_cast<float>(rz / pq);
    // Δv += α·p, r −= α·q, z = S·P⁻¹·r; partials r·r, r·z.
    passes.run(
        nv,
        [&](std::size_t c, std::size_t b, std::size_t e) {
          double rr_c, rz_c;
          update_range(s, normals, alpha, p, q, dv, r, z, b, e, rr_c, rz_c);
          part[2 * c] = rr_c;
          part[2 * c + 1] = rz_c;
          patch[2 * c + 1] = rr_c;
        },
        &affinity);
    rr = chunk_sum(w.partials, chunks, 2, 0);
    double rz_next = chunk_sum(w.partials, chunks, 2, 1);
    ++report.iterations;
    done = met();
    if (done) break;
    if (coarse != nullptr) rz_next += coarse_correct(*coarse, s, normals, r, z, passes.tbb());
    beta = static_cast<float>(rz_next / rz);
    rz = rz_next;
  }
  if (constrained) {
    // The impulse each constraint applied: (A·Δv − b)·n.
    w.normal_impulses.assign(nv, 0.0f);
    passes.run(nv, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 n = load3(normals, i);
        if (!s.free[i] || vfit_v3_dot(n, n) == 0.0f) continue;
        w.normal_impulses[i] = vfit_v3_dot(vfit_v3_sub(row_times(s, adjacency, dv, i), load3(s.rhs.data(), i)), n);
      }
    });
  }
  report.relative_residual = scale > 0 ? std::sqrt(rr / scale) : 0.0;
  report.patch_residual = scale > 0 ? options.tolerance * std::sqrt(worst_patch()) : 0.0;
  report.converged = done;
  if (options.preconditioner == ImplicitPreconditioner::AUTO && coarse == nullptr &&
      report.iterations > options.two_level_after)
    w.coarse.get().engaged = true;
  return report;
}
} // namespace

ImplicitSolveReport solve_implicit_system(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                          ImplicitWorkspace& w, bool parallel, const ImplicitConstraints* constraints) {
  return solve_system(adjacency, options, w, ImplicitPasses{parallel, nullptr}, constraints, false);
}

void apply_implicit_preconditioner(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                   ImplicitWorkspace& w, std::span<const float> r, std::vector<float>& z,
                                   const ImplicitConstraints* constraints) {
  const std::size_t nv = adjacency.particle_count();
  assert(r.size() == 3 * nv && "one 3-vector per particle");
  const ImplicitSystem& s = w.system;
  const bool constrained = constraints != nullptr && !constraints->empty();
  const float* normals = constrained ? constraints->normals.data() : nullptr;
  std::vector<float> rf(3 * nv);
  z.assign(3 * nv, 0.0f);
  for (std::size_t i = 0; i < nv; ++i) {
    const vfit_vec3 ri = filter_row(s, normals, i, load3(r.data(), i));
    store3(rf.data(), i, ri);
    store3(z.data(), i, filter_row(s, normals, i, vfit_sym3_apply(load_sliced_sym(s.preconditioner.data(), i), ri)));
  }
  ImplicitCoarseSpace* coarse = coarse_level(adjacency, options, w, normals, false, false);
  if (coarse == nullptr) return;
  coarse_correct(*coarse, s, normals, rf.data(), z.data(), false);
}

ImplicitSolveReport implicit_euler_step_serial(std::span<float> positions, std::span<float> velocities,
                                               const SpringAdjacency& adjacency, const ClothParticles& particles,
                                               float h, const ImplicitSolveOptions& options,
                                               ImplicitWorkspace& workspace, const ImplicitConstraints* constraints,
                                               const ImplicitContactSprings* contact_springs) {
  return implicit_step(positions, velocities, adjacency, particles, h, options, workspace, ImplicitPasses{},
                       constraints, contact_springs);
}

ImplicitSolveReport implicit_euler_step_tbb(std::span<float> positions, std::span<float> velocities,
                                            const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                                            const ImplicitSolveOptions& options, ImplicitWorkspace& workspace,
                                            const ImplicitConstraints* constraints,
                                            const ImplicitContactSprings* contact_springs) {
  // The step's passes by a team held for the step (chunk_team.h) where more than one thread
  // may run: the CG's two passes per iteration then need no TBB fork and join each.
  const std::size_t lanes = ImplicitTeam::lanes_for(chunk_count(adjacency.particle_count()));
  if (lanes < 2)
    return implicit_step(positions, velocities, adjacency, particles, h, options, workspace,
                         ImplicitPasses{true, nullptr}, constraints, contact_springs);
  ImplicitSolveReport report;
  ImplicitTeam::lead(lanes, [&](ImplicitTeam& team) {
    report = implicit_step(positions, velocities, adjacency, particles, h, options, workspace,
                           ImplicitPasses{true, &team}, constraints, contact_springs);
  });
  return report;
}

} // namespace vfit
