// SPDX-License-Identifier: Apache-2.0
#include "ray_caster.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cstring>
#include <limits>

#include "embree_device.h"
#include "parallel.h"

namespace vfit {
namespace {

struct SceneData {
  embree::ErrorLog errors; // declared first, so it outlives the device whose callback points at it
  embree::DevicePtr device;
  embree::ScenePtr scene;
  std::vector<embree::GeometryPtr> geometries; // null for empty meshes
  std::size_t mesh_count = 0;
};

// Adds one mesh as geometry `id`, copying its arrays into buffers Embree allocates (with the
// padding its 16-byte vertex loads need).
embree::GeometryPtr add_mesh(SceneData& s, const RayCastMesh& mesh, unsigned id) {
  const std::size_t vertex_count = mesh.positions.size() / 3;
  const std::size_t face_count = mesh.triangles.size() / 3;
  embree::GeometryPtr g(rtcNewGeometry(s.device.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
  embree::throw_if_failed(s.errors, "rtcNewGeometry");
  void* vertices =
      rtcSetNewGeometryBuffer(g.get(), RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertex_count);
  void* indices = rtcSetNewGeometryBuffer(g.get(), RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                          3 * sizeof(std::uint32_t), face_count);
  embree::throw_if_failed(s.errors, "rtcSetNewGeometryBuffer");
  std::memcpy(vertices, mesh.positions.data(), mesh.positions.size() * sizeof(float));
  std::memcpy(indices, mesh.triangles.data(), mesh.triangles.size() * sizeof(std::int32_t));
  rtcCommitGeometry(g.get());
  embree::throw_if_failed(s.errors, "rtcCommitGeometry");
  rtcAttachGeometryByID(s.scene.get(), g.get(), id);
  embree::throw_if_failed(s.errors, "rtcAttachGeometryByID");
  return g;
}

void write_miss(RayHits& hits, std::size_t i) {
  hits.meshes[i] = -1;
  hits.triangles[i] = -1;
  hits.barycentrics[2 * i] = 0.0f;
  hits.barycentrics[2 * i + 1] = 0.0f;
  hits.distances[i] = std::numeric_limits<float>::infinity();
}

// Rays handed to Embree per stream call: neighbouring pixels' rays traverse the same nodes, so
// Embree's coherent stream mode (rtcIntersect1M) packs them into SIMD packets.
constexpr std::size_t STREAM_SIZE = 64;

void intersect_range(const SceneData& s, std::span<const float> origins, std::span<const float> directions,
                     float t_near, float t_far, RayHits& hits, std::size_t begin, std::size_t end) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  std::array<RTCRayHit, STREAM_SIZE> stream;
  for (std::size_t first = begin; first < end; first += STREAM_SIZE) {
    const std::size_t count = std::min(STREAM_SIZE, end - first);
    for (std::size_t r = 0; r < count; ++r) {
      const std::size_t i = first + r;
      RTCRayHit& rh = stream[r];
      rh.ray.org_x = origins[3 * i];
      rh.ray.org_y = origins[3 * i + 1];
      rh.ray.org_z = origins[3 * i + 2];
      rh.ray.dir_x = directions[3 * i];
      rh.ray.dir_y = directions[3 * i + 1];
      rh.ray.dir_z = directions[3 * i + 2];
      rh.ray.tnear = t_near;
      rh.ray.tfar = t_far;
      rh.ray.time = 0.0f;
      rh.ray.mask = std::numeric_limits<unsigned>::max();
      rh.ray.id = static_cast<unsigned>(r);
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect1M(s.scene.get(), &context, stream.data(), static_cast<unsigned>(count), sizeof(RTCRayHit));
    for (std::size_t r = 0; r < count; ++r) {
      const std::size_t i = first + r;
      const RTCRayHit& rh = stream[r];
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        write_miss(hits, i);
        continue;
      }
      hits.meshes[i] = static_cast<std::int32_t>(rh.hit.geomID);
      hits.triangles[i] = static_cast<std::int32_t>(rh.hit.primID);
      hits.barycentrics[2 * i] = rh.hit.u;
      hits.barycentrics[2 * i + 1] = rh.hit.v;
      hits.distances[i] = rh.ray.tfar;
    }
  }
}

void check_rays(std::span<const float> origins, std::span<const float> directions, float t_near, float t_far) {
  assert(origins.size() % 3 == 0 && origins.size() == directions.size() && "origins and directions must be #R × 3");
  assert(t_near >= 0.0f && t_near <= t_far && "need 0 ≤ t_near ≤ t_far");
}

} // namespace

struct RayCaster::Impl : SceneData {};

void RayHits::resize(std::size_t ray_count) {
  meshes.resize(ray_count);
  triangles.resize(ray_count);
  barycentrics.resize(2 * ray_count);
  distances.resize(ray_count);
}

RayCaster::RayCaster(std::span<const RayCastMesh> meshes) : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.mesh_count = meshes.size();
  assert(meshes.size() < RTC_INVALID_GEOMETRY_ID && "too many meshes");
  m.device = embree::make_device(m.errors);
  m.scene.reset(rtcNewScene(m.device.get()));
  embree::throw_if_failed(m.errors, "rtcNewScene");
  // Robust traversal: no ray slips through the shared edge of two triangles (a pixel-sized hole
  // in a rendered surface would read as a tear in the garment).
  rtcSetSceneFlags(m.scene.get(), RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(m.scene.get(), RTC_BUILD_QUALITY_HIGH);
  embree::throw_if_failed(m.errors, "rtcSetSceneBuildQuality");
  m.geometries.resize(meshes.size());
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const RayCastMesh& mesh = meshes[k];
    assert(mesh.positions.size() % 3 == 0 && mesh.triangles.size() % 3 == 0 && "rows of 3");
    assert(std::all_of(mesh.triangles.begin(), mesh.triangles.end(),
                       [&](std::int32_t v) { return v >= 0 && std::size_t(v) < mesh.positions.size() / 3; }) &&
           "triangle index out of range");
    if (mesh.triangles.empty()) continue;
    m.geometries[k] = add_mesh(m, mesh, static_cast<unsigned>(k));
  }
  rtcCommitScene(m.scene.get());
  embree::throw_if_failed(m.errors, "rtcCommitScene");
}

RayCaster::~RayCaster() = default;
RayCaster::RayCaster(RayCaster&&) noexcept = default;
RayCaster& RayCaster::operator=(RayCaster&&) noexcept = default;

void RayCaster::intersect(std::span<const float> origins, std::span<const float> directions, float t_near, float t_far,
                          RayHits& hits) const {
  check_rays(origins, directions, t_near, t_far);
  const std::size_t count = origins.size() / 3;
  hits.resize(count);
  const Impl& m = *m_impl;
  parallel_for_range(count, RAY_CAST_GRAIN, [&](std::size_t b, std::size_t e) {
    intersect_range(m, origins, directions, t_near, t_far, hits, b, e);
  });
  embree::throw_if_failed(m_impl->errors, "rtcIntersect1M");
}

void RayCaster::intersect_serial(std::span<const float> origins, std::span<const float> directions, float t_near,
                                 float t_far, RayHits& hits) const {
  check_rays(origins, directions, t_near, t_far);
  hits.resize(origins.size() / 3);
  intersect_range(*m_impl, origins, directions, t_near, t_far, hits, 0, origins.size() / 3);
  embree::throw_if_failed(m_impl->errors, "rtcIntersect1M");
}

std::size_t RayCaster::mesh_count() const { return m_impl->mesh_count; }

} // namespace vfit
