// SPDX-License-Identifier: Apache-2.0
#pragma once
// Options that pick a body, shared by `vfit body`, `vfit measure` and `vfit fit`.

#include "args.h"
#include "vfit/engine/fit/body_source.h"
#include "vfit/geometry/body/body_loader.h"
#include "vfit/geometry/body/keypoint_fit.h"
#include "vfit/geometry/body/keypoints.h"
#include "vfit/geometry/body/skeleton.h"

namespace vfit::cli {

/// --preset, the 11 measurement flags (metres), --pose-rest, --vertices (mannequin);
/// --betas b1,b2,... (SMPL-format files); --joints-in FILE (plain meshes); --units U;
/// --rig-mapping FILE (glTF rigs). `source` is "mannequin" or a file.
BodyRequest body_request_from_args(Args& args, const std::string& source);

BodyMeasurements measurements_from_args(Args& args);
RestPose parse_rest_pose(const std::string& flag, const std::string& value);

/// The keypoint flags shared by `vfit body` and `vfit fit`: --focal F (px), --keypoint-layout
/// auto|body25|coco18|lsp|named, and --image-size W H | WxH | W,H (px; the two-token form takes
/// the next positional). Call before Args::positionals(); `image_size_needs_token` says whether
/// the command must accept one more positional for it, handed back to finish_image_size().
KeypointOptions keypoint_options_from_args(Args& args, bool& image_size_needs_token);
/// Completes --image-size from the positionals left over (see keypoint_options_from_args()).
void finish_image_size(Args& args, const std::vector<std::string>& rest, KeypointOptions& options);

/// --keypoints FILE read (keypoints.h) and fitted (keypoint_fit.h); the file's warnings go to
/// stderr unless `quiet`. `read` (optional) receives the keypoints. Errors are vfit::Error
/// naming the file and the element.
KeypointFit fit_keypoint_file(const std::string& file, const KeypointOptions& options, bool quiet,
                              Keypoints* read = nullptr);

} // namespace vfit::cli
