// SPDX-License-Identifier: Apache-2.0
#include "mesh_io.h"

#include <algorithm>
#include <cctype>

#include "atomic_write.h"
#include "gltf_format.h"
#include "obj_format.h"
#include "off_format.h"
#include "ply_format.h"
#include "stl_format.h"
#include "validate.h"
#include "vfit/kernels/error.h"

namespace vfit {

MeshFormat mesh_format_from_path(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".obj") return MeshFormat::OBJ;
  if (ext == ".ply") return MeshFormat::PLY;
  if (ext == ".off") return MeshFormat::OFF;
  if (ext == ".stl") return MeshFormat::STL;
  if (ext == ".glb") return MeshFormat::GLB;
  if (ext == ".gltf") return MeshFormat::GLTF;
  throw Error(path.string(), 0,
              "unknown mesh format '" + (ext.empty() ? std::string("(no extension)") : ext) +
                  "' (expected .obj, .ply, .off, .stl, .glb or .gltf)");
}

ParsedMesh read_mesh(const std::filesystem::path& path, const ReadOptions& options) {
  const MeshFormat format = mesh_format_from_path(path);
  const std::string bytes = read_file_bytes(path);
  const std::string name = path.string();
  if (bytes.empty()) throw Error(name, 0, "empty file");
  ParsedMesh parsed;
  switch (format) {
  case MeshFormat::OBJ: parsed = read_obj(bytes, name); break;
  case MeshFormat::PLY: parsed = read_ply(bytes, name, options.allow_point_cloud); break;
  case MeshFormat::OFF: parsed = read_off(bytes, name); break;
  case MeshFormat::STL: parsed = read_stl(bytes, name); break;
  case MeshFormat::GLB:
  case MeshFormat::GLTF: parsed = read_gltf(bytes, name); break;
  }
  if (parsed.mesh.face_count() == 0) return parsed; // a point cloud (allow_point_cloud): no surface to validate
  ValidationOptions vo;
  vo.repair = options.repair;
  validate_mesh(parsed.mesh, parsed.source, vo, parsed.warnings);
  return parsed;
}

std::string encode_mesh(const std::filesystem::path& path, const Mesh& mesh, const std::string& name) {
  std::string bytes;
  switch (mesh_format_from_path(path)) {
  case MeshFormat::OBJ: bytes = write_obj(mesh); break;
  case MeshFormat::PLY: bytes = write_ply(mesh, true); break;
  case MeshFormat::OFF: bytes = write_off(mesh); break;
  case MeshFormat::STL: bytes = write_stl(mesh); break;
  case MeshFormat::GLB: {
    const NamedMesh one{name, &mesh};
    bytes = write_glb(std::span<const NamedMesh>(&one, 1));
    break;
  }
  case MeshFormat::GLTF:
    throw Error(path.string(), 0, "writing .gltf (JSON) is not supported; write .glb (binary glTF) instead");
  }
  return bytes;
}

void write_mesh(const std::filesystem::path& path, const Mesh& mesh, const std::string& name) {
  write_file_atomically(path, encode_mesh(path, mesh, name));
}

void write_meshes_glb(const std::filesystem::path& path, std::span<const NamedMesh> meshes) {
  if (mesh_format_from_path(path) != MeshFormat::GLB)
    throw Error(path.string(), 0, "several meshes can only be written to a .glb file");
  write_file_atomically(path, write_glb(meshes));
}

} // namespace vfit
