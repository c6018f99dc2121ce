// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Cutting a triangle mesh along the zero set of a function: the part where keep(p) ≥ 0 stays,
/// triangles crossing the cut are split exactly at the crossing, so the cut becomes a clean
/// boundary loop (garment openings: neck, cuffs, hem, waist).

#include <functional>

#include "mesh.h"

namespace vfit {

/// keep(x, y, z): ≥ 0 where the surface stays (m; any function continuous across the cut).
using KeepFunction = std::function<double(double x, double y, double z)>;

/// Returns the kept part of `mesh` (positions and triangles; UVs, normals, labels dropped),
/// with unused vertices removed. Vertices within `snap` (m) of the cut along the surface are
/// first moved onto it, so no sliver triangles appear beside the new boundary.
Mesh clip_mesh(const Mesh& mesh, const KeepFunction& keep, double snap);

/// The largest face-connected component of `mesh` (by face count), unused vertices removed.
Mesh largest_component(const Mesh& mesh);

} // namespace vfit
