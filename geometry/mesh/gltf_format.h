#pragma once
/// \file
/// glTF 2.0: binary `.glb` and JSON `.gltf` (buffers embedded as base64 data URIs or in a
/// `.bin` file beside it). Triangle primitives of every mesh in the default scene are read with
/// their node transforms applied; POSITION, NORMAL and TEXCOORD_0 are kept.

#include <span>
#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses a `.glb` (magic "glTF") or `.gltf` (JSON) file. `path` is used in messages and to
/// resolve external buffer URIs of a `.gltf`. Corners with bit-identical positions are welded
/// into one vertex (glTF splits vertices at UV seams), so the result has the original topology;
/// UVs and normals stay per corner. Each glTF mesh becomes a face label (its name).
/// Throws vfit::Error naming the accessor, buffer view or primitive for malformed input
/// (bad magic, truncated chunks, out-of-range accessors or indices, non-triangle modes).
ParsedMesh read_gltf(std::string_view bytes, const std::string& path);

/// A binary glTF (`.glb`) holding each named mesh as a separate mesh and node (its name kept),
/// with POSITION, NORMAL (computed when the mesh has none) and TEXCOORD_0 (when it has UVs);
/// vertices are split where a position carries several UVs or normals.
std::string write_glb(std::span<const NamedMesh> meshes);

} // namespace vfit
