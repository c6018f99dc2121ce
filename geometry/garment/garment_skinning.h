// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Skin weights for a garment layer (seed 001 §7.1: each garment is skinned to the body's
/// skeleton so that linear blend skinning carries it with the body, the LBS term of eq. 8).
///
/// Rule: a garment vertex takes the weights of its closest point on the body, chain by chain
/// (transfer_skin_weights(): barycentric blend of the body triangle's corners, the limb it
/// belongs to kept when limbs touch); then
///  - for a skirt or a dress, below the hips' height (at rest) the weight the legs give a vertex
///    goes to the two hip joints in equal halves, so the hem follows both thighs on average and
///    never one leg (no vertex between the legs is glued to the nearer one);
///  - the weights are diffused over the garment's own edges (each round: half the vertex's own,
///    half its neighbours' mean) for (smoothing_radius / mean edge length)² rounds, so that
///    neighbouring garment vertices never hang from distant bones (a triangle's corners differ
///    smoothly), then the 4 largest are kept and renormalised.

#include "garment.h"
#include "vfit/geometry/body/body.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

struct GarmentSkinningOptions {
  /// transfer_skin_weights()'s margin (m): how much nearer one limb must be than another for a
  /// vertex to be sure of it.
  double margin = 0.02;
  /// How far along the garment (m) the diffusion spreads weights (≥ 0; 0: none).
  double smoothing_radius = 0.03;
};

/// Weights (#garment vertices × 4) skinning `garment` to `body`'s skeleton. `garment` must lie
/// on `body` as it is (both in the body's rest pose: the pose `body.weights` are bound in), in
/// metres. `type` selects the skirt rule (DRESS, SKIRT). Throws vfit::Error ("garment
/// skinning: ...") for a garment without vertices or a body whose weights do not fit its mesh.
/// O(#V · rounds) after the transfer's closest-point queries.
SkinWeights garment_skin_weights(const Body& body, const Mesh& garment, GarmentType type,
                                 const GarmentSkinningOptions& options = {});

} // namespace vfit
