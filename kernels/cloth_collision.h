// SPDX-License-Identifier: Apache-2.0
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
struct ImplicitConstraints;
struct ImplicitContactSprings;

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

/// Contact constraints for the next implicit Euler step (Baraff & Witkin §5.3; kernels/
/// cloth_implicit.h): `hits` are the closest body points of the particles queried before
/// resolve_body_contacts() moved them (so a particle found closer than τ now sits at τ). A free
/// particle whose distance is below τ + margin (m) and whose row of `released` is 0 (or
/// `released` empty) is constrained along the outward contact normal n to the velocity change
/// Δv·n = (v_b·n − (d − τ)/h) − v·n, which makes it end the step of h (s) at the gap τ moving
/// with the body along n (v_b: the body's velocity at the contact, d: its distance, v: its
/// velocity, #V × 3 m/s). Pinned particles and rows without a hit get a zero normal. Writes
/// out.normals (#V × 3) and out.targets (#V); returns the number of constrained particles.
std::size_t body_contact_constraints(std::span<const float> positions, std::span<const float> velocities,
                                     std::span<const float> inverse_masses, const ClosestHits& hits,
                                     std::span<const float> body_positions,
                                     std::span<const std::int32_t> body_triangles,
                                     std::span<const float> body_velocities, const ContactParameters& contact,
                                     float margin, float h, std::span<const unsigned char> released,
                                     ImplicitConstraints& out);

/// Resting contacts for the next implicit Euler step as stiff one-sided springs
/// (ImplicitContactSprings, kernels/cloth_implicit.h). `hits` as for body_contact_constraints()
/// (queried before resolve_body_contacts() moved the particles: one found closer than τ now
/// sits at τ). A free particle whose distance d is below τ + margin (m) and whose row of
/// `released` is 0 (or `released` empty) gets the outward contact normal n, the gap
/// g₀ = max(d, τ) − τ − h·(v_b·n) (the body's velocity v_b at the contact, from
/// body_velocities, #B × 3 m/s or empty for a body at rest, moves the surface over the step of
/// h s) and the stiffness k = stiffness_ratio·m/h² (m = 1/inverse mass, N/m): the dimensionless
/// stiffness_ratio κ makes h²·k = κ·m, so within one step the spring leaves a particle
/// 1/(1 + κ) of the velocity into the body it would have without it. Other rows get zeros.
/// Writes out.normals (#V × 3), out.gaps and out.stiffness (#V); returns the number of springs.
std::size_t body_contact_springs(std::span<const float> positions, std::span<const float> inverse_masses,
                                 const ClosestHits& hits, std::span<const float> body_positions,
                                 std::span<const std::int32_t> body_triangles, std::span<const float> body_velocities,
                                 const ContactParameters& contact, float margin, float stiffness_ratio, float h,
                                 std::span<const unsigned char> released, ImplicitContactSprings& out);

/// Coulomb friction of the constrained (or contact-spring) contacts after an implicit step of h
/// (s): a particle whose constraint pushed with the normal impulse λ > 0 (N·s, ImplicitWorkspace::
/// normal_impulses) along its row of `normals` (#V × 3: ImplicitConstraints::normals or
/// ImplicitContactSprings::normals; empty = nothing to do) has its tangential velocity relative
/// to the body reduced by μ_f·λ·m⁻¹ (stopping, never reversing), and its position moved by h
/// times that velocity change so it stays consistent with x₁ = x₀ + h·v₁. Same inputs as
/// body_contact_constraints() (the hits the constraints were built from). Parallel over
/// particles.
void apply_contact_friction(std::span<float> positions, std::span<float> velocities,
                            std::span<const float> inverse_masses, std::span<const float> normals,
                            std::span<const float> normal_impulses, const ClosestHits& hits,
                            std::span<const std::int32_t> body_triangles, std::span<const float> body_velocities,
                            float friction, float h);

} // namespace vfit
