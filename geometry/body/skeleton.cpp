// SPDX-License-Identifier: Apache-2.0
#include "skeleton.h"

#include <algorithm>
#include <cmath>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

constexpr std::array<std::string_view, JOINT_COUNT> NAMES = {
    "pelvis",     "left_hip",    "right_hip",    "spine1",      "left_knee",     "right_knee",
    "spine2",     "left_ankle",  "right_ankle",  "spine3",      "left_foot",     "right_foot",
    "neck",       "left_collar", "right_collar", "head",        "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist",   "right_wrist", "left_hand",     "right_hand"};

constexpr std::array<int, JOINT_COUNT> PARENTS = {-1, 0, 0, 0,  1,  2,  3,  4,  5,  6,  7,  8,
                                                  9,  9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};

constexpr std::size_t LBS_GRAIN = 2048;

} // namespace

std::string_view joint_name(int joint) { return NAMES.at(static_cast<std::size_t>(joint)); }

std::optional<int> joint_from_name(std::string_view name) {
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (NAMES[j] == name) return j;
  return std::nullopt;
}

int joint_parent(int joint) { return PARENTS.at(static_cast<std::size_t>(joint)); }

int mirrored_joint(int joint) {
  const std::string_view n = joint_name(joint);
  std::string m(n);
  if (n.rfind("left_", 0) == 0)
    m = "right_" + std::string(n.substr(5));
  else if (n.rfind("right_", 0) == 0)
    m = "left_" + std::string(n.substr(6));
  return *joint_from_name(m);
}

Pose Pose::from_smpl_vector(std::span<const double> theta72, const Eigen::Vector3d& translation) {
  if (theta72.size() != 3 * JOINT_COUNT)
    throw Error("pose", 0, "expected 72 pose numbers (24 joints × 3), got " + std::to_string(theta72.size()));
  Pose p;
  for (int j = 0; j < JOINT_COUNT; ++j)
    for (int k = 0; k < 3; ++k)
      p.axis_angle(j, k) = theta72[3 * j + k];
  p.translation = translation;
  return p;
}

Eigen::Matrix3d axis_angle_to_matrix(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
}

Eigen::Vector3d matrix_to_axis_angle(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

std::array<Eigen::Isometry3d, JOINT_COUNT> joint_world_transforms(const JointPositions& rest, const Pose& pose) {
  std::array<Eigen::Isometry3d, JOINT_COUNT> g;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
    local.linear() = axis_angle_to_matrix(pose.axis_angle.row(j).transpose());
    const int p = PARENTS[j];
    if (p < 0) {
      local.translation() = rest.row(j).transpose() + pose.translation;
      g[j] = local;
    } else {
      local.translation() = (rest.row(j) - rest.row(p)).transpose();
      g[j] = g[p] * local;
    }
  }
  return g;
}

JointPositions posed_joints(const JointPositions& rest, const Pose& pose) {
  const auto g = joint_world_transforms(rest, pose);
  JointPositions out;
  for (int j = 0; j < JOINT_COUNT; ++j)
    out.row(j) = g[j].translation().transpose();
  return out;
}

std::array<Eigen::Isometry3d, JOINT_COUNT> skinning_transforms(const JointPositions& rest, const Pose& pose) {
  auto a = joint_world_transforms(rest, pose);
  for (int j = 0; j < JOINT_COUNT; ++j)
    a[j].translation() -= a[j].linear() * rest.row(j).transpose();
  return a;
}

SkinWeights SkinWeights::from_dense(std::span<const double> dense, int joint_count, int fallback_joint) {
  SkinWeights w;
  const std::size_t nv = dense.size() / static_cast<std::size_t>(joint_count);
  w.joints.assign(4 * nv, 0);
  w.weights.assign(4 * nv, 0.0f);
  std::vector<int> order(static_cast<std::size_t>(joint_count));
  for (std::size_t v = 0; v < nv; ++v) {
    const double* row = dense.data() + v * static_cast<std::size_t>(joint_count);
    for (int j = 0; j < joint_count; ++j)
      order[j] = j;
    const int keep = std::min(4, joint_count);
    std::partial_sort(order.begin(), order.begin() + keep, order.end(),
                      [&](int a, int b) { return row[a] > row[b] || (row[a] == row[b] && a < b); });
    double sum = 0;
    for (int k = 0; k < keep; ++k)
      sum += std::max(0.0, row[order[k]]);
    if (sum <= 0) {
      w.joints[4 * v] = fallback_joint;
      w.weights[4 * v] = 1.0f;
      continue;
    }
    for (int k = 0; k < keep; ++k) {
      w.joints[4 * v + k] = order[k];
      w.weights[4 * v + k] = static_cast<float>(std::max(0.0, row[order[k]]) / sum);
    }
  }
  return w;
}

void linear_blend_skinning(std::span<const float> rest, const SkinWeights& weights,
                           const std::array<Eigen::Isometry3d, JOINT_COUNT>& transforms, std::vector<float>& posed) {
  const std::size_t nv = rest.size() / 3;
  posed.resize(rest.size());
  // Float 3×4 copies of the transforms: the blend runs in double per vertex for accuracy.
  std::array<Eigen::Matrix<double, 3, 4>, JOINT_COUNT> m;
  for (int j = 0; j < JOINT_COUNT; ++j)
    m[j] = transforms[j].matrix().topRows<3>();
  parallel_for_range(nv, LBS_GRAIN, [&](std::size_t b, std::size_t e) {
    for (std::size_t v = b; v < e; ++v) {
      Eigen::Matrix<double, 3, 4> blend = Eigen::Matrix<double, 3, 4>::Zero();
      for (int k = 0; k < 4; ++k) {
        const float w = weights.weights[4 * v + k];
        if (w != 0.0f) blend += double(w) * m[weights.joints[4 * v + k]];
      }
      const Eigen::Vector4d p(rest[3 * v], rest[3 * v + 1], rest[3 * v + 2], 1.0);
      const Eigen::Vector3d q = blend * p;
      posed[3 * v] = static_cast<float>(q.x());
      posed[3 * v + 1] = static_cast<float>(q.y());
      posed[3 * v + 2] = static_cast<float>(q.z());
    }
  });
}

void validate_skin_weights(const SkinWeights& weights, std::size_t vertex_count, const std::string& source) {
  if (weights.weights.size() != 4 * vertex_count || weights.joints.size() != 4 * vertex_count)
    throw Error(source, 0,
                "skin weights are for " + std::to_string(weights.weights.size() / 4) + " vertices, the mesh has " +
                    std::to_string(vertex_count));
  for (std::size_t v = 0; v < vertex_count; ++v) {
    double sum = 0;
    for (int k = 0; k < 4; ++k) {
      const int j = weights.joints[4 * v + k];
      const float w = weights.weights[4 * v + k];
      if (j < 0 || j >= JOINT_COUNT)
        throw Error(source, 0,
                    "vertex " + std::to_string(v + 1) + ": joint index " + std::to_string(j) + " out of range");
      if (!std::isfinite(w) || w < 0)
        throw Error(source, 0, "vertex " + std::to_string(v + 1) + ": skin weight is negative or not finite");
      sum += w;
    }
    if (std::abs(sum - 1.0) > 1e-3)
      throw Error(source, 0,
                  "vertex " + std::to_string(v + 1) + ": skin weights sum to " + std::to_string(sum) + ", not 1");
  }
}

} // namespace vfit
