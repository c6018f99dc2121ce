// SPDX-License-Identifier: Apache-2.0
#include "body.h"

namespace vfit {

MeshSkin body_skin(const Body& body) {
  MeshSkin s;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    s.joint_names.emplace_back(joint_name(j));
    s.joint_parents.push_back(joint_parent(j));
    for (int k = 0; k < 3; ++k)
      s.joint_positions.push_back(static_cast<float>(body.joints(j, k)));
  }
  s.joints = body.weights.joints;
  s.weights = body.weights.weights;
  return s;
}

Body pose_body(const Body& body, const Pose& pose) {
  Body out = body;
  if (pose.is_rest()) return out;
  linear_blend_skinning(body.mesh.positions, body.weights, skinning_transforms(body.joints, pose), out.mesh.positions);
  out.joints = posed_joints(body.joints, pose);
  out.mesh.normals.clear();
  out.mesh.normal_triangles.clear();
  return out;
}

} // namespace vfit
