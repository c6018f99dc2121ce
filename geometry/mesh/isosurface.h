// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Closed triangle meshes from signed distance functions: marching tetrahedra over the narrow
/// band of a grid, which always yields a watertight, manifold, consistently oriented surface.
/// Used to generate the built-in mannequin and the garment catalogue.

#include <array>
#include <functional>

#include "mesh.h"

namespace vfit {

/// A signed distance (or any function with the same sign and |∇f| ≈ 1 near its zero set):
/// negative inside, positive outside, in metres.
using DistanceFunction = std::function<double(double x, double y, double z)>;

struct IsosurfaceOptions {
  std::array<double, 3> box_min{-1, -1, -1}; ///< the grid's box (m); the surface must lie inside
  std::array<double, 3> box_max{1, 1, 1};
  double cell_size = 0.01; ///< grid spacing h (m)
  /// Bound on |∇f| used to skip coarse blocks far from the surface (≥ 1; larger is safer).
  double lipschitz = 2.0;
  /// Secant refinements of each edge crossing against `f` (0: linear interpolation only).
  int refinements = 2;
};

/// The zero set of `f` as a closed triangle mesh with outward (towards f > 0) normals.
/// `f` is called concurrently from several threads. Throws vfit::Error when the surface reaches
/// the box (it would not be closed) or when there is none.
Mesh extract_isosurface(const DistanceFunction& f, const IsosurfaceOptions& options);

} // namespace vfit
