// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Welding of coincident vertices: pattern-based garment tools (and many exporters) write each
/// pattern piece with its own copy of the seam's vertices, so a garment arrives as pieces that
/// touch without sharing vertices, and its topology (openings, sleeves, legs) is lost.

#include <cstddef>

#include "mesh.h"

namespace vfit {

/// What weld_coincident_vertices() changed.
struct WeldReport {
  std::size_t welded = 0;       ///< vertices merged into an earlier vertex at the same position
  std::size_t unreferenced = 0; ///< vertices no triangle used, dropped
  std::size_t collapsed = 0;    ///< triangles that lost their area (two corners welded), dropped
  bool changed() const { return welded + unreferenced + collapsed > 0; }
};

/// Merges vertices whose positions are bit-identical (−0.0 taken as 0.0) into the first of
/// them in index order, drops vertices no triangle uses and triangles two of whose corners
/// became one vertex, and renumbers the rest keeping their order. Per-corner UV and normal
/// indices and per-face labels follow their triangles (seams in UVs stay seams). A mesh with
/// nothing to weld or drop is left untouched (the same vertex numbering). Linear in the mesh
/// (an open-addressing hash of the positions' bits). Positions are compared exactly: layers a little apart (a lining)
/// stay apart.
WeldReport weld_coincident_vertices(Mesh& mesh);

/// weld_coincident_vertices(), then the same for the vertices on open boundaries (edges of one
/// triangle) that lie within `relative_tolerance` × the surface's bounding-box diagonal of an
/// earlier such vertex: each is moved onto the first of them in index order and welded to it.
/// Seams whose copies an exporter rounded apart (a few µm: float text in other units) are joined
/// this way; interior vertices and layers farther apart than the tolerance (a lining, mm away)
/// are not touched. 1e-5: 10 µm on a 1 m garment, a hundredth of a 10^6-vertex garment's 1 mm
/// edges. The report sums both welds.
WeldReport weld_seams(Mesh& mesh, float relative_tolerance = 1e-5f);

} // namespace vfit
