// SPDX-License-Identifier: Apache-2.0
// ClothSim's body contacts: the closest-point queries through the broad phase, the contact
// candidate cache (ClothOptions::contact_candidates), continuous contacts
// (ClothOptions::continuous_contacts) and the contact pass.
#include "vfit/engine/cloth/cloth_sim_internal.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace vfit {

// Guard (m) added to the contact reach for the float rounding of a signed distance (~1e-8 m
// at 5 cm) and of the motion bound.
constexpr float CONTACT_REACH_GUARD = 1e-4f;
// Every this many contact passes every particle is queried again (see Impl::update_hits):
// insurance for the one case the distance bound does not cover, a side flip of a particle
// already buried in a self-overlapping posed body.
constexpr int CONTACT_FULL_QUERY_PASSES = 32;

void ClothSim::Impl::query_body(std::span<const float> queries, float radius, ClosestHits& out) const {
  const bool serial = options.backend == Backend::SERIAL;
  if (hash) {
    if (serial)
      hash->closest_points_serial(queries, radius, out);
    else
      hash->closest_points(queries, radius, out);
  } else if (serial) {
    body->closest_points_serial(queries, radius, out);
  } else {
    body->closest_points(queries, radius, out);
  }
}

ContactParameters ClothSim::Impl::contact_parameters() const {
  return ContactParameters{options.contact_thickness, options.contact_friction, options.contact_restitution};
}

float ClothSim::Impl::contact_reach() const {
  return options.contact_thickness + (options.contacts_in_solve ? options.contact_margin : 0.0f) + CONTACT_REACH_GUARD;
}

void ClothSim::Impl::record_query(std::size_t i, float reach) {
  for (int k = 0; k < 3; ++k)
    query_positions[3 * i + k] = x[3 * i + k];
  const float d = hits.triangles[i] < 0 ? options.contact_search_radius : hits.signed_distances[i];
  query_allowance[i] = d - reach;
}

void ClothSim::Impl::update_hits() {
  const std::size_t n = masses.size();
  const float reach = contact_reach();
  const bool full = !options.contact_candidates || !body_closed || !candidates_valid ||
                    ++passes_since_full >= CONTACT_FULL_QUERY_PASSES;
  if (full) {
    query_body(x, options.contact_search_radius, hits);
    query_positions.resize(3 * n);
    query_allowance.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      record_query(i, reach);
    candidates_valid = true;
    passes_since_full = 0;
    return;
  }
  requeried.clear();
  requery_points.clear();
  requery_radii.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const float a = query_allowance[i];
    if (a > 0.0f) {
      float moved2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        const float d = x[3 * i + k] - query_positions[3 * i + k];
        moved2 += d * d;
      }
      if (moved2 < a * a) continue;
    }
    requeried.push_back(static_cast<std::int32_t>(i));
    float to_old_point2 = 0.0f;
    for (int k = 0; k < 3; ++k) {
      requery_points.push_back(x[3 * i + k]);
      const float d = x[3 * i + k] - hits.points[3 * i + k];
      to_old_point2 += d * d;
    }
    // The old closest point is still on the (unmoved) body: the new closest point is no
    // farther than it, so a search radius just past it finds the same answer as the full
    // radius, pruning most of the BVH traversal.
    const float radius =
        hits.triangles[i] < 0
            ? options.contact_search_radius
            : std::min(options.contact_search_radius, std::sqrt(to_old_point2) * (1.0f + 1e-5f) + CONTACT_REACH_GUARD);
    requery_radii.push_back(radius);
  }
  if (body && options.backend != Backend::SERIAL)
    body->closest_points(requery_points, requery_radii, requery_hits);
  else
    query_body(requery_points, options.contact_search_radius, requery_hits);
  for (std::size_t r = 0; r < requeried.size(); ++r) {
    const auto i = static_cast<std::size_t>(requeried[r]);
    hits.copy_row(i, requery_hits, r);
    record_query(i, reach);
  }
}

// Implicit Euler only: under RK4 the particles put back at their path's entry stretched their
// springs past what the explicit substeps absorb (the 4 cm rod drop from 1.8 m, ClothSim.
// FastClothDoesNotTunnelThroughAThinRod with RK4: runaway stretch at frame 39).
bool ClothSim::Impl::continuous() const {
  return options.continuous_contacts && body != nullptr && options.integrator == ClothIntegrator::IMPLICIT_EULER;
}

void ClothSim::Impl::mark_step_start(double body_time) {
  if (!continuous() || step_start_valid) return;
  start_body_time = body_time;
  const std::size_t n = masses.size();
  step_start.assign(x.begin(), x.end());
  start_bound.assign(n, 0.0f);
  if (candidates_valid && hits.size() == n && query_positions.size() == 3 * n)
    for (std::size_t i = 0; i < n; ++i) {
      const float d = hits.triangles[i] < 0 ? options.contact_search_radius : hits.signed_distances[i];
      float moved2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        const float e = x[3 * i + k] - query_positions[3 * i + k];
        moved2 += e * e;
      }
      start_bound[i] = std::max(0.0f, d - std::sqrt(moved2));
    }
  step_start_valid = true;
}

std::array<float, 3> ClothSim::Impl::body_velocity_at(const ClosestHits& h, std::size_t i) const {
  if (body_velocities.empty() || h.triangles[i] < 0) return {0.0f, 0.0f, 0.0f};
  const std::int32_t* t = body_triangles.data() + 3 * static_cast<std::size_t>(h.triangles[i]);
  const float u = h.barycentrics[2 * i], w = h.barycentrics[2 * i + 1], c[3] = {1.0f - u - w, u, w};
  float out[3] = {0.0f, 0.0f, 0.0f};
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < 3; ++k)
      out[k] += c[a] * body_velocities[3 * static_cast<std::size_t>(t[a]) + k];
  return {out[0], out[1], out[2]};
}

void ClothSim::Impl::undo_crossings() {
  if (!step_start_valid) return;
  step_start_valid = false;
  const double h = start_body_time;
  const std::size_t n = masses.size();
  float body_speed = 0.0f; // the fastest body vertex: the most it moved towards a particle
  for (std::size_t b = 0; b + 2 < body_velocities.size(); b += 3)
    body_speed = std::max(body_speed, std::sqrt(body_velocities[b] * body_velocities[b] +
                                                body_velocities[b + 1] * body_velocities[b + 1] +
                                                body_velocities[b + 2] * body_velocities[b + 2]));
  const float body_moved = body_speed * static_cast<float>(h);
  const float min_path = 2.0f * options.contact_thickness;
  ccd_rows.clear();
  ccd_from.clear();
  ccd_to.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (particles.inverse_masses[i] == 0.0f) continue;
    float moved2 = 0.0f;
    for (int k = 0; k < 3; ++k) {
      const float e = x[3 * i + k] - step_start[3 * i + k];
      moved2 += e * e;
    }
    // A path shorter than both its start's distance (it cannot reach the surface) and 2τ
    // (from the surface it cannot pass the middle of a part thicker than 4τ, 1.2 cm by
    // default: the discrete response pushes it back out on its own side) is not tested.
    const float reach = std::sqrt(moved2) + body_moved;
    if (reach < start_bound[i] || reach < min_path) continue;
    // The path relative to the body: from where the start lies once the body has moved on.
    const std::array<float, 3> vb = body_velocity_at(hits, i);
    const float hf = static_cast<float>(h);
    const float from[3] = {step_start[3 * i] + hf * vb[0], step_start[3 * i + 1] + hf * vb[1],
                           step_start[3 * i + 2] + hf * vb[2]};
    if (from[0] == x[3 * i] && from[1] == x[3 * i + 1] && from[2] == x[3 * i + 2]) continue; // no relative motion
    ccd_rows.push_back(static_cast<std::int32_t>(i));
    ccd_from.insert(ccd_from.end(), {from[0], from[1], from[2]});
    ccd_to.insert(ccd_to.end(), {x[3 * i], x[3 * i + 1], x[3 * i + 2]});
  }
  if (ccd_rows.empty()) return;
  body->first_hits(ccd_from, ccd_to, ccd_hits);
  ccd_undone.clear();
  ccd_points.clear();
  const float gap = 0.5f * options.contact_thickness; // inside τ: the response lifts it to τ
  for (std::size_t r = 0; r < ccd_rows.size(); ++r) {
    if (ccd_hits.triangles[r] == -1) continue;
    const float* nm = ccd_hits.normals.data() + 3 * r;
    const float dir[3] = {ccd_to[3 * r] - ccd_from[3 * r], ccd_to[3 * r + 1] - ccd_from[3 * r + 1],
                          ccd_to[3 * r + 2] - ccd_from[3 * r + 2]};
    if (dir[0] * nm[0] + dir[1] * nm[1] + dir[2] * nm[2] >= 0.0f) continue; // met from inside
    const auto i = static_cast<std::size_t>(ccd_rows[r]);
    // Where the discrete response would push it: along the outward normal of its closest point.
    const float d = hits.triangles[i] < 0 ? INFINITY : hits.signed_distances[i];
    if (d < 0.0f) {
      float out[3], len2 = 0.0f;
      for (int k = 0; k < 3; ++k) {
        out[k] = hits.points[3 * i + k] - x[3 * i + k]; // inside: towards the closest point
        len2 += out[k] * out[k];
      }
      // A shallow entry, pushed back out on its own side: the discrete response is right.
      if (len2 > 0.0f && out[0] * nm[0] + out[1] * nm[1] + out[2] * nm[2] >= 0.0f) continue;
    }
    const float t = ccd_hits.t[r];
    for (int k = 0; k < 3; ++k) {
      x[3 * i + k] = ccd_from[3 * r + k] + t * dir[k] + gap * nm[k];
      ccd_points.push_back(x[3 * i + k]);
    }
    ccd_undone.push_back(static_cast<std::int32_t>(i));
  }
  if (ccd_undone.empty()) return;
  crossings_undone += ccd_undone.size();
  query_body(ccd_points, options.contact_search_radius, ccd_requery);
  const float reach = contact_reach();
  for (std::size_t r = 0; r < ccd_undone.size(); ++r) {
    const auto i = static_cast<std::size_t>(ccd_undone[r]);
    hits.copy_row(i, ccd_requery, r);
    if (query_positions.size() == 3 * n) record_query(i, reach);
  }
  state_changed();
}

std::size_t ClothSim::Impl::resolve_contacts() {
  if (!has_body()) return 0;
  update_hits();
  undo_crossings();
  hits_valid = true;
  return resolve_body_contacts(x, v, particles.inverse_masses, hits, body_positions, body_triangles, body_velocities,
                               contact_parameters());
}

} // namespace vfit
