#include "proximity.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "parallel.h"
#include "pseudo_normals.h"
#include "vertex_normals.h"

namespace vfit {
namespace {
using std::sqrt; // the shared math headers call sqrt(float) as OpenCL C does.
#include "closest_point_math.h"

static_assert(static_cast<int>(TriangleFeature::NONE) == VFIT_FEATURE_NONE);
static_assert(static_cast<int>(TriangleFeature::FACE) == VFIT_FEATURE_FACE);
static_assert(static_cast<int>(TriangleFeature::EDGE_0) == VFIT_FEATURE_EDGE_0);
static_assert(static_cast<int>(TriangleFeature::VERTEX_0) == VFIT_FEATURE_VERTEX_0);
static_assert(static_cast<int>(TriangleFeature::VERTEX_2) == VFIT_FEATURE_VERTEX_2);

// Embree reports errors through a callback, possibly from its build threads: it only records
// the first one; the wrapper throws after the call that caused it.
struct EmbreeErrorLog {
  std::mutex mutex;
  RTCError code = RTC_ERROR_NONE;
  std::string message;
};

void record_embree_error(void* user, RTCError code, const char* message) {
  auto* log = static_cast<EmbreeErrorLog*>(user);
  std::lock_guard<std::mutex> lock(log->mutex);
  if (log->code != RTC_ERROR_NONE) return;
  log->code = code;
  log->message = message ? message : "";
}

void throw_if_failed(EmbreeErrorLog& log, const char* call) {
  std::lock_guard<std::mutex> lock(log.mutex);
  if (log.code == RTC_ERROR_NONE) return;
  const std::string what =
      std::string("Embree ") + call + " failed (error " + std::to_string(int(log.code)) + "): " + log.message;
  log.code = RTC_ERROR_NONE;
  log.message.clear();
  throw std::runtime_error(what);
}

struct DeviceRelease {
  void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
};
struct SceneRelease {
  void operator()(RTCScene s) const { rtcReleaseScene(s); }
};
struct GeometryRelease {
  void operator()(RTCGeometry g) const { rtcReleaseGeometry(g); }
};
using EmbreeDevice = std::unique_ptr<RTCDeviceTy, DeviceRelease>;
using EmbreeScene = std::unique_ptr<RTCSceneTy, SceneRelease>;
using EmbreeGeometry = std::unique_ptr<RTCGeometryTy, GeometryRelease>;

vfit_vec3 load(const float* p, std::int32_t v) {
  const float* q = p + 3 * static_cast<std::size_t>(v);
  return vfit_vec3{q[0], q[1], q[2]};
}

// The tie rule shared by the BVH and brute-force paths: strictly closer, or equally close and
// a lower triangle index.
bool improves(float distance2, std::uint32_t triangle, float best_distance2, std::uint32_t best_triangle) {
  return distance2 < best_distance2 || (distance2 == best_distance2 && triangle < best_triangle);
}

constexpr std::uint32_t NO_TRIANGLE = std::numeric_limits<std::uint32_t>::max();

// Everything the index owns; ProximityIndex::Impl is this under the name the header declares.
struct IndexData {
  EmbreeErrorLog errors; // declared first, so it outlives the device whose callback points at it
  EmbreeDevice device;
  EmbreeScene scene;
  EmbreeGeometry geometry; // null for an empty mesh
  // Shared with Embree; one float of padding after #V × 3 because Embree reads vertices with
  // 16-byte loads.
  std::vector<float> positions;
  std::vector<std::int32_t> triangles; // #F × 3, shared with Embree as UINT3
  std::size_t vertex_count = 0, face_count = 0;
  MeshEdges edges;
  VertexFaceAdjacency vertex_faces;
  PseudoNormals normals;

  vfit_closest_point closest_on(vfit_vec3 q, std::uint32_t f) const {
    const std::int32_t* t = triangles.data() + 3 * static_cast<std::size_t>(f);
    const float* p = positions.data();
    return vfit_closest_point_on_triangle(q, load(p, t[0]), load(p, t[1]), load(p, t[2]));
  }

  // Pseudo-normal of `feature` of triangle f (Bærentzen & Aanæs 2005).
  const float* feature_normal(std::uint32_t f, int feature) const {
    const std::size_t row = 3 * static_cast<std::size_t>(f);
    if (feature == VFIT_FEATURE_FACE) return normals.faces.data() + row;
    if (feature <= VFIT_FEATURE_EDGE_2) {
      const std::size_t e = static_cast<std::size_t>(edges.triangle_edges[row + (feature - VFIT_FEATURE_EDGE_0)]);
      return normals.edges.data() + 3 * e;
    }
    const std::size_t v = static_cast<std::size_t>(triangles[row + (feature - VFIT_FEATURE_VERTEX_0)]);
    return normals.vertices.data() + 3 * v;
  }

  void update_normals() {
    pseudo_normals_tbb(std::span<const float>(positions.data(), 3 * vertex_count), triangles, edges, vertex_faces,
                       normals);
  }
};

// Per-query state handed to Embree's callback through userPtr.
struct QueryState {
  const IndexData* index;
  vfit_vec3 query;
  vfit_closest_point best;
  std::uint32_t best_triangle;
};

QueryState start_query(const IndexData& index, const float* q, float max_distance) {
  QueryState s{&index, vfit_vec3{q[0], q[1], q[2]}, {}, NO_TRIANGLE};
  s.best.distance2 = max_distance * max_distance;
  return s;
}

// Called by rtcPointQuery for every triangle whose bounds meet the query sphere; shrinking the
// radius to the best distance so far prunes the rest of the traversal.
bool closest_triangle_callback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<QueryState*>(args->userPtr);
  const vfit_closest_point c = s->index->closest_on(s->query, args->primID);
  if (!improves(c.distance2, args->primID, s->best.distance2, s->best_triangle)) return false;
  s->best = c;
  s->best_triangle = args->primID;
  args->query->radius = std::sqrt(c.distance2);
  return true;
}

void write_hit(const IndexData& index, const QueryState& s, std::size_t i, ClosestHits& hits) {
  if (s.best_triangle == NO_TRIANGLE) {
    hits.points[3 * i] = s.query.x;
    hits.points[3 * i + 1] = s.query.y;
    hits.points[3 * i + 2] = s.query.z;
    hits.triangles[i] = -1;
    hits.barycentrics[2 * i] = 0.0f;
    hits.barycentrics[2 * i + 1] = 0.0f;
    hits.signed_distances[i] = std::numeric_limits<float>::infinity();
    hits.features[i] = static_cast<std::int8_t>(TriangleFeature::NONE);
    return;
  }
  const vfit_closest_point& c = s.best;
  hits.points[3 * i] = c.point.x;
  hits.points[3 * i + 1] = c.point.y;
  hits.points[3 * i + 2] = c.point.z;
  hits.triangles[i] = static_cast<std::int32_t>(s.best_triangle);
  hits.barycentrics[2 * i] = c.u;
  hits.barycentrics[2 * i + 1] = c.v;
  hits.features[i] = static_cast<std::int8_t>(c.feature);
  // seed 000 eq. 18: f = (g − h)·n_h < 0 ⇒ inside, with n_h the closest feature's pseudo-normal.
  const float* n = index.feature_normal(s.best_triangle, c.feature);
  const vfit_vec3 d = vfit_v3_sub(s.query, c.point);
  const float side = d.x * n[0] + d.y * n[1] + d.z * n[2];
  const float distance = std::sqrt(c.distance2);
  hits.signed_distances[i] = side < 0.0f ? -distance : distance;
}

void closest_points_range(const IndexData& index, std::span<const float> queries, float max_distance, ClosestHits& hits,
                          std::size_t begin, std::size_t end) {
  for (std::size_t i = begin; i < end; ++i) {
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
    write_hit(index, s, i, hits);
  }
}

void check_queries(std::span<const float> queries, float max_distance) {
  assert(queries.size() % 3 == 0 && "queries must be #Q × 3");
  assert(max_distance >= 0.0f && "max_distance must be ≥ 0");
}
} // namespace

struct ProximityIndex::Impl : IndexData {};

void ClosestHits::resize(std::size_t query_count) {
  points.resize(3 * query_count);
  triangles.resize(query_count);
  barycentrics.resize(2 * query_count);
  signed_distances.resize(query_count);
  features.resize(query_count);
}

ProximityIndex::ProximityIndex(std::span<const float> positions, std::span<const std::int32_t> triangles)
    : m_impl(std::make_unique<Impl>()) {
  assert(positions.size() % 3 == 0 && triangles.size() % 3 == 0 && "positions and triangles must be rows of 3");
  Impl& m = *m_impl;
  m.vertex_count = positions.size() / 3;
  m.face_count = triangles.size() / 3;
  assert(m.vertex_count < NO_TRIANGLE && m.face_count < NO_TRIANGLE && "mesh too large for 32-bit indices");
  m.positions.assign(positions.begin(), positions.end());
  m.positions.push_back(0.0f);
  m.triangles.assign(triangles.begin(), triangles.end());
  m.edges = build_mesh_edges(triangles, m.vertex_count);
  m.vertex_faces = build_vertex_face_adjacency(triangles, m.vertex_count);
  m.update_normals();

  m.device.reset(rtcNewDevice(nullptr));
  if (!m.device)
    throw std::runtime_error("Embree rtcNewDevice failed (error " + std::to_string(int(rtcGetDeviceError(nullptr))) +
                             ")");
  rtcSetDeviceErrorFunction(m.device.get(), record_embree_error, &m.errors);
  m.scene.reset(rtcNewScene(m.device.get()));
  throw_if_failed(m.errors, "rtcNewScene");
  // A dynamic scene of low quality selects Embree's two-level structure, the one that honours
  // the per-geometry REFIT quality below: refit() then updates the bounds of the SAH-built
  // tree instead of rebuilding it (2 ms instead of 25–50 ms for 100k triangles; without the
  // DYNAMIC flag Embree 3.13 rebuilds).
  rtcSetSceneFlags(m.scene.get(), RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_DYNAMIC);
  rtcSetSceneBuildQuality(m.scene.get(), RTC_BUILD_QUALITY_LOW);
  throw_if_failed(m.errors, "rtcSetSceneBuildQuality");
  if (m.face_count > 0) {
    m.geometry.reset(rtcNewGeometry(m.device.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
    throw_if_failed(m.errors, "rtcNewGeometry");
    RTCGeometry g = m.geometry.get();
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                               3 * sizeof(float), m.vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.triangles.data(), 0,
                               3 * sizeof(std::int32_t), m.face_count);
    throw_if_failed(m.errors, "rtcSetSharedGeometryBuffer");
    rtcCommitGeometry(g);
    throw_if_failed(m.errors, "rtcCommitGeometry");
    rtcAttachGeometry(m.scene.get(), g);
    throw_if_failed(m.errors, "rtcAttachGeometry");
  }
  rtcCommitScene(m.scene.get());
  throw_if_failed(m.errors, "rtcCommitScene");
}

ProximityIndex::~ProximityIndex() = default;
ProximityIndex::ProximityIndex(ProximityIndex&&) noexcept = default;
ProximityIndex& ProximityIndex::operator=(ProximityIndex&&) noexcept = default;

void ProximityIndex::refit(std::span<const float> positions) {
  Impl& m = *m_impl;
  assert(positions.size() == 3 * m.vertex_count && "refit needs the vertex count of construction");
  std::copy(positions.begin(), positions.end(), m.positions.begin());
  m.update_normals();
  if (!m.geometry) return;
  rtcUpdateGeometryBuffer(m.geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0);
  throw_if_failed(m.errors, "rtcUpdateGeometryBuffer");
  rtcCommitGeometry(m.geometry.get());
  throw_if_failed(m.errors, "rtcCommitGeometry");
  rtcCommitScene(m.scene.get());
  throw_if_failed(m.errors, "rtcCommitScene");
}

void ProximityIndex::closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const {
  check_queries(queries, max_distance);
  const std::size_t count = queries.size() / 3;
  hits.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, PROXIMITY_QUERY_GRAIN,
                     [&](std::size_t b, std::size_t e) { closest_points_range(m, queries, max_distance, hits, b, e); });
  throw_if_failed(m_impl->errors, "rtcPointQuery");
}

void ProximityIndex::closest_points_serial(std::span<const float> queries, float max_distance,
                                           ClosestHits& hits) const {
  check_queries(queries, max_distance);
  hits.resize(queries.size() / 3);
  closest_points_range(*m_impl, queries, max_distance, hits, 0, queries.size() / 3);
  throw_if_failed(m_impl->errors, "rtcPointQuery");
}

void ProximityIndex::closest_points_brute_force(std::span<const float> queries, float max_distance,
                                                ClosestHits& hits) const {
  check_queries(queries, max_distance);
  hits.resize(queries.size() / 3);
  brute_force_range(*m_impl, queries, max_distance, hits, 0, queries.size() / 3);
}

std::size_t ProximityIndex::vertex_count() const { return m_impl->vertex_count; }
std::size_t ProximityIndex::face_count() const { return m_impl->face_count; }

void closest_points(std::span<const float> positions, std::span<const std::int32_t> triangles,
                    std::span<const float> queries, float max_distance, ClosestHits& hits) {
  ProximityIndex(positions, triangles).closest_points(queries, max_distance, hits);
}

} // namespace vfit
