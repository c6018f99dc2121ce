// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Spatial hash of a body's triangles (seed 004 §2: collision against the body through a
/// spatial hash, after Teschner et al. 2003, "Optimized spatial hashing for collision detection
/// of deformable objects"): the alternative broad phase to the Embree BVH of proximity.h for
/// cloth–body contacts. Space is divided into cubic cells of side h; each triangle is entered in
/// every cell its axis-aligned bounding box overlaps, and a cell (i, j, k) lives in bucket
/// (i·73856093 ⊕ j·19349663 ⊕ k·83492791) mod T (Teschner's §4 hash, T a prime). A query visits
/// the cells in shells of growing Chebyshev radius around its own cell and stops once the
/// closest triangle found is nearer than any cell not yet visited (or past the search radius).
/// The narrow phase and the side are exactly the proximity core's: closest_point_math.h for the
/// closest point and the angle-weighted pseudo-normal of the closest feature (pseudo_normals.h,
/// Bærentzen & Aanæs 2005) for the side, with the same hole caps (hole_caps.h) on an open mesh,
/// so the answers equal ProximityIndex's (up to ties between equally close triangles).
///
/// Rebuilding is the update when the body moves (Teschner's approach: the hash is refilled
/// every step, which costs O(#F) and no tree); there is no refit state to go stale.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include "proximity.h" // ClosestHits, OpenMeshSide

namespace vfit {

/// Queries per TBB task in SpatialHash::closest_points.
inline constexpr std::size_t SPATIAL_HASH_QUERY_GRAIN = 256;

/// Teschner et al.'s three large primes of the cell hash (§4).
inline constexpr std::uint32_t SPATIAL_HASH_PRIMES[3] = {73856093u, 19349663u, 83492791u};

/// A spatial hash over one triangle mesh (the body), answering closest-point queries with the
/// same ClosestHits as ProximityIndex::closest_points.
///
/// The cell side h is the mesh's mean edge length unless given: Teschner et al. (§5, Fig. 3)
/// find the query cost lowest for a cell about the mean edge length, where a triangle spans a
/// few cells and a cell holds a few triangles. (BM_hash_cell_size in
/// bench/engine/cloth_sim_bench.cpp compares other cell sides.) The table holds T buckets, T the
/// smallest prime > 2 × the number of (triangle, cell) entries at construction (kept by
/// update() while the entries stay within 2T), so hash collisions add on average under one
/// foreign entry per visited bucket. Thread safety: queries are const and may run
/// concurrently; update() may not run concurrently with anything on the same hash.
class SpatialHash {
public:
  /// positions: #V × 3 (m); triangles: #F × 3 indices in [0, #V), counter-clockwise from
  /// outside. cell_size (m): h, or 0 for the mean edge length (an all-degenerate mesh then gets
  /// h = 1 m). Throws vfit::Error ("spatial hash mesh: …") when positions or triangles are not
  /// rows of 3, for a non-finite coordinate (naming the vertex), an index out of range (naming
  /// the triangle and the index) or a negative or non-finite cell_size. Degenerate (zero-area)
  /// triangles are kept. An empty mesh is allowed: every query reports no hit. open_side as for
  /// ProximityIndex (CAP_HOLES: boundary loops get cap triangles used for the side test only).
  SpatialHash(std::span<const float> positions, std::span<const std::int32_t> triangles, float cell_size = 0.0f,
              OpenMeshSide open_side = OpenMeshSide::CAP_HOLES);
  ~SpatialHash();
  /// Movable, not copyable; a moved-from hash may only be destroyed or assigned to.
  SpatialHash(SpatialHash&&) noexcept;
  SpatialHash& operator=(SpatialHash&&) noexcept;
  SpatialHash(const SpatialHash&) = delete;
  SpatialHash& operator=(const SpatialHash&) = delete;

  /// Moves the vertices (same topology): positions #V × 3 (m) with the #V of construction.
  /// Throws vfit::Error ("spatial hash update: …") for another size or naming the first vertex
  /// with a non-finite coordinate; the hash is unchanged then. Recomputes the pseudo-normals and
  /// hole caps and refills the table in O(#F), keeping the cell size (and T while the entries
  /// stay within 2T, else a new prime T); answers afterwards equal a fresh hash's with that cell
  /// size.
  void update(std::span<const float> positions);

  /// Closest points of `queries` (#Q × 3, m) within max_distance (m, ≥ 0 or +∞), TBB-parallel
  /// (grain SPATIAL_HASH_QUERY_GRAIN); `hits` resized to #Q. Shapes, signs, the no-hit row and
  /// the errors are ProximityIndex::closest_points's (check_proximity_queries(): vfit::Error
  /// "proximity queries: …" for a size not a multiple of 3, a negative or NaN max_distance, or
  /// naming the first non-finite query); ties between equally close triangles go to the lower
  /// index among those seen.
  void closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const;
  /// Serial reference of closest_points(): the same answers, one query after another.
  void closest_points_serial(std::span<const float> queries, float max_distance, ClosestHits& hits) const;

  float cell_size() const;          ///< h (m)
  std::size_t table_size() const;   ///< T, the number of buckets
  std::size_t entry_count() const;  ///< (triangle, cell) entries, caps included
  std::size_t vertex_count() const; ///< #V of the input mesh (hole-cap centroids not counted)
  std::size_t face_count() const;   ///< #F of the input mesh (cap triangles not counted)

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
