// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Retargeting motion capture onto the canonical 24-joint skeleton (seed 001 §7: the motion
/// that drives a dressed body).
///
/// A BVH rig names its joints in its own convention and stands in its own rest pose (a T-pose,
/// an A-pose, Z up...). Each canonical joint is mapped to one BVH joint (MotionMapping); the rig's
/// axes are turned into ours (Y up, facing +Z, the character's left at +X: the rig's up axis
/// from the file, its left from its hips); then, per frame, every mapped joint's world rotation
/// is the BVH joint's world rotation composed with a rest alignment (the rotation taking our
/// rest bone onto the rig's rest bone: T-pose against A-pose, a rig's bent elbows), and turned
/// further so that our bone points exactly where the rig's posed bone points (joint to mapped
/// child): intermediate rig joints that have no canonical joint (five spine joints onto three)
/// still bend the chain. The pelvis and the chest take their frame from two posed directions
/// each (up the spine, across the hips or shoulders). Joints without a mapped BVH joint keep
/// their rest rotation relative to their parent. The root's motion is scaled by the ratio of
/// our leg length to the rig's (hips above the lowest foot joint at rest): horizontally from the
/// first frame, vertically above the lowest the rig's feet go in the clip.

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "bvh.h"
#include "vfit/geometry/body/skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// For each canonical joint (SMPL order), the BVH joint that drives it, or empty.
struct MotionMapping {
  std::string name; ///< a built-in convention's name, or the mapping file's path
  std::array<std::string, JOINT_COUNT> joint;
};

/// The canonical joints a motion needs: the pelvis, hips, knees, ankles, shoulders, elbows,
/// wrists, the neck or the head, and one of the three spine joints.
bool motion_mapping_complete(const MotionMapping& mapping, std::string* missing = nullptr);

/// Built-in conventions, in the order detect_motion_mapping() prefers them on ties:
/// "smpl" (pelvis, left_hip, ...), "mixamo" (Hips, LeftUpLeg, Spine, ..., any "xxx:" prefix),
/// "cmu" (Hips, LHipJoint, LeftUpLeg, LowerBack, ...: CMU's ASF-derived BVH), "motionbuilder"
/// (Hips, LeftHip, LeftKnee, LeftAnkle, Chest, LeftCollar, ...), "daz" (hip, abdomen, chest,
/// lThigh, lShin, lCollar, lShldr, ...: the cgspeed conversions of CMU), "makehuman"
/// (MakeHuman's default rig: root, upperleg01.L, spine04, ...), "makehuman_old" (Root, Spine1,
/// UpLeg_L, LoArm_R, ...: MakeHuman's older BVH rig).
std::vector<std::string> builtin_motion_mappings();

/// The built-in convention `name` (see builtin_motion_mappings()); throws vfit::Error for an
/// unknown name.
MotionMapping builtin_motion_mapping(std::string_view name);

/// The built-in convention that maps the most canonical joints of `motion` (its joint names
/// compared case-insensitively, after any "prefix:" such as "mixamorig:"), complete in the
/// sense of motion_mapping_complete(); the mapping holds the file's own spelling. Throws
/// vfit::Error "<source>: ..." naming the best candidate and the joints it misses, and
/// suggesting a mapping file.
MotionMapping detect_motion_mapping(const BvhMotion& motion);

/// Parses a mapping file: a JSON object from canonical joint names to the BVH's joint names,
/// e.g. {"pelvis": "Hips", "left_hip": "LeftUpLeg", ...}; joints left out are not driven.
/// Throws vfit::Error "<path>: ..." naming the key for invalid JSON, an unknown canonical name,
/// a value that is not a non-empty string, a BVH joint mapped twice, or a mapping that is not
/// complete (motion_mapping_complete()).
MotionMapping parse_motion_mapping(std::string_view json_text, const std::string& path);
/// Reads and parses the mapping file at `path` (see parse_motion_mapping()).
MotionMapping load_motion_mapping(const std::string& path);

/// Our body's motion: one pose per frame (axis-angle per joint relative to its parent,
/// translation in m) at `fps` frames per second.
struct RetargetedMotion {
  std::vector<Pose> frames;
  double fps = 0;
  std::string mapping;       ///< the mapping's name
  double leg_ratio = 1;      ///< our leg length over the rig's (both at rest, m)
  std::vector<int> unmapped; ///< canonical joints no BVH joint drives (they keep their rest rotation)
};

/// Retargets every frame of `motion` onto a skeleton whose rest joints are `rest` (m; the body
/// the poses are for, any rest pose). A mapped joint whose bone to its next mapped joint has no
/// length at rest (on either skeleton) is driven as an end: its rig joint's rotation with its
/// parent's alignment. Throws vfit::Error naming the source when a mapped name is not a joint of
/// the file, when the mapping is not complete, when the hips coincide across the up axis or when
/// the hips are not above the ankles at rest. O(#frames · #BVH joints).
RetargetedMotion retarget_bvh(const BvhMotion& motion, const JointPositions& rest, const MotionMapping& mapping);

/// A BVH of our skeleton in motion: joints named as SMPL names them (pelvis, left_hip, ...),
/// parents before children with an end site past the head, hands and feet, OFFSETs from the
/// rest joints `rest` in centimetres (Y up, facing +Z); the root with position channels (the
/// pelvis's world position: rest plus the pose's translation) and every joint with "Zrotation
/// Yrotation Xrotation" (R = Rz·Ry·Rx, degrees). The inverse of retarget_bvh() with the "smpl"
/// mapping, for poses whose ankles are at their rest height in some frame (that frame sets the
/// floor). `fps` > 0; throws vfit::Error otherwise.
BvhMotion poses_to_bvh(const JointPositions& rest, const std::vector<Pose>& frames, double fps);

/// glTF keyframes of `frames` at `fps` (> 0) for the canonical skeleton as body_skin() writes
/// it (rest joints `rest`, m): each joint's rotation as a unit quaternion, the pelvis at its rest
/// position plus the frame's translation; frame k at k / fps seconds. Throws vfit::Error for no
/// frames or a rate that is not positive.
SkinAnimation poses_to_skin_animation(const JointPositions& rest, const std::vector<Pose>& frames, double fps,
                                      const std::string& name);

/// `frames` at `from_fps` resampled to `to_fps` (> 0) over the same duration: joint rotations
/// interpolated by spherical linear interpolation of their quaternions, the translation
/// linearly; frame k at time k / to_fps, the last at or before the clip's end. Throws
/// vfit::Error for a rate that is not positive.
std::vector<Pose> resample_poses(const std::vector<Pose>& frames, double from_fps, double to_fps);

} // namespace vfit
