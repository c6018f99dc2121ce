// SPDX-License-Identifier: Apache-2.0
#include "cloth_collision.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <optional>

#include "cloth_gather.h"
#include "cloth_implicit.h"
#include "parallel.h"
#include "proximity.h"

namespace vfit {
namespace {
using namespace cloth_detail;

// Outward unit normal of the contact of query x with closest point p (signed distance sd) on
// triangle t; the face normal when x is (numerically) on the surface.
vfit_vec3 contact_normal(vfit_vec3 x, vfit_vec3 p, float sd, std::span<const float> body,
                         std::span<const std::int32_t> tris, std::int32_t t) {
  vfit_vec3 d = vfit_v3_sub(x, p);
  const float len = std::sqrt(vfit_v3_dot(d, d));
  if (len > 1e-7f) {
    const float s = (sd < 0.0f ? -1.0f : 1.0f) / len;
    return vfit_vec3{s * d.x, s * d.y, s * d.z};
  }
  const auto corner = [&](int k) { return load3(body.data(), static_cast<std::size_t>(tris[3 * std::size_t(t) + k])); };
  return vfit_normalised_or_zero(vfit_triangle_area_normal(corner(0), corner(1), corner(2)));
}

vfit_vec3 body_velocity_at(std::span<const float> body_v, std::span<const std::int32_t> tris, std::int32_t t, float u,
                           float v) {
  if (body_v.empty()) return vfit_vec3{0.0f, 0.0f, 0.0f};
  const auto corner = [&](int k) {
    return load3(body_v.data(), static_cast<std::size_t>(tris[3 * std::size_t(t) + k]));
  };
  return vfit_barycentric_point(corner(0), corner(1), corner(2), u, v);
}
} // namespace

std::size_t resolve_body_contacts(std::span<float> positions, std::span<float> velocities,
                                  std::span<const float> inverse_masses, const ClosestHits& hits,
                                  std::span<const float> body_positions, std::span<const std::int32_t> body_triangles,
                                  std::span<const float> body_velocities, const ContactParameters& contact) {
  const std::size_t n = inverse_masses.size();
  assert(positions.size() == 3 * n && velocities.size() == 3 * n && hits.size() == n && "one hit per particle");
  std::size_t contacts = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (hits.triangles[i] >= 0 && inverse_masses[i] != 0.0f && hits.signed_distances[i] < contact.thickness) ++contacts;
  if (contacts == 0) return 0;
  parallel_for_range(n, CLOTH_CONTACT_GRAIN, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::int32_t t = hits.triangles[i];
      const float sd = hits.signed_distances[i];
      if (t < 0 || inverse_masses[i] == 0.0f || !(sd < contact.thickness)) continue;
      vfit_vec3 x = load3(positions.data(), i), v = load3(velocities.data(), i);
      const vfit_vec3 p = load3(hits.points.data(), i);
      const vfit_vec3 nrm = contact_normal(x, p, sd, body_positions, body_triangles, t);
      const vfit_vec3 bv =
          body_velocity_at(body_velocities, body_triangles, t, hits.barycentrics[2 * i], hits.barycentrics[2 * i + 1]);
      vfit_contact_response(&x, &v, nrm, contact.thickness - sd, bv, contact.friction, contact.restitution);
      store3(positions.data(), i, x);
      store3(velocities.data(), i, v);
    }
  });
  return contacts;
}

namespace {

// A particle resting on the body, as the implicit solve's contact models see it: its distance
// d = max(signed distance, τ) (the hit was taken before the contact response, which moved a
// particle then closer than τ out to τ: x − p points outwards, no flip), the outward normal and
// the body's velocity at the hit.
struct RestingContact {
  float d;
  vfit_vec3 normal, body_velocity;
};

// Particle i's resting contact, or nothing when it has no hit, is pinned, is farther than
// τ + margin, was released, or its normal is degenerate.
std::optional<RestingContact> resting_contact(std::size_t i, std::span<const float> positions,
                                              std::span<const float> inverse_masses, const ClosestHits& hits,
                                              std::span<const float> body_positions,
                                              std::span<const std::int32_t> body_triangles,
                                              std::span<const float> body_velocities, const ContactParameters& contact,
                                              float margin, std::span<const unsigned char> released) {
  const std::int32_t t = hits.triangles[i];
  const float sd = hits.signed_distances[i];
  if (t < 0 || inverse_masses[i] == 0.0f || !(sd < contact.thickness + margin)) return std::nullopt;
  if (!released.empty() && released[i]) return std::nullopt;
  const float d = std::max(sd, contact.thickness);
  const vfit_vec3 nrm =
      contact_normal(load3(positions.data(), i), load3(hits.points.data(), i), d, body_positions, body_triangles, t);
  if (!(vfit_v3_dot(nrm, nrm) > 0.0f)) return std::nullopt;
  return RestingContact{
      d, nrm,
      body_velocity_at(body_velocities, body_triangles, t, hits.barycentrics[2 * i], hits.barycentrics[2 * i + 1])};
}

} // namespace

std::size_t body_contact_constraints(std::span<const float> positions, std::span<const float> velocities,
                                     std::span<const float> inverse_masses, const ClosestHits& hits,
                                     std::span<const float> body_positions,
                                     std::span<const std::int32_t> body_triangles,
                                     std::span<const float> body_velocities, const ContactParameters& contact,
                                     float margin, float h, std::span<const unsigned char> released,
                                     ImplicitConstraints& out) {
  const std::size_t n = inverse_masses.size();
  assert(positions.size() == 3 * n && velocities.size() == 3 * n && hits.size() == n && "one hit per particle");
  assert((released.empty() || released.size() == n) && "one release flag per particle");
  out.normals.assign(3 * n, 0.0f);
  out.targets.assign(n, 0.0f);
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = resting_contact(i, positions, inverse_masses, hits, body_positions, body_triangles, body_velocities,
                                   contact, margin, released);
    if (!c) continue;
    const float target_vn = vfit_v3_dot(c->body_velocity, c->normal) - (c->d - contact.thickness) / h;
    store3(out.normals.data(), i, c->normal);
    out.targets[i] = target_vn - vfit_v3_dot(load3(velocities.data(), i), c->normal);
    ++count;
  }
  return count;
}

std::size_t body_contact_springs(std::span<const float> positions, std::span<const float> inverse_masses,
                                 const ClosestHits& hits, std::span<const float> body_positions,
                                 std::span<const std::int32_t> body_triangles, std::span<const float> body_velocities,
                                 const ContactParameters& contact, float margin, float stiffness_ratio, float h,
                                 std::span<const unsigned char> released, ImplicitContactSprings& out) {
  const std::size_t n = inverse_masses.size();
  assert(positions.size() == 3 * n && hits.size() == n && "one hit per particle");
  assert((released.empty() || released.size() == n) && "one release flag per particle");
  out.normals.assign(3 * n, 0.0f);
  out.gaps.assign(n, 0.0f);
  out.stiffness.assign(n, 0.0f);
  parallel_for_range(n, CLOTH_CONTACT_GRAIN, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto c = resting_contact(i, positions, inverse_masses, hits, body_positions, body_triangles,
                                     body_velocities, contact, margin, released);
      if (!c) continue;
      store3(out.normals.data(), i, c->normal);
      out.gaps[i] = (c->d - contact.thickness) - h * vfit_v3_dot(c->body_velocity, c->normal);
      out.stiffness[i] = stiffness_ratio / (inverse_masses[i] * h * h);
    }
  });
  // The rows written: a resting contact's normal is nonzero.
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i)
    count += (out.normals[3 * i] != 0.0f || out.normals[3 * i + 1] != 0.0f || out.normals[3 * i + 2] != 0.0f) ? 1 : 0;
  return count;
}

void apply_contact_friction(std::span<float> positions, std::span<float> velocities,
                            std::span<const float> inverse_masses, std::span<const float> normals,
                            std::span<const float> normal_impulses, const ClosestHits& hits,
                            std::span<const std::int32_t> body_triangles, std::span<const float> body_velocities,
                            float friction, float h) {
  const std::size_t n = inverse_masses.size();
  if (normals.empty() || normal_impulses.size() != n) return;
  assert(normals.size() == 3 * n && "one normal row per particle");
  assert(positions.size() == 3 * n && velocities.size() == 3 * n && hits.size() == n && "one hit per particle");
  parallel_for_range(n, CLOTH_CONTACT_GRAIN, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float lambda = normal_impulses[i];
      if (!(lambda > 0.0f) || inverse_masses[i] == 0.0f || hits.triangles[i] < 0) continue;
      const vfit_vec3 nrm = load3(normals.data(), i);
      const vfit_vec3 bv = body_velocity_at(body_velocities, body_triangles, hits.triangles[i],
                                            hits.barycentrics[2 * i], hits.barycentrics[2 * i + 1]);
      const vfit_vec3 v = load3(velocities.data(), i);
      const vfit_vec3 rel = vfit_v3_sub(v, bv);
      const float vn = vfit_v3_dot(rel, nrm);
      const vfit_vec3 vt{rel.x - vn * nrm.x, rel.y - vn * nrm.y, rel.z - vn * nrm.z};
      const float vt_len = std::sqrt(vfit_v3_dot(vt, vt));
      if (!(vt_len > 0.0f)) continue;
      const float cut = std::min(vt_len, friction * lambda * inverse_masses[i]);
      const float s = cut / vt_len;
      const vfit_vec3 dv{-s * vt.x, -s * vt.y, -s * vt.z};
      store3(velocities.data(), i, vfit_vec3{v.x + dv.x, v.y + dv.y, v.z + dv.z});
      const vfit_vec3 x = load3(positions.data(), i);
      store3(positions.data(), i, vfit_vec3{x.x + h * dv.x, x.y + h * dv.y, x.z + h * dv.z});
    }
  });
}

} // namespace vfit
