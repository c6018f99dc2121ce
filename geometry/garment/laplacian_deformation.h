#pragma once
/// \file
/// Laplacian surface deformation (seed 000 §5.4, after Sorkine et al. 2004): positions x that
/// keep given differential coordinates δ while constrained vertices reach their targets,
/// argmin ‖L x − δ‖² + w² Σ_c ‖x_c − t_c‖², solved per axis with one factorisation reused for
/// every new set of targets and δ.

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "geometry/mesh/mesh.h"
#include "kernels/least_squares.h"

namespace vfit {

class LaplacianDeformer {
public:
  /// mesh: the rest surface (its cotangent Laplacian is used; uniform when `uniform`).
  /// constrained: vertex indices held near their targets with weight `weight` (≥ 1 keeps
  /// them within about 1/weight² of the target's pull against the Laplacian term).
  /// ok() is false when the system is singular (a connected part has no constraint).
  LaplacianDeformer(const Mesh& mesh, std::span<const std::int32_t> constrained, double weight, bool uniform = false);

  bool ok() const { return m_solver.ok(); }

  /// δ of arbitrary positions (#V × 3, m): L · x. Pass the rigidly transformed mesh to get the
  /// rotated detail that deform() should preserve.
  Eigen::MatrixXd laplacian_coordinates(std::span<const float> positions) const;

  /// Solves for all vertices. delta: #V × 3; targets: #C × 3 (m), in `constrained` order.
  /// Returns #V × 3 positions as floats (flat).
  std::vector<float> deform(const Eigen::MatrixXd& delta, const Eigen::MatrixXd& targets) const;

private:
  SparseMatrix m_laplacian;
  std::vector<std::int32_t> m_constrained;
  double m_weight;
  SparseLeastSquares m_solver;
};

} // namespace vfit
