// SPDX-License-Identifier: Apache-2.0
#include "scan_unpose.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "scan_skin_transfer.h"
#include "vfit/kernels/error.h"

namespace vfit::scan_detail {
namespace {

using Vec3 = Eigen::Vector3d;

// Mends `unposed` (a copy of `posed` with moved vertices) where the move tore the surface: a
// vertex most of whose edges came out longer than TEAR_STRETCH times their posed length plus
// TEAR_SLACK is moved as its mended neighbours moved (their mean displacement), outward from the
// intact surface. Unposing is nearly rigid per part where the weights are right; a few vertices
// with another part's weights (a fingertip of a hand folded on the belly) fly off and span webs
// from the hand to the belly that hide where the arm leaves the torso from the joint estimator.
constexpr double TEAR_STRETCH = 2.0, TEAR_SLACK = 0.01;
void mend_torn_vertices(Mesh& unposed, const Mesh& posed) {
  const std::size_t n = unposed.vertex_count();
  auto length = [](const Mesh& m, std::int32_t a, std::int32_t b) {
    return (Eigen::Vector3f::Map(&m.positions[3 * static_cast<std::size_t>(a)]) -
            Eigen::Vector3f::Map(&m.positions[3 * static_cast<std::size_t>(b)]))
        .norm();
  };
  std::vector<int> edges(n, 0), torn(n, 0);
  std::vector<std::vector<std::int32_t>> neighbours(n);
  for (std::size_t f = 0; f < unposed.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = unposed.triangles[3 * f + k], b = unposed.triangles[3 * f + (k + 1) % 3];
      const bool t = length(unposed, a, b) > TEAR_STRETCH * length(posed, a, b) + TEAR_SLACK;
      for (std::int32_t v : {a, b}) {
        ++edges[static_cast<std::size_t>(v)];
        torn[static_cast<std::size_t>(v)] += t;
      }
      neighbours[static_cast<std::size_t>(a)].push_back(b);
      neighbours[static_cast<std::size_t>(b)].push_back(a);
    }
  std::vector<bool> settled(n);
  std::vector<std::size_t> front;
  for (std::size_t v = 0; v < n; ++v)
    settled[v] = 2 * torn[v] <= edges[v];
  // Rings of torn vertices, each from the settled ones around it.
  for (bool changed = true; changed;) {
    changed = false;
    front.clear();
    for (std::size_t v = 0; v < n; ++v)
      if (!settled[v])
        for (std::int32_t w : neighbours[v])
          if (settled[static_cast<std::size_t>(w)]) {
            front.push_back(v);
            break;
          }
    for (std::size_t v : front) {
      Eigen::Vector3f shift = Eigen::Vector3f::Zero();
      int count = 0;
      for (std::int32_t w : neighbours[v])
        if (settled[static_cast<std::size_t>(w)]) {
          const auto u = 3 * static_cast<std::size_t>(w);
          shift += Eigen::Vector3f::Map(&unposed.positions[u]) - Eigen::Vector3f::Map(&posed.positions[u]);
          ++count;
        }
      Eigen::Vector3f::Map(&unposed.positions[3 * v]) =
          Eigen::Vector3f::Map(&posed.positions[3 * v]) + shift / static_cast<float>(count);
    }
    for (std::size_t v : front)
      settled[v] = changed = true;
  }
}

} // namespace

Mesh unpose_scan(const Mesh& scan, const SkinWeights& w, const std::array<Eigen::Isometry3d, JOINT_COUNT>& A) {
  Mesh unposed = scan;
  for (std::size_t v = 0; v < scan.vertex_count(); ++v) {
    Eigen::Matrix<double, 3, 4> M = Eigen::Matrix<double, 3, 4>::Zero();
    for (int k = 0; k < 4; ++k)
      M += w.weights[4 * v + k] * A[static_cast<std::size_t>(w.joints[4 * v + k])].matrix().topRows<3>();
    const Vec3 p = M.leftCols<3>().inverse() *
                   (Vec3(scan.positions[3 * v], scan.positions[3 * v + 1], scan.positions[3 * v + 2]) - M.col(3));
    for (int a = 0; a < 3; ++a)
      unposed.positions[3 * v + a] = static_cast<float>(p[a]);
  }
  mend_torn_vertices(unposed, scan);
  return unposed;
}

std::vector<int> limb_roots() {
  std::vector<int> out;
  for (int j = 1; j < JOINT_COUNT; ++j)
    if (skin_chain_of_joint(j) != skin_chain_of_joint(joint_parent(j))) out.push_back(j);
  return out;
}

void move_limb_pivot(std::array<Eigen::Isometry3d, JOINT_COUNT>& A, int root, const Eigen::Vector3d& pivot) {
  if (root <= 0 || root >= JOINT_COUNT || skin_chain_of_joint(root) == skin_chain_of_joint(joint_parent(root)))
    throw Error("limb pivot", 0, "joint " + std::to_string(root) + " does not start a limb (a shoulder or a hip)");
  const Vec3 d = A[static_cast<std::size_t>(joint_parent(root))] * pivot - A[static_cast<std::size_t>(root)] * pivot;
  const int chain = skin_chain_of_joint(root);
  for (int k = 0; k < JOINT_COUNT; ++k)
    if (skin_chain_of_joint(k) == chain) A[static_cast<std::size_t>(k)].pretranslate(d);
}

double seam_stretch(const Mesh& posed, const SkinWeights& w, const std::array<Eigen::Isometry3d, JOINT_COUNT>& A,
                    int chain) {
  const std::size_t n = posed.vertex_count();
  std::vector<char> seam(n, 0);
  for (std::size_t v = 0; v < n; ++v) {
    bool on = false, off = false;
    for (int k = 0; k < 4; ++k)
      if (w.weights[4 * v + k] > 0) (skin_chain_of_joint(w.joints[4 * v + k]) == chain ? on : off) = true;
    seam[v] = on && off;
  }
  std::vector<Vec3> unposed(n);
  std::vector<char> done(n, 0);
  auto at = [&](std::size_t v) -> const Vec3& { // v unposed as unpose_scan() does
    if (!done[v]) {
      Eigen::Matrix<double, 3, 4> M = Eigen::Matrix<double, 3, 4>::Zero();
      for (int k = 0; k < 4; ++k)
        M += w.weights[4 * v + k] * A[static_cast<std::size_t>(w.joints[4 * v + k])].matrix().topRows<3>();
      unposed[v] = M.leftCols<3>().inverse() *
                   (Vec3(posed.positions[3 * v], posed.positions[3 * v + 1], posed.positions[3 * v + 2]) - M.col(3));
      done[v] = 1;
    }
    return unposed[v];
  };
  auto point = [&](std::size_t v) {
    return Vec3(posed.positions[3 * v], posed.positions[3 * v + 1], posed.positions[3 * v + 2]);
  };
  double sum = 0;
  for (std::size_t t = 0; t < posed.triangles.size(); ++t) {
    const auto a = static_cast<std::size_t>(posed.triangles[t]);
    const auto b = static_cast<std::size_t>(posed.triangles[t % 3 == 2 ? t - 2 : t + 1]);
    if (seam[a] || seam[b]) sum += std::abs((at(a) - at(b)).norm() - (point(a) - point(b)).norm());
  }
  return sum;
}

} // namespace vfit::scan_detail
