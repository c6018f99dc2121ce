#include "decimate.h"

#include <algorithm>
#include <unordered_map>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include "kernels/error.h"

namespace vfit {
namespace {

struct Traits : OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d; // double: quadrics of a fine isosurface need the precision
  VertexAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status | OpenMesh::Attributes::Normal);
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<Traits>;

} // namespace

Mesh decimate_to_vertex_count(const Mesh& mesh, std::size_t target_vertices, bool lock_boundary) {
  if (target_vertices >= mesh.vertex_count()) return mesh;
  OmMesh om;
  std::vector<OmMesh::VertexHandle> handles(mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    handles[v] = om.add_vertex(OmMesh::Point(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]));
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    auto fh = om.add_face(handles[mesh.triangles[3 * f]], handles[mesh.triangles[3 * f + 1]],
                          handles[mesh.triangles[3 * f + 2]]);
    if (!fh.is_valid())
      throw Error("decimate", 0, "face " + std::to_string(f + 1) + " is non-manifold; decimation needs a manifold mesh");
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
  dec.module(aspect).set_aspect_ratio(6.0);       // reject collapses that make slivers
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
    for (auto v : om.fv_range(f)) out.triangles.push_back(v.idx());
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
    for (int k = 0; k < 3; ++k) out.positions.push_back(0.5f * (mesh.positions[3 * a + k] + mesh.positions[3 * b + k]));
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
