// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A rigged body: its rest-pose mesh, the canonical joints in that rest pose, and skin weights.

#include <string>

#include "skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// The rest pose a body or garment was built in.
enum class RestPose { TPOSE, APOSE, OTHER };

/// A body with a skeleton. The mesh is closed and in metres; `joints` are the canonical joints
/// of the rest pose; `weights` skin the mesh to them (≤ 4 influences per vertex).
struct Body {
  Mesh mesh;
  JointPositions joints = JointPositions::Zero();
  SkinWeights weights;
  RestPose rest_pose = RestPose::OTHER;
  std::string source; ///< where it came from: "mannequin", a file path, ...
};

/// The body's skeleton and weights as a generic mesh skin (canonical joint names and parents,
/// rest joints as the bind pose), for writing a rigged glTF.
MeshSkin body_skin(const Body& body);

/// The body's mesh and joints in `pose` (LBS with its weights). Returns a copy.
Body pose_body(const Body& body, const Pose& pose);

} // namespace vfit
