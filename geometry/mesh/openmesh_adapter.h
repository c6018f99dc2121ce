// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Conversion between vfit::Mesh and an OpenMesh half-edge mesh, for the stages that need
/// topology (hole filling, one-ring walks). OpenMesh itself stays out of this header.

#include <memory>

#include "mesh.h"

namespace vfit {

/// A half-edge triangle mesh (OpenMesh::TriMesh_ArrayKernelT with default traits), kept
/// opaque so that only the .cpp files that walk it include OpenMesh.
struct HalfEdgeMesh;
struct HalfEdgeMeshDeleter {
  void operator()(HalfEdgeMesh* m) const;
};
using HalfEdgeMeshPtr = std::unique_ptr<HalfEdgeMesh, HalfEdgeMeshDeleter>;

/// Builds the half-edge mesh of `mesh` (positions and triangles). Requires a manifold,
/// consistently oriented mesh: throws vfit::Error naming `source` and the first face OpenMesh
/// rejects ("face N makes a non-manifold edge or vertex") otherwise.
HalfEdgeMeshPtr to_half_edge_mesh(const Mesh& mesh, const std::string& source);

/// Number of boundary loops of a half-edge mesh, counted by walking its boundary half-edges.
std::size_t half_edge_boundary_loops(const HalfEdgeMesh& mesh);

/// Positions and triangles of a half-edge mesh back as a vfit::Mesh.
Mesh from_half_edge_mesh(const HalfEdgeMesh& mesh);

} // namespace vfit
