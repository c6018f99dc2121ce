// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Fast decimation to even edge lengths by half-edge collapses (each removes one vertex and
/// leaves the other where it was), for the coarse simulation proxy of a high-resolution
/// garment (engine/cloth/cloth_proxy.h). Unlike OpenMesh's quadric decimater (geometry/mesh/decimate.h,
/// one heap, every collapse re-queueing its ring), this runs in rounds of independent
/// collapses, each round a few passes over the mesh.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mesh.h"

namespace vfit {

/// Collapses edges of a manifold, consistently oriented triangle mesh (#V × 3 positions, #F × 3
/// triangles; open or closed) until `target_vertices` vertices are left, or no legal collapse
/// is. Rounds: each takes the edges no longer than 1.5 × the round's lower-quartile length,
/// shortest first, and collapses an edge when none of its vertices' rings was touched earlier
/// in the round, its removed vertex into the other: an interior vertex into any neighbour, a
/// boundary vertex only along its boundary (so boundary loops stay loops of input boundary
/// vertices, at their positions), under the link condition (the two ends share exactly the
/// vertices across their edge: no pinch, no non-manifold edge), each vertex across the edge
/// keeping 3 or more triangles, and guards on the triangles that change: none turns by more
/// than 60° or degenerates, and none gets longer than 6 times its height (longest edge / height;
/// 1.15 for an equilateral triangle) unless one of the removed vertex's triangles already was.
/// The result's vertices are a subset of the input's at their input positions: `source_vertices`
/// (resized to the result's #V) gives each one's input index, ascending; triangles keep their
/// orientation; vertices in no triangle are dropped (so a mesh whose triangles use at most
/// `target_vertices` vertices comes back with those vertices and its triangles). Non-manifold input is not detected
/// here (its collapses may be wrong); validate first. Deterministic (serial).
Mesh decimate_evenly(const Mesh& mesh, std::size_t target_vertices, std::vector<std::int32_t>& source_vertices);

} // namespace vfit
