#include "penetration.h"

#include <chrono>
#include <cmath>

#include "kernels/laplacian.h"
#include "kernels/least_squares.h"
#include "kernels/parallel.h"
#include "kernels/proximity.h"

namespace vfit {
namespace {

// Body proximity farther than this (m) cannot make a vertex "near": queries stop there.
constexpr float NEAR_SEARCH = 0.05f;

} // namespace

PenetrationStats measure_penetration(std::span<const float> garment_positions, const ProximityIndex& body,
                                     double clearance) {
  ClosestHits hits;
  body.closest_points(garment_positions, NEAR_SEARCH, hits);
  PenetrationStats s;
  double depth_sum = 0;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (hits.triangles[i] < 0) continue;
    const double d = hits.signed_distances[i];
    if (d < clearance) ++s.near_count;
    if (d < 0) {
      ++s.inside_count;
      depth_sum += -d;
      s.max_depth = std::max(s.max_depth, -d);
    }
  }
  if (s.inside_count) s.mean_depth = depth_sum / double(s.inside_count);
  return s;
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const PenetrationOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  PenetrationReport report;
  report.before = measure_penetration(garment.positions, body, o.clearance);
  report.after = report.before;
  if (report.before.near_count == 0) return report;

  const std::size_t nv = garment.vertex_count();
  const SparseMatrix L = uniform_laplacian(garment.triangle_view(), nv);
  const double ws = std::sqrt(o.smoothness);
  // A = [√λ L; I]: AᵀA = λ LᵀL + I is fixed, so one factorisation serves every round.
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(L.nonZeros()) + nv);
  for (Eigen::Index r = 0; r < L.outerSize(); ++r)
    for (SparseMatrix::InnerIterator it(L, r); it; ++it) t.emplace_back(it.row(), it.col(), ws * it.value());
  for (std::size_t v = 0; v < nv; ++v) t.emplace_back(static_cast<int>(nv + v), static_cast<int>(v), 1.0);
  SparseMatrix A(static_cast<Eigen::Index>(2 * nv), static_cast<Eigen::Index>(nv));
  A.setFromTriplets(t.begin(), t.end());
  const SparseLeastSquares solver(A);

  ClosestHits hits;
  Eigen::MatrixXd y(static_cast<Eigen::Index>(nv), 3), b(static_cast<Eigen::Index>(2 * nv), 3);
  for (int iter = 0; iter < o.max_iterations; ++iter) {
    body.closest_points(garment.positions, NEAR_SEARCH, hits);
    bool any = false;
    for (std::size_t v = 0; v < nv; ++v) {
      for (int k = 0; k < 3; ++k) y(static_cast<Eigen::Index>(v), k) = garment.positions[3 * v + k];
      Eigen::RowVector3d target = y.row(static_cast<Eigen::Index>(v));
      const double d = hits.triangles[v] >= 0 ? hits.signed_distances[v] : INFINITY;
      if (d < o.clearance) {
        any = true;
        const Eigen::RowVector3d h(hits.points[3 * v], hits.points[3 * v + 1], hits.points[3 * v + 2]);
        Eigen::RowVector3d dir = target - h;
        const double len = dir.norm();
        // Outward: from the closest point towards the vertex when outside, away from it when inside.
        if (len > 1e-9) dir *= (d < 0 ? -1.0 : 1.0) / len;
        if (len > 1e-9) target = h + o.clearance * dir;
      }
      b.row(static_cast<Eigen::Index>(nv + v)) = target;
    }
    if (!any) break;
    b.topRows(static_cast<Eigen::Index>(nv)) = ws * (L * y);
    const Eigen::MatrixXd x = solver.solve(b);
    for (std::size_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k) garment.positions[3 * v + k] = static_cast<float>(x(static_cast<Eigen::Index>(v), k));
    report.iterations = iter + 1;
    report.after = measure_penetration(garment.positions, body, o.clearance);
    if (report.after.inside_count == 0) break; // clearance is a target, not a requirement
  }
  report.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

} // namespace vfit
