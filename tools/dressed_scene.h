// SPDX-License-Identifier: Apache-2.0
#pragma once
// A body and its garments as one glTF scene (.glb): every mesh skinned to the body's skeleton
// and given a material of its own colour, so the file can be posed or animated in Blender or a
// game engine. Shared by `vfit fit` (the fitted scene) and `vfit animate` (its colours).
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/body/body.h"

namespace vfit::cli {

/// Linear RGB base colours: the body a skin tone; garment g (inner first) from a palette of
/// four that repeats.
std::array<float, 3> body_colour();
std::array<float, 3> garment_colour(std::size_t g);

/// The .glb bytes of `body` as it stands and `garments` fitted onto it: the skeleton's bind
/// pose is the body's current pose (joints at its posed positions, no rotation), the body keeps
/// its skin weights and each garment gets garment_skin_weights() from the body as it stands
/// (skirts and dresses by their rule). Mesh names: "body", then each garment's file stem.
/// Throws vfit::Error as garment_skin_weights() does. O(Σ garment vertices · smoothing rounds).
std::string fitted_scene_glb(const Body& body, const std::vector<FittedGarment>& garments);

} // namespace vfit::cli
