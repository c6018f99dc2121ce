// SPDX-License-Identifier: Apache-2.0
// The triangle mesh a closest-point search runs over, shared by ProximityIndex
// (kernels/proximity.cpp) and SpatialHash (kernels/spatial_hash.cpp): the mesh with its hole
// caps, its edges and the angle-weighted pseudo-normals the side test reads. Not a public
// header: it is included textually, like closest_point_math.h, inside those files' anonymous
// namespace after closest_point_math.h (whose types it uses), with hole_caps.h,
// pseudo_normals.h and vertex_normals.h included at the top.

inline vfit_vec3 load(const float* p, std::int32_t v) {
  const float* q = p + 3 * static_cast<std::size_t>(v);
  return vfit_vec3{q[0], q[1], q[2]};
}

// The tie rule of every search (BVH, brute force, spatial hash): strictly closer, or equally
// close and a lower triangle index, so all of them answer the same triangle.
inline bool improves(float distance2, std::uint32_t triangle, float best_distance2, std::uint32_t best_triangle) {
  return distance2 < best_distance2 || (distance2 == best_distance2 && triangle < best_triangle);
}

// The capped mesh: #V mesh vertices then #L loop centroids, #F mesh triangles then #C cap
// triangles. Edges and pseudo-normals are those of the capped mesh, which is closed where the
// original had holes (so the side test stays exact there); the caps take part in the side
// decision only, never in the closest-point answer.
struct CappedSurface {
  HoleCaps caps;
  std::vector<float> positions;        // capped vertices × 3 (m), then any padding floats
  std::vector<std::int32_t> triangles; // (#F + #C) × 3
  std::size_t vertex_count = 0, face_count = 0;
  std::size_t capped_vertex_count = 0, capped_face_count = 0;
  std::size_t hole_count = 0; // boundary loops found, capped or not
  MeshEdges edges;
  VertexFaceAdjacency vertex_faces;
  PseudoNormals normals;
  // Per mesh triangle, 8 floats: a bounding sphere (centre = the centroid, radius), then a
  // unit normal n̂ and the slab half-width h = max over the corners v of |n̂·(v − centroid)|
  // (0 up to rounding for a flat triangle); see cannot_improve().
  std::vector<float> bounds;

  // Builds from a validated mesh. ONE_SIDED: holes are counted but not capped. `padding`
  // floats follow the coordinates (Embree reads vertices with 16-byte loads).
  void build(std::span<const float> mesh_positions, std::span<const std::int32_t> mesh_triangles,
             OpenMeshSide open_side, std::size_t padding) {
    vertex_count = mesh_positions.size() / 3;
    face_count = mesh_triangles.size() / 3;
    caps = build_hole_caps(mesh_triangles, vertex_count);
    hole_count = caps.loop_count();
    if (open_side == OpenMeshSide::ONE_SIDED) caps = HoleCaps{{0}, {}, {}};
    capped_vertex_count = vertex_count + caps.loop_count();
    capped_face_count = face_count + caps.triangles.size() / 3;
    positions.assign(mesh_positions.begin(), mesh_positions.end());
    positions.resize(3 * capped_vertex_count + padding, 0.0f); // centroids filled by update_normals()
    triangles.assign(mesh_triangles.begin(), mesh_triangles.end());
    triangles.insert(triangles.end(), caps.triangles.begin(), caps.triangles.end());
    edges = build_mesh_edges(triangles, capped_vertex_count);
    vertex_faces = build_vertex_face_adjacency(triangles, capped_vertex_count);
    update_normals();
  }

  vfit_closest_point closest_on(vfit_vec3 q, std::uint32_t f) const {
    const std::int32_t* t = triangles.data() + 3 * static_cast<std::size_t>(f);
    const float* p = positions.data();
    return vfit_closest_point_on_triangle(q, load(p, t[0]), load(p, t[1]), load(p, t[2]));
  }

  // The reach of a search whose best squared distance so far is best_distance2: a triangle
  // farther than this from the query cannot tie or win. The slack (relative 1e-5 on the
  // distance, 1e-7 m absolute) covers several float roundings of the values compared and of the
  // exact computation's own squared distance.
  static float reach_of(float best_distance2) { return std::sqrt(best_distance2) * (1.0f + 1e-5f) + 1e-7f; }

  // Whether mesh triangle f is certainly farther from q than `reach` (reach_of() the best so
  // far), so the exact closest-point computation can be skipped. Two lower bounds on the
  // distance from q to any point y of the triangle, both conservative:
  // - the bounding sphere: |q − y| ≥ |q − centroid| − radius;
  // - the triangle's slab: |q − y| ≥ |n̂·(q − y)| ≥ |n̂·(q − centroid)| − h, since n̂·(y − centroid)
  //   is affine in y and so at most h over the triangle (|n̂| ≤ 1 after rounding: see
  //   update_normals()); 1e-6 m covers the float rounding of q − centroid (coordinates of a
  //   few metres) and of the dot product.
  // A search therefore answers the same triangle with and without this cull. The slab prunes
  // the neighbours of the closest triangle that the spheres keep: a query over a gently curved
  // surface lies within every neighbour's sphere but well off its plane.
  bool cannot_improve(vfit_vec3 q, std::uint32_t f, float reach) const {
    const float* b = bounds.data() + 8 * static_cast<std::size_t>(f);
    const float dx = q.x - b[0], dy = q.y - b[1], dz = q.z - b[2];
    const float sphere = reach + b[3];
    if (dx * dx + dy * dy + dz * dz > sphere * sphere) return true;
    return std::fabs(dx * b[4] + dy * b[5] + dz * b[6]) - b[7] - 1e-6f > reach;
  }

  // Pseudo-normal of `feature` of triangle f (Bærentzen & Aanæs 2005).
  const float* feature_normal(std::uint32_t f, int feature) const {
    const std::size_t row = 3 * static_cast<std::size_t>(f);
    if (feature == VFIT_FEATURE_FACE) return normals.faces.data() + row;
    if (feature <= VFIT_FEATURE_EDGE_2) {
      const auto e = static_cast<std::size_t>(edges.triangle_edges[row + (feature - VFIT_FEATURE_EDGE_0)]);
      return normals.edges.data() + 3 * e;
    }
    const auto v = static_cast<std::size_t>(triangles[row + (feature - VFIT_FEATURE_VERTEX_0)]);
    return normals.vertices.data() + 3 * v;
  }

  // Recomputes the loop centroids from the first #V × 3 of `positions`, then the pseudo-normals.
  void update_normals() {
    if (caps.loop_count() > 0) {
      std::vector<float> capped;
      capped_positions(std::span<const float>(positions.data(), 3 * vertex_count), caps, capped);
      std::copy(capped.begin(), capped.end(), positions.begin());
    }
    pseudo_normals_tbb(std::span<const float>(positions.data(), 3 * capped_vertex_count), triangles, edges,
                       vertex_faces, normals);
    bounds.resize(8 * face_count);
    for (std::size_t f = 0; f < face_count; ++f) {
      const std::int32_t* t = triangles.data() + 3 * f;
      const float* p[3] = {positions.data() + 3 * std::size_t(t[0]), positions.data() + 3 * std::size_t(t[1]),
                           positions.data() + 3 * std::size_t(t[2])};
      float* b = bounds.data() + 8 * f;
      float radius2 = 0.0f;
      for (int k = 0; k < 3; ++k)
        b[k] = (p[0][k] + p[1][k] + p[2][k]) / 3.0f;
      for (const float* v : p)
        radius2 = std::max(radius2, (v[0] - b[0]) * (v[0] - b[0]) + (v[1] - b[1]) * (v[1] - b[1]) +
                                        (v[2] - b[2]) * (v[2] - b[2]));
      b[3] = std::sqrt(radius2) * (1.0f + 1e-5f) + 1e-7f; // float rounding of the centroid and the radius
      // The slab, in double: any unit n̂ gives a valid bound with its own h, so only |n̂| ≤ 1
      // matters (the 1 − 1e-6 scale keeps it below 1 after rounding to float); a degenerate
      // triangle gets n̂ = 0, h = 0, and the slab bound never culls it.
      double e1[3], e2[3], n[3];
      for (int k = 0; k < 3; ++k) {
        e1[k] = double(p[1][k]) - double(p[0][k]);
        e2[k] = double(p[2][k]) - double(p[0][k]);
      }
      n[0] = e1[1] * e2[2] - e1[2] * e2[1];
      n[1] = e1[2] * e2[0] - e1[0] * e2[2];
      n[2] = e1[0] * e2[1] - e1[1] * e2[0];
      const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      double h = 0.0;
      for (int k = 0; k < 3; ++k) {
        n[k] = length > 0.0 ? n[k] / length * (1.0 - 1e-6) : 0.0;
        b[4 + k] = float(n[k]);
      }
      for (const float* v : p) {
        double d = 0.0;
        for (int k = 0; k < 3; ++k)
          d += double(b[4 + k]) * (double(v[k]) - double(b[k]));
        h = std::max(h, std::fabs(d));
      }
      b[7] = float(h * (1.0 + 1e-6) + 1e-9); // rounded up: the bound only needs h not too small
    }
  }
};
