// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Object File Format (OFF, also COFF/NOFF headers): vertex and face counts, then vertices,
/// then polygons (fan-triangulated). Colours after a face's indices are ignored.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of an OFF file: one vertex or face per line, `#` comments, counts on the
/// header line or the next. NOFF/CNOFF normals become per-vertex normals; other extra values
/// on a line (colours) are ignored. face_origin holds each triangle's 1-based line.
/// Throws vfit::Error "<path>:<line>: <what>" ("vertex 3: coordinate is NaN", vertices and
/// faces numbered from 1) for a missing header or counts, a truncated body, NaN/Inf,
/// non-numeric values, indices out of range, faces with fewer than 3 vertices, or no faces.
ParsedMesh read_off(std::string_view bytes, const std::string& path);

/// The OFF text of `mesh` (positions, with shortest round-trip floats, and triangles only).
std::string write_off(const Mesh& mesh);

} // namespace vfit
