// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// STL, ASCII and binary. STL stores unshared triangle corners; vertices with bit-identical
/// positions are welded back into one vertex so the result has topology.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of an STL file (binary when its size is 84 + 50·n for the n in its
/// header, ASCII when it starts with "solid" and is not binary). Corners with bit-identical
/// positions (0.0 and -0.0 alike) become one vertex; stored facet normals are ignored;
/// ASCII loops of more than 3 vertices are fanned; several solids are concatenated.
/// face_origin: the 1-based line of each `facet` (ASCII) or the 1-based facet index (binary).
/// Throws vfit::Error naming the line (ASCII) or the facet (binary) for a truncated file,
/// NaN/Inf, syntax, or no facets.
ParsedMesh read_stl(std::string_view bytes, const std::string& path);

/// Binary STL of `mesh`: header "vfit binary STL", unit facet normals from the right-hand
/// rule (zero for degenerate triangles), attribute bytes zero.
std::string write_stl(const Mesh& mesh);

} // namespace vfit
