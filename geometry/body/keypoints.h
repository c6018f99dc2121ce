// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// 2D body keypoints from a photo (seed 000 §3: the body comes from fitting a body model to the
/// image's 2D joints, as in SMPLify): OpenPose JSON (BODY_25 and COCO-18), the 14-joint Leeds
/// Sports Pose layout, and a plain JSON of named joints, mapped onto points of our body.
///
/// Accepted files (pixels: x right, y down, origin at the top-left corner of the image):
/// - OpenPose: {"people": [{"pose_keypoints_2d": [x0, y0, c0, x1, y1, c1, ...]}, ...]}; 75
///   numbers = BODY_25, 54 = COCO-18 (detected from the count unless a layout is forced).
///   OpenPose files carry no image size: pass it (KeypointOptions::image_size), or add our
///   optional top-level keys "image_size": [W, H] and "focal": F.
/// - LSP: {"layout": "lsp", "image_size": [W, H], "focal": F (optional),
///   "keypoints": [[x, y, v] × 14] or 42 numbers}, in LSP's order: right ankle, right knee,
///   right hip, left hip, left knee, left ankle, right wrist, right elbow, right shoulder, left
///   shoulder, left elbow, left wrist, neck, head top. v is LSP's visibility or a confidence in
///   [0, 1] (LSP's 0/1 flag reads as confidence 0 or 1).
/// - Named: {"image_size": [W, H], "focal": F (optional), "joints": {"<name>": [x, y] or
///   [x, y, c], ...}}; names are our canonical SMPL joint names ("left_knee", ...), OpenPose's
///   BODY_25 names ("LKnee", "Nose", "MidHip", "LBigToe", ...) or LSP's "head_top". c defaults
///   to 1.
/// "Left" is always the person's left, as in OpenPose, LSP and SMPL.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "skeleton.h"

namespace vfit {

/// Points of the body that a keypoint can observe: indices 0..23 are the canonical joints
/// (Joint); the landmarks below are surface points attached to a joint (their rest positions
/// come from the mannequin's shape: keypoint_fit.h).
enum class Landmark : int {
  NOSE = JOINT_COUNT, ///< nose (OpenPose/COCO); the first landmark, = JOINT_COUNT (24)
  LEFT_EYE,           ///< left eye
  RIGHT_EYE,          ///< right eye
  LEFT_EAR,           ///< left ear
  RIGHT_EAR,          ///< right ear
  HEAD_TOP,           ///< top of the skull (LSP)
  NECK_BASE,          ///< OpenPose's "Neck": between the shoulders, below SMPL's neck joint
  MID_HIP,            ///< OpenPose's "MidHip": midway between the two hip landmarks
  LEFT_HIP_SURFACE,   ///< OpenPose/COCO/LSP hips (see keypoint_body_point())
  RIGHT_HIP_SURFACE,  ///< right counterpart of LEFT_HIP_SURFACE
  LEFT_BIG_TOE,       ///< BODY_25 "LBigToe"
  LEFT_SMALL_TOE,     ///< BODY_25 "LSmallToe"
  LEFT_HEEL,          ///< BODY_25 "LHeel"
  RIGHT_BIG_TOE,      ///< BODY_25 "RBigToe"
  RIGHT_SMALL_TOE,    ///< BODY_25 "RSmallToe"
  RIGHT_HEEL,         ///< BODY_25 "RHeel"
  END                 ///< one past the last landmark (= BODY_POINT_COUNT), not a point
};

/// Number of body points: 24 joints + the landmarks.
inline constexpr int BODY_POINT_COUNT = static_cast<int>(Landmark::END);

/// The body point (row of a BODY_POINT_COUNT × 3 table) of landmark `l`, as idx(Joint) is a
/// joint's: in [JOINT_COUNT, BODY_POINT_COUNT) for a landmark other than END.
constexpr int idx(Landmark l) { return static_cast<int>(l); }

/// Name of body point `point`: a canonical joint name, or "nose", "left_eye", ... "right_heel";
/// "unknown" for a point outside [0, BODY_POINT_COUNT) (never throws).
std::string_view body_point_name(int point);

/// Keypoint layouts. AUTO: OpenPose files by their count (75 → BODY_25, 54 → COCO_18), files
/// with "layout": "lsp" as LSP_14, files with "joints" as NAMED.
enum class KeypointLayout {
  AUTO,    ///< detect from the file (above)
  BODY_25, ///< OpenPose BODY_25: 25 keypoints, 75 numbers
  COCO_18, ///< OpenPose COCO-18: 18 keypoints, 54 numbers
  LSP_14,  ///< Leeds Sports Pose: 14 keypoints, in LSP's order (file comment)
  NAMED    ///< {"joints": {"<name>": [x, y(, c)]}}
};

/// "auto", "body25", "coco18", "lsp14", "named".
std::string_view keypoint_layout_name(KeypointLayout layout);
/// The layout of that name (also "body_25", "coco", "coco_18", "lsp"); nullopt when unknown.
std::optional<KeypointLayout> keypoint_layout_from_name(std::string_view name);

/// The body point a keypoint of `layout` observes, by its index in the layout (BODY_25: 0..24,
/// COCO_18: 0..17, LSP_14: 0..13); −1 for an index out of range.
/// Mapping: shoulders, elbows, wrists, knees and ankles are SMPL's joints of the same name (the
/// annotations mark joint centres as seen from outside, close to the model's joint centres).
/// Hips are NOT SMPL's hip joints: annotators (and OpenPose trained on them) mark the hip at
/// the side of the pelvis, a few cm lower and wider than the hip joint centre that SMPL
/// regresses; they map to LEFT/RIGHT_HIP_SURFACE, placed there (keypoint_fit.h), and are
/// trusted half as much as other keypoints in the fit. OpenPose's Neck (midpoint of the
/// shoulders) maps to NECK_BASE; LSP's neck (the top of the neck, under the chin) to SMPL's
/// neck joint; face keypoints, head top, toes and heels to landmarks on the head and feet.
int keypoint_body_point(KeypointLayout layout, int index);

/// The body point named `name` in a named-joints file (canonical names, BODY_25 names,
/// "head_top"); −1 when unknown.
int named_body_point(std::string_view name);

/// One confident 2D observation.
struct Keypoint2D {
  int point = 0;           ///< body point in [0, BODY_POINT_COUNT)
  Eigen::Vector2d pixel;   ///< (x right, y down) px
  double confidence = 1.0; ///< in (min_confidence, 1]
};

/// Default focal length (px) for an image of `width` × `height` px when the file gives none:
/// 1.2 × the longer side, i.e. a 43 mm lens on a full-frame (36 mm) sensor, a "normal" lens
/// (diagonal field of view ~ 53°) between a phone's wide camera (~26 mm) and a portrait lens.
/// A wrong focal length mostly trades against the camera distance, not the pose.
double default_focal_length(double width, double height);

/// How parse_keypoints() / read_keypoints() read a file; the defaults read any accepted file
/// that carries its own image size.
struct KeypointOptions {
  /// Force a layout (OpenPose: BODY_25/COCO_18); a file of another kind then throws
  /// vfit::Error ("the file holds … keypoints, not …").
  KeypointLayout layout = KeypointLayout::AUTO;
  std::optional<Eigen::Vector2d> image_size; ///< overrides the file's (px)
  std::optional<double> focal;               ///< overrides the file's (px)
  /// Keypoints at or below this confidence are treated as missing (OpenPose writes 0 for
  /// undetected joints; its scores below ~0.1 are mostly false detections).
  double min_confidence = 0.1;
};

/// Minimum confident keypoints for a fit: 6 (12 numbers, twice the camera's 6 degrees of
/// freedom, leaving some for the pose), including at least 3 of the 4 torso keypoints
/// (shoulders, hips), which anchor the camera's distance and the body's orientation.
inline constexpr int MIN_CONFIDENT_KEYPOINTS = 6;
/// Minimum confident torso keypoints (of left/right shoulder and hip) for a fit.
inline constexpr int MIN_TORSO_KEYPOINTS = 3;

/// The keypoints of one person.
struct Keypoints {
  KeypointLayout layout = KeypointLayout::AUTO;         ///< the layout read (never AUTO)
  std::vector<Keypoint2D> points;                       ///< confident keypoints only, one per body point
  Eigen::Vector2d image_size = Eigen::Vector2d::Zero(); ///< W, H (px)
  double focal = 0;                                     ///< px
  bool focal_given = false;                             ///< false: default_focal_length()
  std::vector<std::string> warnings;                    ///< e.g. "3 people in the file; using person 1"
  std::string source;                                   ///< file name, for messages
};

/// Parses keypoints from JSON text; `source` names it in messages. Throws vfit::Error naming
/// the source and the element for: invalid JSON, no person (empty "people"), an unknown layout
/// (a keypoint count that is neither 75 nor 54, an unknown "layout" or joint name), a file
/// that does not match a forced KeypointOptions::layout, a malformed entry (not an array, a
/// wrong length), the same body point named twice, a value that is not a finite number, a
/// confidence outside [0, 1], a missing or non-positive image size or focal length, and fewer
/// than MIN_CONFIDENT_KEYPOINTS confident keypoints (or fewer than MIN_TORSO_KEYPOINTS torso
/// ones). With several people, keeps the one with the highest summed confidence and adds a
/// warning. Keypoints at or below options.min_confidence are dropped, not errors.
Keypoints parse_keypoints(const std::string& json_text, const std::string& source, const KeypointOptions& options = {});

/// Reads a keypoints file (see parse_keypoints(); `source` is the path). Throws vfit::Error
/// "<path>: cannot open: <reason>" for an unreadable file, else as parse_keypoints().
Keypoints read_keypoints(const std::filesystem::path& path, const KeypointOptions& options = {});

} // namespace vfit
