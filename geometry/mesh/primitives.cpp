// SPDX-License-Identifier: Apache-2.0
#include "primitives.h"

#include <cassert>
#include <cmath>
#include <map>
#include <numbers>

#include <Eigen/Geometry>

namespace vfit {

Mesh make_uv_sphere(int rings, int segments, float radius) {
  assert(rings >= 2 && segments >= 3 && "sphere too coarse");
  Mesh m;
  const float pi = std::numbers::pi_v<float>;
  // Vertex 0: north pole (+Y); then rings−1 latitude rings of `segments`; last: south pole.
  m.positions.insert(m.positions.end(), {0.0f, radius, 0.0f});
  for (int i = 1; i < rings; ++i) {
    const float theta = pi * float(i) / float(rings);
    for (int j = 0; j < segments; ++j) {
      const float phi = 2.0f * pi * float(j) / float(segments);
      m.positions.insert(m.positions.end(), {radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta),
                                             radius * std::sin(theta) * std::cos(phi)});
    }
  }
  m.positions.insert(m.positions.end(), {0.0f, -radius, 0.0f});
  const int south = 1 + (rings - 1) * segments;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  // UVs: (segments + 1) columns per latitude row so the seam gets its own column.
  auto uv_index = [&](int i, int j) { return i * (segments + 1) + j; };
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j)
      m.uvs.insert(m.uvs.end(), {float(j) / float(segments), 1.0f - float(i) / float(rings)});
  auto tri = [&](int a, int b, int c, int ua, int ub, int uc) {
    m.triangles.insert(m.triangles.end(), {a, b, c});
    m.uv_triangles.insert(m.uv_triangles.end(), {ua, ub, uc});
  };
  for (int j = 0; j < segments; ++j) {
    tri(0, ring(1, j), ring(1, j + 1), uv_index(0, j), uv_index(1, j), uv_index(1, j + 1));
    for (int i = 1; i + 1 < rings; ++i) {
      tri(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), uv_index(i, j), uv_index(i + 1, j), uv_index(i + 1, j + 1));
      tri(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1), uv_index(i, j), uv_index(i + 1, j + 1), uv_index(i, j + 1));
    }
    tri(south, ring(rings - 1, j + 1), ring(rings - 1, j), uv_index(rings, j), uv_index(rings - 1, j + 1),
        uv_index(rings - 1, j));
  }
  return m;
}

Mesh make_tube(int rings, int segments, float radius, float length) {
  assert(rings >= 2 && segments >= 3 && "tube too coarse");
  Mesh m;
  const float pi = std::numbers::pi_v<float>;
  for (int i = 0; i < rings; ++i) {
    const float y = length * float(i) / float(rings - 1);
    for (int j = 0; j < segments; ++j) {
      const float phi = 2.0f * pi * float(j) / float(segments);
      m.positions.insert(m.positions.end(), {radius * std::sin(phi), y, radius * std::cos(phi)});
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j <= segments; ++j)
      m.uvs.insert(m.uvs.end(), {float(j) / float(segments), float(i) / float(rings - 1)});
  auto v = [&](int i, int j) { return i * segments + (j % segments); };
  auto t = [&](int i, int j) { return i * (segments + 1) + j; };
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      // Counter-clockwise seen from outside (the normal points away from the axis).
      m.triangles.insert(m.triangles.end(), {v(i, j), v(i, j + 1), v(i + 1, j + 1)});
      m.uv_triangles.insert(m.uv_triangles.end(), {t(i, j), t(i, j + 1), t(i + 1, j + 1)});
      m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j + 1), v(i + 1, j)});
      m.uv_triangles.insert(m.uv_triangles.end(), {t(i, j), t(i + 1, j + 1), t(i + 1, j)});
    }
  return m;
}

Mesh make_grid(int nx, int nz, float size_x, float size_z) {
  assert(nx >= 2 && nz >= 2 && "grid too coarse");
  Mesh m;
  for (int i = 0; i < nz; ++i)
    for (int j = 0; j < nx; ++j) {
      const float u = float(j) / float(nx - 1), w = float(i) / float(nz - 1);
      m.positions.insert(m.positions.end(), {size_x * (u - 0.5f), 0.0f, size_z * (w - 0.5f)});
      m.uvs.insert(m.uvs.end(), {u, w});
    }
  auto v = [&](int i, int j) { return i * nx + j; };
  for (int i = 0; i + 1 < nz; ++i)
    for (int j = 0; j + 1 < nx; ++j) {
      // Seen from +Y, (i, j) → (i+1, j) → (i+1, j+1) is counter-clockwise.
      m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  m.uv_triangles = m.triangles;
  return m;
}

Mesh make_solidified(const Mesh& outer, float thickness, bool stitched) {
  const std::size_t nv = outer.vertex_count(), nf = outer.face_count();
  std::vector<Eigen::Vector3f> normal(nv, Eigen::Vector3f::Zero());
  auto at = [&](std::int32_t v) { return Eigen::Vector3f::Map(&outer.positions[3 * std::size_t(v)]); };
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t* t = &outer.triangles[3 * f];
    const Eigen::Vector3f n = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
    for (int k = 0; k < 3; ++k)
      normal[std::size_t(t[k])] += n;
  }
  Mesh m;
  m.positions = outer.positions;
  for (std::size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3f p = at(std::int32_t(v)) - thickness * normal[v].normalized();
    m.positions.insert(m.positions.end(), {p.x(), p.y(), p.z()});
  }
  m.triangles = outer.triangles;
  const auto n = std::int32_t(nv);
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t* t = &outer.triangles[3 * f];
    m.triangles.insert(m.triangles.end(), {t[0] + n, t[2] + n, t[1] + n});
  }
  if (stitched) {
    // Boundary edges a→b (used once) get the strip (b, a, a'), (b, a', b').
    std::map<std::pair<std::int32_t, std::int32_t>, int> uses;
    for (std::size_t i = 0; i < 3 * nf; ++i) {
      const std::int32_t a = outer.triangles[i], b = outer.triangles[i - i % 3 + (i + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
    for (std::size_t i = 0; i < 3 * nf; ++i) {
      const std::int32_t a = outer.triangles[i], b = outer.triangles[i - i % 3 + (i + 1) % 3];
      if (uses[{std::min(a, b), std::max(a, b)}] == 1)
        m.triangles.insert(m.triangles.end(), {b, a, a + n, b, a + n, b + n});
    }
  }
  return m;
}

} // namespace vfit
