// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Mesh simplification to an exact vertex count (quadric error collapses through OpenMesh's
/// decimater, with aspect-ratio and normal-flip guards) and refinement by midpoint subdivision.

#include <cstddef>

#include "mesh.h"

namespace vfit {

/// Collapses edges of a manifold, consistently oriented triangle mesh until it has exactly
/// `target_vertices` vertices (or as close as legal collapses allow; the result says how many).
/// Topology is preserved: a closed mesh stays closed, boundary loops stay loops. UVs, normals
/// and labels are dropped (callers regenerate them). With `lock_boundary`, boundary vertices
/// never move or disappear (a garment's cut openings stay exactly where they were cut).
/// Throws vfit::Error for non-manifold input.
Mesh decimate_to_vertex_count(const Mesh& mesh, std::size_t target_vertices, bool lock_boundary = false);

/// One step of midpoint subdivision: every triangle becomes four (1→4), a shared edge gets one
/// new vertex. Positions only (UVs, normals, labels are dropped). #V grows to V + E.
Mesh subdivide_midpoints(const Mesh& mesh);

} // namespace vfit
