// SPDX-License-Identifier: Apache-2.0
#include "cross_section.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace vfit {

std::vector<SectionLoop> horizontal_section(const Mesh& mesh, double height) {
  const auto& p = mesh.positions;
  auto y_of = [&](std::int32_t v) {
    const double y = p[3 * v + 1];
    return y == height ? y + 1e-9 : y;
  };
  // Segment endpoints are keyed by their edge; each crossing edge is shared by ≤ 2 segments.
  struct Link {
    std::int64_t other[2] = {-1, -1};
    std::array<double, 2> point{};
  };
  std::unordered_map<std::uint64_t, std::size_t> node_of;
  std::vector<Link> nodes;
  std::vector<std::uint64_t> keys;
  auto node = [&](std::int32_t a, std::int32_t b) {
    const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::uint32_t(std::max(a, b));
    auto it = node_of.find(key);
    if (it != node_of.end()) return it->second;
    const double ya = y_of(a), yb = y_of(b), t = (height - ya) / (yb - ya);
    Link l;
    l.point = {p[3 * a] + t * (p[3 * b] - p[3 * a]), p[3 * a + 2] + t * (p[3 * b + 2] - p[3 * a + 2])};
    nodes.push_back(l);
    keys.push_back(key);
    node_of.emplace(key, nodes.size() - 1);
    return nodes.size() - 1;
  };
  auto connect = [&](std::size_t a, std::size_t b) {
    for (std::size_t s : {a, b}) {
      const std::size_t o = s == a ? b : a;
      Link& l = nodes[s];
      if (l.other[0] < 0)
        l.other[0] = static_cast<std::int64_t>(o);
      else if (l.other[1] < 0)
        l.other[1] = static_cast<std::int64_t>(o);
    }
  };
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const std::int32_t v[3] = {mesh.triangles[3 * f], mesh.triangles[3 * f + 1], mesh.triangles[3 * f + 2]};
    std::size_t ends[2];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = v[k], b = v[(k + 1) % 3];
      if ((y_of(a) < height) != (y_of(b) < height) && n < 2) ends[n++] = node(a, b);
    }
    if (n == 2) connect(ends[0], ends[1]);
  }
  // Walk the links into loops, starting preferably at chain ends so open chains come out whole.
  std::vector<char> used(nodes.size(), 0);
  std::vector<SectionLoop> loops;
  auto walk = [&](std::size_t start) {
    SectionLoop loop;
    std::int64_t prev = -1, cur = static_cast<std::int64_t>(start);
    while (cur >= 0 && !used[cur]) {
      used[cur] = 1;
      loop.push_back(nodes[cur].point);
      const Link& l = nodes[cur];
      const std::int64_t next = l.other[0] != prev ? l.other[0] : l.other[1];
      prev = cur;
      cur = next;
    }
    loops.push_back(std::move(loop));
  };
  for (std::size_t s = 0; s < nodes.size(); ++s)
    if (!used[s] && nodes[s].other[1] < 0) walk(s);
  for (std::size_t s = 0; s < nodes.size(); ++s)
    if (!used[s]) walk(s);
  return loops;
}

bool loop_contains(const SectionLoop& loop, double x, double z) {
  bool inside = false;
  for (std::size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++) {
    const auto& a = loop[i];
    const auto& b = loop[j];
    if ((a[1] > z) != (b[1] > z) && x < (b[0] - a[0]) * (z - a[1]) / (b[1] - a[1]) + a[0]) inside = !inside;
  }
  return inside;
}

double convex_hull_perimeter(const SectionLoop& loop) {
  if (loop.size() < 2) return 0;
  std::vector<std::array<double, 2>> pts(loop.begin(), loop.end());
  std::sort(pts.begin(), pts.end());
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 2) return 0;
  auto cross = [](const auto& o, const auto& a, const auto& b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  };
  // Andrew's monotone chain.
  std::vector<std::array<double, 2>> hull(2 * pts.size());
  std::size_t k = 0;
  for (const auto& q : pts) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], q) <= 0)
      --k;
    hull[k++] = q;
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0)
      --k;
    hull[k++] = pts[i];
  }
  double perimeter = 0;
  for (std::size_t i = 1; i < k; ++i)
    perimeter += std::hypot(hull[i][0] - hull[i - 1][0], hull[i][1] - hull[i - 1][1]);
  return perimeter;
}

double girth_around(const Mesh& mesh, double height, double x, double z) {
  double best = 0;
  for (const auto& loop : horizontal_section(mesh, height))
    if (loop.size() >= 3 && loop_contains(loop, x, z)) best = std::max(best, convex_hull_perimeter(loop));
  return best;
}

} // namespace vfit
