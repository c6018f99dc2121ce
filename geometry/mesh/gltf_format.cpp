// SPDX-License-Identifier: Apache-2.0
// Reading glTF 2.0 (.glb and .gltf) as one mesh; the document machinery lives in
// gltf_document.cpp, write_glb in gltf_writer.cpp.
#include "gltf_format.h"

#include <Eigen/Geometry>

#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <unordered_map>

#include "gltf_document.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace gltf {
namespace {

std::uint32_t weld_bits(float x) { return std::bit_cast<std::uint32_t>(x == 0.0f ? 0.0f : x); }

// Per-corner values (UVs: N = 2, normals: N = 3) → unique values and #F × 3 indices into them.
template <std::size_t N>
void dedupe_corners(const std::vector<float>& corners, std::vector<float>& values, std::vector<std::int32_t>& indices) {
  std::unordered_map<std::array<std::uint32_t, N>, std::int32_t, KeyHash> index_of;
  indices.resize(corners.size() / N);
  for (std::size_t c = 0; c < indices.size(); ++c) {
    std::array<std::uint32_t, N> key;
    for (std::size_t k = 0; k < N; ++k)
      key[k] = weld_bits(corners[N * c + k]);
    auto [it, inserted] = index_of.try_emplace(key, static_cast<std::int32_t>(values.size() / N));
    if (inserted) values.insert(values.end(), corners.begin() + N * c, corners.begin() + N * (c + 1));
    indices[c] = it->second;
  }
}

} // namespace

void GltfMeshBuilder::add_mesh(std::size_t m, const Eigen::Matrix4d& world) {
  const Json& mesh = m_doc.element("meshes", m, "mesh");
  const auto primitives = mesh.find("primitives");
  if (primitives == mesh.end() || !primitives->is_array())
    throw m_doc.fail("mesh " + std::to_string(m) + " has no 'primitives' array");
  // One label per glTF mesh, shared by every node that instances it.
  if (m_label_of_mesh.empty()) m_label_of_mesh.assign(m_doc.array_size("meshes"), -1);
  std::vector<std::string>& names = m_out.mesh.label_names;
  if (m_label_of_mesh[m] < 0) {
    m_label_of_mesh[m] = static_cast<std::int32_t>(names.size());
    const auto name = mesh.find("name");
    const bool named = name != mesh.end() && name->is_string() && !name->get<std::string>().empty();
    names.push_back(named ? name->get<std::string>() : "mesh" + std::to_string(m));
  }
  for (std::size_t p = 0; p < primitives->size(); ++p) {
    if (!(*primitives)[p].is_object())
      throw m_doc.fail("primitive " + std::to_string(p) + " of mesh " + std::to_string(m) + " is not an object");
    add_primitive(m, p, (*primitives)[p], world, m_label_of_mesh[m]);
  }
}

void GltfMeshBuilder::add_primitive(std::size_t m, std::size_t p, const Json& primitive, const Eigen::Matrix4d& world,
                                    std::int32_t label) {
  const std::string owner = "primitive " + std::to_string(p) + " of mesh " + std::to_string(m);
  const std::uint64_t mode = m_doc.index(primitive, "mode", owner, 4);
  if (mode <= 3) {
    m_out.warnings.push_back(owner + ": " + (mode == 0 ? "points" : "lines") + " skipped");
    return;
  }
  if (mode > 6) throw m_doc.fail(owner + ": unknown mode " + std::to_string(mode));
  const auto attributes = primitive.find("attributes");
  if (attributes == primitive.end() || !attributes->is_object() || !attributes->contains("POSITION"))
    throw m_doc.fail(owner + " has no POSITION attribute");
  const std::uint64_t position_accessor = m_doc.index(*attributes, "POSITION", owner);
  const std::vector<float> local = m_doc.read_floats(position_accessor, "POSITION", 3, false);
  const std::size_t n = local.size() / 3;
  for (std::size_t i = 0; i < local.size(); ++i)
    if (!std::isfinite(local[i]))
      throw m_doc.fail("accessor " + std::to_string(position_accessor) + ": POSITION element " + std::to_string(i / 3) +
                       " is not finite");
  auto read_attribute = [&](const char* semantic, int components, bool allow_normalized) {
    if (!attributes->contains(semantic)) return std::vector<float>{};
    const std::uint64_t a = m_doc.index(*attributes, semantic, owner);
    std::vector<float> values = m_doc.read_floats(a, semantic, components, allow_normalized);
    if (values.size() != n * components)
      throw m_doc.fail("accessor " + std::to_string(a) + ": " + semantic + " count differs from POSITION's (" +
                       std::to_string(n) + ")");
    return values;
  };
  const std::vector<float> normals = read_attribute("NORMAL", 3, false);
  const std::vector<float> uvs = read_attribute("TEXCOORD_0", 2, true);

  std::vector<std::uint32_t> indices(n);
  if (primitive.contains("indices"))
    indices = m_doc.read_indices(m_doc.index(primitive, "indices", owner));
  else
    std::iota(indices.begin(), indices.end(), 0u);
  for (std::uint32_t i : indices)
    if (i >= n)
      throw m_doc.fail(owner + ": index " + std::to_string(i) + " out of range (" + std::to_string(n) + " vertices)");
  if (mode == 4 && indices.size() % 3 != 0)
    throw m_doc.fail(owner + ": " + std::to_string(indices.size()) + " indices is not a multiple of 3");
  std::vector<std::uint32_t> corners = mode == 4 ? indices : std::vector<std::uint32_t>{};
  for (std::size_t i = 0; mode != 4 && i + 2 < indices.size(); ++i) {
    // Strip and fan orders from the glTF spec (3.7.2.1), both keeping the first triangle's winding.
    const std::array<std::uint32_t, 3> t = mode == 5
                                               ? std::array{indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]}
                                               : std::array{indices[i + 1], indices[i + 2], indices[0]};
    // Strips are stitched with repeated indices; those zero-area joins are not faces.
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    corners.insert(corners.end(), t.begin(), t.end());
  }
  if (m_out.mesh.triangles.size() + corners.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw m_doc.fail(owner + ": too many faces");

  const Eigen::Matrix3d linear = world.topLeftCorner<3, 3>();
  const Eigen::Vector3d offset = world.topRightCorner<3, 1>();
  const double det = linear.determinant();
  // A mirroring transform turns counter-clockwise triangles clockwise (glTF spec 3.7.4).
  if (det < 0)
    for (std::size_t c = 0; c < corners.size(); c += 3)
      std::swap(corners[c + 1], corners[c + 2]);
  // Normals transform by the inverse transpose, which is the cofactor matrix over det; the
  // cofactor form (sign-corrected) also survives a singular, zero-scale transform.
  Eigen::Matrix3d cofactor;
  cofactor.col(0) = linear.col(1).cross(linear.col(2));
  cofactor.col(1) = linear.col(2).cross(linear.col(0));
  cofactor.col(2) = linear.col(0).cross(linear.col(1));
  if (det < 0) cofactor = -cofactor;

  // Weld in accessor order (not first-use order) so a file that lists each vertex once keeps
  // its vertex order; vertices no triangle uses are dropped.
  std::vector<char> used(n, 0);
  for (std::uint32_t c : corners)
    used[c] = 1;
  std::vector<std::int32_t> welded(n, -1);
  std::vector<float>& positions = m_out.mesh.positions;
  for (std::size_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    const Eigen::Vector3d q = linear * Eigen::Vector3d(local[3 * i], local[3 * i + 1], local[3 * i + 2]) + offset;
    const std::array<float, 3> x{static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
      throw m_doc.fail(owner + ": vertex " + std::to_string(i) + " is not finite after its node transform");
    const PositionKey key{weld_bits(x[0]), weld_bits(x[1]), weld_bits(x[2])};
    const auto [it, inserted] = m_vertex_of.try_emplace(key, static_cast<std::int32_t>(positions.size() / 3));
    if (inserted) positions.insert(positions.end(), x.begin(), x.end());
    welded[i] = it->second;
  }

  m_any_uvs = m_any_uvs || !uvs.empty();
  m_any_normals = m_any_normals || !normals.empty();
  for (std::uint32_t c : corners) {
    m_out.mesh.triangles.push_back(welded[c]);
    // glTF puts the UV origin at the image's top-left, vfit (like OBJ) at its bottom-left.
    m_corner_uvs.push_back(uvs.empty() ? 0.0f : uvs[2 * c]);
    m_corner_uvs.push_back(uvs.empty() ? 0.0f : 1.0f - uvs[2 * c + 1]);
    Eigen::Vector3d nrm = Eigen::Vector3d::Zero();
    if (!normals.empty()) nrm = cofactor * Eigen::Vector3d(normals[3 * c], normals[3 * c + 1], normals[3 * c + 2]);
    if (nrm.norm() > 0.0) nrm.normalize();
    for (int k = 0; k < 3; ++k)
      m_corner_normals.push_back(static_cast<float>(nrm[k]));
    m_corner_has_normal.push_back(!normals.empty());
  }
  m_out.mesh.face_labels.insert(m_out.mesh.face_labels.end(), corners.size() / 3, label);
  m_primitives.push_back({m, p, std::move(welded)});
}

ParsedMesh GltfMeshBuilder::finish() {
  Mesh& mesh = m_out.mesh;
  if (mesh.triangles.empty()) throw m_doc.fail("no faces (no triangle primitives in the default scene)");
  if (m_any_uvs) dedupe_corners<2>(m_corner_uvs, mesh.uvs, mesh.uv_triangles);
  if (m_any_normals) {
    // Corners of primitives without normals get their face's geometric normal.
    for (std::size_t c = 0; c < m_corner_has_normal.size(); ++c) {
      if (m_corner_has_normal[c]) continue;
      const std::size_t f = c / 3;
      auto corner = [&](int k) {
        const std::size_t v = static_cast<std::size_t>(mesh.triangles[3 * f + k]);
        return Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
      };
      Eigen::Vector3d nrm = (corner(1) - corner(0)).cross(corner(2) - corner(0));
      if (nrm.norm() > 0.0) nrm.normalize();
      for (int k = 0; k < 3; ++k)
        m_corner_normals[3 * c + k] = static_cast<float>(nrm[k]);
    }
    dedupe_corners<3>(m_corner_normals, mesh.normals, mesh.normal_triangles);
  }
  m_out.source.path = m_doc.path();
  m_out.source.text = false;
  m_out.source.face_origin.resize(mesh.face_count());
  std::iota(m_out.source.face_origin.begin(), m_out.source.face_origin.end(), std::int64_t{1});
  return std::move(m_out);
}

namespace {

ParsedMesh read_scene(GltfDocument& doc) {
  doc.check_required_extensions();
  GltfMeshBuilder builder(doc);
  std::vector<std::pair<std::size_t, Eigen::Matrix4d>> stack;
  const std::vector<std::size_t> roots = doc.scene_roots();
  for (auto it = roots.rbegin(); it != roots.rend(); ++it)
    stack.emplace_back(*it, Eigen::Matrix4d::Identity());
  std::vector<char> visited(doc.array_size("nodes"), 0);
  // An explicit stack: a hostile file can nest nodes deeper than the call stack allows.
  while (!stack.empty()) {
    auto [n, parent] = stack.back();
    stack.pop_back();
    const Json& node = doc.element("nodes", n, "node");
    if (visited[n]) throw doc.fail("node " + std::to_string(n) + " is reached twice (the hierarchy is not a tree)");
    visited[n] = 1;
    const Eigen::Matrix4d world = parent * doc.local_transform(node, n);
    // glTF ignores a skinned mesh node's transform: its joints place it. The bind-pose
    // positions as stored are the rest pose (read_gltf_body() reads the skin itself).
    const bool skinned = node.contains("skin");
    if (node.contains("mesh"))
      builder.add_mesh(doc.index(node, "mesh", "node " + std::to_string(n)),
                       skinned ? Eigen::Matrix4d::Identity() : world);
    if (const auto children = node.find("children"); children != node.end()) {
      if (!children->is_array()) throw doc.fail("node " + std::to_string(n) + ": 'children' is not an array");
      for (auto it = children->rbegin(); it != children->rend(); ++it)
        stack.emplace_back(doc.as_index(*it, "node " + std::to_string(n) + " child"), world);
    }
  }
  return builder.finish();
}

} // namespace
} // namespace gltf

ParsedMesh read_gltf(std::string_view bytes, const std::string& path) {
  try {
    gltf::GltfDocument doc(bytes, path);
    return gltf::read_scene(doc);
  } catch (const gltf::Json::exception& e) {
    // Our accessors check types; this catches whatever a malformed document slips past them.
    throw Error(path, 0, std::string("invalid glTF: ") + e.what());
  }
}

} // namespace vfit
