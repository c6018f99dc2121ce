// SPDX-License-Identifier: Apache-2.0
#include "even_decimate.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vfit {
namespace {

// A round collapses edges up to this multiple of its lower-quartile edge length.
constexpr double ROUND_LENGTH_FACTOR = 1.5;
// Longest edge / height a changed triangle may reach (unless the removed vertex had a worse one).
constexpr double MAX_ASPECT = 6.0;
// cos 60°: a changed triangle's normal may turn by at most 60°.
constexpr double MIN_NORMAL_COS = 0.5;

using Vec3 = Eigen::Vector3d;

struct Decimation {
  const std::vector<float>& positions;
  std::vector<std::int32_t> tris;               // #F × 3; a removed triangle has −1 corners
  std::vector<std::int32_t> face_offset, faces; // vertex → its live triangles (CSR), rebuilt per round

  Vec3 at(std::int32_t v) const {
    return {double(positions[3 * std::size_t(v)]), double(positions[3 * std::size_t(v) + 1]),
            double(positions[3 * std::size_t(v) + 2])};
  }
  std::span<const std::int32_t> faces_of(std::int32_t v) const {
    return {faces.data() + face_offset[std::size_t(v)], faces.data() + face_offset[std::size_t(v) + 1]};
  }
  void build_rings(std::size_t nv) {
    face_offset.assign(nv + 1, 0);
    for (std::size_t f = 0; f < tris.size() / 3; ++f)
      if (tris[3 * f] >= 0)
        for (int k = 0; k < 3; ++k)
          ++face_offset[std::size_t(tris[3 * f + std::size_t(k)]) + 1];
    for (std::size_t v = 0; v < nv; ++v)
      face_offset[v + 1] += face_offset[v];
    faces.resize(std::size_t(face_offset[nv]));
    std::vector<std::int32_t> fill(face_offset.begin(), face_offset.end() - 1);
    for (std::size_t f = 0; f < tris.size() / 3; ++f)
      if (tris[3 * f] >= 0)
        for (int k = 0; k < 3; ++k)
          faces[std::size_t(fill[std::size_t(tris[3 * f + std::size_t(k)])]++)] = std::int32_t(f);
  }
  // The corner after / before v in triangle f.
  std::int32_t next(std::int32_t f, std::int32_t v) const {
    const std::size_t b = 3 * std::size_t(f);
    return tris[b] == v ? tris[b + 1] : tris[b + 1] == v ? tris[b + 2] : tris[b];
  }
  std::int32_t prev(std::int32_t f, std::int32_t v) const {
    const std::size_t b = 3 * std::size_t(f);
    return tris[b] == v ? tris[b + 2] : tris[b + 1] == v ? tris[b] : tris[b + 1];
  }
  // Whether edge v–w has one triangle only (a consistently oriented manifold: its twin is missing).
  bool boundary_edge(std::int32_t v, std::int32_t w) const {
    int count = 0;
    for (std::int32_t f : faces_of(v))
      count += (next(f, v) == w) + (prev(f, v) == w);
    return count == 1;
  }
  bool boundary_vertex(std::int32_t v) const {
    for (std::int32_t f : faces_of(v))
      if (boundary_edge(v, next(f, v))) return true;
    return false;
  }
  void neighbours(std::int32_t v, std::vector<std::int32_t>& out) const {
    out.clear();
    for (std::int32_t f : faces_of(v)) {
      out.push_back(next(f, v));
      out.push_back(prev(f, v));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
  static double aspect(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& n) {
    const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    return longest / n.norm(); // longest² / (longest · height)
  }

  // Whether removing a into b (a half-edge collapse) is legal (the header's rules).
  bool collapse_ok(std::int32_t a, std::int32_t b, std::vector<std::int32_t>& na, std::vector<std::int32_t>& nb) const {
    const bool edge_on_boundary = boundary_edge(a, b);
    if (!edge_on_boundary && boundary_vertex(a)) return false;
    neighbours(a, na);
    neighbours(b, nb);
    std::size_t common = 0;
    for (std::size_t i = 0, j = 0; i < na.size() && j < nb.size();) {
      if (na[i] < nb[j])
        ++i;
      else if (nb[j] < na[i])
        ++j;
      else
        ++common, ++i, ++j;
    }
    if (common != (edge_on_boundary ? 1u : 2u)) return false;
    double old_worst = 0;
    for (std::int32_t f : faces_of(a)) {
      const std::int32_t c = next(f, a), d = prev(f, a);
      const Vec3 n = (at(c) - at(a)).cross(at(d) - at(a));
      old_worst = std::max(old_worst, n.norm() > 0 ? aspect(at(a), at(c), at(d), n) : INFINITY);
      if (c == b || d == b) {
        const std::int32_t across = c == b ? d : c;
        if (faces_of(across).size() < 3) return false;
      }
    }
    const double max_aspect = std::max(MAX_ASPECT, old_worst);
    for (std::int32_t f : faces_of(a)) {
      const std::int32_t c = next(f, a), d = prev(f, a);
      if (c == b || d == b) continue; // removed with the edge
      const Vec3 n_old = (at(c) - at(a)).cross(at(d) - at(a));
      const Vec3 n_new = (at(c) - at(b)).cross(at(d) - at(b));
      const double len = n_new.norm();
      if (!(len > 0) || n_new.dot(n_old) < MIN_NORMAL_COS * len * n_old.norm()) return false;
      if (aspect(at(b), at(c), at(d), n_new) > max_aspect) return false;
    }
    return true;
  }
  void collapse(std::int32_t a, std::int32_t b) {
    for (std::int32_t f : faces_of(a)) {
      const std::size_t base = 3 * std::size_t(f);
      if (tris[base] == b || tris[base + 1] == b || tris[base + 2] == b) {
        tris[base] = tris[base + 1] = tris[base + 2] = -1;
        continue;
      }
      for (std::size_t k = 0; k < 3; ++k)
        if (tris[base + k] == a) tris[base + k] = b;
    }
  }
};

} // namespace

Mesh decimate_evenly(const Mesh& mesh, std::size_t target_vertices, std::vector<std::int32_t>& source_vertices) {
  const std::size_t nv = mesh.vertex_count();
  Decimation d{mesh.positions, mesh.triangles, {}, {}};
  std::vector<char> alive(nv, 0);
  for (std::int32_t v : mesh.triangles)
    alive[std::size_t(v)] = 1;
  std::size_t live = std::size_t(std::count(alive.begin(), alive.end(), 1));

  std::vector<char> locked(nv);
  std::vector<std::uint64_t> edges;
  std::vector<float> lengths, order_keys;
  std::vector<std::pair<std::int32_t, std::int32_t>> ends;
  std::vector<std::int32_t> na, nb;
  while (live > target_vertices) {
    d.build_rings(nv);
    // Each edge once: an interior one as its directed half a → b with a < b, a boundary one
    // (no twin) whichever way its one triangle runs.
    lengths.clear();
    ends.clear();
    for (std::size_t f = 0; f < d.tris.size() / 3; ++f) {
      if (d.tris[3 * f] < 0) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::int32_t a = d.tris[3 * f + k], b = d.tris[3 * f + (k + 1) % 3];
        if (a > b && !d.boundary_edge(a, b)) continue;
        lengths.push_back(float((d.at(b) - d.at(a)).squaredNorm()));
        ends.push_back({a, b});
      }
    }
    if (ends.empty()) break;
    order_keys.assign(lengths.begin(), lengths.end());
    std::nth_element(order_keys.begin(), order_keys.begin() + std::ptrdiff_t(order_keys.size() / 4), order_keys.end());
    const float limit = float(ROUND_LENGTH_FACTOR * ROUND_LENGTH_FACTOR) * order_keys[order_keys.size() / 4]; // squared
    // Shortest first, ties by edge: a non-negative float's bits order as the float does.
    edges.clear();
    for (std::size_t e = 0; e < ends.size(); ++e)
      if (lengths[e] <= limit) edges.push_back((std::uint64_t(std::bit_cast<std::uint32_t>(lengths[e])) << 32) | e);
    std::sort(edges.begin(), edges.end());
    std::fill(locked.begin(), locked.end(), 0);
    std::size_t collapsed = 0;
    for (const std::uint64_t key : edges) {
      auto [a, b] = ends[std::size_t(key & 0xffffffffu)];
      if (locked[std::size_t(a)] || locked[std::size_t(b)]) continue;
      // Remove the end that may go (an interior vertex rather than a boundary one).
      if (!d.collapse_ok(a, b, na, nb)) {
        std::swap(a, b);
        if (!d.collapse_ok(a, b, na, nb)) continue;
      }
      // Lock the removed vertex's ring and the kept one: their triangles change, and later
      // checks in this round read the rings as they were at its start. Other vertices' triangles
      // are the same (a triangle that changes holds a), so their checks stay exact.
      for (std::int32_t v : na)
        locked[std::size_t(v)] = 1;
      locked[std::size_t(a)] = locked[std::size_t(b)] = 1;
      d.collapse(a, b);
      alive[std::size_t(a)] = 0;
      ++collapsed;
      if (--live <= target_vertices) break;
    }
    if (collapsed == 0) break;
  }

  std::vector<std::int32_t> index(nv, -1);
  source_vertices.clear();
  Mesh out;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!alive[v]) continue;
    index[v] = std::int32_t(source_vertices.size());
    source_vertices.push_back(std::int32_t(v));
    out.positions.insert(out.positions.end(), mesh.positions.begin() + std::ptrdiff_t(3 * v),
                         mesh.positions.begin() + std::ptrdiff_t(3 * v + 3));
  }
  for (std::size_t f = 0; f < d.tris.size() / 3; ++f)
    if (d.tris[3 * f] >= 0)
      for (std::size_t k = 0; k < 3; ++k)
        out.triangles.push_back(index[std::size_t(d.tris[3 * f + k])]);
  return out;
}

} // namespace vfit
