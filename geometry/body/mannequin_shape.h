// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The built-in mannequin as a signed distance function: a skeleton placed from the 11
/// measurements of seed 004 and simple anatomical shapes around it (an elliptic generalised
/// cylinder for the torso, round cones for limbs and neck, ellipsoids for head, hands, feet and
/// buttocks) joined by smooth unions. The mesh (mannequin.h) and the garment catalogue are
/// both generated from it.

#include <array>
#include <functional>
#include <vector>

#include "body.h"
#include "measurements.h"

namespace vfit {

/// A horizontal torso section: half-width a (x), half-depth b (z), centre z = c, at height y (m).
struct TorsoSection {
  double y, a, b, c;
};

/// A round cone: two spheres (centres p, q; radii rp, rq) and the hull between them.
struct RoundCone {
  Eigen::Vector3d p, q;
  double rp, rq;
  int joint; ///< the joint this piece moves with (for skin weights)
};

/// An ellipsoid with semi-axes `radii` along the columns of `axes` (orthonormal).
struct Ellipsoid {
  Eigen::Vector3d centre;
  Eigen::Matrix3d axes;
  Eigen::Vector3d radii;
  int joint;
};

/// Which of the mannequin's shapes take part in a distance query and how much each is grown
/// (m), for garments built around the body: the zero set of the grown distance is a surface
/// `offset` away from the skin.
struct ShapeInflation {
  std::function<double(double y)> torso_offset; ///< torso and buttocks, by height; empty: 0
  std::function<double(double y)> leg_offset;   ///< legs, by height; empty: 0
  double arm_offset = 0;
  double neck_offset = 0;
  bool with_arms = true, with_legs = true, with_head = true, with_hands = true, with_feet = true;
  /// > 0: each grown leg is cut flat this far (m) from the mid-plane x = 0 and the two are not
  /// blended with each other, so legs grown wider than the gap between the thighs stay two tubes
  /// (wide shorts). 0: the legs are grown and blended as the body's.
  double legs_gap = 0;
};

class MannequinShape {
public:
  /// Places the skeleton and shapes for `m` in `pose` (TPOSE or APOSE: arms 45° down), then
  /// calibrates the crotch height and the five girths on the distance function itself (so the
  /// zero set measures within about 0.5 % of the request before meshing).
  MannequinShape(const BodyMeasurements& m, RestPose pose);

  /// The same mannequin without the girth calibration, and so far cheaper to build: the
  /// skeleton (joints(), bone_segments()) and the head, hand, foot, arm and neck shapes are
  /// bit-for-bit those of the calibrated shape, since the calibration only rescales the torso,
  /// buttocks and leg shapes and moves the torso's bottom; the torso, buttocks and legs are as
  /// first placed, so distance() and section_girth() miss the requested girths by a few per
  /// cent. For callers that read the skeleton and the shapes it does not touch (the keypoint
  /// fit's body model).
  static MannequinShape uncalibrated(const BodyMeasurements& m, RestPose pose);

  /// Signed distance (m), negative inside; |∇| ≈ 1 near the surface.
  double distance(double x, double y, double z) const { return distance(x, y, z, nullptr); }
  /// The distance to the shapes selected by `inflation`, each grown by its offset.
  double distance(double x, double y, double z, const ShapeInflation* inflation) const {
    return evaluate_distance(x, y, z, inflation, true);
  }
  /// distance() evaluating every shape, without its bounds that skip shapes too far to change
  /// the result: bit-for-bit equal to distance() (the oracle its tests compare against), slower.
  double distance_of_every_shape(double x, double y, double z, const ShapeInflation* inflation) const {
    return evaluate_distance(x, y, z, inflation, false);
  }
  const JointPositions& joints() const { return m_joints; }
  const BodyMeasurements& measurements() const { return m_measurements; }
  RestPose pose() const { return m_pose; }
  /// Axis-aligned box containing the body with a margin (m).
  std::pair<Eigen::Vector3d, Eigen::Vector3d> bounding_box(double margin) const;
  /// z of the torso's centre line at height y.
  double torso_centre_z(double y) const;
  /// Approximate girth of the distance function's section around (x, z) at height y, by
  /// casting rays from that point (the convex hull of the first exits).
  double section_girth(double y, double x, double z) const;

  /// Bone segments per joint, for skin weights: (joint, from, to).
  struct BoneSegment {
    int joint;
    Eigen::Vector3d a, b;
  };
  const std::vector<BoneSegment>& bone_segments() const { return m_bones; }

  /// Unnormalised skin affinity of a surface point to each joint: the shapes the point lies on
  /// (a soft-min over shape distances, so blends between shapes share) hand their share to the
  /// joints that move them, split by distance to those joints' bones. make_mannequin() smooths
  /// and truncates these into skin weights.
  std::array<double, JOINT_COUNT> skin_affinity(const Eigen::Vector3d& p) const;

private:
  MannequinShape(const BodyMeasurements& m, RestPose pose, bool calibrated);
  void place_skeleton();
  void build_shapes();
  double evaluate_distance(double x, double y, double z, const ShapeInflation* inflation, bool bounded) const;
  TorsoSection torso_at(double y) const;
  double torso_distance(double x, double y, double z) const;

public:
  /// Shapes of the mannequin (read-only), for garments that follow single parts.
  const std::vector<RoundCone>& cones() const { return m_cones; }
  const std::vector<Ellipsoid>& ellipsoids() const { return m_ellipsoids; }
  /// The torso section at height y (clamped to the torso's extent).
  TorsoSection torso_section(double y) const { return torso_at(y); }

private:
  void calibrate();

  BodyMeasurements m_measurements;
  RestPose m_pose;
  JointPositions m_joints = JointPositions::Zero();
  std::vector<TorsoSection> m_torso;                      ///< keyframes, ascending y
  std::vector<double> m_key_y, m_key_a, m_key_b, m_key_c; ///< the keyframes as columns
  double m_torso_bottom = 0, m_torso_top = 0;
  std::vector<RoundCone> m_cones;
  std::vector<Ellipsoid> m_ellipsoids;
  std::vector<BoneSegment> m_bones;
  /// Per cone: a sphere containing it; per ellipsoid: its centre, largest and smallest radius
  /// (distance()'s lower bounds).
  struct ShapeBound {
    Eigen::Vector3d centre;
    double outer, inner;
  };
  std::vector<ShapeBound> m_cone_bounds, m_ellipsoid_bounds;
  // Calibration factors (1 = as placed).
  double m_scale_chest = 1, m_scale_waist = 1, m_scale_hip = 1, m_scale_thigh = 1, m_scale_calf = 1;
  double m_crotch_shift = 0;
};

} // namespace vfit
