// SPDX-License-Identifier: Apache-2.0
// Mass-spring cloth on an OpenCL device (see cloth_springs.h and cloth_rk4.h). The per-spring
// force and the per-particle RK4 stage update are shared with the C++ reference through
// cloth_math.h; the gather order (each particle's row in ascending spring index, read from the
// sliced rows the C++ gather reads) is the same too.
#pragma OPENCL FP_CONTRACT OFF
#include "cloth_math.h"

static vfit_vec3 vfit_cloth_load3(__global const float* p, int i) {
  vfit_vec3 r;
  r.x = p[3 * i];
  r.y = p[3 * i + 1];
  r.z = p[3 * i + 2];
  return r;
}

static void vfit_cloth_store3(__global float* p, int i, vfit_vec3 v) {
  p[3 * i] = v.x;
  p[3 * i + 1] = v.y;
  p[3 * i + 2] = v.z;
}

// The spring forces on particle i = W·slice + lane (W = slice_width, the adjacency's
// CLOTH_SLICE_WIDTH) at the state (x, v), gathered over the adjacency's sliced rows
// (SpringAdjacency::slice_offsets): column k of the slice holds entry k of each lane's row, so
// the lane sums its row in the CSR order (null slots past a row's end add ±0: the same bits as
// the CSR gather). A lane past #V (i ≥ count) reads the last particle and its sum is unused.
static vfit_vec3 vfit_cloth_slice_gather(__global const float* x, __global const float* v,
                                         __global const int* slice_offsets, __global const int* neighbor_offsets,
                                         __global const float* rest, __global const float* stiffness,
                                         __global const float* damping, int slice, int lane, int slice_width,
                                         int count) {
  slice = min(slice, (count - 1) / slice_width); /* a work-item past the last slice: unused */
  int i = min(slice * slice_width + lane, count - 1);
  vfit_vec3 xi = vfit_cloth_load3(x, i), vi = vfit_cloth_load3(v, i);
  vfit_vec3 f;
  f.x = 0.0f;
  f.y = 0.0f;
  f.z = 0.0f;
  int end = slice_offsets[slice + 1];
  for (int slot = slice_offsets[slice] + lane; slot < end; slot += slice_width) {
    int j3 = neighbor_offsets[slot]; /* 3·j */
    vfit_vec3 d, dv;
    d.x = x[j3] - xi.x;
    d.y = x[j3 + 1] - xi.y;
    d.z = x[j3 + 2] - xi.z;
    dv.x = v[j3] - vi.x;
    dv.y = v[j3 + 1] - vi.y;
    dv.z = v[j3 + 2] - vi.z;
    vfit_vec3 fs = vfit_spring_force_relative(d, dv, rest[slot], stiffness[slot], damping[slot]);
    f.x += fs.x;
    f.y += fs.y;
    f.z += fs.z;
  }
  return f;
}

// One work-item per particle (global size a multiple of slice_width, ≥ count): the spring
// forces of the state (x, v), gathered.
__kernel void cloth_spring_forces(__global const float* x, __global const float* v, __global const int* slice_offsets,
                                  __global const int* neighbor_offsets, __global const float* rest,
                                  __global const float* stiffness, __global const float* damping,
                                  __global float* forces, int slice_width, int count) {
  int i = get_global_id(0);
  vfit_vec3 f = vfit_cloth_slice_gather(x, v, slice_offsets, neighbor_offsets, rest, stiffness, damping,
                                        i / slice_width, i % slice_width, slice_width, count);
  if (i < count) vfit_cloth_store3(forces, i, f);
}

// RK4 stage `stage` of particle i from its spring force f, evaluated at (xs, vs) from the step
// start (x0, v0); writes the running sums and the next stage state (the result at stage 3,
// which may be x0/v0 themselves: each particle touches only its own row there).
static void vfit_cloth_rk4_update(vfit_vec3 f, __global const float* vs, __global const float* x0,
                                  __global const float* v0, __global float* acc_x, __global float* acc_v,
                                  __global float* next_x, __global float* next_v,
                                  __global const float* inverse_masses, vfit_vec3 g, float global_damping, float h,
                                  int stage, int i) {
  float inv_mass = inverse_masses[i];
  vfit_vec3 vsi = vfit_cloth_load3(vs, i);
  vfit_vec3 a = vfit_particle_acceleration(f, vsi, inv_mass, g, global_damping);
  vfit_vec3 slope_x = vsi;
  if (inv_mass == 0.0f) {
    slope_x.x = 0.0f;
    slope_x.y = 0.0f;
    slope_x.z = 0.0f;
  }
  vfit_vec3 ax, av, nx, nv;
  ax.x = 0.0f;
  ax.y = 0.0f;
  ax.z = 0.0f;
  av = ax;
  if (stage != 0) { /* stage 0 starts the running sums: it does not read them */
    ax = vfit_cloth_load3(acc_x, i);
    av = vfit_cloth_load3(acc_v, i);
  }
  vfit_rk4_stage_update(vfit_cloth_load3(x0, i), vfit_cloth_load3(v0, i), slope_x, a, h, stage, &ax, &av, &nx, &nv);
  if (stage != 3) { /* stage 3 writes the result instead */
    vfit_cloth_store3(acc_x, i, ax);
    vfit_cloth_store3(acc_v, i, av);
  }
  vfit_cloth_store3(next_x, i, nx);
  vfit_cloth_store3(next_v, i, nv);
}

// One work-item per particle: RK4 stage `stage` evaluated at (xs, vs) (a GPU's kernel).
__kernel void cloth_rk4_stage(__global const float* xs, __global const float* vs, __global const float* x0,
                              __global const float* v0, __global float* acc_x, __global float* acc_v,
                              __global float* next_x, __global float* next_v, __global const int* slice_offsets,
                              __global const int* neighbor_offsets, __global const float* rest,
                              __global const float* stiffness, __global const float* damping,
                              __global const float* inverse_masses, float gx, float gy, float gz,
                              float global_damping, float h, int stage, int slice_width, int count) {
  int i = get_global_id(0);
  vfit_vec3 f = vfit_cloth_slice_gather(xs, vs, slice_offsets, neighbor_offsets, rest, stiffness, damping,
                                        i / slice_width, i % slice_width, slice_width, count);
  if (i >= count) return;
  vfit_vec3 g;
  g.x = gx;
  g.y = gy;
  g.z = gz;
  vfit_cloth_rk4_update(f, vs, x0, v0, acc_x, acc_v, next_x, next_v, inverse_masses, g, global_damping, h, stage, i);
}

// ---- A CPU device's RK4 stage: one work-item per slice of 16 particles, in float16 ----
// An OpenCL compiler for CPUs (PoCL) runs a work-group's work-items as a loop around the
// kernel body and vectorises that loop only when nothing inside it loops; the per-particle
// kernel above has its spring loop inside, so each work-item runs scalar (measured: 0.34–0.39×
// the TBB path). This kernel is the C++ gather (cloth_gather.h's slice_spring_forces) in
// OpenCL C: 16 lanes, one particle each, a column of the sliced rows per vector step, the
// spring arithmetic of VFIT_SPRING_FORCE_SCALE on float16, and a consecutive column
// (SpringAdjacency::slice_consecutive_columns) loaded as three vectors and deinterleaved.
// Each lane sums its row in the CSR order, so the same bits as the scalar kernels.

#define VFIT_ONE_IF_FLOAT16(c) select((float16)(0.0f), (float16)(1.0f), (c))

// p[j3.sN + c] for the 16 lanes N: a gather.
static float16 vfit_cloth_gather16(__global const float* p, int16 j3, int c) {
  return (float16)(p[j3.s0 + c], p[j3.s1 + c], p[j3.s2 + c], p[j3.s3 + c], p[j3.s4 + c], p[j3.s5 + c],
                   p[j3.s6 + c], p[j3.s7 + c], p[j3.s8 + c], p[j3.s9 + c], p[j3.sa + c], p[j3.sb + c],
                   p[j3.sc + c], p[j3.sd + c], p[j3.se + c], p[j3.sf + c]);
}

// The 16 rows j3/3 (j3: 3·j, one per lane) of a #V × 3 array, deinterleaved into x, y, z.
static void vfit_cloth_gather_rows16(__global const float* p, int16 j3, float16* cx, float16* cy, float16* cz) {
  *cx = vfit_cloth_gather16(p, j3, 0);
  *cy = vfit_cloth_gather16(p, j3, 1);
  *cz = vfit_cloth_gather16(p, j3, 2);
}

// The x, y and z components of 16 consecutive rows of a #V × 3 array from p: three vector
// loads, deinterleaved.
static void vfit_cloth_load_rows16(__global const float* p, float16* cx, float16* cy, float16* cz) {
  float16 a = vload16(0, p), b = vload16(1, p), c = vload16(2, p);
  float16 ab_x = shuffle2(a, b, (uint16)(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 0, 0, 0, 0, 0));
  float16 ab_y = shuffle2(a, b, (uint16)(1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31, 0, 0, 0, 0, 0));
  float16 ab_z = shuffle2(a, b, (uint16)(2, 5, 8, 11, 14, 17, 20, 23, 26, 29, 0, 0, 0, 0, 0, 0));
  *cx = shuffle2(ab_x, c, (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 17, 20, 23, 26, 29));
  *cy = shuffle2(ab_y, c, (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 18, 21, 24, 27, 30));
  *cz = shuffle2(ab_z, c, (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 16, 19, 22, 25, 28, 31));
}

// Global size ≥ the slice count ⌈count / 16⌉; the adjacency's slice width must be 16.
__kernel void cloth_rk4_stage_slices(__global const float* xs, __global const float* vs, __global const float* x0,
                                     __global const float* v0, __global float* acc_x, __global float* acc_v,
                                     __global float* next_x, __global float* next_v,
                                     __global const int* slice_offsets, __global const int* neighbor_offsets,
                                     __global const float* rest, __global const float* stiffness,
                                     __global const float* damping, __global const float* inverse_masses, float gx,
                                     float gy, float gz, float global_damping, float h, int stage,
                                     __global const uint* consecutive_columns, int count) {
  int slice = get_global_id(0);
  int first = 16 * slice;
  if (first >= count) return;
  float16 xx, xy, xz, vx, vy, vz;
  if (first + 16 <= count) {
    vfit_cloth_load_rows16(xs + 3 * first, &xx, &xy, &xz);
    vfit_cloth_load_rows16(vs + 3 * first, &vx, &vy, &vz);
  } else { /* the last, partial slice: lanes past #V read the last particle */
    int16 own = 3 * min((int16)(first) + (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                        (int16)(count - 1));
    vfit_cloth_gather_rows16(xs, own, &xx, &xy, &xz);
    vfit_cloth_gather_rows16(vs, own, &vx, &vy, &vz);
  }
  float16 fx = (float16)(0.0f), fy = (float16)(0.0f), fz = (float16)(0.0f);
  uint consecutive = consecutive_columns[slice];
  int end = slice_offsets[slice + 1];
  for (int column = slice_offsets[slice]; column < end; column += 16, consecutive >>= 1) {
    int16 j3 = vload16(0, neighbor_offsets + column);
    float16 dx, dy, dz, dvx, dvy, dvz;
    if (consecutive & 1u) {
      vfit_cloth_load_rows16(xs + j3.s0, &dx, &dy, &dz);
      vfit_cloth_load_rows16(vs + j3.s0, &dvx, &dvy, &dvz);
    } else {
      vfit_cloth_gather_rows16(xs, j3, &dx, &dy, &dz);
      vfit_cloth_gather_rows16(vs, j3, &dvx, &dvy, &dvz);
    }
    dx -= xx;
    dy -= xy;
    dz -= xz;
    dvx -= vx;
    dvy -= vy;
    dvz -= vz;
    float16 L = vload16(0, rest + column), k = vload16(0, stiffness + column), c = vload16(0, damping + column);
    float16 t;
    VFIT_SPRING_FORCE_SCALE(float16, VFIT_ONE_IF_FLOAT16, dx, dy, dz, dvx, dvy, dvz, L, k, c, t);
    fx += t * dx;
    fy += t * dy;
    fz += t * dz;
  }
  float lane_f[3][16];
  vstore16(fx, 0, lane_f[0]);
  vstore16(fy, 0, lane_f[1]);
  vstore16(fz, 0, lane_f[2]);
  vfit_vec3 g;
  g.x = gx;
  g.y = gy;
  g.z = gz;
  int lanes = min(16, count - first);
  for (int l = 0; l < lanes; ++l) {
    vfit_vec3 f;
    f.x = lane_f[0][l];
    f.y = lane_f[1][l];
    f.z = lane_f[2][l];
    vfit_cloth_rk4_update(f, vs, x0, v0, acc_x, acc_v, next_x, next_v, inverse_masses, g, global_damping, h, stage,
                          first + l);
  }
}

// One work-item per particle: row i of the filtered implicit Euler matrix times p
// (cloth_implicit.h's implicit_system_multiply): D_i·p_i + Σ_e S_e·(p_i − p_j) over the row,
// with pinned entries of p read as zero and pinned rows written as zero. D_i (particle_blocks)
// is a vfit_sym3 (6 floats: xx, xy, xz, yy, yz, zz); each spring's S_e in rank-one form (u, a,
// t: vfit_spring_rank_one_apply) from the sliced springs, component-major over `slots` (all
// u_x, then u_y, u_z, a, t), entry k of particle i at slice_offsets[i / width] + width·k +
// i mod width (ImplicitSystem::sliced_springs); the same order of operations as the C++
// reference.
static vfit_sym3 vfit_cloth_load_sym(__global const float* s, int i) {
  vfit_sym3 r;
  r.xx = s[6 * i];
  r.xy = s[6 * i + 1];
  r.xz = s[6 * i + 2];
  r.yy = s[6 * i + 3];
  r.yz = s[6 * i + 4];
  r.zz = s[6 * i + 5];
  return r;
}

__kernel void cloth_implicit_multiply(__global const float* particle_blocks, __global const float* springs,
                                      __global const int* slice_offsets, __global const int* offsets,
                                      __global const int* neighbors, __global const uchar* free_rows,
                                      __global const float* p, __global float* out, int count, int slots, int width) {
  int i = get_global_id(0);
  if (i >= count) return;
  vfit_vec3 r;
  r.x = 0.0f;
  r.y = 0.0f;
  r.z = 0.0f;
  if (free_rows[i]) {
    vfit_vec3 pi = vfit_cloth_load3(p, i);
    r = vfit_sym3_apply(vfit_cloth_load_sym(particle_blocks, i), pi);
    int slot = slice_offsets[i / width] + i % width;
    for (int e = offsets[i]; e < offsets[i + 1]; ++e, slot += width) {
      int j = neighbors[e];
      vfit_vec3 d = pi;
      if (free_rows[j]) d = vfit_v3_sub(pi, vfit_cloth_load3(p, j)); // the filter: a pinned p_j reads as zero
      vfit_vec3 u;
      u.x = springs[slot];
      u.y = springs[slots + slot];
      u.z = springs[2 * slots + slot];
      vfit_vec3 t = vfit_spring_rank_one_apply(u, springs[3 * slots + slot], springs[4 * slots + slot], d);
      r.x += t.x;
      r.y += t.y;
      r.z += t.z;
    }
  }
  vfit_cloth_store3(out, i, r);
}
