// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The body half of a fit: the body to fit onto, made from what an app has — the parametric
/// mannequin (11 measurements, seed 004 §3.1), an SMPL-format model file with its shape
/// coefficients (seed 001 §4), a rigged glTF, a scan or a plain mesh (geometry/body/
/// body_loader.h) — posed by a named pose, a pose file, or a photo's 2D keypoints, whose fit
/// gives the mannequin its measurements and its pose (seed 000 §3; geometry/body/keypoint_fit.h).

#include <optional>
#include <string>

#include "vfit/geometry/body/body.h"
#include "vfit/geometry/body/body_loader.h"
#include "vfit/geometry/body/keypoint_fit.h"
#include "vfit/geometry/body/skeleton.h"

namespace vfit {

/// Where a body comes from and how it is posed.
struct BodySource {
  /// The body's source and how to read it ("mannequin" or a file; units, axes, rig mapping).
  BodyRequest request;
  /// A photo's keypoints fitted (fit_keypoints()): the mannequin takes their measurements and
  /// every source their pose (re-expressed for its rest pose, the camera's translation dropped,
  /// so the body stands in its own frame). Absent: the request's measurements, the rest pose.
  std::optional<KeypointFit> keypoints;
  /// A built-in pose name (named_pose_names()) or a pose JSON file (pose_io.h), resolved for
  /// the body's rest pose; it replaces the keypoints' pose. Empty: none.
  std::string pose;
};

/// A body made from a BodySource: as loaded (its rest skeleton, kind and warnings) and posed.
struct SourcedBody {
  LoadedBody loaded;
  Body body; ///< posed, metres, Y up facing +Z, closed and outward-oriented
};

/// Loads and poses the body of `source`. Throws vfit::Error naming the file and the element for
/// a body that cannot be read or checked (load_body()), and naming the pose for an unknown pose
/// name or a bad pose file.
SourcedBody make_body(const BodySource& source);

/// The pose a keypoint fit gives a body whose rest pose is `rest`: re-expressed for that rest
/// (pose_for_rest()) with the camera's translation dropped.
Pose pose_from_keypoint_fit(const KeypointFit& fit, RestPose rest);

/// A pose by name or file for a body whose rest pose is `rest`: a pose JSON file when `value`
/// names an existing file, else a built-in pose (throws vfit::Error for an unknown name).
Pose pose_by_name_or_file(const std::string& value, RestPose rest);

} // namespace vfit
