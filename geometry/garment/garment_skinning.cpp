// SPDX-License-Identifier: Apache-2.0
#include "garment_skinning.h"

#include <algorithm>
#include <cmath>

#include "vfit/geometry/body/scan_skin_transfer.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

constexpr int LEFT_LEG_CHAIN = 3, RIGHT_LEG_CHAIN = 4;

Eigen::Vector3d point(std::span<const float> p, std::size_t v) { return {p[3 * v], p[3 * v + 1], p[3 * v + 2]}; }

} // namespace

SkinWeights garment_skin_weights(const Body& body, const Mesh& garment, GarmentType type,
                                 const GarmentSkinningOptions& options) {
  const std::size_t nv = garment.vertex_count();
  if (nv == 0) throw Error("garment skinning", 0, "the garment has no vertices");
  validate_skin_weights(body.weights, body.mesh.vertex_count(), "garment skinning: the body's weights");
  const SkinWeights transferred = transfer_skin_weights(body.mesh, body.weights, garment, options.margin);
  std::vector<double> dense(nv * JOINT_COUNT, 0.0);
  for (std::size_t v = 0; v < nv; ++v)
    for (std::size_t k = 0; k < 4; ++k)
      dense[v * JOINT_COUNT + std::size_t(transferred.joints[4 * v + k])] += transferred.weights[4 * v + k];

  if (type == GarmentType::SKIRT || type == GarmentType::DRESS) {
    const double hips = 0.5 * (body.joints(idx(Joint::LEFT_HIP), 1) + body.joints(idx(Joint::RIGHT_HIP), 1));
    for (std::size_t v = 0; v < nv; ++v) {
      if (garment.positions[3 * v + 1] >= hips) continue;
      double legs = 0;
      for (int j = 0; j < JOINT_COUNT; ++j) {
        const int chain = skin_chain_of_joint(j);
        if (chain != LEFT_LEG_CHAIN && chain != RIGHT_LEG_CHAIN) continue;
        legs += dense[v * JOINT_COUNT + std::size_t(j)];
        dense[v * JOINT_COUNT + std::size_t(j)] = 0;
      }
      dense[v * JOINT_COUNT + std::size_t(idx(Joint::LEFT_HIP))] += 0.5 * legs;
      dense[v * JOINT_COUNT + std::size_t(idx(Joint::RIGHT_HIP))] += 0.5 * legs;
    }
  }

  // Neighbours over the garment's edges, and its mean edge length.
  std::vector<std::vector<std::int32_t>> neighbours(nv);
  double length = 0;
  std::size_t edges = 0;
  for (std::size_t f = 0; f < garment.face_count(); ++f)
    for (std::size_t k = 0; k < 3; ++k) {
      const auto a = std::size_t(garment.triangles[3 * f + k]), b = std::size_t(garment.triangles[3 * f + (k + 1) % 3]);
      if (std::find(neighbours[a].begin(), neighbours[a].end(), std::int32_t(b)) != neighbours[a].end()) continue;
      neighbours[a].push_back(std::int32_t(b));
      neighbours[b].push_back(std::int32_t(a));
      length += (point(garment.positions, a) - point(garment.positions, b)).norm();
      ++edges;
    }
  if (edges > 0 && options.smoothing_radius > 0) {
    const double mean = length / double(edges);
    const int rounds = mean > 0 ? int(std::ceil(std::pow(options.smoothing_radius / mean, 2))) : 0;
    std::vector<double> next(dense.size());
    for (int round = 0; round < rounds; ++round) {
      for (std::size_t v = 0; v < nv; ++v) {
        double* out = &next[v * JOINT_COUNT];
        const double* own = &dense[v * JOINT_COUNT];
        if (neighbours[v].empty()) {
          std::copy(own, own + JOINT_COUNT, out);
          continue;
        }
        const double share = 0.5 / double(neighbours[v].size());
        for (int j = 0; j < JOINT_COUNT; ++j)
          out[j] = 0.5 * own[j];
        for (const std::int32_t n : neighbours[v]) {
          const double* theirs = &dense[std::size_t(n) * JOINT_COUNT];
          for (int j = 0; j < JOINT_COUNT; ++j)
            out[j] += share * theirs[j];
        }
      }
      dense.swap(next);
    }
  }
  return SkinWeights::from_dense(dense, JOINT_COUNT, idx(Joint::PELVIS));
}

} // namespace vfit
