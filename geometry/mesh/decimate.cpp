// SPDX-License-Identifier: Apache-2.0
#include "decimate.h"

#include <algorithm>
#include <unordered_map>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

struct Traits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d; // double: quadrics of a fine isosurface need the precision
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
};
using OmBase = OpenMesh::TriMesh_ArrayKernelT<Traits>;

// The distribution's OpenMesh library is compiled with assertions on: every status() read inside its
// out-of-line functions builds a std::string of the property's type name and compares it (a malloc,
// a memcmp and a free). TriConnectivity::is_collapse_ok (called for every outgoing halfedge of every
// vertex the decimater re-heaps) does about a dozen, and was ~45 % of make_mannequin's time. The
// decimater is a template that calls these through the mesh type, so this mesh shadows the two it
// calls with the same logic inlined here (compiled with this build's settings): the same answers in
// the same order, so the same collapses and the same output bit for bit.
struct OmMesh : OmBase {
  /// Same as OpenMesh::TriConnectivity::is_collapse_ok (OpenMesh 9.0): whether collapsing v0v1 keeps
  /// the mesh a 2-manifold (link condition, no boundary-triangle collapse). Tags v0's/v1's 1-ring.
  bool is_collapse_ok(HalfedgeHandle v0v1) {
    if (status(edge_handle(v0v1)).deleted()) return false;
    const HalfedgeHandle v1v0 = opposite_halfedge_handle(v0v1);
    const VertexHandle v0 = to_vertex_handle(v1v0), v1 = to_vertex_handle(v0v1);
    if (status(v0).deleted() || status(v1).deleted()) return false;
    VertexHandle vl, vr;
    if (!is_boundary(v0v1)) {
      const HalfedgeHandle h1 = next_halfedge_handle(v0v1), h2 = next_halfedge_handle(h1);
      vl = to_vertex_handle(h1);
      if (is_boundary(opposite_halfedge_handle(h1)) && is_boundary(opposite_halfedge_handle(h2))) return false;
    }
    if (!is_boundary(v1v0)) {
      const HalfedgeHandle h1 = next_halfedge_handle(v1v0), h2 = next_halfedge_handle(h1);
      vr = to_vertex_handle(h1);
      if (is_boundary(opposite_halfedge_handle(h1)) && is_boundary(opposite_halfedge_handle(h2))) return false;
    }
    if (vl == vr) return false;
    for (auto vv = vv_iter(v0); vv.is_valid(); ++vv)
      status(*vv).set_tagged(false);
    for (auto vv = vv_iter(v1); vv.is_valid(); ++vv)
      status(*vv).set_tagged(true);
    for (auto vv = vv_iter(v0); vv.is_valid(); ++vv)
      if (status(*vv).tagged() && *vv != vl && *vv != vr) return false;
    if (is_boundary(v0) && is_boundary(v1) && !is_boundary(v0v1) && !is_boundary(v1v0)) return false;
    return true;
  }
  /// Same as OpenMesh::PolyConnectivity::find_halfedge: the halfedge from `from` to `to`, or an
  /// invalid handle when they are not adjacent.
  HalfedgeHandle find_halfedge(VertexHandle from, VertexHandle to) const {
    for (auto voh = cvoh_iter(from); voh.is_valid(); ++voh)
      if (to_vertex_handle(*voh) == to) return *voh;
    return HalfedgeHandle();
  }
};

} // namespace

Mesh decimate_to_vertex_count(const Mesh& mesh, std::size_t target_vertices, bool lock_boundary) {
  if (target_vertices >= mesh.vertex_count()) return mesh;
  OmMesh om;
  std::vector<OmMesh::VertexHandle> handles(mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    handles[v] =
        om.add_vertex(OmMesh::Point(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]));
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    auto fh = om.add_face(handles[mesh.triangles[3 * f]], handles[mesh.triangles[3 * f + 1]],
                          handles[mesh.triangles[3 * f + 2]]);
    if (!fh.is_valid())
      throw Error("decimate", 0,
                  "face " + std::to_string(f + 1) + " is non-manifold; decimation needs a manifold mesh");
  }
  om.update_face_normals();
  if (lock_boundary)
    for (auto v : om.vertices())
      if (om.is_boundary(v)) om.status(v).set_locked(true);

  using Decimater = OpenMesh::Decimater::DecimaterT<OmMesh>;
  Decimater dec(om);
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
  OpenMesh::Decimater::ModAspectRatioT<OmMesh>::Handle aspect;
  OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flips;
  dec.add(quadric);
  dec.add(aspect);
  dec.add(flips);
  dec.module(quadric).unset_max_err();
  dec.module(aspect).set_aspect_ratio(6.0);         // reject collapses that make slivers
  dec.module(flips).set_max_normal_deviation(60.0); // degrees: no folded-over faces
  dec.initialize();
  dec.decimate_to(target_vertices);
  om.garbage_collection();

  Mesh out;
  out.positions.reserve(3 * om.n_vertices());
  for (auto v : om.vertices()) {
    const auto& p = om.point(v);
    out.positions.insert(out.positions.end(), {float(p[0]), float(p[1]), float(p[2])});
  }
  out.triangles.reserve(3 * om.n_faces());
  for (auto f : om.faces())
    for (auto v : om.fv_range(f))
      out.triangles.push_back(v.idx());
  return out;
}

Mesh subdivide_midpoints(const Mesh& mesh) {
  Mesh out;
  out.positions = mesh.positions;
  std::unordered_map<std::uint64_t, std::int32_t> midpoint;
  midpoint.reserve(mesh.triangles.size());
  auto mid = [&](std::int32_t a, std::int32_t b) {
    const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::uint32_t(std::max(a, b));
    auto it = midpoint.find(key);
    if (it != midpoint.end()) return it->second;
    const auto id = static_cast<std::int32_t>(out.positions.size() / 3);
    for (int k = 0; k < 3; ++k)
      out.positions.push_back(0.5f * (mesh.positions[3 * a + k] + mesh.positions[3 * b + k]));
    midpoint.emplace(key, id);
    return id;
  };
  out.triangles.reserve(4 * mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t a = mesh.triangles[3 * f], b = mesh.triangles[3 * f + 1], c = mesh.triangles[3 * f + 2];
    const std::int32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    out.triangles.insert(out.triangles.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  return out;
}

} // namespace vfit
