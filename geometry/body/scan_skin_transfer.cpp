// SPDX-License-Identifier: Apache-2.0
#include "scan_skin_transfer.h"

#include <algorithm>
#include <array>
#include <deque>
#include <limits>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

using Vec3 = Eigen::Vector3d;
constexpr int CHAINS = 5;
constexpr std::size_t GRAIN = 512; // target vertices per TBB task
// Chains are searched this far (m) from each target vertex: farther than a fit leaves a scan
// vertex off its template (a few cm), near enough to prune the search; a vertex with no chain
// this near keeps the plain closest point.
constexpr double CHAIN_RADIUS = 0.15;

Vec3 point(std::span<const float> p, std::size_t v) { return {p[3 * v], p[3 * v + 1], p[3 * v + 2]}; }

Vec3 triangle_normal(const Mesh& m, std::int32_t f) {
  const auto c = [&](int k) {
    return point(m.positions, static_cast<std::size_t>(m.triangles[3 * static_cast<std::size_t>(f) + k]));
  };
  const Vec3 n = (c(1) - c(0)).cross(c(2) - c(0));
  return n.norm() > 0 ? Vec3(n.normalized()) : Vec3::Zero();
}

// The weights at a closest point: its triangle's corners blended barycentrically, the 4 largest
// kept and renormalised (in float, as stored), written into row `row` of `out`.
void blend_at(const Mesh& source, const SkinWeights& w, const ClosestHits& hits, std::size_t i, SkinWeights& out,
              std::size_t row) {
  const double u = hits.barycentrics[2 * i], v = hits.barycentrics[2 * i + 1];
  const auto f = 3 * static_cast<std::size_t>(hits.triangles[i]);
  std::array<int, 4> joint;
  std::array<double, 4> weight;
  largest_blended_influences(w, {source.triangles[f], source.triangles[f + 1], source.triangles[f + 2]},
                             {1 - u - v, u, v}, joint, weight);
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    out.joints[4 * row + k] = joint[k];
    out.weights[4 * row + k] = static_cast<float>(weight[k]);
    sum += weight[k];
  }
  for (int k = 0; k < 4; ++k)
    out.weights[4 * row + k] = sum > 0 ? static_cast<float>(out.weights[4 * row + k] / sum) : (k == 0 ? 1.f : 0.f);
}

} // namespace

int skin_chain_of_joint(int joint) {
  switch (static_cast<Joint>(joint)) {
  case Joint::LEFT_SHOULDER:
  case Joint::LEFT_ELBOW:
  case Joint::LEFT_WRIST:
  case Joint::LEFT_HAND: return 1;
  case Joint::RIGHT_SHOULDER:
  case Joint::RIGHT_ELBOW:
  case Joint::RIGHT_WRIST:
  case Joint::RIGHT_HAND: return 2;
  case Joint::LEFT_HIP:
  case Joint::LEFT_KNEE:
  case Joint::LEFT_ANKLE:
  case Joint::LEFT_FOOT: return 3;
  case Joint::RIGHT_HIP:
  case Joint::RIGHT_KNEE:
  case Joint::RIGHT_ANKLE:
  case Joint::RIGHT_FOOT: return 4;
  default: return 0;
  }
}

SkinWeights transfer_skin_weights(const Mesh& source, const SkinWeights& source_weights, const Mesh& target,
                                  double margin) {
  if (source.face_count() == 0) throw Error("skin weight transfer", 0, "the source mesh has no faces");
  validate_skin_weights(source_weights, source.vertex_count(), "skin weight transfer");
  const std::size_t n = target.vertex_count();
  SkinWeights out;
  out.joints.assign(4 * n, 0);
  out.weights.assign(4 * n, 0.f);

  // The source's triangles by the chain of their dominant joint.
  std::array<std::vector<std::int32_t>, CHAINS> chain_triangles;
  std::vector<int> triangle_chain(source.face_count());
  for (std::size_t f = 0; f < source.face_count(); ++f) {
    std::array<double, JOINT_COUNT> dense{};
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 4; ++k) {
        const std::size_t s = 4 * static_cast<std::size_t>(source.triangles[3 * f + c]) + k;
        dense[static_cast<std::size_t>(source_weights.joints[s])] += source_weights.weights[s];
      }
    const int chain =
        skin_chain_of_joint(static_cast<int>(std::max_element(dense.begin(), dense.end()) - dense.begin()));
    triangle_chain[f] = chain;
    for (int c = 0; c < 3; ++c)
      chain_triangles[static_cast<std::size_t>(chain)].push_back(source.triangles[3 * f + c]);
  }
  const ProximityIndex whole(source.positions, source.triangles);
  ClosestHits closest;
  whole.closest_points(target.positions, std::numeric_limits<float>::infinity(), closest);
  if (target.face_count() == 0) { // a point cloud: no normals to tell the sides apart, no edges
    parallel_for_range(n, GRAIN, [&](std::size_t begin, std::size_t end) {
      for (std::size_t v = begin; v < end; ++v)
        blend_at(source, source_weights, closest, v, out, v);
    });
    return out;
  }

  // Per chain, the closest point of each target vertex, kept when the surfaces face alike.
  const std::vector<Vec3> normals = area_weighted_vertex_normals(target.positions, target.triangles);
  std::array<ClosestHits, CHAINS> hits;
  std::array<Mesh, CHAINS> parts;
  std::vector<std::array<double, CHAINS>> distance(n);
  const double reach = 2.5 * margin;
  for (int c = 0; c < CHAINS; ++c) {
    const auto u = static_cast<std::size_t>(c);
    for (auto& d : distance)
      d[u] = std::numeric_limits<double>::infinity();
    if (chain_triangles[u].empty()) continue;
    parts[u].positions = source.positions;
    parts[u].triangles = chain_triangles[u];
    const ProximityIndex index(parts[u].positions, parts[u].triangles, OpenMeshSide::ONE_SIDED);
    index.closest_points(target.positions, static_cast<float>(CHAIN_RADIUS), hits[u]);
    for (std::size_t v = 0; v < n; ++v) {
      const double d = std::abs(hits[u].signed_distances[v]);
      // A chain counts only near the body's closest surface (within `reach`): an arm 40 cm off
      // is no candidate for a vertex whose own part's closest surface faces away.
      if (hits[u].triangles[v] >= 0 && d <= std::abs(closest.signed_distances[v]) + reach &&
          triangle_normal(parts[u], hits[u].triangles[v]).dot(normals[v]) > 0)
        distance[v][u] = d;
    }
  }

  // Sure vertices keep their nearest chain; the others take the nearest sure vertex's (in edges).
  constexpr int UNSURE = -1;
  std::vector<int> chain(n, UNSURE);
  std::deque<std::size_t> queue;
  for (std::size_t v = 0; v < n; ++v) {
    const auto& d = distance[v];
    const auto best = static_cast<std::size_t>(std::min_element(d.begin(), d.end()) - d.begin());
    double second = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < CHAINS; ++c)
      if (c != best) second = std::min(second, d[c]);
    if (std::isfinite(d[best]) && second - d[best] > margin) {
      chain[v] = static_cast<int>(best);
      queue.push_back(v);
    }
  }
  std::vector<std::vector<std::int32_t>> neighbours(n);
  for (std::size_t f = 0; f < target.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::size_t>(target.triangles[3 * f + k]);
      neighbours[a].push_back(target.triangles[3 * f + (k + 1) % 3]);
      neighbours[a].push_back(target.triangles[3 * f + (k + 2) % 3]);
    }
  auto spread = [&] { // multi-source breadth-first: each unsure vertex takes the nearest labelled one's chain
    while (!queue.empty()) {
      const std::size_t v = queue.front();
      queue.pop_front();
      for (std::int32_t w : neighbours[v])
        if (chain[static_cast<std::size_t>(w)] == UNSURE) {
          chain[static_cast<std::size_t>(w)] = chain[v];
          queue.push_back(static_cast<std::size_t>(w));
        }
    }
  };
  spread();
  // A limb is one piece: islands of a chain apart from its largest piece (fingers of one hand
  // among the other hand's template) lose it and take their surroundings' chain.
  std::vector<int> piece(n, -1);
  std::vector<std::size_t> piece_size;
  std::array<int, CHAINS> largest;
  largest.fill(-1);
  for (std::size_t s = 0; s < n; ++s) {
    if (piece[s] >= 0 || chain[s] == UNSURE) continue;
    const int id = static_cast<int>(piece_size.size());
    std::size_t size = 0;
    std::vector<std::size_t> stack = {s};
    piece[s] = id;
    while (!stack.empty()) {
      const std::size_t v = stack.back();
      stack.pop_back();
      ++size;
      for (std::int32_t w : neighbours[v])
        if (piece[static_cast<std::size_t>(w)] < 0 && chain[static_cast<std::size_t>(w)] == chain[s]) {
          piece[static_cast<std::size_t>(w)] = id;
          stack.push_back(static_cast<std::size_t>(w));
        }
    }
    piece_size.push_back(size);
    int& best = largest[static_cast<std::size_t>(chain[s])];
    if (best < 0 || size > piece_size[static_cast<std::size_t>(best)]) best = id;
  }
  for (std::size_t v = 0; v < n; ++v)
    if (chain[v] != UNSURE && piece[v] != largest[static_cast<std::size_t>(chain[v])]) chain[v] = UNSURE;
  for (std::size_t v = 0; v < n; ++v)
    if (chain[v] != UNSURE) queue.push_back(v);
  spread();
  parallel_for_range(n, GRAIN, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v < end; ++v) {
      const int c = chain[v];
      // The closest point of all where no sure vertex reaches the vertex, where its chain has
      // no surface within CHAIN_RADIUS, or where the closest point lies on its chain. A chain
      // farther than the closest surface still gives the weights: a folded hand whose template
      // hand lies 5 cm off, nearer the other forearm or the belly, keeps its own arm's (the
      // nearest surface's tore 250 of the corpus body's hand vertices off their arm), and so
      // does a chain as near as another's (hands or an arm and the belly pressed into each
      // other: counting a chain within 0.1 mm of the closest point as the closest handed
      // elbows_bent's wrists the other hand's weights, re-posed 94 cm off).
      const int closest_chain = triangle_chain[static_cast<std::size_t>(closest.triangles[v])];
      const bool own_closest = c == UNSURE || hits[static_cast<std::size_t>(c)].triangles[v] < 0 || closest_chain == c;
      if (own_closest)
        blend_at(source, source_weights, closest, v, out, v);
      else
        blend_at(parts[static_cast<std::size_t>(c)], source_weights, hits[static_cast<std::size_t>(c)], v, out, v);
    }
  });
  return out;
}

void largest_blended_influences(const SkinWeights& weights, const std::array<std::int32_t, 3>& corners,
                                const std::array<double, 3>& bary, std::array<int, 4>& joint,
                                std::array<double, 4>& weight) {
  std::array<double, JOINT_COUNT> dense{};
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 4; ++k) {
      const std::size_t i = 4 * static_cast<std::size_t>(corners[c]) + k;
      dense[static_cast<std::size_t>(weights.joints[i])] += bary[c] * weights.weights[i];
    }
  joint.fill(0);
  weight.fill(0);
  for (int k = 0; k < 4; ++k) {
    const auto it = std::max_element(dense.begin(), dense.end());
    if (*it <= 0) break;
    joint[k] = static_cast<int>(it - dense.begin());
    weight[k] = *it;
    *it = 0;
  }
}

std::vector<Vec3> area_weighted_vertex_normals(std::span<const float> positions,
                                               std::span<const std::int32_t> triangles) {
  std::vector<Vec3> n(positions.size() / 3, Vec3::Zero());
  for (std::size_t f = 0; f + 2 < triangles.size(); f += 3) {
    const Vec3 a = point(positions, static_cast<std::size_t>(triangles[f]));
    const Vec3 fn = (point(positions, static_cast<std::size_t>(triangles[f + 1])) - a)
                        .cross(point(positions, static_cast<std::size_t>(triangles[f + 2])) - a);
    for (int k = 0; k < 3; ++k)
      n[static_cast<std::size_t>(triangles[f + k])] += fn;
  }
  for (Vec3& v : n)
    if (v.norm() > 0) v.normalize();
  return n;
}

} // namespace vfit
