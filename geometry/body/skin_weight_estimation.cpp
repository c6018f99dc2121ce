// SPDX-License-Identifier: Apache-2.0
// estimate_skin_weights() (declared in joint_estimation.h): inverse-distance weights to the
// bones near a vertex, smoothed over the mesh, the 4 largest kept.

#include <algorithm>
#include <cmath>

#include "joint_estimation.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

// One-ring averaging passes (half self, half neighbours) spread a weight over about
// edge·√(passes / 2): enough passes to blur the transitions over SMOOTHING_LENGTH of the
// skeleton's height, within these bounds.
constexpr double SMOOTHING_LENGTH = 0.012;
constexpr int MIN_SMOOTHING = 4, MAX_SMOOTHING = 40;
constexpr double FALLOFF = 6;          // weight ∝ 1 / (d² + ε²)^(FALLOFF / 2)
constexpr double CUTOFF_RATIO = 2;     // bones this many times farther than the nearest get nothing
constexpr double CORE_RADIUS = 0.01;   // ε, as a fraction of the skeleton's height
constexpr double LEAF_EXTENSION = 0.8; // end joints' bones: this much of the parent bone again
constexpr std::size_t GRAIN = 512;

// A bone segment and the joint whose rotation moves the flesh around it.
struct Bone {
  int joint;
  Eigen::Vector3d a, b;
};

std::vector<Bone> bones_of(const JointPositions& joints) {
  auto at = [&](int j) -> Eigen::Vector3d { return joints.row(j).transpose(); };
  std::vector<Bone> bones;
  std::vector<int> child_count(JOINT_COUNT, 0);
  for (int j = 1; j < JOINT_COUNT; ++j) {
    bones.push_back({joint_parent(j), at(joint_parent(j)), at(j)});
    ++child_count[std::size_t(joint_parent(j))];
  }
  // End joints (head, feet, hands) carry a bone continuing their parent's.
  for (int j = 1; j < JOINT_COUNT; ++j)
    if (child_count[std::size_t(j)] == 0)
      bones.push_back({j, at(j), at(j) + LEAF_EXTENSION * (at(j) - at(joint_parent(j)))});
  return bones;
}

double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

} // namespace

SkinWeights estimate_skin_weights(const Mesh& body, const JointPositions& joints) {
  const std::size_t nv = body.vertex_count();
  if (nv == 0 || body.face_count() == 0) throw Error("body", 0, "cannot skin an empty mesh");
  const std::vector<Bone> bones = bones_of(joints);
  const double eps = CORE_RADIUS * (joints.col(1).maxCoeff() - joints.col(1).minCoeff());
  std::vector<double> w(nv * JOINT_COUNT, 0.0);
  parallel_for_range(nv, GRAIN, [&](std::size_t begin, std::size_t end) {
    std::vector<double> d(bones.size());
    for (std::size_t v = begin; v < end; ++v) {
      const Eigen::Vector3d p(body.positions[3 * v], body.positions[3 * v + 1], body.positions[3 * v + 2]);
      std::size_t nearest = 0;
      for (std::size_t k = 0; k < bones.size(); ++k) {
        d[k] = distance_to_segment(p, bones[k].a, bones[k].b);
        if (d[k] < d[nearest]) nearest = k;
      }
      // Bones more than CUTOFF_RATIO times farther than the nearest get nothing, so that a
      // hand near a thigh never takes the thigh's weight; the offset keeps the cut continuous.
      double* row = &w[v * JOINT_COUNT];
      const double dn = d[nearest] * d[nearest] + eps * eps, offset = std::pow(CUTOFF_RATIO, -FALLOFF);
      double sum = 0;
      for (std::size_t k = 0; k < bones.size(); ++k) {
        const double x = std::pow(dn / (d[k] * d[k] + eps * eps), FALLOFF / 2) - offset;
        if (x <= 0) continue;
        row[bones[k].joint] += x;
        sum += x;
      }
      for (int j = 0; j < JOINT_COUNT; ++j)
        row[j] /= sum;
    }
  });
  // One-ring neighbours (CSR) for smoothing.
  std::vector<std::size_t> start(nv + 1, 0);
  const auto& t = body.triangles;
  for (std::size_t f = 0; f < body.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      start[std::size_t(t[3 * f + k]) + 1] += 2;
  for (std::size_t v = 0; v < nv; ++v)
    start[v + 1] += start[v];
  std::vector<std::int32_t> nbr(start[nv]);
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < body.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::size_t v = std::size_t(t[3 * f + k]);
      nbr[fill[v]++] = t[3 * f + (k + 1) % 3];
      nbr[fill[v]++] = t[3 * f + (k + 2) % 3];
    }
  double edge_sum = 0;
  for (std::size_t v = 0; v < nv; ++v)
    for (std::size_t k = start[v]; k < start[v + 1]; ++k) {
      const float* a = &body.positions[3 * v];
      const float* b = &body.positions[3 * std::size_t(nbr[k])];
      edge_sum += std::sqrt(
          double((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])));
    }
  const double mean_edge = nbr.empty() ? 1.0 : edge_sum / double(nbr.size());
  const double reach =
      SMOOTHING_LENGTH * (joints.col(1).maxCoeff() - joints.col(1).minCoeff()) / std::max(mean_edge, 1e-9);
  const int passes = std::clamp(int(std::lround(2 * reach * reach)), MIN_SMOOTHING, MAX_SMOOTHING);
  std::vector<double> next(w.size());
  for (int iter = 0; iter < passes; ++iter) {
    parallel_for_range(nv, GRAIN, [&](std::size_t begin, std::size_t end) {
      for (std::size_t v = begin; v < end; ++v)
        for (int j = 0; j < JOINT_COUNT; ++j) {
          double s = 0;
          for (std::size_t k = start[v]; k < start[v + 1]; ++k)
            s += w[std::size_t(nbr[k]) * JOINT_COUNT + std::size_t(j)];
          const double own = w[v * JOINT_COUNT + std::size_t(j)];
          const std::size_t n = start[v + 1] - start[v];
          next[v * JOINT_COUNT + std::size_t(j)] = n == 0 ? own : 0.5 * own + 0.5 * s / double(n);
        }
    });
    w.swap(next);
  }
  return SkinWeights::from_dense(w, JOINT_COUNT, idx(Joint::PELVIS));
}

} // namespace vfit
