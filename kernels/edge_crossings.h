// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Edge–triangle crossings: which edges of a garment pass through the surface of a body. A
/// vertex test (kernels/proximity.h) misses an edge whose two ends are outside while its middle
/// is inside, e.g. a sleeve edge cutting through a thin wrist. Each edge a→b
/// is cast as an Embree ray from a along b − a, limited to t ∈ [0, 1] (the segment itself).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace vfit {

/// The distinct edges of a triangle mesh as #E × 2 vertex indices (lower index first), in the
/// edge order of build_mesh_edges() (kernels/pseudo_normals.h). triangles: #F × 3 indices in
/// [0, vertex_count). An empty mesh gives no edges.
std::vector<std::int32_t> mesh_edge_endpoints(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// First crossings of #E segments, one row per segment, in segment order. A segment that
/// crosses nothing has triangle −1, parameter +∞ and barycentrics (0, 0).
struct SegmentCrossings {
  std::vector<std::int32_t> triangles; ///< #E crossed body triangle nearest the segment's first end, or −1
  /// #E parameters t ∈ [0, 1] of that crossing: point = a + t·(b − a), or +∞ for none.
  std::vector<float> parameters;
  std::vector<float> barycentrics; ///< #E × 2 (u, v) of the crossing on its triangle

  /// Number of segments answered (#E).
  std::size_t size() const { return triangles.size(); }
  /// Resizes every array for `segment_count` segments (contents unspecified until written).
  void resize(std::size_t segment_count);
  /// Number of segments that cross (triangle ≥ 0).
  std::size_t crossing_count() const;
};

/// Segments per TBB task in EdgeCrossingIndex::first_crossings (one incoherent ray each).
inline constexpr std::size_t EDGE_CROSSING_GRAIN = 1024;

/// A segment-intersection scene over one triangle mesh (the body): an Embree BVH in robust
/// (watertight) mode, so a segment through the shared edge of two triangles crosses one of
/// them, never neither. Triangles count from both sides. Keeps a copy of the mesh, so the face
/// normal of a crossed triangle and the brute-force reference are available.
///
/// Thread safety: the query functions are const and may run concurrently. Embree failures throw
/// std::runtime_error naming the Embree call.
class EdgeCrossingIndex {
public:
  /// positions: #V × 3 (m); triangles: #F × 3 indices in [0, #V) (validated by the caller;
  /// assert only). An empty mesh is allowed: nothing is ever crossed.
  EdgeCrossingIndex(std::span<const float> positions, std::span<const std::int32_t> triangles);
  ~EdgeCrossingIndex();
  EdgeCrossingIndex(EdgeCrossingIndex&&) noexcept;
  EdgeCrossingIndex& operator=(EdgeCrossingIndex&&) noexcept;
  EdgeCrossingIndex(const EdgeCrossingIndex&) = delete;
  EdgeCrossingIndex& operator=(const EdgeCrossingIndex&) = delete;

  /// For each segment (edges: #E × 2 indices into `points`, #P × 3, m), the body crossing
  /// nearest its first end, TBB-parallel (grain EDGE_CROSSING_GRAIN). Swap the two columns of
  /// `edges` for the crossing nearest the second end. A zero-length segment crosses nothing.
  /// `crossings` is resized to #E.
  void first_crossings(std::span<const float> points, std::span<const std::int32_t> edges,
                       SegmentCrossings& crossings) const;

  /// Serial reference of first_crossings(): the same Embree query, one segment after another.
  void first_crossings_serial(std::span<const float> points, std::span<const std::int32_t> edges,
                              SegmentCrossings& crossings) const;

  /// Brute-force reference for tests: every triangle is tested against every segment
  /// (Möller–Trumbore in double precision, O(#E·#F), serial); the smallest t ∈ [0, 1] wins.
  void first_crossings_brute_force(std::span<const float> points, std::span<const std::int32_t> edges,
                                   SegmentCrossings& crossings) const;

  /// Unit normal of body triangle f (counter-clockwise ⇒ outward), or zero when degenerate.
  void face_normal(std::int32_t f, float normal[3]) const;

  /// #F of the indexed mesh.
  std::size_t face_count() const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
