// SPDX-License-Identifier: Apache-2.0
#include "coarse_move.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Cholesky>

#include "vfit/kernels/proximity.h"

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

namespace {

// Re-weighting rounds of the asymmetric least squares per closest-point query; the weights of
// an expectile fit settle within a few (each round is a 4 × 4 solve over the points).
constexpr int ENVELOPE_REWEIGHTS = 20;

// Tikhonov weight on Δ relative to Σw_i: directions no point constrains (along a straight
// trunk) stay.
constexpr double TIKHONOV = 1e-3;

// One closest-point query's linearisation: s_i + n_iᵀΔ is the signed distance after moving by Δ.
struct Linearised {
  std::vector<double> s;
  std::vector<Eigen::Vector3d> n;
};

// `warm`: `hits` holds the answers for the points before their last small move, so each query
// searches only as far as its previous closest point (same answers, less traversal).
Linearised linearise(std::span<const float> moved, const ProximityIndex& body, bool warm, ClosestHits& hits) {
  if (warm)
    body.requery_closest_points(moved, INFINITY, hits);
  else
    body.closest_points(moved, INFINITY, hits);
  Linearised out;
  const std::size_t n = moved.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    if (hits.triangles[i] < 0) continue;
    const Eigen::Vector3d x(moved[3 * i], moved[3 * i + 1], moved[3 * i + 2]);
    const Eigen::Vector3d c(hits.points[3 * i], hits.points[3 * i + 1], hits.points[3 * i + 2]);
    Eigen::Vector3d normal = x - c;
    const double d = normal.norm();
    if (d < 1e-9) continue; // on the surface: no direction
    const double sd = hits.signed_distances[i];
    out.s.push_back(sd);
    out.n.push_back(normal / (sd < 0 ? -d : d));
  }
  return out;
}

// min_{Δ, m} Σ w_i (s_i + n_iᵀΔ − m)² + TIKHONOV·Σw_i·|Δ|² for one linearisation, re-weighted
// until the weights settle; returns Δ.
Eigen::Vector3d fit_envelope(const Linearised& lin, double tau) {
  using Vec4 = Eigen::Matrix<double, 4, 1>;
  Vec4 x = Vec4::Zero();
  std::vector<double> w(lin.s.size(), 0.5);
  auto row = [&](std::size_t i) {
    Vec4 a;
    a << lin.n[i], -1.0; // residual = s_i + aᵀx
    return a;
  };
  for (int round = 0; round < ENVELOPE_REWEIGHTS; ++round) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
    Vec4 b = Vec4::Zero();
    double weight = 0; // Σ w_i, the trace of Σ w_i n_i n_iᵀ (unit n_i)
    for (std::size_t i = 0; i < lin.s.size(); ++i) {
      const Vec4 a = row(i);
      A += w[i] * a * a.transpose();
      b -= w[i] * lin.s[i] * a;
      weight += w[i];
    }
    A.topLeftCorner<3, 3>() += TIKHONOV * weight * Eigen::Matrix3d::Identity();
    x = A.ldlt().solve(b);
    bool settled = true;
    for (std::size_t i = 0; i < lin.s.size(); ++i) {
      const double wi = lin.s[i] + row(i).dot(x) > 0 ? tau : 1 - tau;
      settled = settled && wi == w[i];
      w[i] = wi;
    }
    if (settled && round > 0) break;
  }
  return x.head<3>();
}

} // namespace

Eigen::Vector3d contact_translation(std::span<const float> points, const ProximityIndex& body,
                                    const ContactMoveOptions& options) {
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  const std::size_t n = points.size() / 3;
  if (n == 0 || body.face_count() == 0) return total;
  std::vector<float> moved(points.begin(), points.begin() + static_cast<std::ptrdiff_t>(3 * n));
  ClosestHits hits;
  for (int round = 0; round < options.max_iterations; ++round) {
    const Linearised lin = linearise(moved, body, round > 0, hits);
    if (lin.s.empty()) break;
    // A garment touching the body nowhere where its key joints put it (loose all round, like
    // the catalogue's eased trousers) has no contact to level: it stays.
    if (round == 0 && std::none_of(lin.s.begin(), lin.s.end(), [](double s) { return s < 0; })) break;
    const Eigen::Vector3d step = fit_envelope(lin, options.envelope_weight);
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
