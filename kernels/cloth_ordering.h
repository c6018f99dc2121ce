// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A locality numbering of a cloth's particles for the force gathers (kernels/cloth_rk4.h,
/// cloth_implicit.h): the particles in Cuthill–McKee order of the spring graph (breadth-first
/// levels from a pseudo-peripheral particle, each particle's new neighbours by ascending spring
/// count), so every spring joins particles in the same or adjacent levels: the neighbours a
/// slice of CLOTH_SLICE_WIDTH particles gathers lie within a band of about two levels (a
/// garment's cross-section: about 2,000 particles, 48 kB of one #V × 3 array, at 10^6
/// particles), and the RK4 driver's wavefront (cloth_rk4.h) can run each stage that far behind
/// the previous one. Then, inside each window of CLOTH_ORDER_WINDOW particles, the particles are
/// grouped by the length of their spring row (spring count), so the rows of one slice are of
/// about the same length and the sliced rows (SpringAdjacency::slice_offsets) carry little
/// padding.
///
/// The numbering renames particles and nothing else: renumber_cloth_springs() keeps the springs
/// in their order, so each particle's row lists the same springs in the same order and every
/// gather, force and RK4 step gives, particle for particle, the bits of the original numbering.
/// ClothSim (engine/cloth/cloth_sim.h) applies it when it builds its springs and keeps it internal;
/// the benchmarks (bench/kernels/cloth_bench.cpp) apply the same function.
///
/// What it buys (catalogue tee, bench/kernels/cloth_bench.cpp BM_rk4_tbb_tee): the catalogue's
/// own numbering scatters a slice's neighbours over the whole garment and pads its sliced rows
/// by 20 % (null slots per spring end); in this numbering they are a few kB apart and the
/// padding falls to a few %. A Morton (Z-order) curve of the positions, the order before this
/// one, gathers as locally but is not banded: at 10^6 particles 1 % of the slices reach
/// neighbours 28,000 slices away along the curve, where Cuthill–McKee's farthest reach is 230.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "cloth_springs.h"

namespace vfit {

/// Particles per window of cloth_particle_order() whose rows are grouped by length: 8 slices
/// of CLOTH_SLICE_WIDTH, about 1.5 kB of #V × 3 floats, so the regrouping moves a particle by
/// at most that far from its place in the breadth-first order.
inline constexpr std::size_t CLOTH_ORDER_WINDOW = 8 * CLOTH_SLICE_WIDTH;

/// Fraction of the columns of `adjacency`'s sliced rows whose neighbours are consecutive
/// particles (SpringAdjacency::slice_consecutive_columns; a gather loads them as vectors): 0
/// with no columns.
double consecutive_column_fraction(const SpringAdjacency& adjacency);

/// cloth_particle_order() keeps the input numbering when at least this fraction of the sliced
/// rows' columns is consecutive in it (a mesh numbered row by row, as a grid: 98 % of a 1000 ×
/// 1000 grid's columns), as the vector loads of those columns beat any renumbering's gathers.
inline constexpr double CLOTH_KEEP_NUMBERING_CONSECUTIVE = 0.5;

/// The locality order of the file comment: order[k] = the particle (in the input numbering) put
/// at position k, a permutation of [0, particle_count). springs: ends in [0, particle_count)
/// (assert only); a particle in no spring is a component of its own. The identity when the input
/// numbering already loads most columns as vectors (CLOTH_KEEP_NUMBERING_CONSECUTIVE, judged on
/// build_spring_adjacency(springs, particle_count)). Components are numbered by their lowest
/// particle, ties in degree keep input order, and rows of equal length keep level order inside a
/// window: the result depends on the input alone (no threads).
std::vector<std::int32_t> cloth_particle_order(std::size_t particle_count, const ClothSprings& springs);

/// The inverse of a permutation: rank[order[k]] = k. order: a permutation of [0, n) (assert only).
std::vector<std::int32_t> inverse_permutation(std::span<const std::int32_t> order);

/// `springs` with each end i renamed rank[i] (rank: the inverse of an order, #V entries), the
/// pair stored smaller first as build_cloth_springs() does; the springs keep their order, rest
/// lengths, constants and kinds.
ClothSprings renumber_cloth_springs(const ClothSprings& springs, std::span<const std::int32_t> rank);

/// Rows of `width` values gathered into a new order: out[width·k + c] = in[width·order[k] + c]
/// for k < #order (out resized). To go back, gather with the inverse permutation.
void gather_rows(std::span<const float> in, std::span<const std::int32_t> order, std::size_t width,
                 std::vector<float>& out);

} // namespace vfit
