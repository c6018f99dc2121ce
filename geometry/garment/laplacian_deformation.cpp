#include "laplacian_deformation.h"

#include "kernels/error.h"

namespace vfit {
namespace {

// [L; w·S] where S selects the constrained vertices.
SparseMatrix stacked_system(const SparseMatrix& L, std::span<const std::int32_t> constrained, double weight) {
  const Eigen::Index n = L.rows(), c = static_cast<Eigen::Index>(constrained.size());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(L.nonZeros() + c));
  for (Eigen::Index r = 0; r < L.outerSize(); ++r)
    for (SparseMatrix::InnerIterator it(L, r); it; ++it) t.emplace_back(it.row(), it.col(), it.value());
  for (Eigen::Index k = 0; k < c; ++k) t.emplace_back(n + k, constrained[static_cast<std::size_t>(k)], weight);
  SparseMatrix A(n + c, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

} // namespace

LaplacianDeformer::LaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> constrained, double weight, bool uniform)
    : m_laplacian(uniform ? uniform_laplacian(mesh.triangle_view(), mesh.vertex_count())
                          : cotangent_laplacian(mesh.position_view(), mesh.triangle_view())),
      m_constrained(constrained.begin(), constrained.end()), m_weight(weight),
      m_solver(stacked_system(m_laplacian, constrained, weight)) {
  for (std::int32_t v : constrained)
    if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertex_count())
      throw Error("laplacian deformation", 0, "constrained vertex " + std::to_string(v) + " out of range");
}

Eigen::MatrixXd LaplacianDeformer::laplacian_coordinates(std::span<const float> positions) const {
  const Eigen::Index n = m_laplacian.rows();
  Eigen::MatrixXd x(n, 3);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k) x(v, k) = positions[static_cast<std::size_t>(3 * v + k)];
  return m_laplacian * x;
}

std::vector<float> LaplacianDeformer::deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets) const {
  const Eigen::Index n = m_laplacian.rows(), c = static_cast<Eigen::Index>(m_constrained.size());
  Eigen::MatrixXd b(n + c, 3);
  b.topRows(n) = delta;
  b.bottomRows(c) = m_weight * targets;
  const Eigen::MatrixXd x = m_solver.solve(b);
  std::vector<float> out(static_cast<std::size_t>(3 * n));
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k) out[static_cast<std::size_t>(3 * v + k)] = static_cast<float>(x(v, k));
  return out;
}

} // namespace vfit
