// SPDX-License-Identifier: Apache-2.0
/* Per-triangle math of the area-weighted vertex normals, written once in the C subset that
 * both C++ and OpenCL C accept: included by vertex_normals.cpp (the serial and TBB
 * reference) and by vertex_normals.cl (the OpenCL kernels), so every backend evaluates the
 * same expression in the same order. */
#ifndef VFIT_VERTEX_NORMALS_MATH_H
#define VFIT_VERTEX_NORMALS_MATH_H

#ifdef __OPENCL_VERSION__
#define VFIT_INLINE inline
#else
#define VFIT_INLINE static inline
#endif

typedef struct {
  float x, y, z;
} vfit_vec3;

/* (b - a) x (c - a): the triangle's normal scaled by twice its area (m^2), oriented by the
 * counter-clockwise order a, b, c. Zero for a degenerate triangle. */
VFIT_INLINE vfit_vec3 vfit_triangle_area_normal(vfit_vec3 a, vfit_vec3 b, vfit_vec3 c) {
  float ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  float vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  vfit_vec3 n;
  n.x = uy * vz - uz * vy;
  n.y = uz * vx - ux * vz;
  n.z = ux * vy - uy * vx;
  return n;
}

/* s / |s|, or the zero vector when |s| is zero (a vertex with no non-degenerate face). */
VFIT_INLINE vfit_vec3 vfit_normalised_or_zero(vfit_vec3 s) {
  float len2 = s.x * s.x + s.y * s.y + s.z * s.z;
  vfit_vec3 r;
  r.x = 0.0f;
  r.y = 0.0f;
  r.z = 0.0f;
  if (len2 > 0.0f) {
    float inv = 1.0f / sqrt(len2);
    r.x = s.x * inv;
    r.y = s.y * inv;
    r.z = s.z * inv;
  }
  return r;
}

#endif
