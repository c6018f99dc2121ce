// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Mesh Laplacians as sparse matrices (#V × #V): the operators of Laplacian surface deformation
/// (seed 000 §5.4), mean-curvature-flow skeletons (§5.1) and the smoothness terms of penetration
/// removal (eq. 19–21; seed 004 §3.2.2).

#include <cstdint>
#include <span>

#include <Eigen/Sparse>

namespace vfit {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// Uniform (graph) Laplacian: (L x)_i = Σ_{j ∈ N(i)} (x_i − x_j), so rows sum to 0 and L is
/// symmetric positive semi-definite. triangles: #F × 3 indices in [0, vertex_count). An
/// isolated vertex has an all-zero row.
SparseMatrix uniform_laplacian(std::span<const std::int32_t> triangles, std::size_t vertex_count);

/// Cotangent Laplacian: (L x)_i = Σ_j w_ij (x_i − x_j), w_ij = ½ (cot α_ij + cot β_ij) over the
/// angles opposite edge ij (one angle on a boundary edge). Each cotangent is clamped to
/// [−10, 10] (near-degenerate triangles); degenerate triangles contribute nothing. Weights are
/// not clamped at zero, so linear functions stay in the kernel at interior vertices of flat
/// regions (linear precision); a weight is negative where two obtuse angles face one edge, and
/// then L is not positive semi-definite — the least-squares systems built on it (Lᵀ L) are.
/// positions: #V × 3 (m).
SparseMatrix cotangent_laplacian(std::span<const float> positions, std::span<const std::int32_t> triangles);

} // namespace vfit
