// Mass-spring cloth on an OpenCL device (see cloth_springs.h and cloth_rk4.h). The per-spring
// force and the per-particle RK4 stage update are shared with the C++ reference through
// cloth_math.h; the gather order (the CSR rows, ascending spring index) is the same too.
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

static vfit_vec3 vfit_cloth_gather(__global const float* x, __global const float* v, __global const int* offsets,
                                   __global const int* neighbors, __global const float* rest,
                                   __global const float* stiffness, __global const float* damping, int i) {
  vfit_vec3 xi = vfit_cloth_load3(x, i), vi = vfit_cloth_load3(v, i);
  vfit_vec3 f;
  f.x = 0.0f;
  f.y = 0.0f;
  f.z = 0.0f;
  for (int e = offsets[i]; e < offsets[i + 1]; ++e) {
    int j = neighbors[e];
    vfit_vec3 fs = vfit_spring_force(xi, vfit_cloth_load3(x, j), vi, vfit_cloth_load3(v, j), rest[e], stiffness[e],
                                     damping[e]);
    f.x += fs.x;
    f.y += fs.y;
    f.z += fs.z;
  }
  return f;
}

// One work-item per particle: the spring forces of the state (x, v), gathered.
__kernel void cloth_spring_forces(__global const float* x, __global const float* v, __global const int* offsets,
                                  __global const int* neighbors, __global const float* rest,
                                  __global const float* stiffness, __global const float* damping,
                                  __global float* forces, int count) {
  int i = get_global_id(0);
  if (i >= count) return;
  vfit_cloth_store3(forces, i, vfit_cloth_gather(x, v, offsets, neighbors, rest, stiffness, damping, i));
}

// One work-item per particle: RK4 stage `stage` evaluated at (xs, vs) from the step start
// (x0, v0); writes the running sums and the next stage state (the result at stage 3, which
// may be x0/v0 themselves: each work-item touches only its own row there).
__kernel void cloth_rk4_stage(__global const float* xs, __global const float* vs, __global const float* x0,
                              __global const float* v0, __global float* acc_x, __global float* acc_v,
                              __global float* next_x, __global float* next_v, __global const int* offsets,
                              __global const int* neighbors, __global const float* rest,
                              __global const float* stiffness, __global const float* damping,
                              __global const float* inverse_masses, float gx, float gy, float gz,
                              float global_damping, float h, int stage, int count) {
  int i = get_global_id(0);
  if (i >= count) return;
  vfit_vec3 g;
  g.x = gx;
  g.y = gy;
  g.z = gz;
  float inv_mass = inverse_masses[i];
  vfit_vec3 vsi = vfit_cloth_load3(vs, i);
  vfit_vec3 a = vfit_particle_acceleration(
      vfit_cloth_gather(xs, vs, offsets, neighbors, rest, stiffness, damping, i), vsi, inv_mass, g, global_damping);
  vfit_vec3 slope_x = vsi;
  if (inv_mass == 0.0f) {
    slope_x.x = 0.0f;
    slope_x.y = 0.0f;
    slope_x.z = 0.0f;
  }
  vfit_vec3 ax = vfit_cloth_load3(acc_x, i), av = vfit_cloth_load3(acc_v, i), nx, nv;
  vfit_rk4_stage_update(vfit_cloth_load3(x0, i), vfit_cloth_load3(v0, i), slope_x, a, h, stage, &ax, &av, &nx, &nv);
  vfit_cloth_store3(acc_x, i, ax);
  vfit_cloth_store3(acc_v, i, av);
  vfit_cloth_store3(next_x, i, nx);
  vfit_cloth_store3(next_v, i, nv);
}

// One work-item per particle: row i of the filtered implicit Euler matrix times p
// (cloth_implicit.h's implicit_system_multiply): A_ii·p_i − Σ_e S_e·p_j over the CSR row, with
// pinned entries of p read as zero and pinned rows written as zero. Diagonal blocks are
// vfit_sym3 (6 floats: xx, xy, xz, yy, yz, zz); off-diagonal ones component-major (all xx,
// then all xy, …); the same order of operations as the C++ reference.
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

__kernel void cloth_implicit_multiply(__global const float* diagonal, __global const float* off_diagonal,
                                      __global const int* offsets, __global const int* neighbors,
                                      __global const uchar* free_rows, __global const float* p, __global float* out,
                                      int count) {
  int i = get_global_id(0);
  if (i >= count) return;
  vfit_vec3 r;
  r.x = 0.0f;
  r.y = 0.0f;
  r.z = 0.0f;
  if (free_rows[i]) {
    int entries = offsets[count]; /* off_diagonal is component-major over all entries */
    r = vfit_sym3_apply(vfit_cloth_load_sym(diagonal, i), vfit_cloth_load3(p, i));
    for (int e = offsets[i]; e < offsets[i + 1]; ++e) {
      int j = neighbors[e];
      if (!free_rows[j]) continue; // the filter: a pinned p_j reads as zero
      vfit_sym3 s;
      s.xx = off_diagonal[e];
      s.xy = off_diagonal[entries + e];
      s.xz = off_diagonal[2 * entries + e];
      s.yy = off_diagonal[3 * entries + e];
      s.yz = off_diagonal[4 * entries + e];
      s.zz = off_diagonal[5 * entries + e];
      vfit_vec3 t = vfit_sym3_apply(s, vfit_cloth_load3(p, j));
      r.x -= t.x;
      r.y -= t.y;
      r.z -= t.z;
    }
  }
  vfit_cloth_store3(out, i, r);
}
