// SPDX-License-Identifier: Apache-2.0
#pragma once
// Test-only: a small synthetic SMPL-format model and SMPL written out with plain loops (seed 000
// §3), independent of geometry/body/smpl_model.cpp, as the oracle for its tests.

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "npz_test_writer.h"
#include "vfit/geometry/body/skeleton.h"
#include "vfit/geometry/body/smpl_model.h"

namespace vfit::test {

constexpr std::array<int, 24> SMPL_PARENTS = {-1, 0, 0, 0,  1,  2,  3,  4,  5,  6,  7,  8,
                                              9,  9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21};
constexpr std::size_t NB = 4;   // shape coefficients
constexpr std::size_t NP = 207; // pose features

/// Boxes around a few joints; joints regressed from random vertices; weights on 4 joints, except
/// the pelvis box whose vertices have 6 influences (so that the dense weights matter).
struct SyntheticSmpl {
  std::size_t nv = 0;
  std::vector<double> v_template, shapedirs, posedirs, j_regressor, weights, kintree, faces;

  explicit SyntheticSmpl(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    const std::array<int, 6> box_joints = {0, 4, 5, 15, 18, 19};
    const std::array<std::array<double, 3>, 6> centres = {
        {{0, 0.9, 0}, {0.1, 0.5, 0}, {-0.1, 0.5, 0}, {0, 1.6, 0}, {0.5, 1.4, 0}, {-0.5, 1.4, 0}}};
    const int cube[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                             {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    nv = 8 * box_joints.size();
    weights.assign(nv * 24, 0.0);
    for (std::size_t b = 0; b < box_joints.size(); ++b) {
      for (int c = 0; c < 8; ++c) {
        for (int k = 0; k < 3; ++k)
          v_template.push_back(double(float(centres[b][k] + ((c >> k) & 1 ? 0.08 : -0.08) + 0.01 * u(rng))));
        double* w = &weights[(8 * b + c) * 24];
        const int extra = b == 0 ? 5 : 3;
        w[box_joints[b]] += 1.0;
        for (int e = 0; e < extra; ++e)
          w[(box_joints[b] + 1 + 4 * e + (rng() % 3)) % 24] += 0.2 + 0.3 * std::abs(u(rng));
        double sum = 0;
        for (int j = 0; j < 24; ++j)
          sum += w[j];
        for (int j = 0; j < 24; ++j)
          w[j] /= sum;
      }
      for (const auto& t : cube)
        for (int k = 0; k < 3; ++k)
          faces.push_back(double(8 * b + t[k]));
    }
    for (std::size_t i = 0; i < nv * 3 * NB; ++i)
      shapedirs.push_back(0.02 * u(rng));
    for (std::size_t i = 0; i < nv * 3 * NP; ++i)
      posedirs.push_back(0.01 * u(rng));
    j_regressor.assign(24 * nv, 0.0);
    for (int j = 0; j < 24; ++j) {
      for (int s = 0; s < 3; ++s)
        j_regressor[j * nv + rng() % nv] += 1.0 / 3.0;
    }
    for (int j = 0; j < 24; ++j)
      kintree.push_back(SMPL_PARENTS[j]);
    for (int j = 0; j < 24; ++j)
      kintree.push_back(j);
  }

  NpyList arrays() const {
    return {{"v_template", NpyData{"<f4", {nv, 3}, v_template}}, {"shapedirs", NpyData{"<f8", {nv, 3, NB}, shapedirs}},
            {"posedirs", NpyData{"<f8", {nv, 3, NP}, posedirs}}, {"J_regressor", NpyData{"<f8", {24, nv}, j_regressor}},
            {"weights", NpyData{"<f8", {nv, 24}, weights}},      {"kintree_table", NpyData{"<i8", {2, 24}, kintree}},
            {"f", NpyData{"<u4", {faces.size() / 3, 3}, faces}}};
  }
};

using Mat3 = std::array<std::array<double, 3>, 3>;

inline Mat3 rodrigues(const double r[3]) {
  const double angle = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  Mat3 m{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  if (angle == 0) return m;
  const double k[3] = {r[0] / angle, r[1] / angle, r[2] / angle};
  const double kx[3][3] = {{0, -k[2], k[1]}, {k[2], 0, -k[0]}, {-k[1], k[0], 0}};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double kk = 0;
      for (int c = 0; c < 3; ++c)
        kk += kx[a][c] * kx[c][b];
      m[a][b] += std::sin(angle) * kx[a][b] + (1 - std::cos(angle)) * kk;
    }
  return m;
}

/// SMPL written out with loops, straight from the paper. Returns #V × 3 posed vertices and
/// fills `joints_out` (24 × 3 posed joints).
inline std::vector<double> reference_smpl(const SyntheticSmpl& m, const std::vector<double>& betas, const Pose& pose,
                                          std::vector<double>* joints_out = nullptr) {
  const std::size_t nv = m.nv;
  std::vector<double> vs(m.v_template);
  for (std::size_t i = 0; i < 3 * nv; ++i)
    for (std::size_t b = 0; b < betas.size(); ++b)
      vs[i] += m.shapedirs[i * NB + b] * betas[b];
  double joints[24][3] = {};
  for (int j = 0; j < 24; ++j)
    for (std::size_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k)
        joints[j][k] += m.j_regressor[j * nv + v] * vs[3 * v + k];
  std::array<Mat3, 24> rot;
  for (int j = 0; j < 24; ++j) {
    const double r[3] = {pose.axis_angle(j, 0), pose.axis_angle(j, 1), pose.axis_angle(j, 2)};
    rot[j] = rodrigues(r);
  }
  std::vector<double> vp(vs);
  for (std::size_t i = 0; i < 3 * nv; ++i)
    for (int j = 1; j < 24; ++j)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          vp[i] += m.posedirs[i * NP + 9 * (j - 1) + 3 * a + b] * (rot[j][a][b] - (a == b));
  double g[24][3][4]; // world transforms [R | t]
  for (int j = 0; j < 24; ++j) {
    const int p = SMPL_PARENTS[j];
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        g[j][a][b] = 0;
        for (int c = 0; c < 3; ++c)
          g[j][a][b] += (p < 0 ? (a == c) : g[p][a][c]) * rot[j][c][b];
      }
      double t = p < 0 ? joints[j][a] : g[p][a][3];
      if (p >= 0)
        for (int c = 0; c < 3; ++c)
          t += g[p][a][c] * (joints[j][c] - joints[p][c]);
      g[j][a][3] = t;
    }
  }
  if (joints_out) {
    joints_out->clear();
    for (int j = 0; j < 24; ++j)
      for (int a = 0; a < 3; ++a)
        joints_out->push_back(g[j][a][3] + pose.translation(a));
  }
  std::vector<double> out(3 * nv, 0.0);
  for (std::size_t v = 0; v < nv; ++v)
    for (int j = 0; j < 24; ++j) {
      const double w = m.weights[v * 24 + j];
      for (int a = 0; a < 3; ++a) {
        double x = g[j][a][3];
        for (int c = 0; c < 3; ++c)
          x += g[j][a][c] * (vp[3 * v + c] - joints[j][c]);
        out[3 * v + a] += w * x;
      }
    }
  for (std::size_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      out[3 * v + a] += pose.translation(a);
  return out;
}

inline Pose random_pose(unsigned seed, double scale = 0.6) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-scale, scale);
  Pose pose;
  for (int j = 0; j < 24; ++j)
    pose.axis_angle.row(j) << u(rng), u(rng), u(rng);
  pose.translation << u(rng), u(rng), u(rng);
  return pose;
}

inline double max_difference(const VertexPositions& got, const std::vector<double>& expected) {
  double worst = 0;
  for (Eigen::Index v = 0; v < got.rows(); ++v)
    for (int k = 0; k < 3; ++k)
      worst = std::max(worst, std::abs(got(v, k) - expected[3 * v + k]));
  return worst;
}

} // namespace vfit::test
