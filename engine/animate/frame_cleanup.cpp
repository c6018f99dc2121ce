// SPDX-License-Identifier: Apache-2.0
#include "frame_cleanup.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "vfit/engine/dress/detection.h"
#include "vfit/engine/dress/layer_piercing.h"
#include "vfit/engine/dress/layering.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// Moves the vertex at `v` onto `closest` plus `target` along the outward direction: away from
// `closest` when the vertex is outside (signed ≥ 0), towards it when inside, or along the face
// normal `face` when the vertex lies on the surface.
void push_to(float* v, const float* closest, float signed_distance, const float* face, double target) {
  double n[3], len2 = 0;
  for (int k = 0; k < 3; ++k) {
    n[k] = double(v[k]) - closest[k];
    len2 += n[k] * n[k];
  }
  double scale = len2 > 1e-14 ? (signed_distance < 0 ? -1.0 : 1.0) / std::sqrt(len2) : 0.0;
  if (scale == 0.0)
    for (int k = 0; k < 3; ++k)
      n[k] = face[k], scale = 1.0;
  for (int k = 0; k < 3; ++k)
    v[k] = float(closest[k] + target * scale * n[k]);
}

float distance3(const float* a, const float* b) {
  double s = 0;
  for (int k = 0; k < 3; ++k)
    s += (double(a[k]) - b[k]) * (double(a[k]) - b[k]);
  return float(std::sqrt(s));
}

} // namespace

FrameCleanup::FrameCleanup(const Mesh& body, std::span<const Mesh* const> garments, const FrameCleanupOptions& options)
    : m_options(options), m_body_triangles(body.triangles), m_body_positions(body.positions),
      m_body(std::make_shared<ProximityIndex>(body.positions, body.triangles)) {
  if (!(options.body_gap >= 0) || !(options.layer_clearance >= 0) || !(options.reach > 0) ||
      options.crossing_rounds < 0)
    throw Error("frame clean-up", 0, "body_gap and layer_clearance must be ≥ 0, reach > 0, crossing_rounds ≥ 0");
  for (const Mesh* g : garments) {
    const InnerLayer layer(*g, *m_body, options.layer_clearance, options.reach);
    const LayerObstacle o = layer.obstacle();
    m_layers.push_back(Layer{g->triangles,
                             {o.triangles.begin(), o.triangles.end()},
                             {o.boundary.begin(), o.boundary.end()},
                             {o.edges.begin(), o.edges.end()},
                             {o.edge_offsets.begin(), o.edge_offsets.end()},
                             {o.vertex_edges.begin(), o.vertex_edges.end()},
                             ProximityIndex(o.points, o.triangles, OpenMeshSide::ONE_SIDED)});
    m_layer_positions.emplace_back(o.points.begin(), o.points.end());
  }
  m_previous_body.resize(garments.size());
  m_previous_layer.resize(garments.size());
  for (std::size_t g = 0; g < garments.size(); ++g)
    m_previous_layer[g].resize(g);
}

void FrameCleanup::refit_body(std::span<const float> positions) {
  m_body->refit(positions);
  m_body_positions.assign(positions.begin(), positions.end());
}

void FrameCleanup::query(const ProximityIndex& index, std::span<const float> surface,
                         std::span<const std::int32_t> triangles, std::span<const float> x, float cap,
                         Previous& previous, ClosestHits& hits) {
  const std::size_t nv = x.size() / 3;
  m_radii.assign(nv, cap);
  if (previous.triangles.size() == nv)
    for (std::size_t v = 0; v < nv; ++v) {
      const std::int32_t t = previous.triangles[v];
      if (t < 0) continue;
      const float u = previous.barycentrics[2 * v], w = previous.barycentrics[2 * v + 1];
      const float* a = &surface[3 * std::size_t(triangles[3 * std::size_t(t)])];
      const float* b = &surface[3 * std::size_t(triangles[3 * std::size_t(t) + 1])];
      const float* c = &surface[3 * std::size_t(triangles[3 * std::size_t(t) + 2])];
      float p[3];
      for (int k = 0; k < 3; ++k)
        p[k] = (1 - u - w) * a[k] + u * b[k] + w * c[k];
      m_radii[v] = std::min(cap, requery_radius(&x[3 * v], p));
    }
  index.closest_points(x, m_radii, hits);
  previous.triangles.assign(hits.triangles.begin(), hits.triangles.end());
  previous.barycentrics.assign(hits.barycentrics.begin(), hits.barycentrics.end());
}

std::size_t FrameCleanup::crossing_round(const Layer& layer, std::span<float> x, bool push) {
  const std::size_t ne = m_edge_rows.size();
  m_from.resize(3 * ne);
  m_to.resize(3 * ne);
  for (std::size_t i = 0; i < ne; ++i) {
    const auto e = std::size_t(m_edge_rows[i]);
    const auto a = std::size_t(layer.edges[2 * e]), b = std::size_t(layer.edges[2 * e + 1]);
    std::copy_n(&x[3 * a], 3, &m_from[3 * i]);
    std::copy_n(&x[3 * b], 3, &m_to[3 * i]);
  }
  m_body->first_hits(m_from, m_to, m_forward);
  m_body->first_hits(m_to, m_from, m_backward);
  // The middle of each chord inside: between the first meeting from a and the first from b.
  m_rows.clear();
  m_points.clear();
  for (std::size_t i = 0; i < ne; ++i) {
    if (m_forward.triangles[i] < 0) continue;
    const float t1 = m_forward.t[i], t2 = m_backward.triangles[i] < 0 ? 0.0f : m_backward.t[i];
    const float t = 0.5f * (t1 + 1.0f - t2);
    m_rows.push_back(std::int32_t(i));
    for (int k = 0; k < 3; ++k)
      m_points.push_back(m_from[3 * i + k] + t * (m_to[3 * i + k] - m_from[3 * i + k]));
  }
  if (!push || m_rows.empty()) return m_rows.size();
  m_body->closest_points(m_points, m_options.reach, m_sub_hits);
  const std::span<const float> faces = m_body->side_mesh().face_normals;
  std::fill(m_push.begin(), m_push.end(), 0.0f);
  for (std::size_t r = 0; r < m_rows.size(); ++r) {
    const auto e = std::size_t(m_edge_rows[std::size_t(m_rows[r])]);
    if (m_sub_hits.triangles[r] < 0) { // deeper than the reach: tested again next round, unmoved
      for (const std::int32_t end : {layer.edges[2 * e], layer.edges[2 * e + 1]})
        m_push[4 * std::size_t(end) + 3] = std::max(m_push[4 * std::size_t(end) + 3], 1e-30f);
      continue;
    }
    float middle[3];
    std::copy_n(&m_points[3 * r], 3, middle);
    push_to(middle, &m_sub_hits.points[3 * r], m_sub_hits.signed_distances[r],
            &faces[3 * std::size_t(m_sub_hits.triangles[r])], m_options.body_gap);
    float d[3];
    for (int k = 0; k < 3; ++k)
      d[k] = middle[k] - m_points[3 * r + k];
    const double len2 = double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2];
    for (const std::int32_t end : {layer.edges[2 * e], layer.edges[2 * e + 1]}) {
      float* p = &m_push[4 * std::size_t(end)];
      if (len2 <= double(p[3])) continue; // the largest push on a vertex wins
      std::copy_n(d, 3, p);
      p[3] = float(len2);
    }
  }
  m_moved.clear();
  for (std::size_t v = 0; 4 * v < m_push.size(); ++v) {
    if (m_push[4 * v + 3] <= 0.0f) continue;
    for (int k = 0; k < 3; ++k)
      x[3 * v + std::size_t(k)] += m_push[4 * v + std::size_t(k)];
    m_moved.push_back(std::int32_t(v));
  }
  return m_rows.size();
}

FrameCleanupCounts FrameCleanup::clean(std::size_t g, std::span<float> x) {
  FrameCleanupCounts counts;
  auto t0 = Clock::now();
  const Layer& own = m_layers.at(g);
  const std::size_t nv = x.size() / 3;
  const std::span<const float> body_faces = m_body->side_mesh().face_normals;
  const float reach = m_options.reach;

  // 1. Out of the body.
  query(*m_body, m_body_positions, m_body_triangles, x, INFINITY, m_previous_body[g], m_hits);
  m_distance.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const bool hit = m_hits.triangles[v] >= 0;
    m_distance[v] = hit ? m_hits.signed_distances[v] : reach;
    if (!hit || m_distance[v] >= 0) continue;
    push_to(&x[3 * v], &m_hits.points[3 * v], m_distance[v], &body_faces[3 * std::size_t(m_hits.triangles[v])],
            m_options.body_gap);
    m_distance[v] = float(m_options.body_gap);
    ++counts.body_pushed;
  }

  // 2. Edges through the body, rounds over the edges around what the last round moved.
  const std::size_t ne = own.edges.size() / 2;
  m_push.assign(4 * nv, 0.0f);
  m_moved_flag.assign(nv, 0);
  m_edge_flag.assign(ne, 1);
  for (int round = 0; round <= m_options.crossing_rounds; ++round) {
    const bool last = round == m_options.crossing_rounds;
    m_edge_rows.clear();
    for (std::size_t e = 0; e < ne; ++e) {
      if (!m_edge_flag[e]) continue;
      const auto a = std::size_t(own.edges[2 * e]), b = std::size_t(own.edges[2 * e + 1]);
      if (m_distance[a] < 0 || m_distance[b] < 0) continue; // an end inside: a vertex test's case
      if (double(m_distance[a]) + m_distance[b] > double(distance3(&x[3 * a], &x[3 * b])) + 2e-6) continue;
      m_edge_rows.push_back(std::int32_t(e));
    }
    const std::size_t found = crossing_round(own, x, !last);
    if (last) {
      counts.left_crossing = found;
      break;
    }
    counts.crossings_pushed += found;
    if (m_moved.empty()) break;
    // The moved vertices' distances again, and the edges around them for the next round.
    m_points.clear();
    for (const std::int32_t v : m_moved)
      m_points.insert(m_points.end(), &x[3 * std::size_t(v)], &x[3 * std::size_t(v)] + 3);
    m_body->closest_points(m_points, reach, m_sub_hits);
    std::fill(m_edge_flag.begin(), m_edge_flag.end(), 0);
    for (std::size_t i = 0; i < m_moved.size(); ++i) {
      const auto v = std::size_t(m_moved[i]);
      const bool hit = m_sub_hits.triangles[i] >= 0;
      m_distance[v] = hit ? m_sub_hits.signed_distances[i] : reach;
      if (hit && m_distance[v] < 0) {
        push_to(&x[3 * v], &m_sub_hits.points[3 * i], m_distance[v],
                &body_faces[3 * std::size_t(m_sub_hits.triangles[i])], m_options.body_gap);
        m_distance[v] = float(m_options.body_gap);
      }
      for (auto k = own.edge_offsets[v]; k < own.edge_offsets[v + 1]; ++k)
        m_edge_flag[std::size_t(own.vertex_edges[std::size_t(k)])] = 1;
    }
  }
  for (std::size_t v = 0; v < nv; ++v)
    if (m_distance[v] < -0.001f) ++counts.left_inside_1mm;
  counts.body_ms = ms_since(t0);
  t0 = Clock::now();

  // 3. Out of the garments under this one (eq. 7), innermost first; then the layer's edges
  // that still poke out through this garment's triangles (the waistband through a tee) push
  // those triangles out.
  for (std::size_t l = 0; l < g; ++l) {
    const Layer& layer = m_layers[l];
    LayerObstacle o;
    o.surface = &layer.index;
    o.boundary = layer.boundary;
    o.clearance = m_options.layer_clearance;
    o.reach = reach;
    o.points = m_layer_positions[l];
    o.triangles = layer.triangles;
    o.edges = layer.edges;
    o.edge_offsets = layer.edge_offsets;
    o.vertex_edges = layer.vertex_edges;
    query(layer.index, m_layer_positions[l], layer.triangles, x, reach, m_previous_layer[g][l], m_hits);
    const std::span<const float> faces = layer.index.side_mesh().face_normals;
    for (std::size_t v = 0; v < nv; ++v) {
      const std::int32_t t = m_hits.triangles[v];
      if (t < 0 || m_hits.signed_distances[v] >= 0 || dress::on_layer_boundary(o, t, m_hits.features[v])) continue;
      push_to(&x[3 * v], &m_hits.points[3 * v], m_hits.signed_distances[v], &faces[3 * std::size_t(t)],
              m_options.layer_clearance);
      ++counts.layer_pushed;
    }
    for (int round = 0; round < m_options.crossing_rounds; ++round) {
      find_layer_piercings(x, own.triangles_as_given, o, m_hits, m_piercings);
      if (m_piercings.empty()) break;
      std::fill(m_push.begin(), m_push.end(), 0.0f);
      for (const LayerPiercing& p : m_piercings) {
        const double len2 = p.push.squaredNorm();
        for (std::size_t k = 0; k < 3; ++k) {
          float* q = &m_push[4 * std::size_t(own.triangles_as_given[3 * std::size_t(p.triangle) + k])];
          if (len2 <= double(q[3])) continue;
          for (int c = 0; c < 3; ++c)
            q[c] = float(p.push[c]);
          q[3] = float(len2);
        }
      }
      for (std::size_t v = 0; v < nv; ++v)
        for (std::size_t k = 0; k < 3; ++k)
          x[3 * v + k] += m_push[4 * v + k];
      counts.layer_piercings_pushed += m_piercings.size();
    }
  }
  if (g + 1 < m_layers.size()) m_layers[g].index.refit(x);
  counts.layering_ms = ms_since(t0);
  m_layer_positions[g].assign(x.begin(), x.end());
  return counts;
}

} // namespace vfit
