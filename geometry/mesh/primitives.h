// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Procedural meshes for tests, benchmarks and the demo: spheres, open tubes and grids with UVs,
/// and a sheet given thickness.

#include "mesh.h"

namespace vfit {

/// A closed UV sphere of `radius` (m) centred at the origin: `rings` ≥ 2 latitude bands,
/// `segments` ≥ 3 longitude segments, poles as single vertices; outward CCW triangles, UVs
/// with a seam. #V = (rings − 1)·segments + 2.
Mesh make_uv_sphere(int rings, int segments, float radius);

/// An open tube (a sleeve-like cylinder) along +Y from y = 0 to `length`, `radius` (m),
/// `rings` ≥ 2 vertex rings × `segments` ≥ 3; two boundary loops; outward normals.
Mesh make_tube(int rings, int segments, float radius, float length);

/// A flat grid in the XZ plane of nx × nz vertices (≥ 2 each) spanning `size_x` × `size_z` m,
/// normals +Y, UVs in [0, 1]².
Mesh make_grid(int nx, int nz, float size_x, float size_z);

/// A sheet given thickness, as a solidify modifier does: `outer` (positions and triangles;
/// UVs, normals and labels are not carried) followed by a copy offset by `thickness` (m)
/// against its area-weighted vertex normals, wound the other way (the copy is inside when
/// `outer` is wound outward). With `stitched` each boundary edge a→b (used by one triangle) is
/// joined to its copy by the strip (b, a, a'), (b, a', b'): one closed surface of 2·#V vertices;
/// without, the copy is a separate piece (a shell and its lining). A vertex with no area around
/// it has no normal and its copy gets NaN coordinates.
Mesh make_solidified(const Mesh& outer, float thickness, bool stitched);

} // namespace vfit
