// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Loading a glTF 2.0 skinned mesh (Mixamo, MakeHuman, SMPL exports, ...) as a vfit::Body: the
/// rig's bones are mapped onto the canonical joints and its skin weights carried over.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "body.h"
#include "rig_mapping.h"

namespace vfit {

/// Rest pose from the upper arms' direction in the rest joints: the mean angle of
/// shoulder → elbow below the horizontal (XZ) plane, both sides; < 20° → TPOSE, 20°–70° →
/// APOSE, otherwise (or for coincident joints) OTHER.
RestPose classify_rest_pose(const JointPositions& joints);

/// Parses a `.glb` or `.gltf` (as read_gltf() does; `path` names it in messages and resolves a
/// `.gltf`'s buffer files) holding a skinned body.
///
/// The body is the first node, in depth-first scene order, with both `mesh` and `skin`. Its mesh
/// is read as read_gltf() reads a skinned mesh: positions as stored (the node's own transform
/// is ignored, as the glTF spec says), corners with identical positions welded, UVs and normals
/// kept; other meshes of the file are not part of the body. The bind-pose world matrix of each
/// skin joint is inverse(inverseBindMatrix) (the node hierarchy's world transforms when the skin
/// has none), which puts joints in the mesh's space whatever the armature's transform.
///
/// Bones are the skin's joint nodes, named by their node names ("node<N>" when unnamed).
/// `mapping` names the bone of each canonical joint; without one detect_rig_mapping() picks a
/// built-in mapping. Canonical joint j = head (world bind translation) of its mapped bone.
///
/// Skin weights come from JOINTS_n/WEIGHTS_n (n = 0, 1, ...; joints unsigned byte or short,
/// weights float or normalized unsigned byte or short). Each bone's weight goes to the
/// canonical joint of its nearest mapped ancestor-or-self in the node hierarchy (finger bones →
/// the wrist or hand joint, twist bones → their parent's joint; bones with no mapped ancestor,
/// such as a root above the hips, → the pelvis); per vertex, duplicates are summed, the 4
/// largest kept and renormalised to sum 1. A welded vertex takes the weights of its first
/// POSITION element.
///
/// Units: when detect_body_units() reads the mesh as dm, cm, mm or inches, the mesh and joints are
/// scaled to metres and a warning says so. The rest pose comes from classify_rest_pose().
/// `warnings` (optional) receives the mesh reader's warnings, the unit conversion and the rig
/// mapping used. body.source = `path`.
///
/// Throws vfit::Error "<path>: <what>" for everything read_gltf() rejects and for: no skinned
/// mesh node; a skin without joints; a bad inverseBindMatrices accessor (not MAT4 float, too
/// few) or a singular one; a primitive without JOINTS_0 or WEIGHTS_0, or whose counts differ
/// from POSITION's; a joint index past the skin's joint count; a negative or non-finite
/// weight; a vertex whose weights are all zero; a mapped bone that is not a skin joint or
/// names two joints; a rig no built-in mapping covers (listing the missing joints); a mesh
/// whose size gives no units.
Body parse_gltf_body(std::string_view bytes, const std::string& path, const std::optional<RigMapping>& mapping = {},
                     std::vector<std::string>* warnings = nullptr);

/// Reads the file at `path` and parses it with parse_gltf_body().
Body read_gltf_body(const std::string& path, const std::optional<RigMapping>& mapping = {},
                    std::vector<std::string>* warnings = nullptr);

} // namespace vfit
