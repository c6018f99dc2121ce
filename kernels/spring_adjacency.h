// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Particle → spring adjacency of a mass-spring cloth (seed 000 §6.3), the layout the
/// per-particle gathers stream: built by build_spring_adjacency() (cloth_springs.h), read by the
/// force and implicit-solve kernels (cloth_gather.h, cloth_implicit.h).

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vfit {

/// Particle → spring adjacency in compressed sparse rows with each spring's parameters copied
/// into both of its rows, so a per-particle gather streams its rows contiguously. The entries
/// of particle i are [offsets[i], offsets[i+1]), in ascending spring index (so a gather adds
/// the forces in the order a serial scatter over the springs would, giving the same bits).
struct SpringAdjacency {
  std::vector<std::int32_t> offsets;   ///< #V + 1
  std::vector<std::int32_t> neighbors; ///< 2·#S: the spring's other particle
  std::vector<std::int32_t> springs;   ///< 2·#S: the spring's index in ClothSprings
  std::vector<float> rest_lengths;     ///< 2·#S (m)
  std::vector<float> stiffness;        ///< 2·#S (N/m)
  std::vector<float> damping;          ///< 2·#S (N·s/m)

  /// The same entries again in slices of CLOTH_SLICE_WIDTH consecutive particles (sliced
  /// ELLPACK), for the CPU force gathers, which run one particle per SIMD lane: slice s covers
  /// particles [W·s, W·s + W) and owns the slots [slice_offsets[s], slice_offsets[s + 1]), a
  /// column of W slots per entry index k up to its longest row: slot slice_offsets[s] + W·k + l
  /// holds entry k of particle W·s + l. Past the end of a row (or of the particles) a slot is a
  /// null entry: the particle itself (the last particle past #V) as neighbour, rest length,
  /// stiffness and damping 0, whose force is ±0 and leaves a sum started at +0 unchanged bit
  /// for bit, so a lane adds its row's forces in the CSR order and gets the CSR gather's bits.
  /// A slot names its neighbour j by 3·j, where j's row starts in a #V × 3 array, so a SIMD
  /// gather loads x_j with no index arithmetic (hence #V < 2³¹ / 3).
  std::vector<std::int32_t> slice_offsets;          ///< ⌈#V / W⌉ + 1 slot offsets (multiples of W)
  std::vector<std::int32_t> slice_neighbor_offsets; ///< #slots: 3·j
  std::vector<float> slice_rest_lengths;            ///< #slots (m)
  std::vector<float> slice_stiffness;               ///< #slots (N/m)
  std::vector<float> slice_damping;                 ///< #slots (N·s/m)
  /// Per slice, bit k set when column k's W neighbours are W consecutive particles j, j + 1,
  /// …, j + W − 1 (slot offsets 3·j rising by 3 lane to lane), so a gather may load their
  /// states as contiguous vectors; columns k ≥ 32 are never marked. A mesh numbered row by
  /// row marks most columns (98 % of a 1000 × 1000 grid's); the catalogue's tee marks none.
  std::vector<std::uint32_t> slice_consecutive_columns; ///< ⌈#V / W⌉
  /// Per slice s, the lowest and highest slice holding a neighbour of one of its particles
  /// (slots' neighbours, null slots included; s itself at least), so first ≤ s ≤ last: a stage
  /// pass on slice s reads the previous stage's states of these slices only. The RK4 driver
  /// (cloth_rk4.h) schedules its stages by them; a numbering with little spread between the two
  /// (kernels/cloth_ordering.h) lets a later stage follow an earlier one closely.
  std::vector<std::int32_t> slice_neighbor_first, slice_neighbor_last; ///< ⌈#V / W⌉ each

  std::size_t particle_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
  std::size_t slice_count() const { return slice_offsets.empty() ? 0 : slice_offsets.size() - 1; }
};

/// Particles per slice of SpringAdjacency's sliced rows: the lanes of one AVX-512 register of
/// floats (two AVX2 registers, four SSE ones).
inline constexpr std::size_t CLOTH_SLICE_WIDTH = 16;

} // namespace vfit
