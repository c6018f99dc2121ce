#include "coarse_move.h"

#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Cholesky>

#include "kernels/proximity.h"

namespace vfit {
namespace {

bool is_bottom(GarmentType type) {
  return type == GarmentType::TROUSERS || type == GarmentType::SHORTS || type == GarmentType::SKIRT;
}

std::optional<Eigen::Vector3d> root_node(std::span<const PartSkeleton> skeletons, GarmentPart part) {
  for (const PartSkeleton& s : skeletons)
    if (s.part == part && !s.nodes.empty()) return s.nodes.front();
  return std::nullopt;
}

Eigen::Vector3d joint(const JointPositions& joints, Joint j) { return joints.row(idx(j)).transpose(); }

} // namespace

std::string to_string(CoarseMoveRule rule) {
  switch (rule) {
  case CoarseMoveRule::SLEEVE_ROOTS_TO_SHOULDERS: return "sleeve roots -> shoulders (eq. 16)";
  case CoarseMoveRule::LEG_ROOTS_TO_HIPS: return "leg roots -> hips (eq. 17)";
  case CoarseMoveRule::COLLAR_TO_NECK: return "collar centre -> neck";
  case CoarseMoveRule::WAISTBAND_TO_PELVIS: return "waistband centre -> pelvis/spine1";
  case CoarseMoveRule::IN_DRIVING: return "key joints -> body joints, within the skeleton driving (eq. 16-17)";
  }
  return "unknown";
}

CoarseMove compute_coarse_move(GarmentType type, const SegmentationKeyPoints& key_points,
                               std::span<const PartSkeleton> skeletons, const JointPositions& joints) {
  CoarseMove move;
  if (is_bottom(type)) {
    const auto left = root_node(skeletons, GarmentPart::LEFT_LEG);
    const auto right = root_node(skeletons, GarmentPart::RIGHT_LEG);
    if (left && right) {
      move.rule = CoarseMoveRule::LEG_ROOTS_TO_HIPS;
      move.garment_anchor = 0.5 * (*left + *right);
      move.body_anchor = 0.5 * (joint(joints, Joint::LEFT_HIP) + joint(joints, Joint::RIGHT_HIP));
    } else {
      move.rule = CoarseMoveRule::WAISTBAND_TO_PELVIS;
      move.garment_anchor = key_points.source;
      move.body_anchor = 0.5 * (joint(joints, Joint::PELVIS) + joint(joints, Joint::SPINE1));
    }
  } else {
    const auto left = root_node(skeletons, GarmentPart::LEFT_SLEEVE);
    const auto right = root_node(skeletons, GarmentPart::RIGHT_SLEEVE);
    if (left && right) {
      move.rule = CoarseMoveRule::SLEEVE_ROOTS_TO_SHOULDERS;
      move.garment_anchor = 0.5 * (*left + *right);
      move.body_anchor = 0.5 * (joint(joints, Joint::LEFT_SHOULDER) + joint(joints, Joint::RIGHT_SHOULDER));
    } else {
      move.rule = CoarseMoveRule::COLLAR_TO_NECK;
      move.garment_anchor = key_points.source;
      move.body_anchor = joint(joints, Joint::NECK);
    }
  }
  move.translation = move.body_anchor - move.garment_anchor;
  return move;
}

Eigen::Vector3d contact_translation(std::span<const float> points, const ProximityIndex& body,
                                    const ContactMoveOptions& options) {
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  const std::size_t n = points.size() / 3;
  if (n == 0 || body.face_count() == 0) return total;
  std::vector<float> moved(points.begin(), points.begin() + static_cast<std::ptrdiff_t>(3 * n));
  ClosestHits hits;
  for (int round = 0; round < options.max_iterations; ++round) {
    body.closest_points(moved, INFINITY, hits);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    std::size_t inside = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double sd = hits.signed_distances[i];
      if (hits.triangles[i] < 0 || sd >= options.clearance) continue;
      const Eigen::Vector3d x(moved[3 * i], moved[3 * i + 1], moved[3 * i + 2]);
      const Eigen::Vector3d c(hits.points[3 * i], hits.points[3 * i + 1], hits.points[3 * i + 2]);
      Eigen::Vector3d normal = x - c;
      const double d = normal.norm();
      if (d < 1e-9) continue; // on the surface: no direction, and nothing to push with κ = 0
      normal /= sd < 0 ? -d : d;
      // n·(x + Δ − c) = κ  ⇔  n·Δ = κ − sd.
      A += normal * normal.transpose();
      b += normal * (options.clearance - sd);
      ++inside;
    }
    if (inside == 0) break;
    A += 1e-3 * A.trace() * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d step = A.ldlt().solve(b);
    total += step;
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        moved[3 * i + static_cast<std::size_t>(c)] =
            points[3 * i + static_cast<std::size_t>(c)] + static_cast<float>(total[c]);
    if (step.norm() < options.tolerance) break;
  }
  return total;
}

void translate_positions(std::span<float> positions, const Eigen::Vector3d& translation) {
  const Eigen::Vector3f t = translation.cast<float>();
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3)
    for (int c = 0; c < 3; ++c)
      positions[i + static_cast<std::size_t>(c)] += t[c];
}

} // namespace vfit
