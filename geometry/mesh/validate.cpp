// SPDX-License-Identifier: Apache-2.0
#include "validate.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <tbb/parallel_sort.h>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

std::string plural(std::size_t n, const char* word) { return std::to_string(n) + " " + word + (n == 1 ? "" : "s"); }

[[noreturn]] void fail_face(const MeshSource& src, std::size_t f, const std::string& what) {
  throw Error(src.path, src.line_of(f), src.element_of(f) + what);
}

void check_indices(const std::vector<std::int32_t>& tris, std::size_t count, const char* what, const MeshSource& src) {
  for (std::size_t i = 0; i < tris.size(); ++i) {
    const std::int32_t v = tris[i];
    if (v < 0 || static_cast<std::size_t>(v) >= count)
      fail_face(src, i / 3,
                std::string(what) + " index " + std::to_string(static_cast<std::int64_t>(v) + 1) + " out of range (" +
                    std::to_string(count) + " " + what + (count == 1 ? ")" : "s)"));
  }
}

// Removes the faces whose flag is set from every per-face array.
void drop_faces(Mesh& m, MeshSource& src, const std::vector<char>& drop) {
  std::size_t out = 0;
  for (std::size_t f = 0; f < drop.size(); ++f) {
    if (drop[f]) continue;
    for (int k = 0; k < 3; ++k) {
      m.triangles[3 * out + k] = m.triangles[3 * f + k];
      if (m.has_uvs()) m.uv_triangles[3 * out + k] = m.uv_triangles[3 * f + k];
      if (m.has_normals()) m.normal_triangles[3 * out + k] = m.normal_triangles[3 * f + k];
    }
    if (m.has_labels()) m.face_labels[out] = m.face_labels[f];
    if (f < src.face_origin.size()) src.face_origin[out] = src.face_origin[f];
    ++out;
  }
  m.triangles.resize(3 * out);
  if (m.has_uvs()) m.uv_triangles.resize(3 * out);
  if (m.has_normals()) m.normal_triangles.resize(3 * out);
  if (m.has_labels()) m.face_labels.resize(out);
  if (src.face_origin.size() > out) src.face_origin.resize(out);
}

} // namespace

void validate_mesh(Mesh& mesh, MeshSource& source, const ValidationOptions& options,
                   std::vector<std::string>& warnings) {
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (nv == 0 || nf == 0)
    throw Error(source.path, 0, "empty mesh (" + plural(nv, "vertex") + ", " + plural(nf, "face") + ")");
  if (mesh.positions.size() % 3 != 0 || mesh.triangles.size() % 3 != 0)
    throw Error(source.path, 0, "internal: position or triangle array is not a multiple of 3");
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!std::isfinite(mesh.positions[i]))
      throw Error(source.path, 0,
                  "vertex " + std::to_string(i / 3 + 1) + ": coordinate is " +
                      (std::isnan(mesh.positions[i]) ? "NaN" : "infinite"));
  check_indices(mesh.triangles, nv, "vertex", source);
  if (mesh.has_uvs()) {
    if (mesh.uv_triangles.size() != mesh.triangles.size())
      throw Error(source.path, 0, "internal: UV index count differs from triangles");
    check_indices(mesh.uv_triangles, mesh.uvs.size() / 2, "texture coordinate", source);
  }
  if (mesh.has_normals()) {
    if (mesh.normal_triangles.size() != mesh.triangles.size())
      throw Error(source.path, 0, "internal: normal index count differs from triangles");
    check_indices(mesh.normal_triangles, mesh.normals.size() / 3, "normal", source);
  }
  if (mesh.has_labels() && mesh.face_labels.size() != nf)
    throw Error(source.path, 0, "internal: label count differs from faces");

  std::vector<char> drop(nf, 0);
  std::size_t degenerate = 0, duplicate = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t a = mesh.triangles[3 * f], b = mesh.triangles[3 * f + 1], c = mesh.triangles[3 * f + 2];
    if (a == b || b == c || a == c) {
      if (!options.repair)
        fail_face(source, f,
                  "degenerate face: vertex " + std::to_string((a == b || a == c ? a : b) + 1) +
                      " is used twice (use --repair to drop such faces)");
      drop[f] = 1;
      ++degenerate;
    }
  }
  // Duplicate faces: sort (smallest, middle, largest, face) keys and compare neighbours.
  std::vector<std::array<std::int32_t, 4>> keys(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    std::array<std::int32_t, 3> t{mesh.triangles[3 * f], mesh.triangles[3 * f + 1], mesh.triangles[3 * f + 2]};
    std::sort(t.begin(), t.end());
    keys[f] = {t[0], t[1], t[2], static_cast<std::int32_t>(f)};
  }
  tbb::parallel_sort(keys.begin(), keys.end());
  for (std::size_t i = 1; i < nf; ++i) {
    const auto& p = keys[i - 1];
    const auto& q = keys[i];
    if (p[0] == q[0] && p[1] == q[1] && p[2] == q[2] && !drop[q[3]] && p[0] != p[1] && p[1] != p[2]) {
      if (!options.repair)
        fail_face(source, static_cast<std::size_t>(q[3]),
                  "duplicate face: same vertices as face " + std::to_string(p[3] + 1) +
                      (source.text && static_cast<std::size_t>(p[3]) < source.face_origin.size()
                           ? " (line " + std::to_string(source.face_origin[p[3]]) + ")"
                           : std::string()) +
                      " (use --repair to drop such faces)");
      drop[q[3]] = 1;
      ++duplicate;
    }
  }
  if (degenerate + duplicate > 0) {
    drop_faces(mesh, source, drop);
    warnings.push_back(source.path + ": repaired: dropped " + plural(degenerate, "degenerate face") + " and " +
                       plural(duplicate, "duplicate face"));
    if (mesh.face_count() == 0) throw Error(source.path, 0, "empty mesh after repair (every face was degenerate)");
  }
}

} // namespace vfit
