// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Poses by name and from JSON files.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "body.h"

namespace vfit {

/// Built-in poses, expressed for a body whose rest pose is `rest` (TPOSE or APOSE; OTHER is
/// treated as TPOSE): "rest", "tpose", "apose", "arms_down", "arms_raised", "elbows_bent",
/// "walking", "knee_bent" (the left knee, 60°), "legs_apart", "demo" (arms down, left knee
/// bent), "contrapposto". Throws vfit::Error for an unknown name.
Pose named_pose(std::string_view name, RestPose rest);
std::vector<std::string> named_pose_names();

/// Reads a pose JSON: {"<canonical joint name>": [x, y, z] (axis-angle, radians), ...,
/// "global_orient": [x, y, z], "translation": [x, y, z] (m)} — joints not named stay at rest —
/// or {"pose": [72 numbers], "translation": [...]}. Throws vfit::Error naming the file and the
/// key for invalid JSON, an unknown joint name, a value that is not 3 finite numbers, or an
/// angle above 2π.
Pose read_pose_json(const std::filesystem::path& path);

/// A motion as our own poses: frames at `fps` frames per second.
struct PoseSequence {
  double fps = 30;
  std::vector<Pose> frames;
};

/// Reads a pose-sequence JSON: {"fps": N, "frames": [pose, ...]}, each pose in either form
/// read_pose_json() reads. Throws vfit::Error naming the file and the key ("frames[3].left_elbow")
/// for invalid JSON, a missing or non-positive fps (at most 1000), no frames, an unknown key, or
/// a pose read_pose_json() would refuse.
PoseSequence read_pose_sequence_json(const std::filesystem::path& path);

/// A procedural walk cycle of `frames` frames at `fps` (> 0), for a body whose rest pose is
/// `rest`, walking in place: arms lowered to 72° and swinging ±15° against the thighs, which
/// swing ±25°; each knee bends up to 45° while its leg swings forward; elbows bent 15°; the pelvis
/// dips 1 cm as the legs pass. Throws vfit::Error for no frames or a rate that is not positive.
PoseSequence walk_cycle(RestPose rest, double fps = 30, std::size_t frames = 30);

/// The JSON text of a pose sequence (read_pose_sequence_json() reads it back).
std::string pose_sequence_json(const PoseSequence& sequence);

/// The JSON text of a pose in the first form above (non-zero joints only).
std::string pose_json(const Pose& pose);

} // namespace vfit
