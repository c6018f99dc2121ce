// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/penetration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <tuple>

#include <tbb/parallel_invoke.h>

#include "vfit/engine/dress/detection.h"
#include "vfit/engine/dress/pushes.h"
#include "vfit/engine/dress/removal.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/laplacian.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/region_least_squares.h"

namespace vfit {
namespace {

using namespace dress;

// Rings of neighbours around the pushed vertices that a solve may move; the rest of the garment
// is the fixed region and keeps its place exactly. With λ2/λ1 = 1 on the uniform Laplacian a
// push decays by about half per ring, so 6 rings leave under 2 % of it at the region's edge
// (a 4 mm push: a 0.06 mm step there, which the next round's solve smooths if it matters),
// and the solve covers a few thousand vertices instead of the whole garment. Measured against
// 8 rings (< 0.5 %) on the Table-1 twins: the same rounds and end states, mean edge change
// within 0.01 % (slightly lower), regions ~40 % smaller, removal ~10–15 % faster.
constexpr int REGION_RINGS = 6;
// Push gains. A push p on one vertex moves it by only part of p: the Laplacian term spreads
// the push over the neighbours (alone on a mesh of valence 6 with λ2/λ1 = 1, a vertex moves by
// well under a fifth of its push), so a vertex still inside after a round crept out by a
// fraction of its depth per round (the Table-1 Pant 1 (P3): one vertex, 1.7 → 0.4 mm over six
// rounds). The solve is linear, so a vertex pushed again is pushed by the displacement it
// wants divided by the fraction of its previous push that it achieved (its response), at most
// PUSH_GAIN_INSIDE times for a vertex inside the body and PUSH_GAIN_OTHER times for the ends
// of crossing edges and layer pushes, whose neighbours' pushes overlap theirs (a gain of 4
// there overshoots: corpus jeans 1.96 % mean edge change against 1.89 %). Measured: Table-1
// rows from 1–16 rounds to 1–5, corpus outfits from 16–19 to 4–9, the same offences at the
// end, mean edge change within 0.07 % of before.
constexpr double PUSH_GAIN_INSIDE = 4.0;
constexpr double PUSH_GAIN_OTHER = 2.0;

// Regions of at least this many unknowns are rebuilt around a later round's pushes when those
// are under an eighth of the pushes the region was grown from (see remove()).
constexpr std::size_t SHRINK_REGION_FROM = 2000;

Eigen::MatrixXd as_matrix(std::span<const float> p) {
  Eigen::MatrixXd y(static_cast<Eigen::Index>(p.size() / 3), 3);
  for (Eigen::Index v = 0; v < y.rows(); ++v)
    for (int k = 0; k < 3; ++k)
      y(v, k) = p[3 * std::size_t(v) + std::size_t(k)];
  return y;
}

// Adds the wall time of f() to `total` (ms) and returns f()'s result.
template <class F> auto timed(double& total, F&& f) {
  struct Add {
    double& total;
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    ~Add() { total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(); }
  } add{total};
  return f();
}

bool resolved(const PenetrationStats& s) {
  return s.inside_count == 0 && s.crossing_edges == 0 && s.layer_inside_count == 0 && s.layer_crossing_edges == 0;
}

// The direct rounds (PenetrationOptions::direct_rounds): from a state with no vertex deeper
// than the tolerance and edges still crossing, each round moves every crossing edge's ends and
// every vertex inside by its push (push_crossing_edges(), push_vertices()) and detects them
// again; the best state over the rounds is kept, so the result is never worse than the solved
// rounds'. They stop after 2 × stall_rounds rounds in a row without improvement (a push that
// moves a chord along a curved limb gains a little per round: measured on the corpus outfits
// after simulation, a long-sleeve cuff's last 6 crossing edges went in 4 rounds where 100
// solved rounds left 1; the overalls' hem over a foot needed 57).
template <class Badness>
void push_directly(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                   const GarmentEdges& edges, std::span<const LayerObstacle> layers, double clearance,
                   const PenetrationOptions& o, const Badness& badness, Detection& detection,
                   PenetrationReport& report) {
  const std::size_t nv = garment.vertex_count();
  const std::vector<float> reference = garment.positions;
  detection.reference = reference;
  timed(report.detection_ms,
        [&] { detect(garment.positions, body, &crossings, &edges, layers, nullptr, nullptr, nullptr, detection); });
  report.after = stats_of(detection, o.clearance);
  PenetrationStats best = report.after;
  std::vector<float> best_positions = garment.positions;
  std::vector<std::size_t> moved;
  int last_improvement = -1;
  for (int round = 0; round < o.direct_rounds && !resolved(report.after); ++round) {
    Pushes pushes(nv);
    push_vertices(garment.positions, detection.body, clearance, 0.0, pushes);
    push_crossing_edges(garment.positions, body, crossings, edges, detection, clearance, pushes);
    if (!pushes.any()) break;
    moved.clear();
    for (std::size_t v = 0; v < nv; ++v)
      if (pushes.flagged[v]) {
        moved.push_back(v);
        for (int c = 0; c < 3; ++c)
          garment.positions[3 * v + std::size_t(c)] += static_cast<float>(pushes.displacement[v][c]);
      }
    // Only the moved vertices and their edges can have changed (the body is static): detected
    // again, every one of them queried afresh, so the statistics stay exact.
    timed(report.detection_ms, [&] {
      detect(garment.positions, body, &crossings, &edges, layers, &moved, &pushes.flagged, &moved, detection);
    });
    report.after = stats_of(detection, o.clearance);
    ++report.direct_rounds;
    if (badness(report.after) < badness(best)) {
      best = report.after;
      best_positions = garment.positions;
      last_improvement = round;
    } else if (o.stall_rounds > 0 && round - last_improvement >= 2 * o.stall_rounds) {
      break;
    }
  }
  detection.reference = {};
  if (badness(best) < badness(report.after)) {
    garment.positions = std::move(best_positions);
    report.after = best;
  }
}

} // namespace

namespace dress {

GarmentTopology::GarmentTopology(const Mesh& garment)
    : laplacian(uniform_laplacian(garment.triangle_view(), garment.vertex_count())), edges(laplacian) {}

PenetrationReport remove(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex* crossings,
                         std::span<const LayerObstacle> layers, const PenetrationOptions& o,
                         const GarmentTopology* topology) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool seed004 = o.method == PenetrationMethod::SEED_004;
  const std::size_t nv = garment.vertex_count();
  SparseMatrix own_laplacian;
  std::optional<GarmentEdges> own_edges;
  const SparseMatrix& L = topology ? topology->laplacian : own_laplacian;
  const double clearance = seed004 ? 0.0 : o.clearance; // seed 004 projects onto the face
  Detection detection;
  detection.reach = near_reach(o.clearance);
  detection.triangles = garment.triangles;
  PenetrationReport report;
  const GarmentEdges* edge_list = nullptr;
  timed(report.detection_ms, [&] {
    if (topology) {
      closest_points_of(body, garment.positions, detection.reach, nullptr, detection.body);
      if (crossings) edge_list = &topology->edges;
    } else {
      // The garment's Laplacian and edges (serial) are built while the body is queried for
      // every vertex (parallel): neither needs the other, and the rest of the detection needs
      // both.
      tbb::parallel_invoke(
          [&] {
            own_laplacian = uniform_laplacian(garment.triangle_view(), nv);
            if (crossings) own_edges.emplace(own_laplacian);
          },
          [&] { closest_points_of(body, garment.positions, detection.reach, nullptr, detection.body); });
      if (own_edges) edge_list = &*own_edges;
    }
    detection.adjacency = &L;
    detection.body_queried = true;
    detect(garment.positions, body, crossings, edge_list, layers, nullptr, nullptr, nullptr, detection);
  });
  report.before = stats_of(detection, o.clearance);
  report.after = report.before;
  Pushes pushes(nv);
  // Vertices merely closer than κ (or a layer's k) are pushed in the first round only;
  // afterwards only those inside are. The solve leaves a pushed vertex a little short of κ (the
  // Laplacian pulls it back), and re-pushing all of those every round inflates the garment
  // round after round (corpus outfits: 2.2 % mean edge change against 1.9 % this way).
  // Crossing edges are pushed once no vertex is deeper than the tolerance: where a garment passes through a
  // limb (a T-pose sleeve on an arms-down body), chord pushes toward the nearest surface fight
  // the vertex pushes and can carry vertices deep inside.
  auto propose = [&](bool first_round) {
    pushes = Pushes(nv);
    push_vertices(garment.positions, detection.body, clearance, first_round ? clearance : 0.0, pushes);
    const bool deep_inside = vertex_stats(detection.body, 0.0).max_depth > o.tolerance;
    if (crossings && !deep_inside)
      push_crossing_edges(garment.positions, body, *crossings, *edge_list, detection, clearance, pushes);
    // Like crossing edges, layer edges through the garment wait until no vertex is deep inside
    // the body: their pushes fought the body's on the worksuit's tee (dressed over overalls
    // whose bib covers it), which ended with 27 vertices inside the body instead of 8.
    push_out_of_layers(garment.positions, layers, detection, first_round, !deep_inside, pushes);
    return pushes.any();
  };
  if (!timed(report.detection_ms, [&] { return propose(true); })) {
    report.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return report;
  }

  const std::vector<float> start_positions = garment.positions;
  const Eigen::MatrixXd rest_laplacian =
      seed004 ? Eigen::MatrixXd(L * as_matrix(garment.positions)) : Eigen::MatrixXd();
  const int rounds = seed004 ? std::min(o.max_iterations, o.seed004_iterations) : o.max_iterations;

  // The best state seen, returned when the rounds run out unresolved: never worse than that.
  // Depth beyond the tolerance weighs most (it is what the quality bars and the simulation's
  // contact handling care about), then the offences against the body, then those against inner
  // layers (a garment that cannot get out of a layer it is dressed under, e.g. a tee under the
  // bib of overalls, keeps the state best for the body: the worksuit's tee ended with 24
  // vertices inside the body and 122 crossing edges when layer offences counted as much), then
  // the depth.
  auto badness = [&o](const PenetrationStats& st) {
    return std::make_tuple(st.max_depth > o.tolerance, st.inside_count + st.crossing_edges,
                           st.layer_inside_count + st.layer_crossing_edges, st.max_depth);
  };
  std::vector<float> best_positions;
  PenetrationStats best = report.before;
  SolveRegion region;
  std::optional<RegionSystem> system;
  std::vector<char> seeds; // the pushed vertices the region was grown from
  std::size_t seed_count = 0;
  int last_improvement = -1;
  std::vector<std::size_t> requery;
  std::vector<double> response(nv, 1.0);                      // per vertex: see PUSH_GAIN_INSIDE; 1 until pushed
  std::vector<char> crossings_pending(crossings ? nv : 0, 0); // moved since their edges' last check
  auto check_pending_crossings = [&] {
    detect_crossings(garment.positions, detection.body, detection.drift, *crossings, *edge_list, &crossings_pending,
                     detection);
    std::fill(crossings_pending.begin(), crossings_pending.end(), char(0));
  };
  // Queries again the vertices skipped since their last query (may_have_changed()) and takes
  // the statistics afresh. The skip is exact where the body's signed distance is continuous; a
  // posed body that intersects itself (skin folded at an armpit) makes the side jump, so a
  // skipped vertex can be found inside here: before the rounds end, and before they stop as
  // resolved, every vertex is queried again, and the report is exact on any body.
  auto refresh_skipped = [&] {
    requery.clear();
    for (std::size_t v = 0; v < nv; ++v)
      if (detection.drift[v] > 0) requery.push_back(v);
    if (requery.empty()) return;
    timed(report.detection_ms, [&] {
      closest_points_of(body, garment.positions, detection.reach, &requery, detection.body);
      resolve_far_vertices(garment.positions, body, crossings, &requery, detection.reach, detection.adjacency,
                           detection.body);
    });
    for (std::size_t v : requery)
      detection.drift[v] = 0.0f;
    report.after = stats_of(detection, o.clearance);
  };
  for (int iter = 0; iter < rounds; ++iter) {
    if (iter > 0 && !timed(report.detection_ms, [&] { return propose(false); })) break;
    // The region: REGION_RINGS rings around the pushed vertices. A push outside it (a later
    // round finds a new spot) grows it. When a later round pushes far fewer vertices than the
    // region was grown from (the first round pushes thousands, the next ones tens), a region
    // around those alone is rebuilt once it is large: factoring a few hundred unknowns costs
    // less than two solves over thousands (measured on the Table-1 shorts: 6,216 unknowns,
    // 1.5 ms per solve, then ~600).
    const std::size_t pushed_now = std::size_t(std::count(pushes.flagged.begin(), pushes.flagged.end(), char(1)));
    const bool shrink = system && region.vertices.size() >= SHRINK_REGION_FROM && 8 * pushed_now < seed_count;
    if (!system || shrink || !region.covers(pushes.flagged)) {
      if (!system || shrink)
        seeds = pushes.flagged;
      else
        for (std::size_t v = 0; v < nv; ++v)
          seeds[v] |= pushes.flagged[v];
      seed_count = std::size_t(std::count(seeds.begin(), seeds.end(), char(1)));
      region = make_solve_region(L, seeds, REGION_RINGS);
      // AUTO factors only the first round's region: a region rebuilt later (shrunk around a
      // few remaining pushes, or grown to a new spot) is mostly solved once or twice, where
      // the factorisation's ordering and elimination cost more than CG on its few hundred
      // unknowns (see PenetrationSolver::AUTO).
      const bool direct = o.solver == PenetrationSolver::CHOLESKY || (o.solver == PenetrationSolver::AUTO && !system &&
                                                                      region.vertices.size() < o.direct_solve_limit);
      timed(report.system_ms, [&] {
        system.emplace(L, region, seed004 ? 1.0 + o.seed004_damping : 1.0, seed004 ? o.seed004_smoothing : o.smoothness,
                       direct, o.cg_tolerance);
      });
      ++report.region_builds;
    }
    for (std::size_t v = 0; v < nv; ++v)
      if (pushes.flagged[v] && response[v] < 1.0) {
        const bool inside = detection.body.triangles[v] >= 0 && detection.body.signed_distances[v] < 0;
        pushes.displacement[v] *= std::min(1.0 / response[v], inside ? PUSH_GAIN_INSIDE : PUSH_GAIN_OTHER);
      }
    const auto n = static_cast<Eigen::Index>(region.vertices.size());
    Eigen::MatrixXd rhs(n, 3);
    for (Eigen::Index k = 0; k < n; ++k)
      rhs.row(k) = pushes.displacement[region.vertices[std::size_t(k)]];
    if (seed004) {
      const Eigen::MatrixXd drift = rest_laplacian - L * as_matrix(garment.positions);
      Eigen::MatrixXd g(system->rows(), 3);
      for (Eigen::Index r = 0; r < g.rows(); ++r)
        g.row(r) = drift.row(Eigen::Index(region.rows[std::size_t(r)]));
      rhs += system->transpose_times(g);
    }
    int cg_iterations = 0;
    const Eigen::MatrixXd delta = timed(report.solve_ms, [&] { return system->solve(rhs, cg_iterations); });
    report.solver_iterations += cg_iterations;
    for (Eigen::Index k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c)
        garment.positions[3 * region.vertices[std::size_t(k)] + std::size_t(c)] += static_cast<float>(delta(k, c));
    report.iterations = iter + 1;
    for (Eigen::Index k = 0; k < n; ++k) // each pushed vertex's response (see PUSH_GAIN_INSIDE)
      if (const std::size_t v = region.vertices[std::size_t(k)]; pushes.flagged[v])
        if (const double pushed2 = pushes.displacement[v].squaredNorm(); pushed2 > 0)
          response[v] = std::clamp(delta.row(k).dot(pushes.displacement[v]) / pushed2, 0.0, 1.0);
    requery.clear();
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::size_t v = region.vertices[std::size_t(k)];
      const float moved = float(delta.row(k).norm()) + 1e-6f; // + float rounding of the positions
      if (may_have_changed(detection, v, moved, o.clearance))
        requery.push_back(v);
      else
        detection.drift[v] += moved;
    }
    timed(report.detection_ms, [&] {
      detect(garment.positions, body, nullptr, edge_list, layers, &region.vertices, &region.moves, &requery, detection);
      if (!crossings) return;
      // While a vertex is deeper than the tolerance the next round pushes no crossing edge
      // (propose()), so the edges' check waits: the vertices moved meanwhile are remembered
      // and their edges checked once it is needed (Table-1 Shorts 1: two rounds of ~18k edge
      // checks saved). Meanwhile the statistics carry the last crossing count.
      for (std::size_t v : region.vertices)
        crossings_pending[v] = 1;
      if (vertex_stats(detection.body, 0.0).max_depth > o.tolerance) return;
      check_pending_crossings();
    });
    report.after = stats_of(detection, o.clearance);
    // clearance is a target, not a requirement
    if (resolved(report.after) && (refresh_skipped(), resolved(report.after))) break;
    if (badness(report.after) < badness(best)) {
      best = report.after;
      best_positions = garment.positions;
      last_improvement = iter;
    } else if (o.stall_rounds > 0 && iter - last_improvement >= o.stall_rounds) {
      break;
    }
  }
  if (std::find(crossings_pending.begin(), crossings_pending.end(), char(1)) != crossings_pending.end()) {
    timed(report.detection_ms, check_pending_crossings);
    report.after = stats_of(detection, o.clearance);
  }
  if (!resolved(report.after) && badness(best) < badness(report.after)) {
    if (!best_positions.empty()) {
      garment.positions = best_positions;
      // best's statistics were taken with skipped vertices: measure the state returned afresh.
      timed(report.detection_ms, [&] {
        detect(garment.positions, body, crossings, edge_list, layers, nullptr, nullptr, nullptr, detection);
      });
      report.after = stats_of(detection, o.clearance);
    } else {
      garment.positions = start_positions; // the start was best
      report.after = best;
    }
  } else if (!resolved(report.after)) {
    refresh_skipped();
  }
  if (crossings && !seed004 && report.after.crossing_edges > 0 && report.after.max_depth <= o.tolerance)
    push_directly(garment, body, *crossings, *edge_list, layers, clearance, o, badness, detection, report);
  report.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

PenetrationStats measure(const Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                         std::span<const LayerObstacle> layers, double clearance, const GarmentTopology* topology) {
  std::optional<GarmentTopology> own;
  if (!topology) topology = &own.emplace(garment);
  Detection d;
  d.reach = near_reach(clearance);
  d.adjacency = &topology->laplacian;
  d.triangles = garment.triangles;
  detect(garment.positions, body, &crossings, &topology->edges, layers, nullptr, nullptr, nullptr, d);
  return stats_of(d, clearance);
}

} // namespace dress

using dress::measure;
using dress::remove;

PenetrationStats measure_penetration(std::span<const float> garment_positions, const ProximityIndex& body,
                                     double clearance) {
  ClosestHits hits;
  body.closest_points(garment_positions, NEAR_SEARCH, hits);
  resolve_far_vertices(garment_positions, body, nullptr, nullptr, NEAR_SEARCH, nullptr, hits);
  return vertex_stats(hits, clearance);
}

PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, double clearance) {
  return measure(garment, body, crossings, {}, clearance, nullptr);
}

PenetrationStats measure_penetration(const Mesh& garment, const ProximityIndex& body,
                                     const EdgeCrossingIndex& crossings, std::span<const LayerObstacle> layers,
                                     double clearance) {
  return measure(garment, body, crossings, layers, clearance, nullptr);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const PenetrationOptions& o) {
  return remove(garment, body, nullptr, {}, o, nullptr);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     const PenetrationOptions& o) {
  return remove(garment, body, &crossings, {}, o, nullptr);
}

PenetrationReport remove_penetration(Mesh& garment, const ProximityIndex& body, const EdgeCrossingIndex& crossings,
                                     std::span<const LayerObstacle> layers, const PenetrationOptions& o) {
  return remove(garment, body, &crossings, layers, o, nullptr);
}

} // namespace vfit
