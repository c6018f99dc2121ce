// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/surface_embedding.h"

#include <cassert>
#include <cmath>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {
namespace {

using Vec3 = Eigen::Vector3d;

Vec3 load(std::span<const float> xyz, std::size_t i) {
  return {double(xyz[3 * i]), double(xyz[3 * i + 1]), double(xyz[3 * i + 2])};
}

// The closest point q and the frame (t1, t2, N) at barycentrics (u, v) of carrier triangle t
// (file comment of surface_embedding.h); the world axes where the frame is degenerate.
struct Frame {
  Vec3 origin;
  Vec3 axes[3];
};

Frame frame_at(std::span<const float> positions, std::span<const float> normals,
               std::span<const std::int32_t> triangles, std::int32_t t, float u, float v) {
  const std::size_t i[3] = {std::size_t(triangles[3 * std::size_t(t)]), std::size_t(triangles[3 * std::size_t(t) + 1]),
                            std::size_t(triangles[3 * std::size_t(t) + 2])};
  const double w[3] = {1.0 - double(u) - double(v), double(u), double(v)};
  Frame f;
  f.origin = w[0] * load(positions, i[0]) + w[1] * load(positions, i[1]) + w[2] * load(positions, i[2]);
  const Vec3 n = w[0] * load(normals, i[0]) + w[1] * load(normals, i[1]) + w[2] * load(normals, i[2]);
  const Vec3 edge = load(positions, i[1]) - load(positions, i[0]);
  const double n_norm = n.norm();
  if (n_norm > 0) {
    const Vec3 nn = n / n_norm;
    const Vec3 t1 = edge - edge.dot(nn) * nn;
    // An edge within ~1e-6 rad of N (or of zero length) gives no tangent direction.
    if (t1.norm() > 1e-6 * edge.norm() && t1.norm() > 0) {
      f.axes[0] = t1.normalized();
      f.axes[1] = nn.cross(f.axes[0]);
      f.axes[2] = nn;
      return f;
    }
  }
  f.axes[0] = Vec3::UnitX();
  f.axes[1] = Vec3::UnitY();
  f.axes[2] = Vec3::UnitZ();
  return f;
}

} // namespace

void embed_points(std::span<const float> points, std::span<const float> carrier_positions,
                  std::span<const std::int32_t> carrier_triangles, std::span<const std::uint8_t> mask,
                  SurfaceEmbedding& embedding) {
  const std::size_t n = points.size() / 3;
  if (!mask.empty() && mask.size() != n)
    throw Error("surface embedding", 0,
                "mask has " + std::to_string(mask.size()) + " entries for " + std::to_string(n) + " points");
  embedding.triangles.assign(n, -1);
  embedding.barycentrics.assign(2 * n, 0.0f);
  embedding.offsets.assign(3 * n, 0.0f);
  const ProximityIndex index(carrier_positions, carrier_triangles, OpenMeshSide::ONE_SIDED);
  if (carrier_triangles.empty()) return;
  std::vector<float> normals;
  vertex_normals_tbb(carrier_positions, carrier_triangles, normals);
  ClosestHits hits;
  index.closest_points(points, INFINITY, hits);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, SURFACE_EMBEDDING_GRAIN), [&](const auto& range) {
    for (std::size_t p = range.begin(); p != range.end(); ++p) {
      if ((!mask.empty() && mask[p] == 0) || hits.triangles[p] < 0) continue;
      const float u = hits.barycentrics[2 * p], v = hits.barycentrics[2 * p + 1];
      const Frame f = frame_at(carrier_positions, normals, carrier_triangles, hits.triangles[p], u, v);
      const Vec3 d = load(points, p) - f.origin;
      embedding.triangles[p] = hits.triangles[p];
      embedding.barycentrics[2 * p] = u;
      embedding.barycentrics[2 * p + 1] = v;
      for (int k = 0; k < 3; ++k)
        embedding.offsets[3 * p + std::size_t(k)] = float(d.dot(f.axes[k]));
    }
  });
}

void carry_embedded_points(const SurfaceEmbedding& embedding, std::span<const float> carrier_positions,
                           std::span<const std::int32_t> carrier_triangles, std::span<float> points) {
  assert(points.size() == 3 * embedding.size() && "carry_embedded_points: #P × 3 points");
  std::vector<float> normals;
  vertex_normals_tbb(carrier_positions, carrier_triangles, normals);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, embedding.size(), SURFACE_EMBEDDING_GRAIN),
                    [&](const auto& range) {
                      for (std::size_t p = range.begin(); p != range.end(); ++p) {
                        const std::int32_t t = embedding.triangles[p];
                        if (t < 0) continue;
                        const Frame f = frame_at(carrier_positions, normals, carrier_triangles, t,
                                                 embedding.barycentrics[2 * p], embedding.barycentrics[2 * p + 1]);
                        Vec3 x = f.origin;
                        for (int k = 0; k < 3; ++k)
                          x += double(embedding.offsets[3 * p + std::size_t(k)]) * f.axes[k];
                        for (int c = 0; c < 3; ++c)
                          points[3 * p + std::size_t(c)] = float(x[c]);
                      }
                    });
}

} // namespace vfit
