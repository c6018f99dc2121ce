#pragma once
/// \file
/// STL, ASCII and binary. STL stores unshared triangle corners; vertices with bit-identical
/// positions are welded back into one vertex so the result has topology.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of an STL file (binary when its size is 84 + 50·n for the n in its
/// header, ASCII when it starts with "solid" and is not binary). Throws vfit::Error naming
/// the line (ASCII) or the facet index (binary) for a truncated file, NaN/Inf, or syntax.
ParsedMesh read_stl(std::string_view bytes, const std::string& path);

/// Binary STL of `mesh` (facet normals computed from the triangles).
std::string write_stl(const Mesh& mesh);

} // namespace vfit
