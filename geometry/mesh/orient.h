// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Consistent triangle orientation: exporters and hand-edited meshes can leave some triangles
/// wound the other way from their neighbours, which breaks whatever reads a surface's sides
/// (hole filling of part skeletons, normals, inside/outside against a body).

#include <cstddef>

#include "mesh.h"

namespace vfit {

/// What orient_consistently() changed.
struct OrientReport {
  std::size_t flipped = 0;   ///< triangles turned over (two corners swapped)
  std::size_t conflicts = 0; ///< edges whose two triangles cannot agree (a non-orientable piece)
  bool changed() const { return flipped > 0; }
};

/// Makes the triangles of each piece (triangles joined across manifold edges: edges with
/// exactly two triangles) wind the same way as their neighbours: two triangles sharing an edge
/// must run it in opposite directions. Each piece keeps the winding of the larger part of its
/// area, so a mesh wound consistently is left untouched, and a piece with a few stray
/// triangles keeps the winding most of it has. Per-corner UV and normal indices follow their
/// corners. Edges shared by three or more triangles (non-manifold) join nothing; an edge whose
/// triangles cannot agree once their piece is oriented (a Möbius-like piece) is counted in
/// `conflicts` and left as it is. Linear in the mesh (vertex → triangle lists).
OrientReport orient_consistently(Mesh& mesh);

/// The signed volume (in the mesh's units cubed) enclosed by the triangles, Σ v0 · (v1 × v2) / 6:
/// positive for a closed surface wound counter-clockwise seen from outside (outward normals),
/// negative for one wound inside out; for a surface with small holes, close to that of the
/// closed surface. 0 without triangles.
double signed_volume(const Mesh& mesh);

/// Turns every triangle of a body-like surface (closed, or with small holes: a scan) over when
/// its signed volume is negative (wound inside out, normals pointing in), so that inside and
/// outside are read the right way round; UV and normal corners follow. Returns whether it did.
/// Meant for bodies: an open garment encloses no volume to judge by.
bool orient_outward(Mesh& mesh);

} // namespace vfit
