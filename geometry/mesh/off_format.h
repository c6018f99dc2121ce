#pragma once
/// \file
/// Object File Format (OFF, also COFF/NOFF headers): vertex and face counts, then vertices,
/// then polygons (fan-triangulated). Colours after a face's indices are ignored.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of an OFF file. Throws vfit::Error "<path>:<line>: <what>" for a missing
/// header or counts, a truncated body, NaN/Inf, or indices out of range.
ParsedMesh read_off(std::string_view bytes, const std::string& path);

/// The OFF text of `mesh` (positions and triangles only).
std::string write_off(const Mesh& mesh);

} // namespace vfit
