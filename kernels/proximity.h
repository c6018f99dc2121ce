// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Proximity queries against a triangle mesh: for each query point, the closest point on the
/// mesh, its triangle, barycentrics and feature, and the signed distance that detects
/// penetration (seed 000 §6.2, eq. 18: f = (g − h)·n_h < 0 ⇒ the garment vertex g is inside
/// the body, h its closest body point). An Embree BVH finds the closest triangle; the side is
/// decided by the angle-weighted pseudo-normal of the closest feature (Bærentzen & Aanæs 2005,
/// "Signed distance computation using the angle weighted pseudonormal"), which is exact where
/// a plain face normal fails: queries whose closest point is an edge or a vertex.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace vfit {

/// What the closest point lies on. Edge k joins corner k to corner (k + 1) mod 3 of the
/// triangle; vertex k is its corner k. Values match VFIT_FEATURE_* in closest_point_math.h.
enum class TriangleFeature : std::int8_t {
  NONE = -1, ///< no hit within the query radius
  FACE = 0,
  EDGE_0 = 1,
  EDGE_1 = 2,
  EDGE_2 = 3,
  VERTEX_0 = 4,
  VERTEX_1 = 5,
  VERTEX_2 = 6,
};

/// Answers for #Q query points, one row per query, in query order. A query with no triangle
/// within max_distance has triangle −1, feature NONE, point = the query itself,
/// barycentrics (0, 0) and signed distance +∞.
struct ClosestHits {
  std::vector<float> points;           ///< #Q × 3 closest points on the mesh (m)
  std::vector<std::int32_t> triangles; ///< #Q closest triangle, or −1 for no hit
  std::vector<float> barycentrics;     ///< #Q × 2 (u, v): point = (1−u−v)·a + u·b + v·c
  /// #Q signed distances (m): |query − point|, negative when the query is inside the closed
  /// mesh, i.e. when (query − point)·n < 0 with n the pseudo-normal of the closest feature
  /// (seed 000 eq. 18). Zero for a query on the surface.
  std::vector<float> signed_distances;
  std::vector<std::int8_t> features; ///< #Q TriangleFeature values

  /// Number of queries answered (#Q).
  std::size_t size() const { return triangles.size(); }
  /// Resizes every array for `query_count` queries (contents unspecified until written).
  void resize(std::size_t query_count);
  /// Copies row `from_row` of `from` into row `row` (both in range): point, triangle,
  /// barycentrics, signed distance and feature, e.g. a re-queried subset back into the hits of
  /// all queries.
  void copy_row(std::size_t row, const ClosestHits& from, std::size_t from_row);
};

/// Answers for #S segments, one row per segment, in segment order: where each segment, from its
/// start a to its end b, first meets the mesh (or, on a mesh with holes, a hole's cap). A
/// segment that meets nothing has triangle −1, t = +∞ and a zero normal.
struct SegmentHits {
  /// #S mesh triangle first met, −1 for none, or −2 for a hole's cap (ProximityIndex's caps)
  std::vector<std::int32_t> triangles;
  std::vector<float> t;       ///< #S: the first meeting is at a + t·(b − a), t ∈ [0, 1]; +∞ for none
  std::vector<float> normals; ///< #S × 3 unit outward normal of the face met (zero for none)

  /// Number of segments answered (#S).
  std::size_t size() const { return triangles.size(); }
  /// Resizes every array for `segment_count` segments (contents unspecified until written).
  void resize(std::size_t segment_count);
};

/// Queries per TBB task in ProximityIndex::closest_points (each query one BVH traversal).
inline constexpr std::size_t PROXIMITY_QUERY_GRAIN = 256;

/// How ProximityIndex decides the side of a query on a mesh with holes (boundary edges).
enum class OpenMeshSide : std::int8_t {
  /// A body with holes (a scan open at the neck, soles, eyes): the holes are capped internally
  /// and the side is that of the capped, closed mesh (see ProximityIndex). The default.
  CAP_HOLES = 0,
  /// A sheet (a garment used as an obstacle): no caps; the side is the pseudo-normal side of
  /// the open surface itself, a boundary edge's pseudo-normal being its one face's normal.
  ONE_SIDED = 1,
};

/// The mesh on which ProximityIndex decides the side, for other backends that must decide it
/// the same way (OpenClProximity). Views into the index, valid until it is refitted, moved or
/// destroyed. The capped mesh is the indexed mesh plus one fan cap per hole (hole_caps.h):
/// vertices [0, #V) and triangles [0, #F) are the mesh's, the rest belong to caps.
struct ProximitySideMesh {
  std::span<const float> positions;             ///< (#V + #L) × 3 (m), #L loop centroids last
  std::span<const std::int32_t> triangles;      ///< (#F + #C) × 3, cap triangles last
  std::span<const std::int32_t> triangle_edges; ///< (#F + #C) × 3 edge ids (MeshEdges)
  std::span<const float> face_normals;          ///< (#F + #C) × 3 unit pseudo-normals
  std::span<const float> edge_normals;          ///< #E × 3
  std::span<const float> vertex_normals;        ///< (#V + #L) × 3
  std::size_t mesh_face_count = 0;              ///< #F: triangles at or past it are caps
};

/// Closest-point index over one triangle mesh: build once, refit when the vertices move,
/// query many points. Holds an Embree scene (dynamic two-level, robust; the mesh BVH is refitted,
/// not rebuilt, on refit()) and the pseudo-normals of every face, edge and vertex.
///
/// The side (sign) is exact for a closed, edge-manifold, consistently outward-oriented mesh
/// whose shared vertices share indices (edges are found by vertex index) and which does not
/// intersect itself. Where a posed body overlaps itself (an upper arm skinned into the torso),
/// a query inside one part whose closest surface is the other part's buried skin is reported
/// on that skin's side, i.e. outside: the side is local to the closest surface. An open mesh (a scan
/// with holes at the neck, soles or eyes) is capped internally at build time: each boundary
/// loop gets a fan of triangles around its centroid (hole_caps.h). The caps never appear in
/// the answers (closest point, triangle, distance are the mesh's) but the side is decided on
/// the capped, closed mesh: by the pseudo-normals of the capped mesh, and by the nearest cap
/// instead when a cap is strictly closer than the mesh (a query seen through a hole). This is
/// exact for holes whose fan cap does not cut through the mesh (roughly planar, star-shaped
/// rims, as scan holes are); warning() says when it is in use. A degenerate triangle
/// (zero area) has a zero face normal and adds nothing to its edges' and vertices'
/// pseudo-normals; a query whose feature has a zero pseudo-normal is reported outside.
///
/// Thread safety: the query functions are const and may run concurrently; refit() may not run
/// concurrently with anything else on the same index. A moved-from index may only be destroyed
/// or assigned to. Embree failures (out of memory, invalid
/// input that slipped past validation) throw std::runtime_error naming the Embree call.
class ProximityIndex {
public:
  /// Builds the index. positions: #V × 3 (m); triangles: #F × 3 vertex indices in [0, #V),
  /// counter-clockwise seen from outside. Throws vfit::Error ("proximity mesh: …") for a
  /// non-finite coordinate or an index out of range, naming the vertex or triangle.
  /// An empty mesh (#F = 0) is allowed: every query then reports no hit. Boundary edges are
  /// found here; a mesh with holes is capped for the side test (see the class comment).
  /// `open_side` says how a mesh with holes is treated (OpenMeshSide); a closed mesh is the
  /// same either way.
  ProximityIndex(std::span<const float> positions, std::span<const std::int32_t> triangles,
                 OpenMeshSide open_side = OpenMeshSide::CAP_HOLES);
  ~ProximityIndex();
  ProximityIndex(ProximityIndex&&) noexcept;
  ProximityIndex& operator=(ProximityIndex&&) noexcept;
  ProximityIndex(const ProximityIndex&) = delete;
  ProximityIndex& operator=(const ProximityIndex&) = delete;

  /// Moves the vertices (same topology, e.g. an animated body): positions is #V × 3 (m) with
  /// the #V of construction (otherwise vfit::Error). Refits the BVH bounds and recomputes the
  /// pseudo-normals and hole caps; answers afterwards equal those of a fresh index over the same
  /// positions.
  void refit(std::span<const float> positions);

  /// Closest points of `queries` (#Q × 3, m), TBB-parallel over the queries (grain
  /// PROXIMITY_QUERY_GRAIN). Only triangles within `max_distance` (m, ≥ 0; +∞ for no limit)
  /// count: a query farther than that from the mesh reports no hit. `hits` is resized to #Q.
  /// Ties between equally close triangles go to the lower triangle index when both are seen.
  /// An empty span gives empty hits. Throws vfit::Error ("proximity queries: …") naming the
  /// first query with a NaN or infinite coordinate, for a size not a multiple of 3, and for a
  /// negative or NaN max_distance; the check is one pass over the queries.
  void closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const;

  /// As above with a search radius per query: `max_distances` is #Q (m, each ≥ 0 or +∞), query
  /// i seeing only triangles within max_distances[i]. For re-queries whose previous closest
  /// point bounds the new distance (a small radius prunes most of the BVH traversal). Throws
  /// vfit::Error ("proximity queries: …") as above, and when max_distances.size() ≠ #Q or a
  /// radius is negative or NaN.
  void closest_points(std::span<const float> queries, std::span<const float> max_distances, ClosestHits& hits) const;

  /// Re-queries points that moved a little since `hits` answered them (same index, same #Q,
  /// e.g. a garment shifted by a few millimetres between two rounds of a placement search).
  /// The previous closest point of query i still lies on the mesh, so the new closest
  /// distance is at most |queries_i − hits.points_i|: query i searches only that far (times
  /// 1 + 1e-5, plus 1e-6 m for float rounding), which prunes most of Embree's traversal. The
  /// answers equal closest_points(queries, max_distance, hits) but for ties between equally
  /// close triangles. A row without a previous hit searches within `max_distance` (m, ≥ 0 or
  /// +∞). Throws vfit::Error ("proximity queries: …") as closest_points() does, and when
  /// hits.size() ≠ #Q. O(#Q · log #F) for small moves.
  void requery_closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const;

  /// Serial reference of closest_points(): the same Embree query, one point after another.
  void closest_points_serial(std::span<const float> queries, float max_distance, ClosestHits& hits) const;

  /// Brute-force reference for tests and benchmarks: every triangle is measured for every
  /// query (O(#Q·#F), serial), with the same per-triangle math and tie rule as the BVH path.
  void closest_points_brute_force(std::span<const float> queries, float max_distance, ClosestHits& hits) const;

  /// First meeting of each segment a_i → b_i (starts `from`, ends `to`: #S × 3 each, m) with the
  /// mesh or, on a mesh with holes, its caps (so a segment through a hole meets the surface the
  /// side test sees): Embree ray casts over the index's BVH, both faces counted (the normal tells
  /// which side was met: (b − a)·n < 0 enters the closed mesh). TBB-parallel (grain
  /// PROXIMITY_QUERY_GRAIN). Throws vfit::Error ("proximity segments: …") when the sizes differ
  /// or are not multiples of 3, or naming the first segment with a non-finite coordinate. A
  /// segment of zero length meets nothing.
  void first_hits(std::span<const float> from, std::span<const float> to, SegmentHits& hits) const;

  /// Brute-force reference of first_hits() for tests: every triangle (caps included) intersected
  /// with every segment (Möller–Trumbore in double), the smallest t kept, ties to the lower face.
  void first_hits_brute_force(std::span<const float> from, std::span<const float> to, SegmentHits& hits) const;

  /// #V and #F of the indexed mesh.
  std::size_t vertex_count() const;
  std::size_t face_count() const;

  /// Number of holes (boundary loops) found at construction; 0 for a closed mesh.
  std::size_t hole_count() const;
  /// Empty for a closed mesh or OpenMeshSide::ONE_SIDED; otherwise "the body has N holes; the
  /// side is decided as if they were closed", for callers to pass on to the user.
  std::string warning() const;

  /// The capped mesh and pseudo-normals the side is decided with (see ProximitySideMesh).
  ProximitySideMesh side_mesh() const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// The search radius (m) within which a query at `query` (x, y, z; m) finds its closest point
/// on a mesh again, given `previous` (x, y, z; m), a point of that mesh (an earlier answer):
/// |query − previous| in double, widened for float rounding (× (1 + 1e-5), + 1e-6 m). The
/// closest distance is at most |query − previous|, so a search within this radius answers as an
/// unlimited one but for ties between equally close triangles, while Embree prunes the rest of
/// the mesh at once. O(1).
inline float requery_radius(const float* query, const float* previous) {
  double d2 = 0;
  for (int c = 0; c < 3; ++c) {
    const double d = double(query[c]) - double(previous[c]);
    d2 += d * d;
  }
  return float(std::sqrt(d2)) * (1.0f + 1e-5f) + 1e-6f;
}

/// The validation every closest-point entry runs first, in one pass over the queries: throws
/// vfit::Error ("proximity queries: …") when queries.size() is not a multiple of 3, when
/// max_distance is negative or NaN, or naming the first query with a NaN or infinite coordinate.
void check_proximity_queries(std::span<const float> queries, float max_distance);

/// One-call wrapper: builds a ProximityIndex over (positions, triangles) and answers
/// `queries` with closest_points(). Shapes, units and signs as there.
void closest_points(std::span<const float> positions, std::span<const std::int32_t> triangles,
                    std::span<const float> queries, float max_distance, ClosestHits& hits);

} // namespace vfit
