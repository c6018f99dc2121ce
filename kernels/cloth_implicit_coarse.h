// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to kernels/cloth_implicit*.cpp: the coarse level of the implicit solve's two-level
// preconditioner (ImplicitPreconditioner::TWO_LEVEL, cloth_implicit.h). Not a public header.
//
// The coarse space is piecewise-constant translations over aggregates of particles (greedy
// graph aggregation of the spring adjacency: a particle and its spring neighbours, repeated on
// the aggregates' graph for larger ones; see implicit_coarse_aggregates()): the prolongation P
// maps the coarse vector y (3 per aggregate) to (P·y)_i = S_i·y_a(i), S_i the
// solve's filter (0 pinned, I − n·nᵀ on a contact, I otherwise). The coarse matrix is the
// Galerkin product Ac = Pᵀ·A·P (3×3 blocks, assembled per solve in double), factored by a
// sparse Cholesky (CHOLMOD's supernodal LLᵀ through Eigen; the pattern is analysed once per
// adjacency). The preconditioner is additive: M⁻¹ = S·D⁻¹·S + P·Ac⁻¹·Pᵀ, D the block
// diagonal, symmetric positive definite on the free directions as a sum of two such terms.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include "cloth_implicit_system.h"

namespace vfit {

struct ImplicitCoarseSpace {
  using Scalar = double;
  // What the structure was built for: rebuilt when the adjacency's arrays moved or changed
  // size, its offsets differ, or another aggregate size is asked for (a workspace serves one
  // adjacency at a time, as its other scratch does).
  std::vector<std::int32_t> offsets; // copy of the adjacency's CSR offsets
  const std::int32_t* offsets_data = nullptr;
  const std::int32_t* neighbors_data = nullptr;
  std::size_t entries = 0;
  std::size_t target = 0; // the aggregate size asked for

  std::size_t aggregates = 0;
  std::vector<std::int32_t> aggregate_of;   // #V: the particle's aggregate
  std::vector<std::int32_t> member_offsets; // aggregates + 1
  std::vector<std::int32_t> members;        // #V: each aggregate's particles, ascending
  // Block pattern of Ac over aggregates, CSR: aggregate a's blocks [row_offsets[a],
  // row_offsets[a + 1]) with columns `columns` (ascending, a itself included).
  std::vector<std::int32_t> row_offsets, columns;
  std::vector<std::int32_t> diagonal_block; // per aggregate: its (a, a) block
  std::vector<std::int32_t> entry_block;    // per adjacency entry i → j: the block (a(i), a(j))
  std::vector<double> blocks;               // 9 per block, row-major
  std::vector<std::int32_t> value_index;    // 9 per block: index into matrix's values, −1 above the diagonal
  Eigen::SparseMatrix<Scalar> matrix;       // lower triangle of Ac
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<Scalar>, Eigen::Lower> factor;
  bool factored = false; // the factor describes a system of this adjacency
  bool engaged = false;  // AUTO: a block-Jacobi solve of this workspace took too many iterations

  std::vector<double> restricted; // 3 per aggregate: Pᵀ·r
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> rhs, solution;
};

namespace cloth_detail {

// Most aggregates the automatic aggregate size leaves (3 coarse unknowns each).
inline constexpr std::size_t COARSE_AGGREGATE_LIMIT = 2048;

// Whether a solve with `options` on #V = particle_count uses the two-level preconditioner:
// TWO_LEVEL, or AUTO once `coarse` is engaged (see ImplicitPreconditioner::AUTO).
bool use_two_level(const ImplicitSolveOptions& options, std::size_t particle_count, const ImplicitCoarseSpace& coarse);

// The aggregates of `adjacency` for `options` (implicit_coarse_aggregates(), cloth_implicit.h).
std::vector<std::int32_t> coarse_aggregates(const SpringAdjacency& adjacency, std::size_t target, std::size_t& count);

// (Re)builds the structure of `coarse` for `adjacency` and options.aggregate_particles when
// either changed.
void prepare_coarse_space(ImplicitCoarseSpace& coarse, const SpringAdjacency& adjacency,
                          const ImplicitSolveOptions& options);

// Assembles Ac = Pᵀ·S·A·S·P of `system` (normals: the contact filter's #V × 3 rows, or null)
// and factors it; false when the factorisation failed (the caller then uses block Jacobi).
bool factor_coarse_space(ImplicitCoarseSpace& coarse, const ImplicitSystem& system, const SpringAdjacency& adjacency,
                         const float* normals, bool parallel);

// z += P·Ac⁻¹·Pᵀ·r (#V × 3 each): the restriction Σ_{i ∈ a} S_i·r_i (in member order; the
// contact filter is applied again although the CG's r lies in range(S): its updates r −= α·q
// leave float rounding along a constrained normal that does not shrink with r, which an
// aggregate whose particles all share that normal, a near-null coarse direction, amplifies),
// the coarse solve, then (P·y)_i = S_i·y_a(i). Returns (Pᵀ·r)ᵀ·y = rᵀ·P·Ac⁻¹·Pᵀ·r, the coarse
// term's share of rᵀ·M⁻¹·r.
double coarse_correct(ImplicitCoarseSpace& coarse, const ImplicitSystem& system, const float* normals, const float* r,
                      float* z, bool parallel);

} // namespace cloth_detail
} // namespace vfit
