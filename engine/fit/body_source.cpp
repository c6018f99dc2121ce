// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/body_source.h"

#include <filesystem>
#include <system_error>

#include "vfit/geometry/body/pose_io.h"

namespace vfit {

Pose pose_from_keypoint_fit(const KeypointFit& fit, RestPose rest) {
  Pose pose = pose_for_rest(fit.pose, rest);
  pose.translation.setZero();
  return pose;
}

Pose pose_by_name_or_file(const std::string& value, RestPose rest) {
  std::error_code ec;
  return std::filesystem::is_regular_file(value, ec) ? read_pose_json(value) : named_pose(value, rest);
}

SourcedBody make_body(const BodySource& source) {
  BodyRequest request = source.request;
  if (source.keypoints) request.mannequin.measurements = source.keypoints->measurements;
  SourcedBody out{load_body(request), {}};
  Pose pose;
  if (source.keypoints) pose = pose_from_keypoint_fit(*source.keypoints, out.loaded.rest.rest_pose);
  if (!source.pose.empty()) pose = pose_by_name_or_file(source.pose, out.loaded.rest.rest_pose);
  out.body = out.loaded.posed(pose);
  return out;
}

} // namespace vfit
