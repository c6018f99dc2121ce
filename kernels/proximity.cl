// SPDX-License-Identifier: Apache-2.0
// Closest points on a triangle mesh on an OpenCL device (see opencl_proximity.h): one work-item
// per query walks a binary BVH built by Embree's rtcBuildBVH and flattened in depth-first
// order, with a stack, nearer child first. The point-triangle math and the tie rule are those
// of ProximityIndex (closest_point_math.h); the side comes from the same pseudo-normals.
#pragma OPENCL FP_CONTRACT OFF
#include "closest_point_math.h"

#define VFIT_BVH_STACK 64

static vfit_vec3 vfit_prox_load3(__global const float* p, int i) {
  vfit_vec3 r;
  r.x = p[3 * i];
  r.y = p[3 * i + 1];
  r.z = p[3 * i + 2];
  return r;
}

static vfit_closest_point vfit_prox_closest_on(vfit_vec3 q, __global const float* positions,
                                               __global const int* triangles, int f) {
  return vfit_closest_point_on_triangle(q, vfit_prox_load3(positions, triangles[3 * f]),
                                        vfit_prox_load3(positions, triangles[3 * f + 1]),
                                        vfit_prox_load3(positions, triangles[3 * f + 2]));
}

// Squared distance from q to the box of node n (bounds: lo.xyz, pad, hi.xyz, pad); 0 inside.
static float vfit_box_distance2(__global const float4* bounds, int n, vfit_vec3 q) {
  float4 lo = bounds[2 * n], hi = bounds[2 * n + 1];
  float dx = fmax(fmax(lo.x - q.x, q.x - hi.x), 0.0f);
  float dy = fmax(fmax(lo.y - q.y, q.y - hi.y), 0.0f);
  float dz = fmax(fmax(lo.z - q.z, q.z - hi.z), 0.0f);
  return dx * dx + dy * dy + dz * dz;
}

// Pseudo-normal of `feature` of capped-mesh triangle f (as IndexData::feature_normal).
static vfit_vec3 vfit_feature_normal(__global const int* triangles, __global const int* triangle_edges,
                                     __global const float* face_normals, __global const float* edge_normals,
                                     __global const float* vertex_normals, int f, int feature) {
  if (feature == VFIT_FEATURE_FACE) return vfit_prox_load3(face_normals, f);
  if (feature <= VFIT_FEATURE_EDGE_2)
    return vfit_prox_load3(edge_normals, triangle_edges[3 * f + feature - VFIT_FEATURE_EDGE_0]);
  return vfit_prox_load3(vertex_normals, triangles[3 * f + feature - VFIT_FEATURE_VERTEX_0]);
}

// nodes: #N × 2 ints: (count, link). count > 0: a leaf of primitives[link .. link + count);
// count = 0: an inner node whose children are n + 1 and link. Primitives at or past
// mesh_face_count are hole caps: they decide the side when strictly closer, never the answer.
__kernel void closest_points(__global const float4* bounds, __global const int* nodes,
                             __global const int* primitives, __global const float* positions,
                             __global const int* triangles, __global const int* triangle_edges,
                             __global const float* face_normals, __global const float* edge_normals,
                             __global const float* vertex_normals, int mesh_face_count, int node_count,
                             __global const float* queries, int query_count, float max_distance2,
                             __global float* out_points, __global int* out_triangles,
                             __global float* out_barycentrics, __global float* out_signed_distances,
                             __global char* out_features) {
  int i = get_global_id(0);
  if (i >= query_count) return;
  vfit_vec3 q = vfit_prox_load3(queries, i);
  vfit_closest_point best, best_cap;
  best.distance2 = max_distance2;
  best_cap.distance2 = max_distance2;
  int best_triangle = -1, best_cap_triangle = -1;
  int stack[VFIT_BVH_STACK];
  int top = 0;
  if (node_count > 0 && vfit_box_distance2(bounds, 0, q) <= best.distance2) stack[top++] = 0;
  while (top > 0) {
    int n = stack[--top];
    if (vfit_box_distance2(bounds, n, q) > best.distance2) continue;
    int count = nodes[2 * n], link = nodes[2 * n + 1];
    if (count > 0) {
      for (int k = link; k < link + count; ++k) {
        int f = primitives[k];
        vfit_closest_point c = vfit_prox_closest_on(q, positions, triangles, f);
        if (f >= mesh_face_count) {
          if (c.distance2 < best_cap.distance2 && c.distance2 < best.distance2) {
            best_cap = c;
            best_cap_triangle = f;
          }
        } else if (c.distance2 < best.distance2 ||
                   (c.distance2 == best.distance2 && (best_triangle < 0 || f < best_triangle))) {
          best = c;
          best_triangle = f;
        }
      }
      continue;
    }
    int left = n + 1, right = link;
    float dl = vfit_box_distance2(bounds, left, q), dr = vfit_box_distance2(bounds, right, q);
    // Push the farther child first so the nearer one is visited next.
    int near_child = dl <= dr ? left : right, far_child = dl <= dr ? right : left;
    float near_d = dl <= dr ? dl : dr, far_d = dl <= dr ? dr : dl;
    if (far_d <= best.distance2 && top < VFIT_BVH_STACK) stack[top++] = far_child;
    if (near_d <= best.distance2 && top < VFIT_BVH_STACK) stack[top++] = near_child;
  }
  if (best_triangle < 0) {
    out_points[3 * i] = q.x;
    out_points[3 * i + 1] = q.y;
    out_points[3 * i + 2] = q.z;
    out_triangles[i] = -1;
    out_barycentrics[2 * i] = 0.0f;
    out_barycentrics[2 * i + 1] = 0.0f;
    out_signed_distances[i] = INFINITY;
    out_features[i] = (char)VFIT_FEATURE_NONE;
    return;
  }
  out_points[3 * i] = best.point.x;
  out_points[3 * i + 1] = best.point.y;
  out_points[3 * i + 2] = best.point.z;
  out_triangles[i] = best_triangle;
  out_barycentrics[2 * i] = best.u;
  out_barycentrics[2 * i + 1] = best.v;
  out_features[i] = (char)best.feature;
  // seed 000 eq. 18 with the capped mesh's pseudo-normal; a strictly closer cap decides.
  int cap_decides = best_cap_triangle >= 0 && best_cap.distance2 < best.distance2;
  vfit_closest_point side = cap_decides ? best_cap : best;
  vfit_vec3 n = vfit_feature_normal(triangles, triangle_edges, face_normals, edge_normals, vertex_normals,
                                    cap_decides ? best_cap_triangle : best_triangle, side.feature);
  float s = vfit_v3_dot(vfit_v3_sub(q, side.point), n);
  float distance = sqrt(best.distance2);
  out_signed_distances[i] = s < 0.0f ? -distance : distance;
}
