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
  // Per mesh triangle: a bounding sphere, centre (the centroid) and radius, 4 floats; see
  // cannot_improve().
  std::vector<float> spheres;

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

  // Whether mesh triangle f is certainly farther from q than √best_distance2 (its bounding
  // sphere is), so the exact closest-point computation can be skipped. Conservative: the
  // slack (relative 1e-5 on the distance, 1e-7 m absolute, several float roundings of the
  // values compared) keeps every triangle that could tie or win, so a search answers the same
  // triangle with and without this cull. Measured: ~7 % less time per query for garment
  // vertices near the mannequin (a BVH leaf hands over its neighbours' triangles too).
  bool cannot_improve(vfit_vec3 q, std::uint32_t f, float best_distance2) const {
    const float* b = spheres.data() + 4 * static_cast<std::size_t>(f);
    const float dx = q.x - b[0], dy = q.y - b[1], dz = q.z - b[2];
    const float reach = std::sqrt(best_distance2) * (1.0f + 1e-5f) + b[3] + 1e-7f;
    return dx * dx + dy * dy + dz * dz > reach * reach;
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
    spheres.resize(4 * face_count);
    for (std::size_t f = 0; f < face_count; ++f) {
      const std::int32_t* t = triangles.data() + 3 * f;
      const float* p[3] = {positions.data() + 3 * std::size_t(t[0]), positions.data() + 3 * std::size_t(t[1]),
                           positions.data() + 3 * std::size_t(t[2])};
      float* b = spheres.data() + 4 * f;
      float radius2 = 0.0f;
      for (int k = 0; k < 3; ++k) b[k] = (p[0][k] + p[1][k] + p[2][k]) / 3.0f;
      for (const float* v : p)
        radius2 = std::max(radius2, (v[0] - b[0]) * (v[0] - b[0]) + (v[1] - b[1]) * (v[1] - b[1]) +
                                        (v[2] - b[2]) * (v[2] - b[2]));
      b[3] = std::sqrt(radius2) * (1.0f + 1e-5f) + 1e-7f; // float rounding of the centroid and the radius
    }
  }
};
