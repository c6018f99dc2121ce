// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Ray casting against several triangle meshes at once: an Embree BVH over all of them, and
/// batches of rays answered with the first surface each one meets (mesh, triangle,
/// barycentrics, distance). The renderer (engine/render.h) casts one ray per pixel sample.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace vfit {

/// One mesh of a RayCaster scene: flat views of its positions (#V × 3, m) and triangles
/// (#F × 3 vertex indices in [0, #V)). The caster copies them.
struct RayCastMesh {
  std::span<const float> positions;
  std::span<const std::int32_t> triangles;
};

/// Answers for #R rays, one row per ray, in ray order. A ray that meets nothing within its
/// range has mesh −1, triangle −1, barycentrics (0, 0) and distance +∞.
struct RayHits {
  std::vector<std::int32_t> meshes;    ///< #R index of the mesh hit (its position in the scene's list), or −1
  std::vector<std::int32_t> triangles; ///< #R triangle of that mesh, or −1
  std::vector<float> barycentrics;     ///< #R × 2 (u, v): hit point = (1−u−v)·a + u·b + v·c
  /// #R ray parameters t of the hits: hit point = origin + t·direction (metres for unit
  /// directions), or +∞ for a miss.
  std::vector<float> distances;

  /// Number of rays answered (#R).
  std::size_t size() const { return meshes.size(); }
  /// Resizes every array for `ray_count` rays (contents unspecified until written).
  void resize(std::size_t ray_count);
};

/// Rays per TBB task in RayCaster::intersect (coherent primary rays, each cheap).
inline constexpr std::size_t RAY_CAST_GRAIN = 1024;

/// A static ray-intersection scene over several triangle meshes: one Embree BVH over the
/// triangles of all of them (one Embree geometry per mesh). Mesh ids are positions in the list
/// given at construction; an empty mesh (#F = 0) is allowed and is never hit. Triangles are hit
/// from both sides (no back-face culling), so open surfaces such as garments are seen from
/// inside too. A ray that grazes the edge shared by two triangles hits one of them (Embree's
/// watertight test, robust mode). Consecutive rays go to Embree as coherent streams of 64
/// (rtcIntersect1M), so neighbouring pixels' rays should be neighbours in the batch.
///
/// Thread safety: intersect() is const and may run concurrently. Embree failures (out of
/// memory, invalid input that slipped past validation) throw std::runtime_error naming the
/// Embree call.
class RayCaster {
public:
  /// Builds the scene. Inputs are validated by the caller (assert only): every positions span
  /// a multiple of 3 floats, every triangle index in range.
  explicit RayCaster(std::span<const RayCastMesh> meshes);
  ~RayCaster();
  RayCaster(RayCaster&&) noexcept;
  RayCaster& operator=(RayCaster&&) noexcept;
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  /// First hits of #R rays, TBB-parallel over the rays (grain RAY_CAST_GRAIN). origins and
  /// directions: #R × 3 each (m; directions non-zero, need not be unit length). Only hits with
  /// t in [t_near, t_far] count (0 ≤ t_near ≤ t_far; t_far may be +∞). `hits` is resized to #R.
  void intersect(std::span<const float> origins, std::span<const float> directions, float t_near, float t_far,
                 RayHits& hits) const;

  /// Serial reference of intersect(): the same Embree query, one ray after another.
  void intersect_serial(std::span<const float> origins, std::span<const float> directions, float t_near, float t_far,
                        RayHits& hits) const;

  /// Number of meshes in the scene (including empty ones).
  std::size_t mesh_count() const;

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
