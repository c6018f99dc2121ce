// SPDX-License-Identifier: Apache-2.0
// Area-weighted vertex normals on an OpenCL device (see vertex_normals.h). The per-triangle
// math is shared with the C++ reference through vertex_normals_math.h.
#pragma OPENCL FP_CONTRACT OFF
#include "vertex_normals_math.h"

static vfit_vec3 vfit_load3(__global const float* p, int v) {
  vfit_vec3 r;
  r.x = p[3 * v];
  r.y = p[3 * v + 1];
  r.z = p[3 * v + 2];
  return r;
}

// One work-item per triangle: face_normals[f] = (b - a) x (c - a).
__kernel void triangle_area_normals(__global const float* positions, __global const int* triangles,
                                    __global float* face_normals, int face_count) {
  int f = get_global_id(0);
  if (f >= face_count) return;
  vfit_vec3 n = vfit_triangle_area_normal(vfit_load3(positions, triangles[3 * f]),
                                          vfit_load3(positions, triangles[3 * f + 1]),
                                          vfit_load3(positions, triangles[3 * f + 2]));
  face_normals[3 * f] = n.x;
  face_normals[3 * f + 1] = n.y;
  face_normals[3 * f + 2] = n.z;
}

// One work-item per vertex: gather its triangles' area normals over the CSR adjacency, in
// ascending triangle order, then normalise (zero when the sum is zero).
__kernel void gather_vertex_normals(__global const float* face_normals, __global const int* offsets,
                                    __global const int* faces, __global float* normals, int vertex_count) {
  int v = get_global_id(0);
  if (v >= vertex_count) return;
  vfit_vec3 s;
  s.x = 0.0f;
  s.y = 0.0f;
  s.z = 0.0f;
  for (int k = offsets[v]; k < offsets[v + 1]; ++k) {
    int f = faces[k];
    s.x += face_normals[3 * f];
    s.y += face_normals[3 * f + 1];
    s.z += face_normals[3 * f + 2];
  }
  vfit_vec3 r = vfit_normalised_or_zero(s);
  normals[3 * v] = r.x;
  normals[3 * v + 1] = r.y;
  normals[3 * v + 2] = r.z;
}
