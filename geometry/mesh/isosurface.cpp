// SPDX-License-Identifier: Apache-2.0
#include "isosurface.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

// Coarse blocks of BLOCK³ cells are tested against the distance bound first.
constexpr int BLOCK = 4;

// The six tetrahedra of a cube split along its main diagonal (corner 0 → corner 6), with cube
// corners numbered by bits: corner c is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). Every
// cube splits each face along the same diagonal, so neighbouring tetrahedra share faces.
constexpr int TETS[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};

struct Grid {
  int nx = 0, ny = 0, nz = 0; // points per axis
  std::array<double, 3> origin{};
  double h = 0;
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * ny + j) * static_cast<std::size_t>(nx) + i;
  }
  std::array<double, 3> point(int i, int j, int k) const {
    return {origin[0] + i * h, origin[1] + j * h, origin[2] + k * h};
  }
};

} // namespace

Mesh extract_isosurface(const DistanceFunction& f, const IsosurfaceOptions& o) {
  Grid g;
  g.h = o.cell_size;
  for (int a = 0; a < 3; ++a)
    g.origin[a] = o.box_min[a];
  auto cells = [&](int a) {
    const int n = static_cast<int>(std::ceil((o.box_max[a] - o.box_min[a]) / g.h));
    return (n + BLOCK - 1) / BLOCK * BLOCK;
  };
  g.nx = cells(0) + 1;
  g.ny = cells(1) + 1;
  g.nz = cells(2) + 1;
  const int bx = (g.nx - 1) / BLOCK, by = (g.ny - 1) / BLOCK, bz = (g.nz - 1) / BLOCK;

  // 1. Distance at block corners; a block is active when the surface may pass through it.
  auto corner_value = [&](int i, int j, int k) {
    const auto p = g.point(i * BLOCK, j * BLOCK, k * BLOCK);
    return f(p[0], p[1], p[2]);
  };
  const std::size_t nblocks = static_cast<std::size_t>(bx + 1) * (by + 1) * (bz + 1);
  std::vector<double> coarse(nblocks);
  parallel_for_range(nblocks, 256, [&](std::size_t b, std::size_t e) {
    for (std::size_t n = b; n < e; ++n) {
      const int i = static_cast<int>(n % (bx + 1)), j = static_cast<int>((n / (bx + 1)) % (by + 1)),
                k = static_cast<int>(n / (static_cast<std::size_t>(bx + 1) * (by + 1)));
      coarse[n] = corner_value(i, j, k);
    }
  });
  auto cidx = [&](int i, int j, int k) { return (static_cast<std::size_t>(k) * (by + 1) + j) * (bx + 1) + i; };
  const double reach = o.lipschitz * BLOCK * g.h * std::sqrt(3.0);
  std::vector<std::array<int, 3>> active;
  for (int k = 0; k < bz; ++k)
    for (int j = 0; j < by; ++j)
      for (int i = 0; i < bx; ++i) {
        double lo = INFINITY, hi = -INFINITY;
        for (int c = 0; c < 8; ++c) {
          const double v = coarse[cidx(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))];
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
        if (lo <= 0 && hi >= 0)
          active.push_back({i, j, k});
        else if (std::min(std::abs(lo), std::abs(hi)) < reach)
          active.push_back({i, j, k});
      }
  if (active.empty()) throw Error("isosurface", 0, "the distance function has no zero set inside the box");
  // The surface must close inside the box: no block-lattice point on the box faces is inside.
  for (int k = 0; k <= bz; ++k)
    for (int j = 0; j <= by; ++j)
      for (int i = 0; i <= bx; ++i)
        if ((i == 0 || j == 0 || k == 0 || i == bx || j == by || k == bz) && coarse[cidx(i, j, k)] <= 0)
          throw Error("isosurface", 0, "the surface reaches the edge of the grid box; enlarge the box");

  // 2. Fine values inside active blocks (NaN elsewhere: never read).
  std::vector<float> value(static_cast<std::size_t>(g.nx) * g.ny * g.nz, NAN);
  parallel_for_range(active.size(), 4, [&](std::size_t b, std::size_t e) {
    for (std::size_t n = b; n < e; ++n) {
      const auto& blk = active[n];
      for (int k = 0; k <= BLOCK; ++k)
        for (int j = 0; j <= BLOCK; ++j)
          for (int i = 0; i <= BLOCK; ++i) {
            const int gi = blk[0] * BLOCK + i, gj = blk[1] * BLOCK + j, gk = blk[2] * BLOCK + k;
            const std::size_t id = g.index(gi, gj, gk);
            // Shared block faces are written by two tasks with the same value: benign.
            const auto p = g.point(gi, gj, gk);
            float v = static_cast<float>(f(p[0], p[1], p[2]));
            if (v == 0.0f) v = 1e-12f; // no grid point exactly on the surface: crossings stay strict
            value[id] = v;
          }
    }
  });

  // 3. Marching tetrahedra over the fine cells of active blocks.
  Mesh mesh;
  std::unordered_map<std::uint64_t, std::int32_t> edge_vertex;
  edge_vertex.reserve(active.size() * BLOCK * BLOCK * 8);
  auto crossing = [&](std::size_t a, std::size_t b) -> std::int32_t {
    const std::uint64_t key = std::min(a, b) * std::uint64_t(1u << 31) * 2 + std::max(a, b);
    auto it = edge_vertex.find(key);
    if (it != edge_vertex.end()) return it->second;
    auto coords = [&](std::size_t id) {
      const int i = static_cast<int>(id % g.nx), j = static_cast<int>((id / g.nx) % g.ny),
                k = static_cast<int>(id / (static_cast<std::size_t>(g.nx) * g.ny));
      return g.point(i, j, k);
    };
    const auto pa = coords(a), pb = coords(b);
    double va = value[a], vb = value[b];
    double ta = 0, tb = 1, t = va / (va - vb);
    for (int r = 0; r < o.refinements; ++r) {
      const double vt = f(pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]), pa[2] + t * (pb[2] - pa[2]));
      if ((vt < 0) == (va < 0)) {
        ta = t;
        va = vt;
      } else {
        tb = t;
        vb = vt;
      }
      t = std::clamp(ta + (tb - ta) * va / (va - vb), ta, tb);
    }
    const auto id = static_cast<std::int32_t>(mesh.positions.size() / 3);
    for (int c = 0; c < 3; ++c)
      mesh.positions.push_back(static_cast<float>(pa[c] + t * (pb[c] - pa[c])));
    edge_vertex.emplace(key, id);
    return id;
  };
  // Orientation is decided on the linearly interpolated crossings, which lie exactly in one
  // plane per tetrahedron and separate its inside corners from its outside ones; the refined
  // positions can fold a quad slightly and must not flip a triangle.
  auto linear_point = [&](std::size_t a, std::size_t b) {
    auto coords = [&](std::size_t id) {
      const int i = static_cast<int>(id % g.nx), j = static_cast<int>((id / g.nx) % g.ny),
                k = static_cast<int>(id / (static_cast<std::size_t>(g.nx) * g.ny));
      return g.point(i, j, k);
    };
    const auto pa = coords(a), pb = coords(b);
    const double t = double(value[a]) / (double(value[a]) - double(value[b]));
    return Eigen::Vector3d(pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]), pa[2] + t * (pb[2] - pa[2]));
  };
  using Edge = std::pair<std::size_t, std::size_t>; // (inside corner, outside corner)
  auto emit = [&](Edge ea, Edge eb, Edge ec) {
    const Eigen::Vector3d pa = linear_point(ea.first, ea.second), pb = linear_point(eb.first, eb.second),
                          pc = linear_point(ec.first, ec.second);
    std::array<double, 3> in_p, out_p;
    auto coords = [&](std::size_t id) {
      const int i = static_cast<int>(id % g.nx), j = static_cast<int>((id / g.nx) % g.ny),
                k = static_cast<int>(id / (static_cast<std::size_t>(g.nx) * g.ny));
      return g.point(i, j, k);
    };
    in_p = coords(ea.first);
    out_p = coords(ea.second);
    const Eigen::Vector3d dir(out_p[0] - in_p[0], out_p[1] - in_p[1], out_p[2] - in_p[2]);
    std::int32_t a = crossing(ea.first, ea.second), b = crossing(eb.first, eb.second),
                 c = crossing(ec.first, ec.second);
    if ((pb - pa).cross(pc - pa).dot(dir) < 0) std::swap(b, c);
    mesh.triangles.insert(mesh.triangles.end(), {a, b, c});
  };
  for (const auto& blk : active)
    for (int k = 0; k < BLOCK; ++k)
      for (int j = 0; j < BLOCK; ++j)
        for (int i = 0; i < BLOCK; ++i) {
          const int ci = blk[0] * BLOCK + i, cj = blk[1] * BLOCK + j, ck = blk[2] * BLOCK + k;
          std::size_t id[8];
          bool inside[8];
          int count = 0;
          for (int c = 0; c < 8; ++c) {
            id[c] = g.index(ci + (c & 1), cj + ((c >> 1) & 1), ck + ((c >> 2) & 1));
            inside[c] = value[id[c]] < 0;
            count += inside[c];
          }
          if (count == 0 || count == 8) continue;
          for (const auto& tet : TETS) {
            int in[4], out[4], ni = 0, no = 0;
            for (int v : tet)
              (inside[v] ? in[ni++] : out[no++]) = v;
            if (ni == 0 || no == 0) continue;
            if (ni == 1) {
              emit({id[in[0]], id[out[0]]}, {id[in[0]], id[out[1]]}, {id[in[0]], id[out[2]]});
            } else if (no == 1) {
              emit({id[in[0]], id[out[0]]}, {id[in[1]], id[out[0]]}, {id[in[2]], id[out[0]]});
            } else {
              // The quad a-b-c-d: each triangle is oriented on its own plane (a plane through
              // three crossings of one tetrahedron still separates its corners).
              const Edge a{id[in[0]], id[out[0]]}, b{id[in[0]], id[out[1]]}, c{id[in[1]], id[out[1]]},
                  d{id[in[1]], id[out[0]]};
              emit(a, b, c);
              emit(a, c, d);
            }
          }
        }
  if (mesh.triangles.empty()) throw Error("isosurface", 0, "the distance function has no zero set inside the box");
  return mesh;
}

} // namespace vfit
