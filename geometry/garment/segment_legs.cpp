// SPDX-License-Identifier: Apache-2.0
// Leg refinement of seed 000 §4.2 (eq. 3–4), and the other label helpers of segment_garment().
#include <algorithm>
#include <cmath>

#include "segment.h"
#include "segment_parts.h"

namespace vfit::segment_detail {
namespace {

// The body's crotch, through which the planes of eq. 4 pass, lies above the cloth's: by 4 %
// of the hips' width, calibrated on the catalogue (trousers and shorts, sizes P1, P2, M).
constexpr double CROTCH_LIFT = 0.04;
// Trousers have legs at least as long as the hips are wide; shorts shorter ones.
constexpr double TROUSER_LEG_PER_HIP = 1.0;
// The skirt of a dress starts at the lowest slab within 1.5 % of the narrowest girth.
constexpr double WAIST_TOLERANCE = 0.015;

// Width (x) of the main component within a thin slab around height y.
double width_at(const GarmentFrame& fr, double y) {
  const SurfaceGraph& g = *fr.graph;
  const double band = 0.02 * (fr.max_y - fr.min_y);
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (fr.main[v] && std::abs(g.points[v].y() - y) <= band) {
      lo = std::min(lo, g.points[v].x());
      hi = std::max(hi, g.points[v].x());
    }
  return hi > lo ? hi - lo : 2 * fr.half_width;
}

} // namespace

std::int32_t height_saddle(const GarmentFrame& fr, const std::vector<std::int32_t>& a,
                           const std::vector<std::int32_t>& b, const std::vector<char>* within) {
  const SurfaceGraph& g = *fr.graph;
  if (a.empty() || b.empty()) return -1;
  UnionFind sets(g.vertex_count());
  std::vector<char> active(g.vertex_count(), 0);
  // Each set is whole and present from the start: a hem that is not level must not delay the join.
  for (const auto* set : {&a, &b})
    for (std::int32_t v : *set) {
      sets.unite(std::uint32_t(v), std::uint32_t(set->front()));
      active[v] = 1;
    }
  const std::uint32_t ra = std::uint32_t(a.front()), rb = std::uint32_t(b.front());
  if (sets.find(ra) == sets.find(rb)) return a.front();
  std::vector<std::int32_t> order;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (fr.main[v] && !active[v] && (!within || (*within)[v])) order.push_back(std::int32_t(v));
  std::sort(order.begin(), order.end(), [&](auto u, auto v) { return g.points[u].y() < g.points[v].y(); });
  for (std::int32_t v : order) {
    active[v] = 1;
    for (std::int32_t k = g.offsets[v]; k < g.offsets[v + 1]; ++k)
      if (active[g.neighbours[k]]) sets.unite(std::uint32_t(v), std::uint32_t(g.neighbours[k]));
    if (sets.find(ra) == sets.find(rb)) return v;
  }
  return -1;
}

// The crotch from the Reeb graph: the first band from the waist where the garment has split
// into a left and a right node, then the height saddle between those two rings through the
// part of the garment above them. Loose legs whose tubes touch again between the knees do not
// fool it, where the merge tree's saddle (and the height saddle between the hems) would sit at
// the knees. −1 when no band splits so.
std::int32_t crotch_vertex(const GarmentFrame& fr, const ReebGraph& rg) {
  const SurfaceGraph& g = *fr.graph;
  std::vector<char> at_source(g.vertex_count(), 0);
  for (std::int32_t v : g.loops[fr.source].vertices)
    at_source[v] = 1;
  std::vector<char> touches_source(rg.nodes.size(), 0);
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (at_source[v] && rg.vertex_node[v] >= 0) touches_source[rg.vertex_node[v]] = 1;
  std::size_t main_count = 0;
  for (char m : fr.main)
    main_count += m;
  const std::size_t significant = std::max<std::size_t>(3, main_count / 500);
  // Per band: does it hold significant nodes on the left, on the right, in the middle?
  const int bands = int(rg.levels.size()) - 1;
  std::vector<int> has(std::size_t(bands), 0); // bit 0 right, bit 1 left, bit 2 central
  auto side_of = [&](const ReebNode& node) {
    const double dx = node.centroid.x() - fr.mid_x;
    return std::abs(dx) < 0.25 * fr.half_width ? 2 : dx > 0 ? 1 : 0;
  };
  for (std::size_t n = 0; n < rg.nodes.size(); ++n)
    if (!touches_source[n] && rg.nodes[n].vertex_count >= significant)
      has[rg.nodes[n].band] |= 1 << side_of(rg.nodes[n]);
  // The legs have split where a band and the next two hold a left and a right node and nothing
  // in the middle (near the waist a ring can break into arcs for a band or two).
  for (int band = 0; band + 2 < bands; ++band) {
    if (!(has[band] == 3 && has[band + 1] == 3 && has[band + 2] == 3)) continue;
    std::vector<std::int32_t> sides[2]; // right, left
    for (std::size_t v = 0; v < g.vertex_count(); ++v) {
      const std::int32_t n = rg.vertex_node[v];
      if (n >= 0 && rg.nodes[n].band == band && !touches_source[n] && rg.nodes[n].vertex_count >= significant)
        sides[side_of(rg.nodes[n])].push_back(std::int32_t(v));
    }
    std::vector<char> above(g.vertex_count(), 0);
    for (std::size_t v = 0; v < g.vertex_count(); ++v)
      above[v] = (*fr.f)[v] < rg.levels[band + 1];
    return height_saddle(fr, sides[0], sides[1], &above);
  }
  return -1;
}

void refine_legs(const GarmentFrame& fr, const std::vector<Limb>& legs, double slope, GarmentSegmentation& out) {
  const SurfaceGraph& g = *fr.graph;
  double sum_x = 0;
  std::size_t n = 0;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    if (fr.main[v] && out.coarse_parts[v] == GarmentPart::TORSO) {
      sum_x += g.points[v].x();
      ++n;
    }
  std::int32_t pt = crotch_vertex(fr, out.reeb_graph);
  if (pt < 0) pt = height_saddle(fr, g.loops[legs[0].loop].vertices, g.loops[legs[1].loop].vertices);
  if (pt < 0) pt = legs[0].saddle;
  Eigen::Vector3d crotch(n ? sum_x / double(n) : fr.mid_x, g.points[pt].y(), g.points[pt].z());
  const double hips = width_at(fr, crotch.y());
  crotch.y() += CROTCH_LIFT * hips;
  out.key_points.crotch = crotch;
  for (std::size_t v = 0; v < g.vertex_count(); ++v) {
    if (!fr.main[v]) continue;
    const Eigen::Vector3d& p = g.points[v];
    const double dx = p.x() - crotch.x();
    // Eq. 4: S1: −k x + y = −k Pt(x) + Pt(y) (right leg), S2: k x + y = k Pt(x) + Pt(y) (left).
    if (p.y() < crotch.y() + slope * std::abs(dx))
      out.vertex_parts[v] = dx > 0 ? GarmentPart::LEFT_LEG : GarmentPart::RIGHT_LEG;
  }
  keep_largest_pieces(fr, {GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG}, GarmentPart::TORSO, out.vertex_parts);
  const double leg = crotch.y() - fr.min_y;
  out.type = leg >= TROUSER_LEG_PER_HIP * hips ? GarmentType::TROUSERS : GarmentType::SHORTS;
}

double narrowest_girth_height(const GarmentFrame& frame, double top, double bottom) {
  const SurfaceGraph& g = *frame.graph;
  // About 30 vertices per slab, so that each slab's girth is an average, not a sample.
  std::size_t inside = 0;
  for (std::size_t v = 0; v < g.vertex_count(); ++v)
    inside += frame.main[v] && g.points[v].y() >= bottom && g.points[v].y() < top;
  const int slabs = std::clamp(int(inside / 30), 16, 64), half_window = 2;
  const double h = (top - bottom) / slabs;
  // Girth of a slab as 2π × the RMS distance of its vertices from their centre in XZ: every
  // vertex votes, where extents would hang on two.
  std::vector<double> n(slabs, 0), sx(slabs, 0), sz(slabs, 0), sq(slabs, 0);
  for (std::size_t v = 0; v < g.vertex_count(); ++v) {
    if (!frame.main[v]) continue;
    const Eigen::Vector3d& p = g.points[v];
    const int s = int(std::floor((p.y() - bottom) / h));
    if (s < 0 || s >= slabs) continue;
    n[s] += 1;
    sx[s] += p.x();
    sz[s] += p.z();
    sq[s] += p.x() * p.x() + p.z() * p.z();
  }
  std::vector<double> radius(slabs, NAN);
  for (int s = 0; s < slabs; ++s)
    if (n[s] >= 3) radius[s] = std::sqrt(std::max(0.0, sq[s] / n[s] - (sx[s] * sx[s] + sz[s] * sz[s]) / (n[s] * n[s])));
  std::vector<double> smooth(slabs, INFINITY);
  double least = INFINITY;
  for (int s = half_window; s + half_window < slabs; ++s) {
    double sum = 0;
    for (int k = -half_window; k <= half_window; ++k)
      sum += radius[s + k];
    if (std::isfinite(sum)) smooth[s] = sum / (2 * half_window + 1);
    least = std::min(least, smooth[s]);
  }
  if (!std::isfinite(least)) return 0.5 * (top + bottom);
  // The waist is a shallow valley whose floor is noisy; the skirt starts where the garment
  // begins to widen downwards: the lowest slab within 1.5 % of the floor.
  for (int s = 0; s < slabs; ++s)
    if (smooth[s] <= (1 + WAIST_TOLERANCE) * least) return bottom + (s + 0.5) * h;
  return 0.5 * (top + bottom);
}

void keep_largest_pieces(const GarmentFrame& frame, const std::vector<GarmentPart>& limbs, GarmentPart fallback,
                         std::vector<GarmentPart>& parts) {
  const SurfaceGraph& g = *frame.graph;
  const std::size_t nv = g.vertex_count();
  for (GarmentPart part : limbs) {
    std::vector<std::int32_t> piece(nv, -1);
    std::vector<std::size_t> sizes;
    for (std::size_t s = 0; s < nv; ++s) {
      if (parts[s] != part || piece[s] >= 0) continue;
      const std::int32_t id = std::int32_t(sizes.size());
      std::vector<std::int32_t> queue{std::int32_t(s)};
      piece[s] = id;
      for (std::size_t i = 0; i < queue.size(); ++i)
        for (std::int32_t k = g.offsets[queue[i]]; k < g.offsets[queue[i] + 1]; ++k) {
          const std::int32_t u = g.neighbours[k];
          if (parts[u] == part && piece[u] < 0) {
            piece[u] = id;
            queue.push_back(u);
          }
        }
      sizes.push_back(queue.size());
    }
    if (sizes.size() <= 1) continue;
    const std::int32_t largest = std::int32_t(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
    for (std::size_t v = 0; v < nv; ++v)
      if (piece[v] >= 0 && piece[v] != largest) parts[v] = fallback;
  }
}

} // namespace vfit::segment_detail
