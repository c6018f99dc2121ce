// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The body the keypoint fit sees (seed 000 §3): its shape parameters, the body points linear
/// in them, and the pinhole camera that projects them. Shared by keypoint_fit.h and the cost
/// terms of keypoint_costs.h.

#include <array>

#include <Eigen/Core>

#include "keypoints.h"
#include "measurements.h"
#include "skeleton.h"

namespace vfit {

/// Shape parameters of the keypoint model, each in standard deviations of an adult population:
/// 0 stature (every measurement scaled; σ = 7 cm of height), 1 leg length (crotch and knee
/// heights at fixed stature; σ = 2.5 cm), 2 arm length (arm and forearm; σ = 2 cm), 3 shoulder
/// width (σ = 2 cm). Other measurements keep the average body's proportions.
inline constexpr int KEYPOINT_SHAPE_PARAMS = 4;
/// β: KEYPOINT_SHAPE_PARAMS shape parameters in population standard deviations (above).
using KeypointShape = std::array<double, KEYPOINT_SHAPE_PARAMS>;

/// The body seen by the keypoint fit: T-pose rest positions of every body point (24 joints and
/// the landmarks of keypoints.h), linear in the shape: P(β) = mean + Σ_k β_k basis[k]
/// (#BODY_POINT_COUNT × 3, m). Built by central finite differences (±1 σ) of the built-in
/// mannequin's skeleton (MannequinShape::joints(); no meshing) around the average body; the
/// landmarks are placed on the mannequin's head and foot shapes. Each point moves rigidly with
/// its joint.
struct KeypointBodyModel {
  /// BODY_POINT_COUNT × 3 positions (m), row = body point (keypoints.h).
  using Points = Eigen::Matrix<double, BODY_POINT_COUNT, 3, Eigen::RowMajor>;
  Points mean = Points::Zero(); ///< rest points of the average body, β = 0 (m)
  /// Per shape parameter k: the rest points' change per +1 σ of β_k (m per σ).
  std::array<Points, KEYPOINT_SHAPE_PARAMS> basis{};
  std::array<int, BODY_POINT_COUNT> joint{};    ///< the joint each point moves with
  std::array<double, BODY_POINT_COUNT> trust{}; ///< fit weight w_i of a keypoint on that point (0.5 hips, else 1)

  /// The measurements of shape β (the average body for β = 0): stature scales every
  /// measurement by 1 + β₀·7 cm / height; β₁ adds 2.5 cm per σ to the crotch height (knee
  /// height in proportion), β₂ 2 cm to the arm length (forearm in proportion), β₃ 2 cm to the
  /// shoulder width. No range check: extreme β give extreme (even negative) lengths.
  static BodyMeasurements measurements(const KeypointShape& beta);
  /// Rest (T-pose) points of shape β: mean + Σ_k β_k basis[k] (m).
  Points rest_points(const KeypointShape& beta) const;
  /// Rest (T-pose) joints of shape β: the first JOINT_COUNT rows of rest_points() (m).
  JointPositions rest_joints(const KeypointShape& beta) const;
  /// Posed points (m): each point carried by its joint's world transform (skeleton.h FK) of
  /// `pose` (T-pose-relative, translation included) on the rest joints of β.
  Points posed_points(const KeypointShape& beta, const Pose& pose) const;
};

/// A pinhole camera at the origin looking along −Z with Y up (our world convention, so a body
/// facing +Z faces the camera): u = cx + f X / (−Z), v = cy − f Y / (−Z), pixels with v down.
struct PinholeCamera {
  double focal = 1000;                                       ///< px
  Eigen::Vector2d principal_point = Eigen::Vector2d::Zero(); ///< px (the image centre)
  /// Pixel (px, v down) of a point p (m, camera frame) in front of the camera (Z < 0). A point
  /// at or behind the camera plane is projected as if 1e-9 m in front (huge, finite pixels);
  /// no error.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const;
};

} // namespace vfit
