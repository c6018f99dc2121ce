#pragma once
/// \file
/// Stanford PLY: ASCII, binary little- and big-endian. Reads the `vertex` element (x, y, z;
/// optional nx, ny, nz and s/t, u/v or texture_u/texture_v) and the `face` element
/// (`vertex_indices` or `vertex_index` lists, polygons fan-triangulated; optional per-corner
/// `texcoord` list as MeshLab writes it); other elements and properties are skipped.

#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses the bytes of a PLY file. Throws vfit::Error naming the line (ASCII) or the element
/// index (binary) for a bad header, a truncated body (fewer elements than the header
/// declares), NaN/Inf, indices out of range, or faces with fewer than 3 vertices.
ParsedMesh read_ply(std::string_view bytes, const std::string& path);

/// Binary little-endian PLY of `mesh`: float x y z (+ nx ny nz when the mesh has one normal
/// per vertex), int vertex_indices, and a per-face `texcoord` list (6 floats) when it has UVs.
std::string write_ply(const Mesh& mesh, bool binary = true);

} // namespace vfit
