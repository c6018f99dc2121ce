// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The blend of a garment's physical and skinned motion (seed 001 §7.1): per frame,
/// Mesh_blend = w_p · Mesh_physical + w_lbs · Mesh_LBS with w_p + w_lbs = 1 (eq. 8), w_p from the
/// garment's closest distances to the naked body (eq. 9):
///   w_p = (dist_mean − dist_min) / (dist_max − dist_min), capped at 0.5.
/// A loose garment (most vertices far from the body, relative to its spread) gets more physics;
/// a tight one, whose shape the skinning keeps, less. Skirts and dresses are split in two parts
/// with their own w_p (the seed's "special treatment for the skirt": its top is close to the
/// body, its bottom far): the upper part above the hip joints (the height below which the
/// garment's skin weights leave the legs, garment_skinning.h), the lower part below them, the
/// weight ramping linearly across a band around that height so the blend has no seam.

#include <cstddef>
#include <span>
#include <vector>

#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/proximity.h"

namespace vfit {

/// Eq. 9 over one part's distances (m, each ≥ 0): (mean − min) / (max − min), capped at `cap`;
/// 0 for no distances or when they are all equal (max = min: the part is as close everywhere,
/// e.g. a second skin, and is skinned). Throws vfit::Error for a negative or non-finite
/// distance. O(#d).
double physical_weight(std::span<const double> distances, double cap = 0.5);

/// A garment's blend weights.
struct BlendWeights {
  std::vector<float> per_vertex; ///< #V: w_p of each vertex (eq. 8), in [0, cap]
  std::vector<float> distances;  ///< #V: each vertex's distance to the body that eq. 9 took (m, ≥ 0)
  double upper = 0;              ///< w_p of the whole garment, or of its upper part when split
  double lower = 0;              ///< w_p of the lower part when split (= upper otherwise)
  bool split = false;            ///< a skirt or dress, split at split_height
  double split_height = 0;       ///< m (Y up): the hip joints' mean height, when split
  std::size_t upper_vertices = 0, lower_vertices = 0;
};

/// Eq. 9 for `garment` on `body` (the naked body's index, the pose the garment was fitted in):
/// each vertex's distance is its closest distance to the body, 0 for a vertex inside. For a
/// SKIRT or DRESS (`type`) the vertices at or above `hip_height` (m, Y up) form the upper part,
/// those below the lower part, each with its own w_p; per_vertex ramps linearly from the upper
/// to the lower w_p over hip_height ± band (m, ≥ 0; 0: a step). Other types: one part. A part
/// with no vertex takes the other's weight. Throws vfit::Error for an empty garment or a
/// non-finite band or cap. O(#V log #F).
BlendWeights blend_weights(const ProximityIndex& body, const Mesh& garment, GarmentType type, double hip_height,
                           double band, double cap = 0.5);

} // namespace vfit
