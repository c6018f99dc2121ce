// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Validation of a parsed mesh with errors that name the file and the element.

#include <string>
#include <vector>

#include "mesh.h"

namespace vfit {

struct ValidationOptions {
  /// Drop degenerate faces (a vertex used twice) and duplicate faces (the same three vertices
  /// in any order) with a warning, instead of throwing.
  bool repair = false;
};

/// Checks, in this order, and throws vfit::Error naming `source.path` and the line or element
/// on the first failure: no vertices or no faces (empty mesh); a NaN or infinite coordinate
/// (vertex index); a vertex, UV or normal index out of range or negative; a face that uses a
/// vertex twice (degenerate); a face with the same vertex set as an earlier one (duplicate).
/// Faces of zero area with three distinct vertices are allowed (reported by mesh_stats).
/// Non-manifold edges and vertices are not errors here: analyse_topology() reports them and
/// the stages that need a manifold check for themselves. Appends repair notes to `warnings`.
void validate_mesh(Mesh& mesh, MeshSource& source, const ValidationOptions& options,
                   std::vector<std::string>& warnings);

} // namespace vfit
