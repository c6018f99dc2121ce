// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The canonical 24-joint skeleton (SMPL's joint order, names and parents), poses in SMPL's
/// 72-number axis-angle layout plus a global translation, forward kinematics and linear blend
/// skinning with at most 4 influences per vertex (seed 000 §3; seed 001 §7.1).
/// Conventions: metres, Y up, the body facing +Z, +X = the body's left.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vfit {

/// Number of joints of the canonical skeleton.
inline constexpr int JOINT_COUNT = 24;

/// The canonical joints, in SMPL's order.
enum class Joint : int {
  PELVIS,
  LEFT_HIP,
  RIGHT_HIP,
  SPINE1,
  LEFT_KNEE,
  RIGHT_KNEE,
  SPINE2,
  LEFT_ANKLE,
  RIGHT_ANKLE,
  SPINE3,
  LEFT_FOOT,
  RIGHT_FOOT,
  NECK,
  LEFT_COLLAR,
  RIGHT_COLLAR,
  HEAD,
  LEFT_SHOULDER,
  RIGHT_SHOULDER,
  LEFT_ELBOW,
  RIGHT_ELBOW,
  LEFT_WRIST,
  RIGHT_WRIST,
  LEFT_HAND,
  RIGHT_HAND
};

/// SMPL's joint names: "pelvis", "left_hip", ..., "right_hand".
std::string_view joint_name(int joint);
/// The joint with that canonical name, or nullopt.
std::optional<int> joint_from_name(std::string_view name);
/// Parent of each joint (−1 for the pelvis, the root). Parents precede children.
int joint_parent(int joint);
/// The joint mirrored left↔right (itself for the spine, neck, head and pelvis).
int mirrored_joint(int joint);

inline int idx(Joint j) { return static_cast<int>(j); }

/// Joint positions (m), one row per joint in canonical order.
using JointPositions = Eigen::Matrix<double, JOINT_COUNT, 3, Eigen::RowMajor>;

/// A pose: per-joint axis-angle rotations relative to the parent (SMPL's 72 numbers; row 0 is
/// the global orientation about the pelvis) and a global translation (m).
struct Pose {
  Eigen::Matrix<double, JOINT_COUNT, 3, Eigen::RowMajor> axis_angle =
      Eigen::Matrix<double, JOINT_COUNT, 3, Eigen::RowMajor>::Zero();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  /// The 72-number layout (joint-major, x y z per joint).
  static Pose from_smpl_vector(std::span<const double> theta72,
                               const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());
  bool is_rest() const { return axis_angle.isZero(0.0) && translation.isZero(0.0); }
};

/// Rodrigues' formula: the rotation of angle ‖r‖ (rad) about r/‖r‖ (identity for r = 0).
Eigen::Matrix3d axis_angle_to_matrix(const Eigen::Vector3d& r);
/// The inverse: an axis-angle vector of angle in [0, π].
Eigen::Vector3d matrix_to_axis_angle(const Eigen::Matrix3d& R);

/// Forward kinematics of `pose` applied to a skeleton whose rest joints are `rest`:
/// G_j = G_parent(j) · [R_j | J_j − J_parent(j)], with G_root = [R_0 | J_0] then translated.
/// Returns the world transforms (rotation about each posed joint) of every joint.
std::array<Eigen::Isometry3d, JOINT_COUNT> joint_world_transforms(const JointPositions& rest, const Pose& pose);

/// Posed joint positions: the translation part of joint_world_transforms().
JointPositions posed_joints(const JointPositions& rest, const Pose& pose);

/// Skinning transforms A_j = G_j · [I | −J_j^rest]: they map a rest-pose point rigidly
/// attached to joint j to its posed position.
std::array<Eigen::Isometry3d, JOINT_COUNT> skinning_transforms(const JointPositions& rest, const Pose& pose);

/// Per-vertex skin weights, at most 4 influences (unused slots: joint 0, weight 0). Weights of
/// a vertex sum to 1.
struct SkinWeights {
  std::vector<std::int32_t> joints; ///< #V × 4 joint indices in [0, 24)
  std::vector<float> weights;       ///< #V × 4, each row sums to 1

  std::size_t vertex_count() const { return weights.size() / 4; }

  /// Keeps the 4 largest of `dense` (#V × #joints, row-major) and renormalises them; a row of
  /// zeros gets weight 1 on `fallback_joint`.
  static SkinWeights from_dense(std::span<const double> dense, int joint_count, int fallback_joint = 0);
};

/// Linear blend skinning (seed 001 eq. 8's LBS term): v' = Σ_k w_k · A_{j_k} · v. `rest` and
/// `posed` are #V × 3 floats (m); `posed` is resized. Serial and TBB-parallel over vertices.
void linear_blend_skinning(std::span<const float> rest, const SkinWeights& weights,
                           const std::array<Eigen::Isometry3d, JOINT_COUNT>& transforms, std::vector<float>& posed);

/// Throws vfit::Error naming `source` when `weights` does not fit a mesh of `vertex_count`
/// vertices, holds a joint index out of range, a negative or non-finite weight, or a row
/// whose sum differs from 1 by more than 1e-3.
void validate_skin_weights(const SkinWeights& weights, std::size_t vertex_count, const std::string& source);

} // namespace vfit
