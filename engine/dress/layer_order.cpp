// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/layer_order.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "vfit/geometry/mesh/orient.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/hole_caps.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

// The volume of the mesh closed by fan caps over its openings (signed_volume(): positive when
// wound outward).
double capped_volume(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  const HoleCaps caps = build_hole_caps(triangles, positions.size() / 3);
  Mesh closed;
  capped_positions(positions, caps, closed.positions);
  closed.triangles.assign(triangles.begin(), triangles.end());
  closed.triangles.insert(closed.triangles.end(), caps.triangles.begin(), caps.triangles.end());
  return signed_volume(closed);
}

// A garment wound outward (by its capped volume), and its bounding box.
struct Outward {
  std::vector<std::int32_t> triangles;
  std::array<float, 6> box{}; // min x, y, z, max x, y, z of its referenced vertices
};

Outward outward(const Mesh& mesh) {
  Outward out;
  out.triangles = mesh.triangles;
  if (capped_volume(mesh.positions, out.triangles) < 0)
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
      std::swap(out.triangles[3 * f + 1], out.triangles[3 * f + 2]);
  out.box = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
  for (std::int32_t v : mesh.triangles)
    for (int c = 0; c < 3; ++c) {
      const float x = mesh.positions[3 * static_cast<std::size_t>(v) + std::size_t(c)];
      out.box[std::size_t(c)] = std::min(out.box[std::size_t(c)], x);
      out.box[std::size_t(c) + 3] = std::max(out.box[std::size_t(c) + 3], x);
    }
  return out;
}

bool in_box(const float* p, const std::array<float, 6>& box, float margin) {
  for (int c = 0; c < 3; ++c)
    if (p[c] < box[std::size_t(c)] - margin || p[c] > box[std::size_t(c) + 3] + margin) return false;
  return true;
}

// The part of a garment within `margin` of the other garment's box: its index (the triangles
// with a corner there, wound as the whole garment is outward, capped where the crop opens it)
// and every k-th of its vertices there as samples. Only this part can vote or be voted on; at
// 10^6 vertices the crop (a tee's hem band against trousers) is what keeps the index builds cheap.
struct Cropped {
  std::optional<ProximityIndex> index;
  std::vector<float> samples; // #S × 3
};

Cropped crop(const Mesh& mesh, const Outward& whole, const std::array<float, 6>& other_box,
             const LayerOrderOptions& options) {
  Cropped out;
  const auto margin = static_cast<float>(options.reach);
  std::vector<char> inside(mesh.vertex_count(), 0);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    inside[v] = in_box(&mesh.positions[3 * v], other_box, margin);
  std::vector<std::int32_t> triangles;
  std::vector<char> used(mesh.vertex_count(), 0);
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t* t = &whole.triangles[3 * f];
    if (!inside[std::size_t(t[0])] && !inside[std::size_t(t[1])] && !inside[std::size_t(t[2])]) continue;
    triangles.insert(triangles.end(), t, t + 3);
    for (int k = 0; k < 3; ++k)
      used[std::size_t(t[k])] = inside[std::size_t(t[k])];
  }
  if (triangles.empty()) return out;
  out.index.emplace(mesh.positions, triangles, OpenMeshSide::CAP_HOLES);
  const auto count = static_cast<std::size_t>(std::count(used.begin(), used.end(), char{1}));
  const std::size_t stride =
      std::max<std::size_t>(1, (count + options.max_samples - 1) / std::max<std::size_t>(1, options.max_samples));
  std::size_t k = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (!used[v] || k++ % stride != 0) continue;
    out.samples.insert(out.samples.end(), mesh.positions.begin() + std::ptrdiff_t(3 * v),
                       mesh.positions.begin() + std::ptrdiff_t(3 * v + 3));
  }
  return out;
}

// Votes of `samples` against `target`: (inside, outside) counts among the aligned hits.
std::pair<std::size_t, std::size_t> side_votes(const std::vector<float>& samples, const ProximityIndex& target,
                                               const LayerOrderOptions& options) {
  std::size_t inside = 0, outside = 0;
  if (samples.empty()) return {0, 0};
  ClosestHits hits;
  target.closest_points(samples, static_cast<float>(options.reach), hits);
  const ProximitySideMesh side = target.side_mesh();
  for (std::size_t q = 0; q < hits.size(); ++q) {
    const std::int32_t t = hits.triangles[q];
    if (t < 0) continue;
    double d[3], len2 = 0, along = 0;
    for (int c = 0; c < 3; ++c) {
      d[c] = double(samples[3 * q + std::size_t(c)]) - hits.points[3 * q + std::size_t(c)];
      len2 += d[c] * d[c];
      along += d[c] * side.face_normals[3 * static_cast<std::size_t>(t) + std::size_t(c)];
    }
    // A vertex on the other sheet (coincident layers, a shared seam) says nothing about sides.
    constexpr double ON_SURFACE = 1e-5; // m: 10 µm, far below any gap between two fabrics
    if (len2 < ON_SURFACE * ON_SURFACE) continue;
    if (std::abs(along) < options.alignment * std::sqrt(len2)) continue;
    (hits.signed_distances[q] < 0 ? inside : outside) += 1;
  }
  return {inside, outside};
}

} // namespace

LayerOrder infer_layer_order(std::span<const Mesh* const> garments, std::span<const std::size_t> default_order,
                             const std::function<bool(std::size_t, std::size_t)>& comparable,
                             const LayerOrderOptions& options) {
  const std::size_t n = garments.size();
  std::vector<std::size_t> position(n, n);
  if (default_order.size() != n) throw Error("layer order: the default order does not list every garment once");
  for (std::size_t k = 0; k < n; ++k) {
    if (default_order[k] >= n || position[default_order[k]] != n)
      throw Error("layer order: the default order does not list every garment once (entry " + std::to_string(k) + ")");
    position[default_order[k]] = k;
  }
  LayerOrder out;
  out.order.assign(default_order.begin(), default_order.end());
  if (n < 2) return out;

  std::vector<std::optional<Outward>> whole(n);     // built for garments in a comparable pair
  std::vector<std::vector<std::size_t>> over_of(n); // under → the garments over it
  std::vector<std::size_t> preceding(n, 0);         // how many garments must come before
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (comparable && !comparable(i, j)) continue;
      if (garments[i]->face_count() == 0 || garments[j]->face_count() == 0) continue;
      for (std::size_t g : {i, j})
        if (!whole[g]) whole[g] = outward(*garments[g]);
      const Cropped ci = crop(*garments[i], *whole[i], whole[j]->box, options);
      const Cropped cj = crop(*garments[j], *whole[j], whole[i]->box, options);
      if (!ci.index || !cj.index) continue; // too far apart to overlap
      LayerPairVotes v{i, j, 0, 0};
      const auto [i_in_j, i_out_j] = side_votes(ci.samples, *cj.index, options);
      const auto [j_in_i, j_out_i] = side_votes(cj.samples, *ci.index, options);
      v.first_under = i_in_j + j_out_i;
      v.first_over = i_out_j + j_in_i;
      out.votes.push_back(v);
      const std::size_t total = v.first_under + v.first_over;
      const std::size_t best = std::max(v.first_under, v.first_over);
      if (total < options.min_votes || static_cast<double>(best) < options.majority * static_cast<double>(total))
        continue;
      const bool i_under = v.first_under >= v.first_over;
      const LayerRelation r{i_under ? i : j, i_under ? j : i, best, total};
      out.relations.push_back(r);
      over_of[r.under].push_back(r.over);
      ++preceding[r.over];
    }

  // Topological sort, earliest in the default order first among the garments that may come next.
  std::vector<std::size_t> order;
  std::vector<char> placed(n, 0);
  while (order.size() < n) {
    std::size_t next = n;
    for (std::size_t g = 0; g < n; ++g)
      if (!placed[g] && preceding[g] == 0 && (next == n || position[g] < position[next])) next = g;
    if (next == n) { // a cycle: the relations contradict one another
      out.contradictory = true;
      out.relations.clear();
      return out;
    }
    placed[next] = 1;
    order.push_back(next);
    for (std::size_t o : over_of[next])
      --preceding[o];
  }
  out.order = std::move(order);
  return out;
}

} // namespace vfit
