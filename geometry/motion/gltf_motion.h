// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The animation of a rigged glTF 2.0 file as a BVH motion, so that it is retargeted like any
/// motion-capture clip (retarget.h): a body exported with its animation (Mixamo, Blender, our
/// own animated .glb) plays on any other body.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "bvh.h"

namespace vfit {

/// Animation `animation` (0-based) of the glTF document `bytes` (`.glb` or `.gltf`; `path` names
/// it in messages and resolves a `.gltf`'s buffer files), sampled at `fps` frames per second
/// (0: the rate of its keyframes when they are evenly spaced, else 30) from time 0 to its last
/// keyframe, as a BvhMotion over the joints of the file's first skin (named by their node names,
/// parents being each joint's nearest ancestor among them, in depth-first order). Every node is
/// posed per frame (its animated translation, rotation and scale, LINEAR, STEP or CUBICSPLINE,
/// else its own TRS or matrix) and the joints' world transforms are expressed so that the
/// motion's rest (every channel zero) is the nodes' own transforms: each joint gets position
/// channels (its world position relative to its parent's) and Z, Y, X rotation channels (its
/// world rotation relative to its rest one, relative to its parent's). Unit: metres (glTF's);
/// up axis inferred from the skeleton (bvh_infer_up()).
/// Throws vfit::Error "<path>: <what>" for anything GltfDocument refuses and for: no skin, a skin
/// without joints, no animation or an index past them, a channel whose node or path is unknown,
/// a sampler whose input and output counts differ (×3 for CUBICSPLINE), times that are not
/// finite or do not increase, values that are not finite, an unknown interpolation, or a rate
/// outside (0, 1000].
BvhMotion parse_gltf_motion(std::string_view bytes, const std::string& path, double fps = 0, std::size_t animation = 0);

/// Reads the file at `path` and parses it with parse_gltf_motion().
BvhMotion read_gltf_motion(const std::filesystem::path& path, double fps = 0, std::size_t animation = 0);

} // namespace vfit
