#pragma once
// Options that pick a body, shared by `vfit body`, `vfit measure` and (later) `vfit fit`.

#include "args.h"
#include "geometry/body/body_loader.h"

namespace vfit::cli {

/// --preset, the 11 measurement flags (metres), --pose-rest, --vertices (mannequin);
/// --betas b1,b2,... (SMPL-format files); --joints-in FILE (plain meshes); --units U;
/// --rig-mapping FILE (glTF rigs). `source` is "mannequin" or a file.
BodyRequest body_request_from_args(Args& args, const std::string& source);

BodyMeasurements measurements_from_args(Args& args);
RestPose parse_rest_pose(const std::string& flag, const std::string& value);

} // namespace vfit::cli
