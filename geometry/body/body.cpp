#include "body.h"

namespace vfit {

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
