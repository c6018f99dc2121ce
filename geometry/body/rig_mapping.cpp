// SPDX-License-Identifier: Apache-2.0
// Built-in rig mappings, their detection from bone names, and explicit mapping files.
#include "rig_mapping.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <unordered_set>

#include <nlohmann/json.hpp>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using BoneNames = std::array<std::string_view, JOINT_COUNT>;

struct BuiltinAnchor {
  Joint joint;
  std::string_view toward;
  double fraction;
};

struct BuiltinRig {
  std::string_view name;
  BoneNames bones; // canonical (SMPL) order
  std::array<BuiltinAnchor, 3> anchors{};
};

// The bone whose head sits at each canonical joint. SMPL's hand joint is the knuckle line, so
// rigs with finger chains map it to the middle finger's first bone.
constexpr std::array<BuiltinRig, 4> BUILTIN_RIGS{{
    {"smpl", {"pelvis",     "left_hip",    "right_hip",    "spine1",      "left_knee",     "right_knee",
              "spine2",     "left_ankle",  "right_ankle",  "spine3",      "left_foot",     "right_foot",
              "neck",       "left_collar", "right_collar", "head",        "left_shoulder", "right_shoulder",
              "left_elbow", "right_elbow", "left_wrist",   "right_wrist", "left_hand",     "right_hand"}},
    {"smpl_avg", {"Pelvis",     "L_Hip",      "R_Hip",   "Spine1",  "L_Knee",  "R_Knee",   "Spine2",   "L_Ankle",
                  "R_Ankle",    "Spine3",     "L_Foot",  "R_Foot",  "Neck",    "L_Collar", "R_Collar", "Head",
                  "L_Shoulder", "R_Shoulder", "L_Elbow", "R_Elbow", "L_Wrist", "R_Wrist",  "L_Hand",   "R_Hand"}},
    {"mixamo", {"Hips",        "LeftUpLeg",    "RightUpLeg",    "Spine",     "LeftLeg",         "RightLeg",
                "Spine1",      "LeftFoot",     "RightFoot",     "Spine2",    "LeftToeBase",     "RightToeBase",
                "Neck",        "LeftShoulder", "RightShoulder", "Head",      "LeftArm",         "RightArm",
                "LeftForeArm", "RightForeArm", "LeftHand",      "RightHand", "LeftHandMiddle1", "RightHandMiddle1"}},
    {"makehuman_game_engine",
     {"pelvis",     "thigh_l",    "thigh_r",    "spine_01",   "calf_l",  "calf_r",     "spine_02",    "foot_l",
      "foot_r",     "spine_03",   "ball_l",     "ball_r",     "neck_01", "clavicle_l", "clavicle_r",  "head",
      "upperarm_l", "upperarm_r", "lowerarm_l", "lowerarm_r", "hand_l",  "hand_r",     "middle_01_l", "middle_01_r"},
     // SMPL's spine heights (rig_mapping.h). On hm08 the heads of pelvis, spine_02, spine_03 and
     // neck_01 are at 0, 22, 40 and 100 % of pelvis → neck: spine1 (21 %) is spine_02's head;
     // spine2 (48 %) is 33 % of spine_02 → neck_01; spine3 (58 %) is 30 % of spine_03 → neck_01.
     {{{Joint::SPINE1, "spine_02", 1.0}, {Joint::SPINE2, "neck_01", 0.33}, {Joint::SPINE3, "neck_01", 0.30}}}},
}};

std::string json_quoted(std::string_view s) {
  return nlohmann::json(std::string(s)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

RigMapping make_mapping(const BuiltinRig& rig, std::string_view prefix) {
  RigMapping mapping;
  mapping.name = std::string(rig.name);
  for (int j = 0; j < JOINT_COUNT; ++j)
    mapping.bone_for_joint[j] = std::string(prefix) + std::string(rig.bones[j]);
  for (const BuiltinAnchor& anchor : rig.anchors)
    if (!anchor.toward.empty())
      mapping.anchors[idx(anchor.joint)] = {std::string(prefix) + std::string(anchor.toward), anchor.fraction};
  return mapping;
}

// Prefixes under which some bone of `bone_names` carries one of `rig`'s names: "" or a string
// ending in a separator (':', '_', '|', ...), so "Spine" never matches inside "UpperSpine".
std::set<std::string> candidate_prefixes(const BuiltinRig& rig, std::span<const std::string> bone_names) {
  std::set<std::string> prefixes;
  for (const std::string& bone : bone_names)
    for (std::string_view base : rig.bones) {
      if (!bone.ends_with(base)) continue;
      const std::string prefix = bone.substr(0, bone.size() - base.size());
      if (prefix.empty() || !std::isalnum(static_cast<unsigned char>(prefix.back()))) prefixes.insert(prefix);
    }
  return prefixes;
}

} // namespace

std::vector<std::string> builtin_rig_mappings() {
  std::vector<std::string> names;
  for (const BuiltinRig& rig : BUILTIN_RIGS)
    names.emplace_back(rig.name);
  return names;
}

RigMapping builtin_rig_mapping(std::string_view name, std::string_view prefix) {
  for (const BuiltinRig& rig : BUILTIN_RIGS)
    if (rig.name == name) return make_mapping(rig, prefix);
  std::string known;
  for (const BuiltinRig& rig : BUILTIN_RIGS)
    known += (known.empty() ? "" : ", ") + std::string(rig.name);
  throw Error("rig mapping", 0, "unknown built-in rig " + json_quoted(name) + " (known: " + known + ")");
}

RigMapping detect_rig_mapping(std::span<const std::string> bone_names, const std::string& source) {
  const std::unordered_set<std::string> present(bone_names.begin(), bone_names.end());
  const BuiltinRig* best_rig = &BUILTIN_RIGS[0];
  std::string best_prefix;
  int best_covered = -1;
  for (const BuiltinRig& rig : BUILTIN_RIGS)
    for (const std::string& prefix : candidate_prefixes(rig, bone_names)) {
      const auto covered = std::count_if(rig.bones.begin(), rig.bones.end(), [&](std::string_view base) {
        return present.contains(prefix + std::string(base));
      });
      if (covered > best_covered) {
        best_covered = static_cast<int>(covered);
        best_rig = &rig;
        best_prefix = prefix;
      }
    }
  RigMapping mapping = make_mapping(*best_rig, best_prefix);
  if (best_covered == JOINT_COUNT) return mapping;

  std::string missing;
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (!present.contains(mapping.bone_for_joint[j]))
      missing += (missing.empty() ? "" : ", ") + std::string(joint_name(j)) + " (" + mapping.bone_for_joint[j] + ")";
  throw Error(source, 0,
              "cannot map the rig's " + std::to_string(bone_names.size()) +
                  " bones onto the 24 canonical joints: the closest built-in mapping, " + mapping.name +
                  (best_prefix.empty() ? "" : " with prefix " + json_quoted(best_prefix)) + ", misses " + missing +
                  "; give an explicit rig mapping file");
}

RigMapping parse_rig_mapping(std::string_view json_text, const std::string& path) {
  nlohmann::json root;
  try {
    root = nlohmann::json::parse(json_text.begin(), json_text.end());
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(path, 0, std::string("invalid JSON: ") + e.what());
  }
  if (!root.is_object()) throw Error(path, 0, "a rig mapping must be a JSON object {\"pelvis\": \"<bone>\", ...}");
  RigMapping mapping;
  mapping.name = path;
  std::map<std::string, std::string> joint_of_bone;
  for (const auto& [key, value] : root.items()) {
    const std::optional<int> joint = joint_from_name(key);
    if (!joint)
      throw Error(path, 0,
                  "key " + json_quoted(key) + " is not a canonical joint name (pelvis, left_hip, ..., right_hand)");
    std::string bone;
    if (value.is_object()) {
      const auto where = [&key = key] { return "key " + json_quoted(key) + ": "; };
      for (const auto& [member, unused] : value.items())
        if (member != "bone" && member != "toward" && member != "at")
          throw Error(path, 0, where() + "unknown member " + json_quoted(member) + " (expected bone, toward, at)");
      if (!value.contains("bone") || !value["bone"].is_string() || value["bone"].get<std::string>().empty())
        throw Error(path, 0, where() + "\"bone\" must be a non-empty string");
      bone = value["bone"].get<std::string>();
      if (value.contains("toward") || value.contains("at")) {
        if (!value.contains("toward") || !value["toward"].is_string() || value["toward"].get<std::string>().empty())
          throw Error(path, 0, where() + "\"toward\" must be a non-empty bone name when \"at\" is given");
        if (!value.contains("at") || !value["at"].is_number() || !(value["at"].get<double>() >= 0.0) ||
            !(value["at"].get<double>() <= 1.0))
          throw Error(path, 0,
                      where() + "\"at\" must be a number in [0, 1], the fraction of the way toward \"" +
                          value["toward"].get<std::string>() + "\"");
        mapping.anchors[*joint] = {value["toward"].get<std::string>(), value["at"].get<double>()};
      }
    } else if (value.is_string() && !value.get<std::string>().empty()) {
      bone = value.get<std::string>();
    } else {
      throw Error(path, 0,
                  "key " + json_quoted(key) + ": the bone name must be a non-empty string or {\"bone\": ..., " +
                      "\"toward\": ..., \"at\": ...}, got " + value.dump());
    }
    if (const auto [it, inserted] = joint_of_bone.try_emplace(bone, key); !inserted)
      throw Error(path, 0,
                  "key " + json_quoted(key) + ": bone " + json_quoted(bone) + " is already mapped to " + it->second);
    mapping.bone_for_joint[*joint] = bone;
  }
  std::string missing;
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (mapping.bone_for_joint[j].empty()) missing += (missing.empty() ? "" : ", ") + std::string(joint_name(j));
  if (!missing.empty()) throw Error(path, 0, "missing joints: " + missing);
  return mapping;
}

RigMapping load_rig_mapping(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, 0, "cannot read the rig mapping file");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_rig_mapping(text, path);
}

} // namespace vfit
