// SPDX-License-Identifier: Apache-2.0
/* Closest point on a triangle, written once in the C subset that both C++ and OpenCL C accept:
 * included by proximity.cpp (the Embree callback and the brute-force reference, which must
 * agree to the bit) and by any OpenCL kernel that needs the same answer.
 *
 * The triangle (a, b, c) is split into the seven Voronoi regions of its features (Ericson,
 * Real-Time Collision Detection, §5.1.5): three vertices, three edges, the face. The query is
 * classified with dot products of the edge vectors only, so no square root or division is
 * spent until the region is known. Feature codes (VFIT_FEATURE_*) name what the closest point
 * lies on, which selects the pseudo-normal that decides the side (Bærentzen & Aanæs 2005). */
#ifndef VFIT_CLOSEST_POINT_MATH_H
#define VFIT_CLOSEST_POINT_MATH_H

#include "vertex_normals_math.h" /* vfit_vec3, VFIT_INLINE, vfit_triangle_area_normal */

/* Feature codes. Edge k joins corner k to corner (k + 1) mod 3; vertex k is corner k. */
#define VFIT_FEATURE_NONE (-1)
#define VFIT_FEATURE_FACE 0
#define VFIT_FEATURE_EDGE_0 1
#define VFIT_FEATURE_EDGE_1 2
#define VFIT_FEATURE_EDGE_2 3
#define VFIT_FEATURE_VERTEX_0 4
#define VFIT_FEATURE_VERTEX_1 5
#define VFIT_FEATURE_VERTEX_2 6

/* A triangle is treated as degenerate (a segment or a point) when sin of its corner angle at a
 * is below 1e-5: |ab × ac|² ≤ 1e-10 |ab|² |ac|². Float rounding of the cross product alone
 * reaches ~1e-7 relative, so a smaller threshold would let rounding noise pass as an area. */
#define VFIT_DEGENERATE_SIN2 1e-10f

typedef struct {
  vfit_vec3 point; /* the closest point (m) */
  float u, v;      /* barycentrics: point = (1 − u − v)·a + u·b + v·c */
  float distance2; /* squared distance from the query to point (m²) */
  int feature;     /* VFIT_FEATURE_* */
} vfit_closest_point;

VFIT_INLINE vfit_vec3 vfit_v3_sub(vfit_vec3 p, vfit_vec3 q) {
  vfit_vec3 r;
  r.x = p.x - q.x;
  r.y = p.y - q.y;
  r.z = p.z - q.z;
  return r;
}

VFIT_INLINE float vfit_v3_dot(vfit_vec3 p, vfit_vec3 q) { return p.x * q.x + p.y * q.y + p.z * q.z; }

/* p + t·d */
VFIT_INLINE vfit_vec3 vfit_v3_along(vfit_vec3 p, vfit_vec3 d, float t) {
  vfit_vec3 r;
  r.x = p.x + t * d.x;
  r.y = p.y + t * d.y;
  r.z = p.z + t * d.z;
  return r;
}

/* (1 − u − v)·a + u·b + v·c */
VFIT_INLINE vfit_vec3 vfit_barycentric_point(vfit_vec3 a, vfit_vec3 b, vfit_vec3 c, float u, float v) {
  float w = 1.0f - u - v;
  vfit_vec3 r;
  r.x = w * a.x + u * b.x + v * c.x;
  r.y = w * a.y + u * b.y + v * c.y;
  r.z = w * a.z + u * b.z + v * c.z;
  return r;
}

/* num / den, or 0 when den is not positive (a zero-length edge reached by rounding). */
VFIT_INLINE float vfit_safe_ratio(float num, float den) { return den > 0.0f ? num / den : 0.0f; }

VFIT_INLINE vfit_closest_point vfit_make_closest(vfit_vec3 q, vfit_vec3 point, float u, float v, int feature) {
  vfit_closest_point r;
  vfit_vec3 d = vfit_v3_sub(q, point);
  r.point = point;
  r.u = u;
  r.v = v;
  r.distance2 = vfit_v3_dot(d, d);
  r.feature = feature;
  return r;
}

/* Closest point to q on the segment of edge k (from p0 to p1), with the triangle barycentrics
 * of that edge; t ∈ [0, 1] along the edge, clamped, so the ends report the vertex features. */
VFIT_INLINE vfit_closest_point vfit_closest_on_edge(vfit_vec3 q, vfit_vec3 p0, vfit_vec3 p1, int k) {
  vfit_vec3 d = vfit_v3_sub(p1, p0);
  float t = vfit_safe_ratio(vfit_v3_dot(vfit_v3_sub(q, p0), d), vfit_v3_dot(d, d));
  int feature = VFIT_FEATURE_EDGE_0 + k;
  if (t <= 0.0f) {
    t = 0.0f;
    feature = VFIT_FEATURE_VERTEX_0 + k;
  } else if (t >= 1.0f) {
    t = 1.0f;
    feature = VFIT_FEATURE_VERTEX_0 + (k + 1) % 3;
  }
  vfit_vec3 point = t == 1.0f ? p1 : vfit_v3_along(p0, d, t);
  float u = 0.0f, v = 0.0f;
  if (k == 0) u = t; /* a → b */
  if (k == 1) {      /* b → c */
    u = 1.0f - t;
    v = t;
  }
  if (k == 2) v = 1.0f - t; /* c → a */
  return vfit_make_closest(q, point, u, v, feature);
}

/* Degenerate triangle: the nearest of its three edges (ties keep the lower edge). */
VFIT_INLINE vfit_closest_point vfit_closest_on_degenerate(vfit_vec3 q, vfit_vec3 a, vfit_vec3 b, vfit_vec3 c) {
  vfit_closest_point best = vfit_closest_on_edge(q, a, b, 0);
  vfit_closest_point e1 = vfit_closest_on_edge(q, b, c, 1);
  vfit_closest_point e2 = vfit_closest_on_edge(q, c, a, 2);
  if (e1.distance2 < best.distance2) best = e1;
  if (e2.distance2 < best.distance2) best = e2;
  return best;
}

/* The point of triangle (a, b, c) closest to q, its barycentrics, squared distance and feature.
 * Total for any input: a degenerate triangle (collinear or coincident corners) is handled as
 * its three segments, so the result is always a point of the (possibly flat) triangle. */
VFIT_INLINE vfit_closest_point vfit_closest_point_on_triangle(vfit_vec3 q, vfit_vec3 a, vfit_vec3 b, vfit_vec3 c) {
  vfit_vec3 ab = vfit_v3_sub(b, a), ac = vfit_v3_sub(c, a);
  vfit_vec3 n = vfit_triangle_area_normal(a, b, c);
  if (vfit_v3_dot(n, n) <= VFIT_DEGENERATE_SIN2 * vfit_v3_dot(ab, ab) * vfit_v3_dot(ac, ac))
    return vfit_closest_on_degenerate(q, a, b, c);

  vfit_vec3 aq = vfit_v3_sub(q, a);
  float d1 = vfit_v3_dot(ab, aq), d2 = vfit_v3_dot(ac, aq);
  if (d1 <= 0.0f && d2 <= 0.0f) return vfit_make_closest(q, a, 0.0f, 0.0f, VFIT_FEATURE_VERTEX_0);

  vfit_vec3 bq = vfit_v3_sub(q, b);
  float d3 = vfit_v3_dot(ab, bq), d4 = vfit_v3_dot(ac, bq);
  if (d3 >= 0.0f && d4 <= d3) return vfit_make_closest(q, b, 1.0f, 0.0f, VFIT_FEATURE_VERTEX_1);

  /* vc, vb, va: the barycentric areas (scaled by |n|²) opposite c, b, a of q's projection. */
  float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) {
    float t = vfit_safe_ratio(d1, d1 - d3);
    return vfit_make_closest(q, vfit_v3_along(a, ab, t), t, 0.0f, VFIT_FEATURE_EDGE_0);
  }

  vfit_vec3 cq = vfit_v3_sub(q, c);
  float d5 = vfit_v3_dot(ab, cq), d6 = vfit_v3_dot(ac, cq);
  if (d6 >= 0.0f && d5 <= d6) return vfit_make_closest(q, c, 0.0f, 1.0f, VFIT_FEATURE_VERTEX_2);

  float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) {
    float t = vfit_safe_ratio(d2, d2 - d6);
    return vfit_make_closest(q, vfit_v3_along(a, ac, t), 0.0f, t, VFIT_FEATURE_EDGE_2);
  }

  float va = d3 * d6 - d5 * d4;
  float e4 = d4 - d3, e5 = d5 - d6;
  if (va <= 0.0f && e4 >= 0.0f && e5 >= 0.0f) {
    float t = vfit_safe_ratio(e4, e4 + e5);
    return vfit_make_closest(q, vfit_v3_along(b, vfit_v3_sub(c, b), t), 1.0f - t, t, VFIT_FEATURE_EDGE_1);
  }

  /* va + vb + vc = |n|² > 0 here; the guard catches only rounding on near-degenerate input. */
  float denom = va + vb + vc;
  if (!(denom > 0.0f)) return vfit_closest_on_degenerate(q, a, b, c);
  float u = vb / denom, v = vc / denom;
  return vfit_make_closest(q, vfit_barycentric_point(a, b, c, u, v), u, v, VFIT_FEATURE_FACE);
}

#endif
