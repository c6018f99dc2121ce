// SPDX-License-Identifier: Apache-2.0
#include "openmesh_adapter.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include "vfit/kernels/error.h"

namespace vfit {

struct HalfEdgeMesh {
  OpenMesh::TriMesh_ArrayKernelT<> mesh;
};

void HalfEdgeMeshDeleter::operator()(HalfEdgeMesh* m) const { delete m; }

HalfEdgeMeshPtr to_half_edge_mesh(const Mesh& mesh, const std::string& source) {
  HalfEdgeMeshPtr out(new HalfEdgeMesh);
  auto& om = out->mesh;
  std::vector<OpenMesh::VertexHandle> handles(mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    handles[v] = om.add_vertex({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]});
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    // OpenMesh reports a rejected face on stderr; the error we throw says which one it was.
    auto fh = om.add_face(handles[mesh.triangles[3 * f]], handles[mesh.triangles[3 * f + 1]],
                          handles[mesh.triangles[3 * f + 2]]);
    if (!fh.is_valid())
      throw Error(source, 0,
                  "face " + std::to_string(f + 1) +
                      " makes a non-manifold edge or vertex, or flips orientation (this stage needs a manifold, "
                      "consistently oriented mesh)");
  }
  return out;
}

std::size_t half_edge_boundary_loops(const HalfEdgeMesh& mesh) {
  const auto& om = mesh.mesh;
  std::vector<char> seen(om.n_halfedges(), 0);
  std::size_t loops = 0;
  for (auto he : om.halfedges()) {
    if (!om.is_boundary(he) || seen[he.idx()]) continue;
    ++loops;
    for (auto h = he; !seen[h.idx()]; h = om.next_halfedge_handle(h))
      seen[h.idx()] = 1;
  }
  return loops;
}

Mesh from_half_edge_mesh(const HalfEdgeMesh& mesh) {
  const auto& om = mesh.mesh;
  Mesh out;
  out.positions.reserve(3 * om.n_vertices());
  for (auto v : om.vertices()) {
    const auto& p = om.point(v);
    out.positions.insert(out.positions.end(), {p[0], p[1], p[2]});
  }
  for (auto f : om.faces())
    for (auto v : om.fv_range(f))
      out.triangles.push_back(v.idx());
  return out;
}

} // namespace vfit
