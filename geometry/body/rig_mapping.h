// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Mapping a rig's bone names onto the 24 canonical joints (skeleton.h): built-in mappings for
/// SMPL, Mixamo and MakeHuman's game_engine rig, detection from a rig's bone names, and explicit
/// mapping files.

#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skeleton.h"

namespace vfit {

/// Where a canonical joint sits when a rig has no bone head there: on the segment from the head
/// of its bone (RigMapping::bone_for_joint) to the head of bone `toward`, at `fraction` ∈ [0, 1]
/// of the way. An empty `toward` means the joint is its bone's head.
struct JointAnchor {
  std::string toward;
  double fraction = 0.0;
};

/// For each canonical joint (SMPL order), the rig bone the joint rotates, whose skin weights it
/// takes, and whose HEAD is the joint unless an anchor says otherwise; e.g. left_knee → Mixamo
/// "LeftLeg" (the shin), left_hand → "LeftHandMiddle1".
///
/// Anchors exist because rigs disagree on where the spine joints are: SMPL's spine1, spine2 and
/// spine3 sit at 21 %, 48 % and 58 % of the way from the pelvis to the neck (the SMPL neutral
/// template's joints: y = −0.223, −0.114, 0.021, 0.074, 0.288 m), while MakeHuman's game_engine
/// rig puts spine_01..03 at 9 %, 22 % and 40 %. Its built-in mapping therefore keeps spine_0k as
/// the bones (weights, rotations) and anchors the joint positions at SMPL's heights: spine1 at
/// spine_02's head, spine2 and spine3 at 26 % and 61 % of spine_03's head → neck_01's head.
struct RigMapping {
  std::string name; ///< "mixamo", "makehuman_game_engine", ... or the mapping file's path
  std::array<std::string, JOINT_COUNT> bone_for_joint;
  std::array<JointAnchor, JOINT_COUNT> anchors; ///< all empty for rigs whose heads are SMPL's joints
};

/// Names of the built-in mappings, the order detect_rig_mapping() prefers them in on ties:
/// "smpl" (pelvis, left_hip, ...), "smpl_avg" (Pelvis, L_Hip, ..., as SMPL's FBX exports name
/// them after an "m_avg_"/"f_avg_" prefix), "mixamo" (Hips, LeftUpLeg, ...) and
/// "makehuman_game_engine" (pelvis, thigh_l, ...).
std::vector<std::string> builtin_rig_mappings();

/// The built-in mapping `name` with `prefix` prepended to every bone name (e.g. "mixamorig:").
/// Throws vfit::Error for an unknown name.
RigMapping builtin_rig_mapping(std::string_view name, std::string_view prefix = "");

/// The built-in mapping, with the common bone-name prefix ("mixamorig:", "mixamorig1:",
/// "m_avg_", "Armature|", "" ...; a prefix is empty or ends in a character that is not a letter
/// or digit) that names the most canonical joints among `bone_names`. All 24 must be found;
/// otherwise throws vfit::Error "<source>: ..." naming the best candidate and the joints it
/// misses, and suggesting an explicit mapping file.
RigMapping detect_rig_mapping(std::span<const std::string> bone_names, const std::string& source);

/// Parses a mapping file: a JSON object whose keys are the 24 canonical joint names and whose
/// values are bone names, e.g. {"pelvis": "Hips", "left_hip": "LeftUpLeg", ...}, or objects
/// {"bone": "spine_03", "toward": "neck_01", "at": 0.26} for an anchored joint (JointAnchor).
/// Throws vfit::Error "<path>: ..." naming the key for invalid JSON, a key that is not a
/// canonical joint, a value that is not a non-empty string or a valid anchor object ("at"
/// outside [0, 1], unknown members), a missing joint, or one bone mapped twice.
RigMapping parse_rig_mapping(std::string_view json_text, const std::string& path);

/// Reads and parses the mapping file at `path` (see parse_rig_mapping()).
RigMapping load_rig_mapping(const std::string& path);

} // namespace vfit
