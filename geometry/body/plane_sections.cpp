// SPDX-License-Identifier: Apache-2.0
#include "plane_sections.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <functional>
#include <unordered_map>

namespace vfit {
namespace {

// Extent directions for the diameter: the largest width over 16 directions is within
// 1 − cos(π/32) ≈ 0.5 % of the true diameter.
constexpr int DIAMETER_DIRECTIONS = 16;

struct PositionHash {
  std::size_t operator()(const std::array<float, 3>& p) const {
    std::size_t h = 0;
    for (float c : p)
      h = h * 0x9E3779B97F4A7C15ull + std::hash<float>{}(c);
    return h;
  }
};

void summarise(PlaneSection& s, const PlaneSlicer& slicer) {
  const std::size_t n = s.points.size();
  s.uv.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    s.uv[i] = slicer.project(s.points[i]);
  // Shoelace area and centroid about the first point (keeps the sums well conditioned).
  const Eigen::Vector2d o = s.uv[0];
  double a2 = 0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero(), mean = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = s.uv[i] - o, q = s.uv[(i + 1) % n] - o;
    const double cr = p.x() * q.y() - q.x() * p.y();
    a2 += cr;
    c += (p + q) * cr;
    mean += s.uv[i];
    s.perimeter += (s.uv[(i + 1) % n] - s.uv[i]).norm();
  }
  mean /= double(n);
  s.area = std::abs(a2) / 2;
  s.centroid_uv = std::abs(a2) > 1e-14 ? Eigen::Vector2d(o + c / (3 * a2)) : mean;
  const double level = s.points[0].dot(slicer.direction());
  s.centroid = slicer.point(level, s.centroid_uv);
  for (int k = 0; k < DIAMETER_DIRECTIONS; ++k) {
    const double t = M_PI * k / DIAMETER_DIRECTIONS;
    const Eigen::Vector2d e(std::cos(t), std::sin(t));
    double lo = INFINITY, hi = -INFINITY;
    for (const auto& p : s.uv) {
      lo = std::min(lo, p.dot(e));
      hi = std::max(hi, p.dot(e));
    }
    s.diameter = std::max(s.diameter, hi - lo);
  }
}

} // namespace

bool PlaneSection::contains(const Eigen::Vector2d& q) const {
  bool inside = false;
  for (std::size_t i = 0, j = uv.size() - 1; i < uv.size(); j = i++) {
    const Eigen::Vector2d& a = uv[i];
    const Eigen::Vector2d& b = uv[j];
    if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

PlaneSlicer::PlaneSlicer(const Mesh& mesh, const Eigen::Vector3d& direction) : m_mesh(mesh) {
  assert(direction.norm() > 0 && "PlaneSlicer: zero direction");
  m_d = direction.normalized();
  // u: the axis least aligned with d, made orthogonal; v = d × u so that u × v = d.
  const Eigen::Vector3d seed = std::abs(m_d.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  m_u = (seed - seed.dot(m_d) * m_d).normalized();
  m_v = m_d.cross(m_u);
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  m_level.resize(nv);
  m_min = INFINITY;
  m_max = -INFINITY;
  for (std::size_t i = 0; i < nv; ++i) {
    m_level[i] =
        m_d.x() * mesh.positions[3 * i] + m_d.y() * mesh.positions[3 * i + 1] + m_d.z() * mesh.positions[3 * i + 2];
    m_min = std::min(m_min, m_level[i]);
    m_max = std::max(m_max, m_level[i]);
  }
  if (nv == 0) m_min = m_max = 0;
  // Corners at the same position share one index, so that an unwelded mesh (a triangle soup,
  // UV seams split into vertices) still cuts into closed loops.
  m_weld.resize(nv);
  std::unordered_map<std::array<float, 3>, std::int32_t, PositionHash> first;
  first.reserve(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const std::array<float, 3> key{mesh.positions[3 * i] + 0.0f, mesh.positions[3 * i + 1] + 0.0f,
                                   mesh.positions[3 * i + 2] + 0.0f};
    m_weld[i] = first.try_emplace(key, std::int32_t(i)).first->second;
  }
  // About 8 faces per bucket on average: a plane then visits a few hundred faces, not all.
  const std::size_t buckets = std::clamp<std::size_t>(nf / 8, 1, 1 << 16);
  m_bucket = std::max((m_max - m_min) / double(buckets), 1e-12);
  auto bucket_of = [&](double s) {
    return static_cast<std::size_t>(std::clamp((s - m_min) / m_bucket, 0.0, double(buckets - 1)));
  };
  std::vector<std::int32_t> count(buckets + 1, 0);
  auto face_range = [&](std::size_t f) {
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < 3; ++k) {
      const double s = m_level[static_cast<std::size_t>(mesh.triangles[3 * f + k])];
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    return std::pair{bucket_of(lo), bucket_of(hi)};
  };
  for (std::size_t f = 0; f < nf; ++f) {
    const auto [b0, b1] = face_range(f);
    for (std::size_t b = b0; b <= b1; ++b)
      ++count[b + 1];
  }
  for (std::size_t b = 0; b < buckets; ++b)
    count[b + 1] += count[b];
  m_bucket_start = count;
  m_bucket_faces.resize(static_cast<std::size_t>(count[buckets]));
  for (std::size_t f = 0; f < nf; ++f) {
    const auto [b0, b1] = face_range(f);
    for (std::size_t b = b0; b <= b1; ++b)
      m_bucket_faces[static_cast<std::size_t>(count[b]++)] = static_cast<std::int32_t>(f);
  }
}

std::vector<PlaneSection> PlaneSlicer::sections(double level) const {
  std::vector<PlaneSection> out;
  if (m_mesh.face_count() == 0 || level < m_min || level > m_max) return out;
  const std::size_t b =
      static_cast<std::size_t>(std::clamp((level - m_min) / m_bucket, 0.0, double(m_bucket_start.size() - 2)));
  // One node per crossing edge; each crossing face links its two nodes.
  struct Node {
    std::int64_t link[2] = {-1, -1};
    Eigen::Vector3d point;
  };
  std::vector<Node> nodes;
  std::unordered_map<std::uint64_t, std::size_t> node_of;
  const auto& p = m_mesh.positions;
  auto node = [&](std::int32_t a, std::int32_t c) {
    const std::uint64_t key = (std::uint64_t(std::uint32_t(std::min(a, c))) << 32) | std::uint32_t(std::max(a, c));
    const auto [it, fresh] = node_of.try_emplace(key, nodes.size());
    if (fresh) {
      const double la = m_level[std::size_t(a)], lc = m_level[std::size_t(c)], t = (level - la) / (lc - la);
      Node n;
      for (int k = 0; k < 3; ++k)
        n.point[k] = p[3 * std::size_t(a) + k] + t * (p[3 * std::size_t(c) + k] - p[3 * std::size_t(a) + k]);
      nodes.push_back(n);
    }
    return it->second;
  };
  auto link = [&](std::size_t a, std::size_t c) {
    for (auto [s, o] : {std::pair{a, c}, std::pair{c, a}}) {
      Node& n = nodes[s];
      if (n.link[0] < 0)
        n.link[0] = std::int64_t(o);
      else if (n.link[1] < 0)
        n.link[1] = std::int64_t(o);
    }
  };
  for (std::int32_t i = m_bucket_start[b]; i < m_bucket_start[b + 1]; ++i) {
    const std::size_t f = std::size_t(m_bucket_faces[std::size_t(i)]);
    const std::int32_t v[3] = {m_weld[std::size_t(m_mesh.triangles[3 * f])],
                               m_weld[std::size_t(m_mesh.triangles[3 * f + 1])],
                               m_weld[std::size_t(m_mesh.triangles[3 * f + 2])]};
    std::size_t ends[2];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = v[k], c = v[(k + 1) % 3];
      if ((m_level[std::size_t(a)] < level) != (m_level[std::size_t(c)] < level) && n < 2) ends[n++] = node(a, c);
    }
    if (n == 2) link(ends[0], ends[1]);
  }
  std::vector<char> used(nodes.size(), 0);
  auto walk = [&](std::size_t start) {
    PlaneSection s;
    s.closed = nodes[start].link[1] >= 0;
    std::int64_t prev = -1, cur = std::int64_t(start);
    while (cur >= 0 && !used[std::size_t(cur)]) {
      used[std::size_t(cur)] = 1;
      const Node& n = nodes[std::size_t(cur)];
      s.points.push_back(n.point);
      const std::int64_t next = n.link[0] != prev ? n.link[0] : n.link[1];
      prev = cur;
      cur = next;
    }
    if (s.points.size() >= 3) {
      summarise(s, *this);
      out.push_back(std::move(s));
    }
  };
  // Chain ends first, so open chains come out whole.
  for (std::size_t s = 0; s < nodes.size(); ++s)
    if (!used[s] && nodes[s].link[1] < 0) walk(s);
  for (std::size_t s = 0; s < nodes.size(); ++s)
    if (!used[s]) walk(s);
  return out;
}

} // namespace vfit
