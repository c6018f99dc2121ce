// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Closest points on a triangle mesh on an OpenCL device: the GPU path of ProximityIndex
/// (proximity.h). Embree's BVH builder (rtcBuildBVH, SAH, binary) emits our own nodes through
/// create-node / set-bounds / create-leaf callbacks; they are flattened depth-first into a node
/// array (box, and either a leaf's primitive range or the second child's index) that the
/// kernel in proximity.cl walks with a stack, nearer child first.

#include <cstddef>
#include <memory>
#include <span>

#include "proximity.h"

namespace vfit {

class OpenClContext;

/// Primitives per BVH leaf at most: small leaves suit a work-item per query (little divergence).
inline constexpr unsigned OPENCL_PROXIMITY_LEAF_SIZE = 4;

/// Precompute/solve object: the constructor builds the flat BVH over the index's capped mesh
/// (ProximityIndex::side_mesh(): the mesh triangles plus any hole caps) and uploads it with the
/// pseudo-normals; closest_points() uploads the queries, runs one work-item per query and reads
/// the answers back. Answers as ProximityIndex::closest_points() does, in the same ClosestHits
/// layout and with the same tie rule and side test (hole caps included), within float
/// tolerance: the device may round the point–triangle math differently by a few ulps, so two
/// triangles tied to within that may swap. After ProximityIndex::refit(), build a new one.
class OpenClProximity {
public:
  /// Builds from `index` (which need not outlive this object). Throws std::runtime_error on an
  /// OpenCL or Embree failure, vfit::Error in a build without OpenCL.
  OpenClProximity(OpenClContext& context, const ProximityIndex& index);
  ~OpenClProximity();
  OpenClProximity(const OpenClProximity&) = delete;
  OpenClProximity& operator=(const OpenClProximity&) = delete;

  /// Closest points of `queries` (#Q × 3, m) within `max_distance` (m, ≥ 0; +∞ for no limit);
  /// `hits` is resized to #Q. Validates the queries as ProximityIndex::closest_points() does
  /// (vfit::Error for a NaN or infinite coordinate).
  void closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits);

  /// Number of BVH nodes (inner and leaf); 0 for an empty mesh.
  std::size_t node_count() const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
