// SPDX-License-Identifier: Apache-2.0
#include "proximity.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>

#include "embree_device.h"
#include "error.h"
#include "hole_caps.h"
#include "parallel.h"
#include "pseudo_normals.h"
#include "vertex_normals.h"

namespace vfit {
namespace {
using std::sqrt;                // the shared math headers call sqrt(float) as OpenCL C does.
#include "closest_point_math.h" // first: the two below are written against its types

#include "capped_surface.h"
#include "closest_hit_row.h"

static_assert(static_cast<int>(TriangleFeature::NONE) == VFIT_FEATURE_NONE);
static_assert(static_cast<int>(TriangleFeature::FACE) == VFIT_FEATURE_FACE);
static_assert(static_cast<int>(TriangleFeature::EDGE_0) == VFIT_FEATURE_EDGE_0);
static_assert(static_cast<int>(TriangleFeature::VERTEX_0) == VFIT_FEATURE_VERTEX_0);
static_assert(static_cast<int>(TriangleFeature::VERTEX_2) == VFIT_FEATURE_VERTEX_2);

// Everything the index owns; ProximityIndex::Impl is this under the name the header declares.
struct IndexData : CappedSurface {
  embree::ErrorLog errors; // declared first, so it outlives the device whose callback points at it
  embree::DevicePtr device;
  embree::ScenePtr scene;
  embree::GeometryPtr geometry; // null for an empty mesh
  // The hole caps of an open mesh (geometry id 1 of the scene); null for a closed mesh. The
  // capped positions are shared with Embree, with one float of padding (16-byte loads).
  embree::GeometryPtr cap_geometry;
};

// Per-query state handed to Embree's callback through userPtr. best is the closest mesh
// triangle; best_cap the closest cap triangle (capped-mesh face index), tracked only on an open
// mesh and only while it is at least as close as best.
struct QueryState {
  const IndexData* index;
  vfit_vec3 query;
  vfit_closest_point best;
  float reach; // CappedSurface::reach_of(best.distance2)
  std::uint32_t best_triangle;
  vfit_closest_point best_cap;
  std::uint32_t best_cap_triangle;
};

QueryState start_query(const IndexData& index, const float* q, float max_distance) {
  QueryState s{&index, vfit_vec3{q[0], q[1], q[2]}, {}, 0.0f, NO_TRIANGLE, {}, NO_TRIANGLE};
  s.best.distance2 = max_distance * max_distance;
  s.reach = CappedSurface::reach_of(s.best.distance2);
  s.best_cap.distance2 = s.best.distance2;
  return s;
}

// A cap triangle strictly closer than the mesh hit so far decides the side; it never shrinks
// the search radius, which the mesh triangles alone set.
void consider_cap(QueryState& s, std::uint32_t capped_face) {
  const vfit_closest_point c = s.index->closest_on(s.query, capped_face);
  if (c.distance2 >= s.best_cap.distance2 || c.distance2 >= s.best.distance2) return;
  s.best_cap = c;
  s.best_cap_triangle = capped_face;
}

// Called by rtcPointQuery for every triangle whose bounds meet the query sphere; shrinking the
// radius to the best distance so far prunes the rest of the traversal.
bool closest_triangle_callback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<QueryState*>(args->userPtr);
  if (args->geomID != 0) {
    consider_cap(*s, static_cast<std::uint32_t>(s->index->face_count) + args->primID);
    return false;
  }
  if (s->index->cannot_improve(s->query, args->primID, s->reach)) return false;
  const vfit_closest_point c = s->index->closest_on(s->query, args->primID);
  if (!improves(c.distance2, args->primID, s->best.distance2, s->best_triangle)) return false;
  s->best = c;
  s->reach = CappedSurface::reach_of(c.distance2);
  s->best_triangle = args->primID;
  args->query->radius = std::sqrt(c.distance2);
  return true;
}

void write_hit(const IndexData& index, const QueryState& s, std::size_t i, ClosestHits& hits) {
  write_closest_hit(
      s.query, s.best, s.best_triangle, s.best_cap, s.best_cap_triangle,
      [&](std::uint32_t t, int feature) { return index.feature_normal(t, feature); }, i, hits);
}

// `radii` empty: every query searches within max_distance; otherwise query i within radii[i].
// (Starting each query from the previous one's closest triangle was tried: ~2 % faster on a
// garment's vertices in mesh order, but on incoherent queries its exact computation is a few
// cache misses for nothing: random queries on a 100k-triangle sphere fell from ~0.93 to
// ~0.82 of raw Embree's rate.)
void closest_points_range(const IndexData& index, std::span<const float> queries, float max_distance,
                          std::span<const float> radii, ClosestHits& hits, std::size_t begin, std::size_t end) {
  for (std::size_t i = begin; i < end; ++i) {
    if (!radii.empty()) max_distance = radii[i];
    QueryState s = start_query(index, queries.data() + 3 * i, max_distance);
    if (index.geometry) {
      RTCPointQuery query;
      query.x = s.query.x;
      query.y = s.query.y;
      query.z = s.query.z;
      query.time = 0.0f;
      query.radius = max_distance;
      RTCPointQueryContext context;
      rtcInitPointQueryContext(&context);
      rtcPointQuery(index.scene.get(), &query, &context, closest_triangle_callback, &s);
    }
    write_hit(index, s, i, hits);
  }
}

void brute_force_range(const IndexData& index, std::span<const float> queries, float max_distance, ClosestHits& hits,
                       std::size_t begin, std::size_t end) {
  for (std::size_t i = begin; i < end; ++i) {
    QueryState s = start_query(index, queries.data() + 3 * i, max_distance);
    for (std::uint32_t f = 0; f < index.face_count; ++f) {
      const vfit_closest_point c = index.closest_on(s.query, f);
      if (!improves(c.distance2, f, s.best.distance2, s.best_triangle)) continue;
      s.best = c;
      s.best_triangle = f;
    }
    for (std::size_t f = index.face_count; f < index.capped_face_count; ++f)
      consider_cap(s, static_cast<std::uint32_t>(f));
    write_hit(index, s, i, hits);
  }
}

void check_queries(std::span<const float> queries, float max_distance) {
  if (queries.size() % 3 != 0)
    throw Error("proximity queries", 0, "expected #Q × 3 coordinates, got " + std::to_string(queries.size()));
  if (!(max_distance >= 0.0f))
    throw Error("proximity queries", 0, "max_distance must be ≥ 0 (or +inf), got " + std::to_string(max_distance));
  bool finite = true;
  for (const float x : queries)
    finite &= std::isfinite(x);
  if (finite) return;
  for (std::size_t i = 0; i < queries.size(); ++i)
    if (!std::isfinite(queries[i]))
      throw Error("proximity queries", 0,
                  "query " + std::to_string(i / 3) + " has a non-finite coordinate (NaN or infinity)");
}

// The mesh a ProximityIndex is built over: finite coordinates, indices in range.
void check_mesh(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  if (positions.size() % 3 != 0 || triangles.size() % 3 != 0)
    throw Error("proximity mesh", 0, "positions and triangles must be rows of 3");
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (!std::isfinite(positions[i]))
      throw Error("proximity mesh", 0, "vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  const std::size_t vertex_count = positions.size() / 3;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= vertex_count)
      throw Error("proximity mesh", 0,
                  "triangle " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(vertex_count) + ")");
}

// Shares the capped vertex buffer and `count` rows of the index buffer from row `first` with
// a new triangle geometry of REFIT quality, commits and attaches it (geometry ids 0, 1 in order).
embree::GeometryPtr attach_triangles(IndexData& m, std::size_t first, std::size_t count) {
  embree::GeometryPtr geometry(rtcNewGeometry(m.device.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
  embree::throw_if_failed(m.errors, "rtcNewGeometry");
  RTCGeometry g = geometry.get();
  rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0, 3 * sizeof(float),
                             m.capped_vertex_count);
  rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.triangles.data(),
                             3 * sizeof(std::int32_t) * first, 3 * sizeof(std::int32_t), count);
  embree::throw_if_failed(m.errors, "rtcSetSharedGeometryBuffer");
  rtcCommitGeometry(g);
  embree::throw_if_failed(m.errors, "rtcCommitGeometry");
  rtcAttachGeometry(m.scene.get(), g);
  embree::throw_if_failed(m.errors, "rtcAttachGeometry");
  return geometry;
}
} // namespace

struct ProximityIndex::Impl : IndexData {};

// One pass over the queries: a NaN or infinite coordinate would make Embree's traversal and our
// distances meaningless (NaN compares false everywhere), so it is refused up front.
void check_proximity_queries(std::span<const float> queries, float max_distance) {
  check_queries(queries, max_distance);
}

void ClosestHits::resize(std::size_t query_count) {
  points.resize(3 * query_count);
  triangles.resize(query_count);
  barycentrics.resize(2 * query_count);
  signed_distances.resize(query_count);
  features.resize(query_count);
}

void ClosestHits::copy_row(std::size_t row, const ClosestHits& from, std::size_t from_row) {
  for (std::size_t c = 0; c < 3; ++c)
    points[3 * row + c] = from.points[3 * from_row + c];
  triangles[row] = from.triangles[from_row];
  barycentrics[2 * row] = from.barycentrics[2 * from_row];
  barycentrics[2 * row + 1] = from.barycentrics[2 * from_row + 1];
  signed_distances[row] = from.signed_distances[from_row];
  features[row] = from.features[from_row];
}

ProximityIndex::ProximityIndex(std::span<const float> positions, std::span<const std::int32_t> triangles,
                               OpenMeshSide open_side)
    : m_impl(std::make_unique<Impl>()) {
  check_mesh(positions, triangles);
  Impl& m = *m_impl;
  assert(positions.size() / 3 < NO_TRIANGLE / 2 && triangles.size() / 3 < NO_TRIANGLE / 2 &&
         "mesh too large for 32-bit indices");
  m.build(positions, triangles, open_side, 1);

  m.device = embree::make_device(m.errors);
  m.scene.reset(rtcNewScene(m.device.get()));
  embree::throw_if_failed(m.errors, "rtcNewScene");
  // A dynamic scene of low quality selects Embree's two-level structure, the one that honours
  // the per-geometry REFIT quality below: refit() then updates the bounds of the SAH-built
  // tree instead of rebuilding it (2 ms instead of 25–50 ms for 100k triangles; without the
  // DYNAMIC flag Embree 3.13 rebuilds).
  rtcSetSceneFlags(m.scene.get(), RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_DYNAMIC);
  rtcSetSceneBuildQuality(m.scene.get(), RTC_BUILD_QUALITY_LOW);
  embree::throw_if_failed(m.errors, "rtcSetSceneBuildQuality");
  if (m.face_count > 0) {
    m.geometry = attach_triangles(m, 0, m.face_count);
    if (m.capped_face_count > m.face_count)
      m.cap_geometry = attach_triangles(m, m.face_count, m.capped_face_count - m.face_count);
  }
  rtcCommitScene(m.scene.get());
  embree::throw_if_failed(m.errors, "rtcCommitScene");
}

ProximityIndex::~ProximityIndex() = default;
ProximityIndex::ProximityIndex(ProximityIndex&&) noexcept = default;
ProximityIndex& ProximityIndex::operator=(ProximityIndex&&) noexcept = default;

void ProximityIndex::refit(std::span<const float> positions) {
  Impl& m = *m_impl;
  if (positions.size() != 3 * m.vertex_count)
    throw Error("proximity refit", 0,
                "expected " + std::to_string(m.vertex_count) + " × 3 coordinates, got " +
                    std::to_string(positions.size()));
  std::copy(positions.begin(), positions.end(), m.positions.begin());
  m.update_normals();
  if (!m.geometry) return;
  for (RTCGeometry g : {m.geometry.get(), m.cap_geometry.get()}) {
    if (!g) continue;
    rtcUpdateGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0);
    embree::throw_if_failed(m.errors, "rtcUpdateGeometryBuffer");
    rtcCommitGeometry(g);
    embree::throw_if_failed(m.errors, "rtcCommitGeometry");
  }
  rtcCommitScene(m.scene.get());
  embree::throw_if_failed(m.errors, "rtcCommitScene");
}

void ProximityIndex::closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const {
  check_queries(queries, max_distance);
  const std::size_t count = queries.size() / 3;
  hits.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, PROXIMITY_QUERY_GRAIN, [&](std::size_t b, std::size_t e) {
    closest_points_range(m, queries, max_distance, {}, hits, b, e);
  });
  embree::throw_if_failed(m_impl->errors, "rtcPointQuery");
}

void ProximityIndex::closest_points(std::span<const float> queries, std::span<const float> max_distances,
                                    ClosestHits& hits) const {
  check_queries(queries, 0.0f);
  const std::size_t count = queries.size() / 3;
  if (max_distances.size() != count)
    throw Error("proximity queries", 0,
                "expected " + std::to_string(count) + " search radii, got " + std::to_string(max_distances.size()));
  for (std::size_t i = 0; i < count; ++i)
    if (!(max_distances[i] >= 0.0f))
      throw Error("proximity queries", 0,
                  "query " + std::to_string(i) + " has search radius " + std::to_string(max_distances[i]) +
                      " (must be ≥ 0 or +inf)");
  hits.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, PROXIMITY_QUERY_GRAIN, [&](std::size_t b, std::size_t e) {
    closest_points_range(m, queries, 0.0f, max_distances, hits, b, e);
  });
  embree::throw_if_failed(m_impl->errors, "rtcPointQuery");
}

void ProximityIndex::requery_closest_points(std::span<const float> queries, float max_distance,
                                            ClosestHits& hits) const {
  check_queries(queries, max_distance);
  const std::size_t count = queries.size() / 3;
  if (hits.size() != count)
    throw Error("proximity queries", 0,
                "re-query of " + std::to_string(count) + " points with " + std::to_string(hits.size()) +
                    " previous answers");
  std::vector<float> radii(count, max_distance);
  for (std::size_t i = 0; i < count; ++i) {
    if (hits.triangles[i] >= 0) radii[i] = std::min(max_distance, requery_radius(&queries[3 * i], &hits.points[3 * i]));
  }
  closest_points(queries, radii, hits);
}

void ProximityIndex::closest_points_serial(std::span<const float> queries, float max_distance,
                                           ClosestHits& hits) const {
  check_queries(queries, max_distance);
  hits.resize(queries.size() / 3);
  closest_points_range(*m_impl, queries, max_distance, {}, hits, 0, queries.size() / 3);
  embree::throw_if_failed(m_impl->errors, "rtcPointQuery");
}

void ProximityIndex::closest_points_brute_force(std::span<const float> queries, float max_distance,
                                                ClosestHits& hits) const {
  check_queries(queries, max_distance);
  hits.resize(queries.size() / 3);
  brute_force_range(*m_impl, queries, max_distance, hits, 0, queries.size() / 3);
}

std::size_t ProximityIndex::vertex_count() const { return m_impl->vertex_count; }
std::size_t ProximityIndex::face_count() const { return m_impl->face_count; }
std::size_t ProximityIndex::hole_count() const { return m_impl->hole_count; }

std::string ProximityIndex::warning() const {
  const std::size_t holes = m_impl->caps.loop_count();
  if (holes == 0) return {};
  return "the body has " + std::to_string(holes) + (holes == 1 ? " hole" : " holes") + "; the side is decided as if " +
         (holes == 1 ? "it were" : "they were") + " closed";
}

void SegmentHits::resize(std::size_t segment_count) {
  triangles.resize(segment_count);
  t.resize(segment_count);
  normals.resize(3 * segment_count);
}

namespace {
void check_segments(std::span<const float> from, std::span<const float> to) {
  if (from.size() != to.size() || from.size() % 3 != 0)
    throw Error("proximity segments", 0,
                "starts and ends must be rows of 3 of the same count, got " + std::to_string(from.size()) + " and " +
                    std::to_string(to.size()) + " coordinates");
  for (std::size_t i = 0; i < from.size(); ++i)
    if (!std::isfinite(from[i]) || !std::isfinite(to[i]))
      throw Error("proximity segments", 0,
                  "segment " + std::to_string(i / 3) + " has a non-finite coordinate (NaN or infinity)");
}

// Row i of `hits` for face f of the capped mesh (mesh faces first, then caps) met at t.
void write_segment_hit(const IndexData& m, std::size_t face, float t, std::size_t i, SegmentHits& hits) {
  hits.triangles[i] = face < m.face_count ? static_cast<std::int32_t>(face) : -2;
  hits.t[i] = t;
  for (std::size_t k = 0; k < 3; ++k)
    hits.normals[3 * i + k] = m.normals.faces[3 * face + k];
}

void write_segment_miss(std::size_t i, SegmentHits& hits) {
  hits.triangles[i] = -1;
  hits.t[i] = std::numeric_limits<float>::infinity();
  for (std::size_t k = 0; k < 3; ++k)
    hits.normals[3 * i + k] = 0.0f;
}
} // namespace

void ProximityIndex::first_hits(std::span<const float> from, std::span<const float> to, SegmentHits& hits) const {
  check_segments(from, to);
  const std::size_t count = from.size() / 3;
  hits.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, PROXIMITY_QUERY_GRAIN, [&](std::size_t b, std::size_t e) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (std::size_t i = b; i < e; ++i) {
      RTCRayHit rh{};
      rh.ray.org_x = from[3 * i];
      rh.ray.org_y = from[3 * i + 1];
      rh.ray.org_z = from[3 * i + 2];
      rh.ray.dir_x = to[3 * i] - from[3 * i];
      rh.ray.dir_y = to[3 * i + 1] - from[3 * i + 1];
      rh.ray.dir_z = to[3 * i + 2] - from[3 * i + 2];
      rh.ray.tnear = 0.0f;
      rh.ray.tfar = 1.0f; // the direction is the segment itself: t ∈ [0, 1]
      rh.ray.mask = 0xFFFFFFFFu;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      const bool empty = rh.ray.dir_x == 0.0f && rh.ray.dir_y == 0.0f && rh.ray.dir_z == 0.0f;
      if (!empty && m.geometry) rtcIntersect1(m.scene.get(), &context, &rh);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        write_segment_miss(i, hits);
        continue;
      }
      // Geometry 0 holds the mesh's faces, geometry 1 the caps (attach_triangles' order).
      const std::size_t face = rh.hit.geomID == 0 ? rh.hit.primID : m.face_count + rh.hit.primID;
      write_segment_hit(m, face, rh.ray.tfar, i, hits);
    }
  });
  embree::throw_if_failed(m_impl->errors, "rtcIntersect1");
}

void ProximityIndex::first_hits_brute_force(std::span<const float> from, std::span<const float> to,
                                            SegmentHits& hits) const {
  check_segments(from, to);
  const std::size_t count = from.size() / 3;
  hits.resize(count);
  const Impl& m = *m_impl;
  for (std::size_t i = 0; i < count; ++i) {
    const double a[3] = {from[3 * i], from[3 * i + 1], from[3 * i + 2]};
    const double d[3] = {to[3 * i] - a[0], to[3 * i + 1] - a[1], to[3 * i + 2] - a[2]};
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_face = 0;
    for (std::size_t f = 0; f < m.capped_face_count; ++f) {
      const float* p0 = m.positions.data() + 3 * static_cast<std::size_t>(m.triangles[3 * f]);
      const float* p1 = m.positions.data() + 3 * static_cast<std::size_t>(m.triangles[3 * f + 1]);
      const float* p2 = m.positions.data() + 3 * static_cast<std::size_t>(m.triangles[3 * f + 2]);
      const double e1[3] = {double(p1[0]) - p0[0], double(p1[1]) - p0[1], double(p1[2]) - p0[2]};
      const double e2[3] = {double(p2[0]) - p0[0], double(p2[1]) - p0[1], double(p2[2]) - p0[2]};
      const double pv[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
      const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
      if (det == 0.0) continue; // parallel to the plane (or a degenerate face)
      const double tv[3] = {a[0] - p0[0], a[1] - p0[1], a[2] - p0[2]};
      const double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
      if (u < 0.0 || u > 1.0) continue;
      const double qv[3] = {tv[1] * e1[2] - tv[2] * e1[1], tv[2] * e1[0] - tv[0] * e1[2],
                            tv[0] * e1[1] - tv[1] * e1[0]};
      const double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
      if (v < 0.0 || u + v > 1.0) continue;
      const double t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
      if (t < 0.0 || t > 1.0 || t >= best) continue;
      best = t;
      best_face = f;
    }
    if (best == std::numeric_limits<double>::infinity())
      write_segment_miss(i, hits);
    else
      write_segment_hit(m, best_face, static_cast<float>(best), i, hits);
  }
}

ProximitySideMesh ProximityIndex::side_mesh() const {
  const Impl& m = *m_impl;
  return ProximitySideMesh{std::span<const float>(m.positions.data(), 3 * m.capped_vertex_count),
                           m.triangles,
                           m.edges.triangle_edges,
                           m.normals.faces,
                           m.normals.edges,
                           m.normals.vertices,
                           m.face_count};
}

void closest_points(std::span<const float> positions, std::span<const std::int32_t> triangles,
                    std::span<const float> queries, float max_distance, ClosestHits& hits) {
  ProximityIndex(positions, triangles).closest_points(queries, max_distance, hits);
}

} // namespace vfit
