// SPDX-License-Identifier: Apache-2.0
#include "region_least_squares.h"

#include <algorithm>
#include <array>
#include <type_traits>

#include "error.h"
#include "parallel.h"

namespace vfit {
namespace {

constexpr std::size_t CG_GRAIN = 4096; // rows per task of the CG's loops

// y = A·v for a row-major CSR A and n × 3 row-major v, y (rows of A × 3), rows in parallel.
template <class Matrix> void multiply(const Matrix& A, const std::vector<double>& v, std::vector<double>& y) {
  const auto* outer = A.outerIndexPtr();
  const auto* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  parallel_for_range(std::size_t(A.rows()), CG_GRAIN, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      double s0 = 0, s1 = 0, s2 = 0;
      for (auto k = outer[i]; k < outer[i + 1]; ++k) {
        const double* vj = v.data() + 3 * std::size_t(inner[k]);
        s0 += value[k] * vj[0];
        s1 += value[k] * vj[1];
        s2 += value[k] * vj[2];
      }
      y[3 * i] = s0;
      y[3 * i + 1] = s1;
      y[3 * i + 2] = s2;
    }
  });
}

} // namespace

bool SolveRegion::covers(std::span<const char> flagged) const {
  for (std::size_t v = 0; v < flagged.size(); ++v)
    if (flagged[v] && column[v] < 0) return false;
  return true;
}

std::vector<int> rings_around(const SparseMatrix& L, std::vector<int> ring, int rings) {
  std::vector<std::size_t> front;
  for (std::size_t v = 0; v < ring.size(); ++v)
    if (ring[v] == 0) front.push_back(v);
  for (int k = 1; k <= rings && !front.empty(); ++k) {
    std::vector<std::size_t> next;
    for (std::size_t v : front)
      for (SparseMatrix::InnerIterator it(L, Eigen::Index(v)); it; ++it)
        if (ring[std::size_t(it.col())] < 0) {
          ring[std::size_t(it.col())] = k;
          next.push_back(std::size_t(it.col()));
        }
    front.swap(next);
  }
  return ring;
}

SolveRegion make_solve_region(const SparseMatrix& L, const std::vector<char>& seeds, int rings) {
  std::vector<int> ring(seeds.size(), -1);
  for (std::size_t v = 0; v < seeds.size(); ++v)
    if (seeds[v]) ring[v] = 0;
  ring = rings_around(L, std::move(ring), rings + 1);
  SolveRegion r;
  r.column.assign(seeds.size(), -1);
  r.moves.assign(seeds.size(), 0);
  for (std::size_t v = 0; v < seeds.size(); ++v) {
    if (ring[v] < 0) continue;
    r.rows.push_back(v);
    if (ring[v] <= rings) {
      r.moves[v] = 1;
      r.column[v] = std::int32_t(r.vertices.size());
      r.vertices.push_back(v);
    }
  }
  return r;
}

RegionSystem::RegionSystem(const SparseMatrix& L, const SolveRegion& region, double c, double w, bool cholesky,
                           double cg_tolerance)
    : m_c(c), m_w(w), m_cg_tolerance(cg_tolerance) {
  const auto n = static_cast<Eigen::Index>(region.vertices.size());
  const auto m = static_cast<Eigen::Index>(region.rows.size());
  // L_R written straight into compressed row storage: a region row keeps L's entries in the
  // region's columns, already in column order (unknowns are numbered in vertex order).
  const auto* outer = L.outerIndexPtr();
  const auto* inner = L.innerIndexPtr();
  const double* value = L.valuePtr();
  Eigen::Index nonzeros = 0;
  for (const std::size_t v : region.rows)
    for (auto k = outer[v]; k < outer[v + 1]; ++k)
      nonzeros += region.column[std::size_t(inner[k])] >= 0;
  m_L.resize(m, n);
  m_L.resizeNonZeros(nonzeros);
  auto* out_outer = m_L.outerIndexPtr();
  auto* out_inner = m_L.innerIndexPtr();
  double* out_value = m_L.valuePtr();
  Eigen::Index written = 0;
  out_outer[0] = 0;
  for (std::size_t r = 0; r < region.rows.size(); ++r) {
    const std::size_t v = region.rows[r];
    for (auto k = outer[v]; k < outer[v + 1]; ++k)
      if (const std::int32_t col = region.column[std::size_t(inner[k])]; col >= 0) {
        out_inner[written] = col;
        out_value[written++] = value[k];
      }
    out_outer[r + 1] = static_cast<std::remove_pointer_t<decltype(out_outer)>>(written);
  }
  m_Lt = m_L.transpose();
  m_inverse_diagonal = Eigen::VectorXd::Constant(n, c);
  for (Eigen::Index r = 0; r < m; ++r)
    for (SparseMatrix::InnerIterator it(m_L, r); it; ++it)
      m_inverse_diagonal[it.col()] += w * it.value() * it.value();
  m_inverse_diagonal = m_inverse_diagonal.cwiseInverse();
  if (cholesky) {
    Eigen::SparseMatrix<double> M = (m_w * (m_Lt * m_L)).eval();
    for (Eigen::Index v = 0; v < n; ++v)
      M.coeffRef(v, v) += m_c;
    m_cholesky.emplace(M);
    if (m_cholesky->info() != Eigen::Success)
      throw Error("remove_penetration", 0, "the region's system is not positive definite");
  }
}

Eigen::MatrixXd RegionSystem::solve(const Eigen::MatrixXd& rhs, int& iterations) const {
  iterations = 0;
  if (m_cholesky) return solve_factored(rhs);
  const auto n = static_cast<std::size_t>(rhs.rows());
  // Vectors are n × 3, row-major (x, y, z of one vertex together).
  std::vector<double> x(3 * n, 0.0), r(3 * n), z(3 * n), d(3 * n), q(3 * n), t(3 * std::size_t(m_L.rows()));
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      r[3 * i + std::size_t(c)] = rhs(Eigen::Index(i), c);
  // Per-chunk partial dot products (CG_GRAIN rows a chunk), summed in chunk order: the same
  // bits for any thread count. Each pass over the vectors does all the work of one CG step
  // that reads those vectors, and the dot products it needs, in one sweep.
  const std::size_t chunks = (n + CG_GRAIN - 1) / CG_GRAIN;
  std::vector<std::array<double, 6>> partial(chunks);
  auto sweep = [&](const auto& body) {
    parallel_for_range(chunks, 1, [&](std::size_t cb, std::size_t ce) {
      for (std::size_t ch = cb; ch < ce; ++ch) {
        std::array<double, 6> s{};
        body(3 * ch * CG_GRAIN, 3 * std::min(n, (ch + 1) * CG_GRAIN), s);
        partial[ch] = s;
      }
    });
    std::array<double, 6> total{};
    for (const auto& s : partial)
      for (std::size_t k = 0; k < 6; ++k)
        total[k] += s[k];
    return total;
  };
  // z = M⁻¹r (Jacobi), and r·z, r·r per column.
  auto precondition = [&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
    for (std::size_t k = b; k < e; ++k) {
      z[k] = m_inverse_diagonal[Eigen::Index(k / 3)] * r[k];
      s[k % 3] += r[k] * z[k];
      s[3 + k % 3] += r[k] * r[k];
    }
  };
  std::array<double, 6> sums = sweep(precondition);
  d = z;
  std::array<double, 3> rz{sums[0], sums[1], sums[2]}, stop{sums[3], sums[4], sums[5]};
  for (double& s : stop)
    s *= m_cg_tolerance * m_cg_tolerance;
  for (; iterations < 200; ++iterations) {
    if (sums[3] <= stop[0] && sums[4] <= stop[1] && sums[5] <= stop[2]) break;
    multiply(m_L, d, t);
    multiply(m_Lt, t, q);
    // q = c·d + w·L_Rᵀ(L_R d), and d·q per column.
    const std::array<double, 6> dq = sweep([&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
      for (std::size_t k = b; k < e; ++k) {
        q[k] = m_c * d[k] + m_w * q[k];
        s[k % 3] += d[k] * q[k];
      }
    });
    std::array<double, 3> alpha{};
    for (std::size_t c = 0; c < 3; ++c)
      alpha[c] = dq[c] > 0 ? rz[c] / dq[c] : 0.0; // 0: converged (d = 0)
    sums = sweep([&](std::size_t b, std::size_t e, std::array<double, 6>& s) {
      for (std::size_t k = b; k < e; ++k) {
        x[k] += alpha[k % 3] * d[k];
        r[k] -= alpha[k % 3] * q[k];
      }
      precondition(b, e, s);
    });
    std::array<double, 3> beta{};
    for (std::size_t c = 0; c < 3; ++c) {
      beta[c] = rz[c] > 0 ? sums[c] / rz[c] : 0.0;
      rz[c] = sums[c];
    }
    parallel_for_range(n, CG_GRAIN, [&](std::size_t b, std::size_t e) {
      for (std::size_t k = 3 * b; k < 3 * e; ++k)
        d[k] = z[k] + beta[k % 3] * d[k];
    });
  }
  Eigen::MatrixXd out(Eigen::Index(n), 3);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out(Eigen::Index(i), c) = x[3 * i + std::size_t(c)];
  return out;
}

// The factorisation's solve, P M Pᵀ = L D Lᵀ (L unit lower, stored below its diagonal by
// columns), with the three columns of rhs carried together through one sweep of L per
// triangle, where Eigen's solve() sweeps L once per column. Same operations per column in the
// same order (1/d multiplied, as Eigen does), so the same bits as its solve.
Eigen::MatrixXd RegionSystem::solve_factored(const Eigen::MatrixXd& rhs) const {
  const auto& factor = m_cholesky->matrixL().nestedExpression();
  const auto* outer = factor.outerIndexPtr();
  const auto* inner = factor.innerIndexPtr();
  const double* value = factor.valuePtr();
  const auto& diagonal = m_cholesky->vectorD();
  const auto& to = m_cholesky->permutationP().indices(); // row i of rhs is row to[i] of P·rhs
  const auto n = static_cast<std::size_t>(rhs.rows());
  std::vector<double> y(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      y[3 * std::size_t(to[Eigen::Index(i)]) + std::size_t(c)] = rhs(Eigen::Index(i), c);
  for (std::size_t j = 0; j < n; ++j) { // L y = P·rhs
    const double y0 = y[3 * j], y1 = y[3 * j + 1], y2 = y[3 * j + 2];
    for (auto k = outer[j]; k < outer[j + 1]; ++k) {
      double* yi = y.data() + 3 * std::size_t(inner[k]);
      yi[0] -= value[k] * y0;
      yi[1] -= value[k] * y1;
      yi[2] -= value[k] * y2;
    }
  }
  for (std::size_t j = 0; j < n; ++j) { // times 1/d, as Eigen does
    const double inverse = 1.0 / diagonal[Eigen::Index(j)];
    for (std::size_t c = 0; c < 3; ++c)
      y[3 * j + c] *= inverse;
  }
  for (std::size_t j = n; j-- > 0;) { // Lᵀ x = D⁻¹ y
    double s0 = y[3 * j], s1 = y[3 * j + 1], s2 = y[3 * j + 2];
    for (auto k = outer[j]; k < outer[j + 1]; ++k) {
      const double* xi = y.data() + 3 * std::size_t(inner[k]);
      s0 -= value[k] * xi[0];
      s1 -= value[k] * xi[1];
      s2 -= value[k] * xi[2];
    }
    y[3 * j] = s0;
    y[3 * j + 1] = s1;
    y[3 * j + 2] = s2;
  }
  Eigen::MatrixXd out(Eigen::Index(n), 3);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out(Eigen::Index(i), c) = y[3 * std::size_t(to[Eigen::Index(i)]) + std::size_t(c)];
  return out;
}

} // namespace vfit
