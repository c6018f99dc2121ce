#include "cloth_collision.h"

#include <cassert>
#include <cmath>

#include "cloth_gather.h"
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

} // namespace vfit
