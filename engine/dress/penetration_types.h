// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The shared types of the dressing room (engine/dress/): where a garment stands against a
/// body and its inner layers (PenetrationStats), an inner layer as an obstacle (LayerObstacle),
/// and the options and report of penetration removal (seed 000 §6.2, eq. 18–21; seed 004
/// §3.2.2; seed 001 §6.3, eq. 7). Everything else in engine/dress/ includes this header; it
/// includes nothing of the room.

#include <cstddef>
#include <cstdint>
#include <span>

namespace vfit {

class ProximityIndex;

/// Where a garment stands against a body. Depths are in metres (positive = inside).
struct PenetrationStats {
  std::size_t inside_count = 0; ///< vertices inside the body (seed 000 eq. 18: f < 0)
  std::size_t near_count = 0;   ///< vertices inside or closer than the clearance κ
  double max_depth = 0;         ///< deepest vertex inside (0 when none)
  double mean_depth = 0;        ///< mean depth over the vertices inside (0 when none)
  /// Garment edges crossing the body surface (an Embree segment query per edge that has an end
  /// within half its length of the body; the others cannot cross); 0 when the measure was
  /// taken without an EdgeCrossingIndex (see crossings_checked).
  std::size_t crossing_edges = 0;
  bool crossings_checked = false; ///< whether crossing_edges was measured
  /// Vertices inside an inner garment layer (LayerObstacle; 0 when measured without layers).
  std::size_t layer_inside_count = 0;
  double layer_max_depth = 0; ///< deepest vertex inside an inner layer (m; 0 when none)
  /// Edges of inner garment layers that pass through the garment's triangles: a layer poking
  /// out through the garment between its vertices, which layer_inside_count cannot see
  /// (engine/layer_piercing.h; 0 when measured without layers, or with layers that carry no
  /// edges).
  std::size_t layer_crossing_edges = 0;
};

/// An inner garment layer that remove_penetration() keeps a garment outside of, besides the
/// body (seed 001 §6.3, eq. 7); engine/layering.h builds one from a resolved garment. A garment
/// is an open surface, so "inside" is local: a vertex is inside the layer when it lies behind
/// the layer's outward-oriented surface at its closest point (the pseudo-normal side test of
/// ProximityIndex), that point lies within `reach`, and it is not on the layer's boundary (a
/// closest point on a hem, cuff or waistband edge means the vertex is beyond the opening, not
/// under the cloth).
struct LayerObstacle {
  /// Index over the layer's surface, triangles oriented away from the body. Not owned.
  const ProximityIndex* surface = nullptr;
  /// #F of that surface: bit k (k = 0, 1, 2) set when edge k (corner k → corner (k + 1) mod 3)
  /// is a boundary edge, bit 3 + k when corner k is a boundary vertex.
  std::span<const std::uint8_t> boundary;
  double clearance = 0.003; ///< k of seed 001 eq. 7 (m): the gap kept outside the layer
  double reach = 0.05;      ///< layer points farther than this (m) are ignored
  /// The layer's vertices (#V_L × 3, m) and triangles (#F_L × 3, oriented away from the body) as
  /// `surface` indexes them, its distinct edges (#E_L × 2) and each vertex's incident edges
  /// (CSR: edge_offsets has #V_L + 1 entries into vertex_edges, which holds edge rows). With
  /// them the layer's edges that poke out through the garment are found and pushed clear
  /// (engine/layer_piercing.h); left empty, piercing is neither checked nor counted.
  std::span<const float> points;
  std::span<const std::int32_t> triangles;
  std::span<const std::int32_t> edges;
  std::span<const std::int32_t> edge_offsets;
  std::span<const std::int32_t> vertex_edges;
};

/// Which objective remove_penetration() minimises.
enum class PenetrationMethod : std::int8_t {
  /// seed 000 eq. 18–21: targets κ outside the closest body point, λ2/λ1 = smoothness, rounds
  /// until nothing is inside (at most max_iterations).
  SEED_000 = 0,
  /// seed 004 §3.2.2: Σ_{i∈P} ‖y_i − p_i‖² + ω_s Σ_i ‖δ_i(y) − δ_i(y⁰)‖² + ω_d Σ_i ‖y_i − y'_i‖², p_i the
  /// projection of y_i onto its closest body face, y' the previous iterate, at most
  /// seed004_iterations rounds. δ_i(y) = y_i − mean_{j∈N_i} y_j; the paper's smoothing keeps
  /// the wrinkles, so δ is measured against the start y⁰ (a literal ‖δ_i(y)‖² would shrink the
  /// garment). Vertices outside P keep their previous position as target (weight 1), so the
  /// system matrix (1 + ω_d) I + ω_s LᵀL does not depend on P and is set up once. Targets
  /// lie on the surface and the damping slows each round, so a little depth can remain.
  SEED_004 = 1,
};

/// How each round's sparse system (c·I + w·L_RᵀL_R over the region R: c = 1, w = λ2/λ1 for
/// SEED_000; c = 1 + ω_d, w = ω_s for SEED_004) is solved, for the region's displacements δ
/// (#R × 3, m). Both give the same positions up to the CG tolerance.
enum class PenetrationSolver : std::int8_t {
  /// A sparse LDLᵀ factorisation of the region's matrix, computed once per region and reused
  /// by every round. A failed factorisation throws vfit::Error
  /// ("remove_penetration: the region's system is not positive definite").
  CHOLESKY = 0,
  /// Jacobi-preconditioned conjugate gradients, the three columns together, to ‖r‖ ≤ cg_tolerance·‖b‖
  /// per column or 200 iterations at most (a solve stopped by the cap is used as it is, with no
  /// error or status), no factorisation: memory linear in the region, but ~75 iterations per
  /// solve (the matrix's condition number is ~150 for λ = 1); products and dot products in
  /// parallel, the same bits for any thread count. The direct solve's cross-check in the tests
  /// (positions agree within 1e-6 m).
  CONJUGATE_GRADIENT = 1,
  /// CHOLESKY for regions of fewer than PenetrationOptions::direct_solve_limit unknowns,
  /// CONJUGATE_GRADIENT from there on: the factorisation (its ordering, fill and the
  /// elimination itself) grows faster than the region and runs on one core, CG's products
  /// run on all of them in memory linear in the region (docs/benchmarks.md has the crossover).
  /// Only the first round's region is factored: a region rebuilt in a later round (shrunk
  /// around the few pushes left, or grown to a new spot) is mostly solved once or twice, and
  /// CG on its few hundred unknowns costs less than the factorisation. The default.
  AUTO = 2,
};

struct PenetrationOptions {
  double clearance = 0.002; ///< κ (m): the gap left between a pushed vertex and the body
  double smoothness = 1.0;  ///< λ2/λ1: weight of keeping the garment's Laplacian coordinates
  int max_iterations = 25;  ///< detection → solve rounds at most
  /// Stop after this many rounds in a row that did not improve on the best state seen (the
  /// pushes of vertices and of crossing edges can trade offences back and forth without end);
  /// the best state is returned. 0: never stop early.
  int stall_rounds = 8;
  double tolerance = 0.0005; ///< stop when no vertex is deeper than this (m)
  /// Rounds of direct pushes after the solved rounds when edges still cross the body and no
  /// vertex is deeper than `tolerance`: each crossing edge's ends (and any vertex inside) move
  /// by their pushes as they are, without the Laplacian solve that spreads a push over the
  /// neighbours (there a push that a fan of edges shares can be undone by its neighbours' pull
  /// round after round). A crossing edge's push is cut short where it would stretch an edge at
  /// its vertex past 1.5 times its length where the direct rounds began (or by κ, when that is
  /// more): such an edge is left crossing, for the simulation, rather than torn out (unlimited,
  /// a sleeve vertex squeezed between arm and torso was walked 25 cm out in front). The best
  /// state is kept; they stop after 2 × stall_rounds rounds in a row that did not improve on
  /// it. 0: none.
  int direct_rounds = 64;
  PenetrationMethod method = PenetrationMethod::SEED_000;
  double seed004_smoothing = 6.0; ///< ω_s (seed 004 §3.2.2)
  double seed004_damping = 0.8;   ///< ω_d (seed 004 §3.2.2)
  int seed004_iterations = 3;     ///< seed 004 repeats the fix at most 3 times
  PenetrationSolver solver = PenetrationSolver::AUTO;
  /// With PenetrationSolver::AUTO: a first region of at least this many unknowns is solved by
  /// CG (rebuilt regions always are). The measured crossover: docs/benchmarks.md.
  std::size_t direct_solve_limit = 2'000;
  /// PenetrationSolver::CONJUGATE_GRADIENT (and AUTO from the limit) stops when every
  /// column's residual is below this fraction of its right-hand side's norm (or after 200
  /// iterations). A round's solve need not be exact: the next round detects what is still
  /// inside and pushes again, with the gains of the response measured on this solve. 1e-3
  /// takes about half the iterations of 1e-7 and leaves the rounds and end states of the
  /// Table-1 twins and corpus outfits as they were.
  double cg_tolerance = 1e-3;
};

/// Before/after statistics of one remove_penetration() call.
struct PenetrationReport {
  PenetrationStats before, after;
  int iterations = 0; ///< detection → solve rounds run
  /// Region systems set up (factored, with CHOLESKY): 0 when nothing needed a push, else 1 for
  /// the first round, plus one each time a round's pushes left the region (the region then
  /// grows to cover them), plus one each time a region of ≥ 2,000 vertices is rebuilt around
  /// a round that pushes fewer than 1/8 of the vertices it was grown from (it then shrinks).
  int region_builds = 0;
  int direct_rounds = 0; ///< rounds of direct pushes run (PenetrationOptions::direct_rounds)
  /// Conjugate-gradient iterations summed over all rounds (one count per solve of the three
  /// columns together); 0 with PenetrationSolver::CHOLESKY.
  long long solver_iterations = 0;
  double milliseconds = 0; ///< wall time of the whole call
  /// Where `milliseconds` went (wall ms, summed over the rounds): closest-point and edge-crossing
  /// queries, including the first detection and the pushes' own queries; setting up and
  /// factoring the region systems; solving them. The rest is bookkeeping.
  double detection_ms = 0, system_ms = 0, solve_ms = 0;
};

} // namespace vfit
