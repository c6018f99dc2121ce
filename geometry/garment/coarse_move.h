// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Coarse move (seed 000 §6.1, eq. 16–17): the garment is translated — not rotated, not
/// scaled; the paper's move is a pure translation — so that the midpoint of two of its key
/// joints lands on the midpoint of the two matching joints of the body.
///
/// Key joints (seed 000 Fig. 5): for tops (eq. 16) the attachment ends of the two sleeve
/// skeletons (the first node of each chain of skeleton_parts.h, at the shoulder seam) against
/// the body's LEFT_SHOULDER / RIGHT_SHOULDER joints; for trousers and shorts (eq. 17) the
/// attachment ends of the two leg skeletons (at the hip) against LEFT_HIP / RIGHT_HIP.
/// Garments without those parts (a sleeveless top or a dress, a skirt) or whose skeletons are
/// missing use the centre of their source opening (segmentation key point: collar or
/// waistband) against the body's NECK (tops) or the midpoint of PELVIS and SPINE1 (skirts);
/// the report names which rule was used.

#include <span>
#include <string>

#include <Eigen/Core>

#include "garment.h"
#include "segment.h"
#include "skeleton_parts.h"
#include "vfit/geometry/body/skeleton.h"

namespace vfit {

class ProximityIndex;

/// Which key joints decided a coarse move.
enum class CoarseMoveRule {
  SLEEVE_ROOTS_TO_SHOULDERS, ///< eq. 16: sleeve skeletons' first nodes → shoulder joints
  LEG_ROOTS_TO_HIPS,         ///< eq. 17: leg skeletons' first nodes → hip joints
  COLLAR_TO_NECK,            ///< fallback for tops without sleeve skeletons
  WAISTBAND_TO_PELVIS,       ///< fallback for bottoms without leg skeletons (skirts)
  IN_DRIVING,                ///< skeleton driving placed the garment (its eq. 16–17 translation)
};

/// "sleeve roots → shoulders (eq. 16)" and so on.
std::string to_string(CoarseMoveRule rule);

/// The translation of a coarse move and what it was computed from (metres, body frame).
struct CoarseMove {
  CoarseMoveRule rule = CoarseMoveRule::SLEEVE_ROOTS_TO_SHOULDERS;
  Eigen::Vector3d garment_anchor = Eigen::Vector3d::Zero(); ///< midpoint of the garment's key joints
  Eigen::Vector3d body_anchor = Eigen::Vector3d::Zero();    ///< midpoint of the body's key joints
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();    ///< v_c or v_t = body_anchor − garment_anchor
};

/// Computes the coarse move of a garment of `type` with segmentation key points `key_points`
/// and limb skeletons `skeletons` (extract_limb_skeletons(); may be empty) onto a body with
/// `joints` (24 × 3, m). Garment quantities must already be in metres in the body's frame
/// (Y up, facing +Z). A skeleton with no node is ignored. Never fails: a garment with neither
/// skeletons nor a usable key point falls back to its source opening, which always exists.
CoarseMove compute_coarse_move(GarmentType type, const SegmentationKeyPoints& key_points,
                               std::span<const PartSkeleton> skeletons, const JointPositions& joints);

/// Options of contact_translation() (not validated: max_iterations ≤ 0 returns zero).
struct ContactMoveOptions {
  /// Weight of a point lying farther out than the fitted envelope, against 1 − envelope_weight
  /// for one lying within it: an asymmetric least squares (an expectile regression, Newey and
  /// Powell 1987) whose fit follows the garment's closest approach to the body, not its mean
  /// ease, so cloth that hangs (a loose front, a flared hem) barely counts.
  double envelope_weight = 0.1;
  /// Rounds of closest-point queries (each followed by re-weighted least-squares solves) at most.
  int max_iterations = 12;
  /// A round moving the garment by less than this (m) ends the iteration.
  double tolerance = 1e-4;
};

/// The rigid translation Δ that puts `points` (#Q × 3, m: a garment's torso, already oriented
/// and coarsely placed by its key joints, eq. 16–17) where its closest approach to the body
/// indexed by `body` is level all round. The key joints of a garment are estimates (a
/// boundary plane's point, a hip height), wrong by centimetres in ways that depend on the
/// garment's cut, while the garment's own surface says how it sat on the body it was modelled
/// on: touching it, or a few mm into it, at its tight places (shoulders, waist, seat), its ease
/// elsewhere. Each round queries the closest body points c_i and outward directions n_i and,
/// with the points' signed distances s_i held linear in Δ (s_i + n_iᵀΔ), solves
///   min_{Δ, m} Σ_i w_i (s_i + n_iᵀΔ − m)²,  w_i = τ where the residual is > 0, else 1 − τ
/// (τ = options.envelope_weight, re-weighted until the weights settle): the lower envelope of
/// the signed distances made level at a free level m, with a Tikhonov term 10⁻³·Σw_i on Δ so
/// that directions no point constrains do not move. A uniform interpenetration or stand-off is
/// absorbed by m and moves nothing (pushing every point out, the rule before this one, lifted
/// MakeHuman jeans modelled 8 mm into their body by 4 cm up the tapering waist); a garment
/// pressed centimetres into the body on one side and standing off on the other is moved back
/// until its envelope is level again, as is one sitting too high or low on a body whose girth
/// changes along it. A garment with no point inside the body where it starts touches it
/// nowhere (loose all round) and is not moved. Ends after max_iterations or when a round moves
/// less than options.tolerance. Returns Δ (m; zero for no point inside, no point, or a body
/// without triangles). Closest
/// points are searched at any distance; a point within 1e-9 m of the surface has no direction
/// and is skipped; a trailing partial row of `points` is ignored. Throws vfit::Error
/// ("proximity queries: …") naming the first non-finite point. Not in seed 000: a refinement
/// of the eq. 16–17 placement.
Eigen::Vector3d contact_translation(std::span<const float> points, const ProximityIndex& body,
                                    const ContactMoveOptions& options = {});

/// Adds `translation` (m) to every vertex of `positions` (#V × 3, flat).
void translate_positions(std::span<float> positions, const Eigen::Vector3d& translation);

} // namespace vfit
