// SPDX-License-Identifier: Apache-2.0
#include "edge_crossings.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "embree_device.h"
#include "parallel.h"
#include "pseudo_normals.h"

namespace vfit {
namespace {

struct CrossingData {
  embree::ErrorLog errors; // declared first, so it outlives the device whose callback points at it
  embree::DevicePtr device;
  embree::ScenePtr scene;
  embree::GeometryPtr geometry; // null for an empty mesh
  // Shared with Embree; one float of padding after #V × 3 for its 16-byte vertex loads.
  std::vector<float> positions;
  std::vector<std::int32_t> triangles;
  std::size_t face_count = 0;
};

void write_none(SegmentCrossings& c, std::size_t i) {
  c.triangles[i] = -1;
  c.parameters[i] = std::numeric_limits<float>::infinity();
  c.barycentrics[2 * i] = 0.0f;
  c.barycentrics[2 * i + 1] = 0.0f;
}

void first_crossings_range(const CrossingData& s, std::span<const float> points, std::span<const std::int32_t> edges,
                           SegmentCrossings& out, std::size_t begin, std::size_t end) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (std::size_t i = begin; i < end; ++i) {
    write_none(out, i);
    if (!s.geometry) continue;
    const float* a = points.data() + 3 * static_cast<std::size_t>(edges[2 * i]);
    const float* b = points.data() + 3 * static_cast<std::size_t>(edges[2 * i + 1]);
    RTCRayHit rh;
    rh.ray.org_x = a[0];
    rh.ray.org_y = a[1];
    rh.ray.org_z = a[2];
    rh.ray.dir_x = b[0] - a[0];
    rh.ray.dir_y = b[1] - a[1];
    rh.ray.dir_z = b[2] - a[2];
    if (rh.ray.dir_x == 0.0f && rh.ray.dir_y == 0.0f && rh.ray.dir_z == 0.0f) continue;
    // The direction is the whole segment, so t ∈ [0, 1] is exactly the segment.
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = 1.0f;
    rh.ray.time = 0.0f;
    rh.ray.mask = std::numeric_limits<unsigned>::max();
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s.scene.get(), &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
    out.triangles[i] = static_cast<std::int32_t>(rh.hit.primID);
    out.parameters[i] = rh.ray.tfar;
    out.barycentrics[2 * i] = rh.hit.u;
    out.barycentrics[2 * i + 1] = rh.hit.v;
  }
}

struct Vec3d {
  double x, y, z;
};
Vec3d sub(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3d cross(Vec3d a, Vec3d b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double dot(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3d load(const float* p, std::int32_t v) {
  const float* q = p + 3 * static_cast<std::size_t>(v);
  return {q[0], q[1], q[2]};
}

// Möller–Trumbore: the parameter t of segment origin + t·dir on triangle (p0, p1, p2), both
// sides, with barycentrics; false for no intersection or a segment in the triangle's plane.
bool segment_triangle(Vec3d origin, Vec3d dir, Vec3d p0, Vec3d p1, Vec3d p2, double& t, double& u, double& v) {
  const Vec3d e1 = sub(p1, p0), e2 = sub(p2, p0);
  const Vec3d p = cross(dir, e2);
  const double det = dot(e1, p);
  if (det == 0.0) return false;
  const double inv = 1.0 / det;
  const Vec3d s = sub(origin, p0);
  u = dot(s, p) * inv;
  if (u < 0.0 || u > 1.0) return false;
  const Vec3d q = cross(s, e1);
  v = dot(dir, q) * inv;
  if (v < 0.0 || u + v > 1.0) return false;
  t = dot(e2, q) * inv;
  return t >= 0.0 && t <= 1.0;
}

void check_segments(std::span<const float> points, std::span<const std::int32_t> edges) {
  assert(points.size() % 3 == 0 && edges.size() % 2 == 0 && "points are #P × 3, edges #E × 2");
  assert(std::all_of(edges.begin(), edges.end(),
                     [&](std::int32_t v) { return v >= 0 && std::size_t(v) < points.size() / 3; }) &&
         "edge endpoint out of range");
  (void)points;
  (void)edges;
}

} // namespace

std::vector<std::int32_t> mesh_edge_endpoints(std::span<const std::int32_t> triangles, std::size_t vertex_count) {
  const MeshEdges edges = build_mesh_edges(triangles, vertex_count);
  std::vector<std::int32_t> ends(2 * edges.edge_count());
  for (std::size_t f = 0; f < triangles.size() / 3; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::size_t e = static_cast<std::size_t>(edges.triangle_edges[3 * f + k]);
      const std::int32_t a = triangles[3 * f + k], b = triangles[3 * f + (k + 1) % 3];
      ends[2 * e] = std::min(a, b);
      ends[2 * e + 1] = std::max(a, b);
    }
  return ends;
}

void SegmentCrossings::resize(std::size_t segment_count) {
  triangles.resize(segment_count);
  parameters.resize(segment_count);
  barycentrics.resize(2 * segment_count);
}

std::size_t SegmentCrossings::crossing_count() const {
  return static_cast<std::size_t>(
      std::count_if(triangles.begin(), triangles.end(), [](std::int32_t f) { return f >= 0; }));
}

struct EdgeCrossingIndex::Impl : CrossingData {};

EdgeCrossingIndex::EdgeCrossingIndex(std::span<const float> positions, std::span<const std::int32_t> triangles)
    : m_impl(std::make_unique<Impl>()) {
  assert(positions.size() % 3 == 0 && triangles.size() % 3 == 0 && "positions and triangles must be rows of 3");
  Impl& m = *m_impl;
  const std::size_t vertex_count = positions.size() / 3;
  m.face_count = triangles.size() / 3;
  m.positions.assign(positions.begin(), positions.end());
  m.positions.push_back(0.0f);
  m.triangles.assign(triangles.begin(), triangles.end());
  m.device = embree::make_device(m.errors);
  m.scene.reset(rtcNewScene(m.device.get()));
  embree::throw_if_failed(m.errors, "rtcNewScene");
  // Robust (watertight) traversal: a garment edge through the shared edge of two body triangles
  // must count as a crossing.
  rtcSetSceneFlags(m.scene.get(), RTC_SCENE_FLAG_ROBUST);
  embree::throw_if_failed(m.errors, "rtcSetSceneFlags");
  if (m.face_count > 0) {
    m.geometry.reset(rtcNewGeometry(m.device.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
    embree::throw_if_failed(m.errors, "rtcNewGeometry");
    RTCGeometry g = m.geometry.get();
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.positions.data(), 0,
                               3 * sizeof(float), vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.triangles.data(), 0,
                               3 * sizeof(std::int32_t), m.face_count);
    embree::throw_if_failed(m.errors, "rtcSetSharedGeometryBuffer");
    rtcCommitGeometry(g);
    embree::throw_if_failed(m.errors, "rtcCommitGeometry");
    rtcAttachGeometry(m.scene.get(), g);
    embree::throw_if_failed(m.errors, "rtcAttachGeometry");
  }
  rtcCommitScene(m.scene.get());
  embree::throw_if_failed(m.errors, "rtcCommitScene");
}

EdgeCrossingIndex::~EdgeCrossingIndex() = default;
EdgeCrossingIndex::EdgeCrossingIndex(EdgeCrossingIndex&&) noexcept = default;
EdgeCrossingIndex& EdgeCrossingIndex::operator=(EdgeCrossingIndex&&) noexcept = default;

void EdgeCrossingIndex::first_crossings(std::span<const float> points, std::span<const std::int32_t> edges,
                                        SegmentCrossings& crossings) const {
  check_segments(points, edges);
  const std::size_t count = edges.size() / 2;
  crossings.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, EDGE_CROSSING_GRAIN,
                     [&](std::size_t b, std::size_t e) { first_crossings_range(m, points, edges, crossings, b, e); });
  embree::throw_if_failed(m_impl->errors, "rtcIntersect1");
}

void EdgeCrossingIndex::first_crossings_serial(std::span<const float> points, std::span<const std::int32_t> edges,
                                               SegmentCrossings& crossings) const {
  check_segments(points, edges);
  crossings.resize(edges.size() / 2);
  first_crossings_range(*m_impl, points, edges, crossings, 0, edges.size() / 2);
  embree::throw_if_failed(m_impl->errors, "rtcIntersect1");
}

void EdgeCrossingIndex::first_crossings_brute_force(std::span<const float> points, std::span<const std::int32_t> edges,
                                                    SegmentCrossings& crossings) const {
  check_segments(points, edges);
  const Impl& m = *m_impl;
  const std::size_t count = edges.size() / 2;
  crossings.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    write_none(crossings, i);
    const Vec3d a = load(points.data(), edges[2 * i]);
    const Vec3d dir = sub(load(points.data(), edges[2 * i + 1]), a);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t f = 0; f < m.face_count; ++f) {
      const std::int32_t* t = m.triangles.data() + 3 * f;
      double tf = 0, u = 0, v = 0;
      if (!segment_triangle(a, dir, load(m.positions.data(), t[0]), load(m.positions.data(), t[1]),
                            load(m.positions.data(), t[2]), tf, u, v) ||
          tf >= best)
        continue;
      best = tf;
      crossings.triangles[i] = static_cast<std::int32_t>(f);
      crossings.parameters[i] = static_cast<float>(tf);
      crossings.barycentrics[2 * i] = static_cast<float>(u);
      crossings.barycentrics[2 * i + 1] = static_cast<float>(v);
    }
  }
}

void EdgeCrossingIndex::face_normal(std::int32_t f, float normal[3]) const {
  const Impl& m = *m_impl;
  assert(f >= 0 && std::size_t(f) < m.face_count && "triangle out of range");
  const std::int32_t* t = m.triangles.data() + 3 * static_cast<std::size_t>(f);
  const Vec3d p0 = load(m.positions.data(), t[0]);
  const Vec3d n = cross(sub(load(m.positions.data(), t[1]), p0), sub(load(m.positions.data(), t[2]), p0));
  const double len = std::sqrt(dot(n, n));
  const double s = len > 0.0 ? 1.0 / len : 0.0;
  normal[0] = static_cast<float>(n.x * s);
  normal[1] = static_cast<float>(n.y * s);
  normal[2] = static_cast<float>(n.z * s);
}

std::size_t EdgeCrossingIndex::face_count() const { return m_impl->face_count; }

} // namespace vfit
