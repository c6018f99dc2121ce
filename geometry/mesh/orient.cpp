// SPDX-License-Identifier: Apache-2.0
#include "orient.h"

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "vfit/kernels/vertex_normals_math.h"

namespace vfit {
namespace {

// The triangle's area (mesh units²), by the shared per-triangle math of the vertex normals.
double triangle_area(const Mesh& m, std::size_t f) {
  auto p = [&](int k) {
    const auto v = 3 * static_cast<std::size_t>(m.triangles[3 * f + static_cast<std::size_t>(k)]);
    return vfit_vec3{m.positions[v], m.positions[v + 1], m.positions[v + 2]};
  };
  const vfit_vec3 n = vfit_triangle_area_normal(p(0), p(1), p(2));
  return 0.5 * std::sqrt(double(n.x) * n.x + double(n.y) * n.y + double(n.z) * n.z);
}

// Turns triangle f over (corners 1 and 2 swapped), its UV and normal corners with it.
void turn_over(Mesh& mesh, std::size_t f) {
  std::swap(mesh.triangles[3 * f + 1], mesh.triangles[3 * f + 2]);
  if (mesh.uv_triangles.size() == mesh.triangles.size())
    std::swap(mesh.uv_triangles[3 * f + 1], mesh.uv_triangles[3 * f + 2]);
  if (mesh.normal_triangles.size() == mesh.triangles.size())
    std::swap(mesh.normal_triangles[3 * f + 1], mesh.normal_triangles[3 * f + 2]);
}

} // namespace

OrientReport orient_consistently(Mesh& mesh) {
  OrientReport report;
  const std::size_t nf = mesh.face_count(), nv = mesh.vertex_count();
  if (nf == 0) return report;
  // Vertex → triangles (CSR).
  std::vector<std::size_t> start(nv + 1, 0);
  for (std::int32_t v : mesh.triangles)
    ++start[static_cast<std::size_t>(v) + 1];
  for (std::size_t v = 0; v < nv; ++v)
    start[v + 1] += start[v];
  std::vector<std::size_t> faces(start.back());
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k)
        faces[fill[static_cast<std::size_t>(mesh.triangles[3 * f + static_cast<std::size_t>(k)])]++] = f;
  }
  auto corner = [&](std::size_t f, int k) { return mesh.triangles[3 * f + static_cast<std::size_t>(k)]; };
  // Whether triangle g runs a → b as stored (else b → a); g contains both.
  auto runs = [&](std::size_t g, std::int32_t a, std::int32_t b) {
    for (int k = 0; k < 3; ++k)
      if (corner(g, k) == a) return corner(g, (k + 1) % 3) == b;
    return false;
  };
  // The one other triangle on edge {a, b} of f, or nf when the edge is a border or non-manifold.
  auto across = [&](std::size_t f, std::int32_t a, std::int32_t b) {
    std::size_t other = nf;
    int count = 0;
    for (std::size_t i = start[static_cast<std::size_t>(a)]; i < start[static_cast<std::size_t>(a) + 1]; ++i) {
      const std::size_t g = faces[i];
      if (g == f || (i > start[static_cast<std::size_t>(a)] && faces[i - 1] == g)) continue; // a repeated corner
      if (corner(g, 0) == b || corner(g, 1) == b || corner(g, 2) == b) {
        other = g;
        ++count;
      }
    }
    return count == 1 ? other : nf;
  };
  // flip[f]: -1 not reached yet; 0 keep; 1 turn over. Breadth-first per piece.
  std::vector<std::int8_t> flip(nf, -1);
  std::vector<std::size_t> queue, piece;
  for (std::size_t seed = 0; seed < nf; ++seed) {
    if (flip[seed] >= 0) continue;
    flip[seed] = 0;
    queue.assign(1, seed);
    piece.clear();
    bool any_flipped = false;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const std::size_t f = queue[head];
      piece.push_back(f);
      any_flipped = any_flipped || flip[f] == 1;
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = corner(f, k), b = corner(f, (k + 1) % 3);
        const std::size_t g = across(f, a, b);
        if (g == nf) continue;
        // f and g agree when they run the shared edge in opposite directions once turned.
        const std::int8_t want = static_cast<std::int8_t>(runs(g, a, b) ? 1 - flip[f] : flip[f]);
        if (flip[g] < 0) {
          flip[g] = want;
          queue.push_back(g);
        } else if (flip[g] != want && g > f) {
          ++report.conflicts; // each such edge counted once, from its lower triangle
        }
      }
    }
    if (!any_flipped) continue; // consistent as stored: nothing to weigh
    double area_kept = 0, area_flipped = 0;
    for (std::size_t f : piece)
      (flip[f] ? area_flipped : area_kept) += triangle_area(mesh, f);
    if (area_flipped > area_kept)
      for (std::size_t f : piece)
        flip[f] = static_cast<std::int8_t>(1 - flip[f]);
  }
  for (std::size_t f = 0; f < nf; ++f) {
    if (flip[f] != 1) continue;
    ++report.flipped;
    turn_over(mesh, f);
  }
  return report;
}

double signed_volume(const Mesh& mesh) {
  double six_v = 0;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const auto p = [&](int k) {
      const auto v = 3 * static_cast<std::size_t>(mesh.triangles[3 * f + static_cast<std::size_t>(k)]);
      return std::array<double, 3>{mesh.positions[v], mesh.positions[v + 1], mesh.positions[v + 2]};
    };
    const auto a = p(0), b = p(1), c = p(2);
    six_v +=
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return six_v / 6;
}

bool orient_outward(Mesh& mesh) {
  if (!(signed_volume(mesh) < 0)) return false;
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    turn_over(mesh, f);
  return true;
}

} // namespace vfit
