// SPDX-License-Identifier: Apache-2.0
// ClothSim's body: setting and moving it, attaching cloth vertices to it, and the waistband
// auto-pins (ClothOptions::waistband_pins).
#include "vfit/engine/cloth/cloth_sim_internal.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "vfit/geometry/garment/waistband.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/hole_caps.h"

namespace vfit {

void ClothSim::Impl::attached_position(const BodyAttachment& a, double out[3]) const {
  const std::int32_t* t = body_triangles.data() + 3 * static_cast<std::size_t>(a.triangle);
  const float* p[3] = {&body_positions[3 * std::size_t(t[0])], &body_positions[3 * std::size_t(t[1])],
                       &body_positions[3 * std::size_t(t[2])]};
  double e1[3], e2[3];
  for (int k = 0; k < 3; ++k) {
    e1[k] = double(p[1][k]) - p[0][k];
    e2[k] = double(p[2][k]) - p[0][k];
  }
  double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (double& c : n)
    c = len > 0 ? c / len : 0.0;
  for (int k = 0; k < 3; ++k)
    out[k] = p[0][k] + a.s * e1[k] + a.t * e2[k] + a.h * n[k];
}

namespace {

void check_body_indices(std::span<const std::int32_t> triangles, std::size_t nb) {
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= nb)
      throw Error("body", 0,
                  "face " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(nb) + ")");
}

} // namespace

void ClothSim::set_body(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  Impl& m = *m_impl;
  check_body_indices(triangles, positions.size() / 3);
  if (m.options.broad_phase == ClothBroadPhase::SPATIAL_HASH) {
    m.hash.emplace(positions, triangles);
    m.body.reset();
  } else {
    m.body = std::make_shared<ProximityIndex>(positions, triangles);
    m.hash.reset();
  }
  m.body_shared = false;
  m.body_set(positions, triangles);
}

void ClothSim::set_body(std::shared_ptr<ProximityIndex> index, std::span<const float> positions,
                        std::span<const std::int32_t> triangles) {
  Impl& m = *m_impl;
  if (m.options.broad_phase != ClothBroadPhase::BVH)
    throw Error("body", 0, "a shared body index needs the BVH broad phase");
  if (!index || index->vertex_count() != positions.size() / 3 || index->face_count() != triangles.size() / 3)
    throw Error("body", 0, "the shared index does not index this body (vertex or face counts differ)");
  check_body_indices(triangles, positions.size() / 3);
  m.body = std::move(index);
  m.hash.reset();
  m.body_shared = true;
  m.body_set(positions, triangles);
}

void ClothSim::Impl::body_set(std::span<const float> positions, std::span<const std::int32_t> faces) {
  Impl& m = *this;
  const std::size_t nb = positions.size() / 3;
  m.body_positions.assign(positions.begin(), positions.end());
  m.body_triangles.assign(faces.begin(), faces.end());
  m.body_velocities.clear();
  m.hits_valid = false;
  m.candidates_valid = false;
  m.step_start_valid = false; // a path is tested against the body it was taken beside
  m.body_closed = build_hole_caps(faces, nb).loop_count() == 0;
  std::vector<std::int32_t> attach; // internal rows
  for (const BodyAttachment& a : m.attachments)
    attach.push_back(a.vertex);
  if (m.options.waistband_pins && !m.waistband_attached) {
    // Searched in the caller's numbering, on the caller's triangles, as the function documents.
    for (std::int32_t b : waistband_vertices(m.published_positions(), m.triangles, m.options.waistband_width))
      attach.push_back(m.rank[static_cast<std::size_t>(b)]);
    m.waistband_attached = true;
  }
  m.attachments.clear();
  if (!attach.empty()) m.attach_rows(attach);
  m.state_changed();
}

void ClothSim::attach_to_body(std::span<const std::int32_t> vertices) {
  Impl& m = *m_impl;
  if (!m.has_body()) throw Error("cloth", 0, "attach_to_body called before set_body");
  std::vector<std::int32_t> rows;
  rows.reserve(vertices.size());
  for (std::int32_t p : vertices) {
    if (p < 0 || static_cast<std::size_t>(p) >= m.masses.size())
      throw Error("cloth", 0,
                  "attached vertex " + std::to_string(p) + " outside [0, " + std::to_string(m.masses.size()) + ")");
    rows.push_back(m.rank[static_cast<std::size_t>(p)]);
  }
  m.attach_rows(rows);
  m.state_changed();
}

void ClothSim::Impl::attach_rows(std::span<const std::int32_t> vertices) {
  Impl& m = *this;
  std::vector<float> points;
  points.reserve(3 * vertices.size());
  for (std::int32_t p : vertices)
    for (int k = 0; k < 3; ++k)
      points.push_back(m.x[3 * static_cast<std::size_t>(p) + k]);
  ClosestHits found;
  m.query_body(points, INFINITY, found);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    if (found.triangles[i] < 0) continue; // an empty body: nothing to attach to
    BodyAttachment a;
    a.vertex = vertices[i];
    a.triangle = found.triangles[i];
    const std::int32_t* t = m.body_triangles.data() + 3 * static_cast<std::size_t>(a.triangle);
    const float* c[3] = {&m.body_positions[3 * std::size_t(t[0])], &m.body_positions[3 * std::size_t(t[1])],
                         &m.body_positions[3 * std::size_t(t[2])]};
    double e1[3], e2[3], r[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = double(c[1][k]) - c[0][k];
      e2[k] = double(c[2][k]) - c[0][k];
      r[k] = double(points[3 * i + k]) - c[0][k];
    }
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const auto dot = [](const double* p, const double* q) { return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]; };
    const double g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2), det = dot(n, n);
    if (det > 1e-12 * g11 * g22 && det > 0) {
      // Lagrange's identity: det of the Gram matrix [g11 g12; g12 g22] is |e1 × e2|².
      a.h = dot(r, n) / std::sqrt(det);
      const double r1 = dot(r, e1), r2 = dot(r, e2); // the normal part of r is orthogonal to e1, e2
      a.s = (g22 * r1 - g12 * r2) / det;
      a.t = (g11 * r2 - g12 * r1) / det;
    } else {
      a.s = found.barycentrics[2 * i];
      a.t = found.barycentrics[2 * i + 1];
    }
    const auto at = std::lower_bound(m.attachments.begin(), m.attachments.end(), a.vertex,
                                     [](const BodyAttachment& b, std::int32_t row) { return b.vertex < row; });
    if (at != m.attachments.end() && at->vertex == a.vertex)
      *at = a;
    else
      m.attachments.insert(at, a);
    const auto row = static_cast<std::size_t>(a.vertex);
    m.particles.inverse_masses[row] = 0.0f;
    for (int k = 0; k < 3; ++k)
      m.v[3 * row + k] = 0.0f;
  }
  m.masses_changed();
}

std::vector<std::int32_t> ClothSim::attached_vertices() const {
  std::vector<std::int32_t> out;
  out.reserve(m_impl->attachments.size());
  for (const BodyAttachment& a : m_impl->attachments)
    out.push_back(m_impl->order[static_cast<std::size_t>(a.vertex)]);
  std::sort(out.begin(), out.end());
  return out;
}

void ClothSim::move_body(std::span<const float> positions, double dt) {
  Impl& m = *m_impl;
  if (!m.has_body()) throw Error("body", 0, "move_body called before set_body");
  if (positions.size() != m.body_positions.size())
    throw Error("body", 0,
                "moved body has " + std::to_string(positions.size() / 3) + " vertices, expected " +
                    std::to_string(m.body_positions.size() / 3));
  // The particles' paths relative to the body over this move are tested at the next contact
  // pass (ClothOptions::continuous_contacts): the move carries a limb up to its whole frame's
  // motion at once, through cloth in its way.
  m.mark_step_start(dt > 0 ? dt : 0.0);
  m.body_velocities.resize(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i)
    m.body_velocities[i] = dt > 0 ? static_cast<float>((positions[i] - m.body_positions[i]) / dt) : 0.0f;
  m.body_positions.assign(positions.begin(), positions.end());
  m.body_motion_left = dt > 0 ? dt : 0.0;
  if (m.hash)
    m.hash->update(positions);
  else if (!m.body_shared)
    m.body->refit(positions);
  m.hits_valid = false;
  m.candidates_valid = false;
  for (const BodyAttachment& a : m.attachments) {
    double to[3];
    m.attached_position(a, to);
    const auto row = 3 * static_cast<std::size_t>(a.vertex);
    for (int k = 0; k < 3; ++k) {
      m.v[row + k] = dt > 0 ? static_cast<float>((to[k] - m.x[row + k]) / dt) : 0.0f;
      m.x[row + k] = static_cast<float>(to[k]);
    }
  }
  m.state_changed();
}

void ClothSim::set_state(std::span<const float> positions, std::span<const float> velocities) {
  Impl& m = *m_impl;
  const std::size_t n = m.masses.size();
  if (positions.size() != 3 * n || (!velocities.empty() && velocities.size() != 3 * n))
    throw Error("cloth", 0,
                "set_state: " + std::to_string(positions.size()) + " coordinates and " +
                    std::to_string(velocities.size()) + " velocities for " + std::to_string(n) + " particles");
  for (const std::span<const float> s : {positions, velocities})
    for (std::size_t i = 0; i < s.size(); ++i)
      if (!std::isfinite(s[i]))
        throw Error("cloth", 0, "set_state: vertex " + std::to_string(i / 3) + " is not finite");
  for (std::size_t row = 0; row < n; ++row) {
    const auto from = 3 * static_cast<std::size_t>(m.order[row]);
    const bool free = m.particles.inverse_masses[row] > 0.0f;
    for (std::size_t k = 0; k < 3; ++k) {
      m.x[3 * row + k] = positions[from + k];
      m.v[3 * row + k] = free && !velocities.empty() ? velocities[from + k] : 0.0f;
    }
  }
  for (const BodyAttachment& a : m.attachments) {
    double to[3];
    m.attached_position(a, to);
    for (std::size_t k = 0; k < 3; ++k)
      m.x[3 * static_cast<std::size_t>(a.vertex) + k] = static_cast<float>(to[k]);
  }
  m.status = ClothStatus::OK;
  m.body_velocities.clear();
  m.body_motion_left = 0;
  m.hits_valid = false;
  m.candidates_valid = false;
  m.step_start_valid = false;
  m.released.assign(m.released.size(), 0);
  m.state_changed();
}

void ClothSim::set_tethers(std::span<const float> targets, std::span<const float> radii) {
  Impl& m = *m_impl;
  const std::size_t n = m.masses.size();
  if (targets.empty() && radii.empty()) {
    m.tether_targets.clear();
    m.tether_radii.clear();
    return;
  }
  if (targets.size() != 3 * n || radii.size() != n)
    throw Error("cloth", 0,
                "set_tethers: " + std::to_string(targets.size()) + " target coordinates and " +
                    std::to_string(radii.size()) + " radii for " + std::to_string(n) + " particles");
  for (std::size_t i = 0; i < targets.size(); ++i)
    if (!std::isfinite(targets[i]))
      throw Error("cloth", 0, "set_tethers: target " + std::to_string(i / 3) + " is not finite");
  for (std::size_t i = 0; i < n; ++i)
    if (!(radii[i] >= 0)) throw Error("cloth", 0, "set_tethers: radius " + std::to_string(i) + " is negative or NaN");
  m.tether_targets.resize(3 * n);
  m.tether_radii.resize(n);
  for (std::size_t row = 0; row < n; ++row) {
    const auto from = static_cast<std::size_t>(m.order[row]);
    for (std::size_t k = 0; k < 3; ++k)
      m.tether_targets[3 * row + k] = targets[3 * from + k];
    m.tether_radii[row] = radii[from];
  }
}

void ClothSim::Impl::apply_tethers() {
  if (tether_radii.empty()) return;
  const std::size_t n = masses.size();
  auto range = [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      if (particles.inverse_masses[i] == 0.0f) continue;
      float d[3];
      double len2 = 0;
      for (std::size_t k = 0; k < 3; ++k) {
        d[k] = x[3 * i + k] - tether_targets[3 * i + k];
        len2 += double(d[k]) * d[k];
      }
      const double r = tether_radii[i];
      if (!(len2 > r * r)) continue;
      const double len = std::sqrt(len2), scale = r / len;
      double away = 0;
      for (std::size_t k = 0; k < 3; ++k)
        away += double(v[3 * i + k]) * d[k] / len;
      for (std::size_t k = 0; k < 3; ++k) {
        x[3 * i + k] = static_cast<float>(tether_targets[3 * i + k] + scale * d[k]);
        if (away > 0) v[3 * i + k] = static_cast<float>(v[3 * i + k] - away * d[k] / len);
      }
    }
  };
  if (options.backend == Backend::SERIAL)
    range(0, n);
  else
    parallel_for_range(n, 1024, range);
}

} // namespace vfit
