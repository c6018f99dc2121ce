// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Reading and writing meshes by file name: the format comes from the extension
/// (.obj .ply .off .stl .glb .gltf), reading validates, writing is atomic.

#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include "mesh.h"
#include "units.h"

namespace vfit {

enum class MeshFormat { OBJ, PLY, OFF, STL, GLB, GLTF };

/// The format named by `path`'s extension (case-insensitive). Throws vfit::Error for an
/// unknown or missing extension.
MeshFormat mesh_format_from_path(const std::filesystem::path& path);

struct ReadOptions {
  /// Drop degenerate and duplicate faces with a warning instead of rejecting the file.
  bool repair = false;
  /// Accept a PLY file of vertices only (a point cloud, e.g. a body scan): the mesh comes back
  /// with no triangles and is not validated as a surface. Other formats still need faces. Off
  /// by default: garments and bodies need faces.
  bool allow_point_cloud = false;
};

/// Reads, parses and validates a mesh file (validate_mesh()). Positions stay in the file's
/// units. Throws vfit::Error naming the file and the line or element for a missing or
/// unreadable file, a malformed one, or one that fails validation. The file is only read.
ParsedMesh read_mesh(const std::filesystem::path& path, const ReadOptions& options = {});

/// The bytes of `mesh` in the format of `path`'s extension (as write_mesh() writes them), for
/// callers that write several files only once all are ready. Throws vfit::Error naming the path
/// for an extension it cannot write.
std::string encode_mesh(const std::filesystem::path& path, const Mesh& mesh, const std::string& name = "mesh");

/// Writes one mesh; the format comes from the extension (OBJ with UVs, PLY binary, OFF, STL,
/// GLB). The file is written to a temporary file beside it and renamed, so a failure leaves no
/// partial output. `name` names the mesh inside a glTF file.
void write_mesh(const std::filesystem::path& path, const Mesh& mesh, const std::string& name = "mesh");

/// Writes several named meshes into one glTF binary (`.glb`); atomic like write_mesh().
void write_meshes_glb(const std::filesystem::path& path, std::span<const NamedMesh> meshes);

} // namespace vfit
