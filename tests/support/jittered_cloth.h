// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A generic cloth state for the implicit solver's tests (kernels/cloth_implicit*): a jittered
/// n × n grid (side 1 m, numbered row by row) with random spring constants (k 100–500 N/m,
/// damping 0–0.05), positions jittered by up to 0.2 of a cell so that some springs are
/// stretched and some compressed, random velocities (±0.5 m/s), particles of `mass` kg, two
/// pinned corners (0 and n − 1) and a global damping of 0.5. The same seed gives the same cloth.

#include <cstddef>
#include <optional>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/cloth_gather.h"
#include "vfit/kernels/cloth_implicit.h"
#include "vfit/kernels/cloth_springs.h"

namespace vfit {

/// The state jittered_cloth() builds.
struct JitteredCloth {
  std::vector<float> x, v;   ///< #V × 3 positions (m) and velocities (m/s)
  SpringAdjacency adjacency; ///< the grid's springs as per-particle rows
  ClothParticles particles;  ///< inverse masses (0 for the two pinned corners), damping
};

/// See the file comment; n ≥ 2.
inline JitteredCloth jittered_cloth(int n, unsigned seed, float mass) {
  const Mesh m = make_grid(n, n, 1.0f, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.2f / float(n), 0.2f / float(n)), kd(100.0f, 500.0f), cd(0.0f, 0.05f),
      vel(-0.5f, 0.5f);
  ClothSprings s = build_cloth_springs(m.position_view(), m.triangle_view());
  for (std::size_t i = 0; i < s.size(); ++i) {
    s.stiffness[i] = kd(rng);
    s.damping[i] = cd(rng);
  }
  JitteredCloth c;
  c.adjacency = build_spring_adjacency(s, m.vertex_count());
  c.x = m.positions;
  for (float& p : c.x)
    p += jitter(rng); // some springs stretched, some compressed
  c.v.resize(c.x.size());
  for (float& q : c.v)
    q = vel(rng);
  c.particles.inverse_masses.assign(m.vertex_count(), 1.0f / mass);
  c.particles.inverse_masses[0] = c.particles.inverse_masses[std::size_t(n - 1)] = 0.0f;
  c.particles.global_damping = 0.5f;
  return c;
}

/// An assembled implicit system over its free rows, in double, built column by column from
/// implicit_system_multiply() of unit vectors: the oracle the CG solves are checked against.
struct DenseFreeSystem {
  std::vector<std::size_t> free_rows; ///< the free particles' 3 components each, ascending
  Eigen::MatrixXd A;                  ///< #free × #free
  Eigen::VectorXd b;                  ///< the right-hand side on the free rows
};

/// See DenseFreeSystem; `system` assembled over `adjacency`.
inline DenseFreeSystem dense_free_system(const ImplicitSystem& system, const SpringAdjacency& adjacency) {
  const std::size_t nv = adjacency.particle_count();
  DenseFreeSystem d;
  for (std::size_t i = 0; i < nv; ++i)
    if (system.free[i])
      for (std::size_t k = 0; k < 3; ++k)
        d.free_rows.push_back(3 * i + k);
  const auto n = static_cast<Eigen::Index>(d.free_rows.size());
  d.A.resize(n, n);
  d.b.resize(n);
  std::vector<float> unit(3 * nv, 0.0f), column;
  for (Eigen::Index col = 0; col < n; ++col) {
    unit[d.free_rows[std::size_t(col)]] = 1.0f;
    implicit_system_multiply(system, adjacency, unit, column);
    unit[d.free_rows[std::size_t(col)]] = 0.0f;
    for (Eigen::Index row = 0; row < n; ++row)
      d.A(row, col) = column[d.free_rows[std::size_t(row)]];
    d.b(col) = system.rhs[d.free_rows[std::size_t(col)]];
  }
  return d;
}

/// An assembled implicit system over its free rows, in double, built from its blocks rather
/// than from the product under test: A_ii = inertia_i·I + Σ_e S_e, A_ij = −S_e (from
/// ImplicitSystem::inertia and off_diagonal; no contact springs), b = rhs. Free particle i's
/// rows are 3·column_of[i] + 0..2 (column_of[i] = −1 when pinned).
struct SparseFreeSystem {
  std::vector<Eigen::Index> column_of; ///< #V: the free particle's index among the free ones, or −1
  Eigen::SparseMatrix<double> A;       ///< 3·#free × 3·#free
  Eigen::VectorXd b;                   ///< 3·#free
};

/// See SparseFreeSystem; `system` assembled over `adjacency`.
inline SparseFreeSystem sparse_free_system(const ImplicitSystem& system, const SpringAdjacency& adjacency) {
  const std::size_t nv = adjacency.particle_count();
  SparseFreeSystem d;
  d.column_of.assign(nv, -1);
  Eigen::Index n = 0;
  for (std::size_t i = 0; i < nv; ++i)
    if (system.free[i]) d.column_of[i] = n++;
  const std::size_t entries = adjacency.neighbors.size();
  const float* o = system.off_diagonal.data();
  std::vector<Eigen::Triplet<double>> triplets;
  d.b.resize(3 * n);
  for (std::size_t i = 0; i < nv; ++i) {
    const Eigen::Index r = d.column_of[i];
    if (r < 0) continue;
    Eigen::Matrix3d diagonal = double(system.inertia[i]) * Eigen::Matrix3d::Identity();
    for (std::int32_t e = adjacency.offsets[i]; e < adjacency.offsets[i + 1]; ++e) {
      const auto k = static_cast<std::size_t>(e);
      Eigen::Matrix3d se;
      se << o[k], o[entries + k], o[2 * entries + k], o[entries + k], o[3 * entries + k], o[4 * entries + k],
          o[2 * entries + k], o[4 * entries + k], o[5 * entries + k];
      diagonal += se;
      const Eigen::Index q = d.column_of[static_cast<std::size_t>(adjacency.neighbors[k])];
      if (q < 0) continue;
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c)
          triplets.emplace_back(3 * r + a, 3 * q + c, -se(a, c));
    }
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c)
        triplets.emplace_back(3 * r + a, 3 * r + c, diagonal(a, c));
      d.b(3 * r + a) = system.rhs[3 * i + std::size_t(a)];
    }
  }
  d.A.resize(3 * n, 3 * n);
  d.A.setFromTriplets(triplets.begin(), triplets.end());
  return d;
}

/// Contact constraints of a generic state: a random unit normal (seeded) on every third free
/// particle, with a velocity target (m/s) drawn uniformly in [−0.2, 0.2] per constraint, or
/// `target` on every one when given; zero normals elsewhere.
inline ImplicitConstraints random_constraints(const JitteredCloth& c, unsigned seed,
                                              std::optional<float> target = std::nullopt) {
  const std::size_t nv = c.adjacency.particle_count();
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  std::uniform_real_distribution<float> drawn(-0.2f, 0.2f);
  ImplicitConstraints k;
  k.normals.assign(3 * nv, 0.0f);
  k.targets.assign(nv, 0.0f);
  for (std::size_t i = 0; i < nv; i += 3) {
    if (c.particles.inverse_masses[i] == 0.0f) continue;
    Eigen::Vector3f n(gauss(rng), gauss(rng), gauss(rng));
    n.normalize();
    for (int a = 0; a < 3; ++a)
      k.normals[3 * i + std::size_t(a)] = n[a];
    k.targets[i] = target ? *target : drawn(rng);
  }
  return k;
}

} // namespace vfit
