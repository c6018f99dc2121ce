// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Wavefront OBJ: `v`, `vt`, `vn`, `f` (triangles, quads and polygons, fan-triangulated;
/// negative relative indices allowed), `g`/`o` names kept as face labels. Parsed in parallel
/// chunks at close to disk speed.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of an OBJ file. Throws vfit::Error "<path>:<line>: <what>" for a malformed
/// number, NaN/Inf, an index out of range or zero, a face with fewer than 3 vertices, or a
/// file with no faces. Unknown statements (mtllib, usemtl, s, l, p, ...) are skipped.
ParsedMesh read_obj(std::string_view bytes, const std::string& path);

/// The OBJ text of `mesh`: v, vt (if UVs), vn (if normals), g (if labels) and f lines.
/// Floats are written in their shortest exact form (a read gives back the same bits).
std::string write_obj(const Mesh& mesh);

} // namespace vfit
