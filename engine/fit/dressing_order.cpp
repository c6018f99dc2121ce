// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/dressing_order.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "vfit/engine/dress/layer_order.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit::fitting {
namespace {

// Whether two garments from different files may be compared by their geometry as given: only
// when their files look like one frame (a design tool's export of a look, each garment on the
// same avatar): the same up axis; overlapping across (each horizontal extent shares half of the
// narrower one's); and along the up axis, a top above a bottom (its highest point higher, its
// lowest point higher) or two tops or two bottoms sharing half of the shorter one's height.
// Garments from unrelated sources, each centred on its own origin, fail it.
bool frames_agree(const Mesh& a, UpAxis up_a, bool bottom_a, const Mesh& b, UpAxis up_b, bool bottom_b) {
  if (up_a != up_b || a.face_count() == 0 || b.face_count() == 0) return false;
  auto box = [&](const Mesh& m) {
    std::vector<float> p = m.positions;
    rotate_to_y_up(p, up_a);
    std::array<double, 6> bx{+INFINITY, +INFINITY, +INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (std::size_t v = 0; v < p.size() / 3; ++v)
      for (int c = 0; c < 3; ++c) {
        bx[std::size_t(c)] = std::min(bx[std::size_t(c)], double(p[3 * v + std::size_t(c)]));
        bx[std::size_t(c) + 3] = std::max(bx[std::size_t(c) + 3], double(p[3 * v + std::size_t(c)]));
      }
    return bx;
  };
  const auto ba = box(a), bb = box(b);
  auto shares_half = [&](int c) {
    const double overlap =
        std::min(ba[std::size_t(c) + 3], bb[std::size_t(c) + 3]) - std::max(ba[std::size_t(c)], bb[std::size_t(c)]);
    const double shorter =
        std::min(ba[std::size_t(c) + 3] - ba[std::size_t(c)], bb[std::size_t(c) + 3] - bb[std::size_t(c)]);
    return overlap >= 0.5 * shorter;
  };
  if (!shares_half(0) || !shares_half(2)) return false;
  if (bottom_a == bottom_b) return shares_half(1);
  const auto& top = bottom_a ? bb : ba;
  const auto& bottom = bottom_a ? ba : bb;
  return top[4] > bottom[4] && top[1] > bottom[1];
}

} // namespace

bool is_bottom(GarmentType type) {
  return type == GarmentType::TROUSERS || type == GarmentType::SHORTS || type == GarmentType::SKIRT;
}

std::vector<std::size_t> dressing_order(const FitOptions& options, const SplitInputs& split,
                                        const std::vector<Mesh>& as_given, std::vector<GarmentFitReport>& reports) {
  const std::size_t n = reports.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  if (options.layer_order == LayerOrderRule::GIVEN) return order;
  // Bottoms before tops (seed 000 §6: the top is dressed over the trousers).
  std::stable_partition(order.begin(), order.end(), [&](std::size_t i) { return is_bottom(reports[i].type); });
  if (options.layer_order != LayerOrderRule::AUTO || n < 2 || as_given.size() != n) return order;

  std::vector<const Mesh*> meshes(n);
  for (std::size_t i = 0; i < n; ++i)
    meshes[i] = &as_given[i];
  const auto comparable = [&](std::size_t i, std::size_t j) {
    return split.source[i] == split.source[j] || frames_agree(as_given[i], reports[i].up, is_bottom(reports[i].type),
                                                              as_given[j], reports[j].up, is_bottom(reports[j].type));
  };
  const LayerOrder found = infer_layer_order(meshes, order, comparable);
  std::vector<std::size_t> rank(n);
  for (std::size_t k = 0; k < n; ++k)
    rank[order[k]] = k;
  if (found.contradictory) {
    reports[order.front()].warnings.push_back(
        "the garments' geometry as given gives no consistent layer order (their overlaps contradict one another): "
        "dressed bottoms first");
    return order;
  }
  for (const LayerRelation& r : found.relations) {
    if (rank[r.under] < rank[r.over]) continue; // as the type rule has it
    char votes[96];
    std::snprintf(votes, sizeof votes, "%zu of %zu", r.agree, r.total);
    reports[r.under].warnings.push_back("worn under " + reports[r.over].name +
                                        " (read from the garments as given: " + votes +
                                        " of their nearby vertices agree), so dressed before it, not after as "
                                        "bottoms-first would have it");
  }
  return found.order;
}

} // namespace vfit::fitting
