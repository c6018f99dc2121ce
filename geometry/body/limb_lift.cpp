// SPDX-License-Identifier: Apache-2.0
#include "limb_lift.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace vfit {
namespace {

// The point at distance `length` from `centre` on the ray from the origin along unit `ray`,
// nearer or farther; the ray's point closest to `centre` when the ray misses the sphere.
Eigen::Vector3d on_ray(const Eigen::Vector3d& centre, double length, const Eigen::Vector3d& ray, LiftDepth depth) {
  const double b = ray.dot(centre);
  const double disc = b * b - centre.squaredNorm() + length * length;
  const double lambda = b + static_cast<double>(static_cast<int>(depth)) * std::sqrt(std::max(disc, 0.0));
  return std::max(lambda, 0.0) * ray;
}

// Rotation taking the orthonormal frame (a, h, a × h) onto (e, g, e × g); a ⊥ h and e ⊥ g unit.
Eigen::Matrix3d frame_to_frame(const Eigen::Vector3d& a, const Eigen::Vector3d& h, const Eigen::Vector3d& e,
                               const Eigen::Vector3d& g) {
  Eigen::Matrix3d from, to;
  from << a, h, a.cross(h);
  to << e, g, e.cross(g);
  return to * from.transpose();
}

} // namespace

const std::array<HingeLimb, 4>& hinge_limbs() {
  static const std::array<HingeLimb, 4> limbs = {
      HingeLimb{Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW, Joint::LEFT_WRIST, -Eigen::Vector3d::UnitY()},
      HingeLimb{Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW, Joint::RIGHT_WRIST, Eigen::Vector3d::UnitY()},
      HingeLimb{Joint::LEFT_HIP, Joint::LEFT_KNEE, Joint::LEFT_ANKLE, Eigen::Vector3d::UnitX()},
      HingeLimb{Joint::RIGHT_HIP, Joint::RIGHT_KNEE, Joint::RIGHT_ANKLE, Eigen::Vector3d::UnitX()}};
  return limbs;
}

void lift_limb(const JointPositions& rest, const HingeLimb& limb, const Eigen::Vector3d& middle_ray,
               LiftDepth middle_depth, const std::optional<Eigen::Vector3d>& end_ray, LiftDepth end_depth, Pose& pose) {
  const int u = idx(limb.upper), m = idx(limb.middle), e = idx(limb.end);
  const auto G = joint_world_transforms(rest, pose);
  const Eigen::Vector3d upper_bone = (rest.row(m) - rest.row(u)).transpose();
  const Eigen::Vector3d lower_bone = (rest.row(e) - rest.row(m)).transpose();
  const double upper_length = upper_bone.norm(), lower_length = lower_bone.norm();
  if (upper_length < 1e-9 || lower_length < 1e-9 || middle_ray.norm() < 1e-9) return;

  const Eigen::Vector3d a = upper_bone / upper_length, b = lower_bone / lower_length;
  const Eigen::Vector3d& h = limb.flexion_axis;
  // The hinge axis made square to the upper bone: the frame that carries a kept hinge.
  const Eigen::Vector3d h_square = (h - h.dot(a) * a).normalized();

  const Eigen::Vector3d P = G[static_cast<std::size_t>(u)].translation();
  const Eigen::Vector3d E = on_ray(P, upper_length, middle_ray.normalized(), middle_depth);
  if ((E - P).norm() < 1e-9) return;
  const Eigen::Vector3d dir_upper = (E - P).normalized();
  const Eigen::Vector3d middle = P + upper_length * dir_upper; // on the sphere even where the ray missed it
  const Eigen::Matrix3d parent = G[static_cast<std::size_t>(joint_parent(u))].linear();

  if (end_ray && end_ray->norm() > 1e-9) {
    const Eigen::Vector3d W = on_ray(middle, lower_length, end_ray->normalized(), end_depth);
    const Eigen::Vector3d dir_lower = (W - middle).normalized();
    if ((W - middle).norm() > 1e-9 && dir_upper.cross(dir_lower).norm() > 1e-3) {
      // Flexion θ about h that opens the rest bones to the lifted angle: a · R(θ, h) b = e · w,
      // i.e. A cos θ + B sin θ + C = e · w (Rodrigues), taking the root in [0, π].
      const double A = a.dot(b) - a.dot(h) * h.dot(b), B = a.dot(h.cross(b)), C = a.dot(h) * h.dot(b);
      const double amplitude = std::hypot(A, B);
      const double phi = std::atan2(B, A);
      const double alpha =
          std::acos(std::clamp((dir_upper.dot(dir_lower) - C) / std::max(amplitude, 1e-12), -1.0, 1.0));
      auto wrap = [](double x) { return std::remainder(x, 2 * std::numbers::pi); };
      const double t1 = wrap(phi + alpha), t2 = wrap(phi - alpha);
      double flexion = t1 >= 0 && (t2 < 0 || t1 <= t2) ? t1 : t2;
      flexion = std::max(flexion, 0.0);
      const Eigen::Vector3d v = axis_angle_to_matrix(flexion * h) * b; // the lower bone in the upper bone's frame
      const Eigen::Vector3d v_square = v - v.dot(a) * a, w_square = dir_lower - dir_lower.dot(dir_upper) * dir_upper;
      if (v_square.norm() > 1e-9 && w_square.norm() > 1e-9) {
        const Eigen::Matrix3d R_world = frame_to_frame(a, v_square.normalized(), dir_upper, w_square.normalized());
        pose.axis_angle.row(u) = matrix_to_axis_angle(parent.transpose() * R_world).transpose();
        pose.axis_angle.row(m) = (flexion * h).transpose();
        return;
      }
    }
  }
  // No end keypoint, or a straight limb: the hinge keeps its present world axis (made square to
  // the new upper bone) and its flexion.
  Eigen::Vector3d hinge = G[static_cast<std::size_t>(u)].linear() * h_square;
  hinge -= hinge.dot(dir_upper) * dir_upper;
  if (hinge.norm() < 1e-9) return;
  const double flexion = std::max(0.0, pose.axis_angle.row(m).dot(h.transpose()));
  const Eigen::Matrix3d R_world = frame_to_frame(a, h_square, dir_upper, hinge.normalized());
  pose.axis_angle.row(u) = matrix_to_axis_angle(parent.transpose() * R_world).transpose();
  pose.axis_angle.row(m) = (flexion * h).transpose();
}

} // namespace vfit
