#include "primitives.h"

#include <cassert>
#include <cmath>
#include <numbers>

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
    for (int j = 0; j <= segments; ++j) m.uvs.insert(m.uvs.end(), {float(j) / float(segments), 1.0f - float(i) / float(rings)});
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
    for (int j = 0; j <= segments; ++j) m.uvs.insert(m.uvs.end(), {float(j) / float(segments), float(i) / float(rings - 1)});
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

} // namespace vfit
