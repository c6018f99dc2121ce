#pragma once
/// \file
/// Body contact response of cloth particles (seed 004 §2: collision against the body, response
/// by friction and restitution on the velocity). The narrow phase is the proximity core: the
/// caller answers closest points of the particles with a ProximityIndex over the body; this
/// pushes every particle closer than a thickness out to it and corrects its velocity
/// (cloth_math.h's vfit_contact_response, shared with the OpenCL kernels).

#include <cstddef>
#include <cstdint>
#include <span>

namespace vfit {

struct ClosestHits;

/// Contact constants.
struct ContactParameters {
  float thickness = 0.002f; ///< τ (m): the gap kept between cloth particles and the body
  float friction = 0.3f;    ///< μ_f: Coulomb coefficient between cloth and body (≥ 0)
  float restitution = 0.0f; ///< e ∈ [0, 1]: 0 = the particle stops its approach, 1 = bounces
};

/// Particles per TBB task in resolve_body_contacts().
inline constexpr std::size_t CLOTH_CONTACT_GRAIN = 4096;

/// Resolves contacts in place. positions, velocities: #V × 3 (m, m/s), the particles queried;
/// inverse_masses: #V (0 = pinned: never moved); hits: the closest body points of the
/// particles' current positions (ProximityIndex::closest_points, #V rows; rows with no hit are
/// skipped); body_positions / body_triangles: the body mesh the hits refer to (#B × 3, #T × 3);
/// body_velocities: #B × 3 (m/s) or empty for a body at rest. A particle whose signed distance
/// d is below τ moves to d = τ along the outward direction (query − point, flipped when inside;
/// the face normal of the hit triangle when the query lies on the surface) and its velocity
/// relative to the body point (interpolated with the hit's barycentrics) is corrected by
/// restitution and friction. Parallel over particles (TBB); returns the number of contacts.
std::size_t resolve_body_contacts(std::span<float> positions, std::span<float> velocities,
                                  std::span<const float> inverse_masses, const ClosestHits& hits,
                                  std::span<const float> body_positions, std::span<const std::int32_t> body_triangles,
                                  std::span<const float> body_velocities, const ContactParameters& contact);

} // namespace vfit
