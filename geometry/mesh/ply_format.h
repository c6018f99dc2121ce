// SPDX-License-Identifier: Apache-2.0
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

/// Parses the bytes of a PLY file (all of them; `path` only names it in messages).
/// Result: positions #V × 3; triangles #F × 3 (polygons fanned as (0, k, k+1)); per-vertex
/// normals with normal_triangles = triangles; UVs per corner from a face `texcoord` list
/// (preferred, it keeps seams) or per vertex with uv_triangles = triangles. face_origin holds
/// the 1-based line of each triangle's face (ASCII) or its 1-based face index (binary).
/// Throws vfit::Error "<path>:<line>: <element> <n>: <what>" (ASCII) or "<path>: <element> <n>:
/// <what>" (binary; n is 1-based) for a bad header, unsupported types, a truncated body (fewer
/// elements than the header declares), NaN/Inf positions or UVs, indices out of range, faces
/// with fewer than 3 vertices, or no faces. Header counts are never trusted beyond what the
/// bytes can hold. NaN/Inf normals are dropped with a warning (normals can be recomputed).
/// `allow_point_cloud`: a file with vertices and no faces (a scanner's point cloud, with or
/// without a face element) is returned with no triangles instead of rejected; off by default,
/// since garments and bodies need faces.
ParsedMesh read_ply(std::string_view bytes, const std::string& path, bool allow_point_cloud = false);

/// PLY of `mesh`, binary little-endian or (`binary` false) ASCII with shortest round-trip
/// floats: float x y z (+ nx ny nz when the mesh has one normal per vertex, i.e.
/// normal_triangles == triangles), `list uchar int vertex_indices`, and a per-face
/// `list uchar float texcoord` (6 floats) when it has UVs. read_ply gives back the same bits.
std::string write_ply(const Mesh& mesh, bool binary = true);

} // namespace vfit
