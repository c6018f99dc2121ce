// SPDX-License-Identifier: Apache-2.0
// Penetration removal against its speed bars: remove_penetration() on the state the pipeline
// hands it, i.e. each garment after segmentation, skeleton driving and the coarse move onto the
// posed body (fit_garments() with no removal rounds and no simulation), with the pipeline's
// options (κ = 3 mm, λ2/λ1 = 1, edge crossings on).
//  - BM_RemoveTable1/r: the nine Table-1 twins (geometry/garment/table1.h) on their posed
//    mannequins. Counters: the paper's penetration ms, our median ms (removal's own clock, the
//    mesh copy excluded), `speedup` = paper ms / our median ms, vertices
//    inside and crossing edges before and after, rounds. Bar: ≤ 10 ms per row.
//  - BM_RemoveScaled/N/S: the catalogue T-pose tee of N vertices (10^4 … 10^6) driven onto the
//    arms-down mannequin; `vertices_per_s` is the throughput. Bar: 10^6 vertices under 2 s.
//    Second argument: the region solver, 0 = PenetrationSolver::CHOLESKY, 1 = CONJUGATE_GRADIENT.
//    The 10^6 tee takes ~40 s to generate; filter it out with --benchmark_filter when in a hurry.
//  - BM_InferLayerOrder/N: infer_layer_order() (engine/layer_order.h) on the catalogue's T-pose
//    tee M and trousers P2 of N vertices each, as generated (one frame). Counters: the pair's
//    votes (tee under / over the trousers), vertices. The 10^6 pair takes minutes to generate.
// Each iteration copies the pre-removal mesh (a copy of 10^6 × 3 floats is ~1 ms, inside the
// timing; negligible at the bar's scale).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "vfit/engine/dress/layer_order.h"
#include "vfit/engine/dress/penetration.h"
#include "vfit/engine/fit/pipeline.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/table1.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/proximity.h"

namespace {

// A posed body with its indices and one garment as the pipeline hands it to removal.
struct Case {
  vfit::Body body;
  std::unique_ptr<vfit::ProximityIndex> index;
  std::unique_ptr<vfit::EdgeCrossingIndex> crossings;
  vfit::Mesh garment;
};

const vfit::Body& rest_mannequin() {
  static const vfit::Body body = [] {
    vfit::MannequinOptions mo;
    mo.pose = vfit::RestPose::APOSE;
    return vfit::make_mannequin(mo);
  }();
  return body;
}

std::unique_ptr<Case> make_case(const std::string& pose, const vfit::Garment& garment, const std::string& name) {
  auto c = std::make_unique<Case>();
  const vfit::Body& rest = rest_mannequin();
  c->body = vfit::pose_body(rest, vfit::named_pose(pose, rest.rest_pose));
  vfit::FitOptions options;
  options.simulate = false;
  options.penetration_iterations = 0; // detection only: the mesh comes back as removal gets it
  options.garment_units = vfit::Units::M;
  vfit::FitResult fitted = vfit::fit_garments(c->body, {vfit::FitGarmentInput{name, garment.mesh}}, options);
  c->garment = std::move(fitted.garments.front().mesh);
  c->index = std::make_unique<vfit::ProximityIndex>(c->body.mesh.positions, c->body.mesh.triangles);
  c->crossings = std::make_unique<vfit::EdgeCrossingIndex>(c->body.mesh.positions, c->body.mesh.triangles);
  return c;
}

vfit::PenetrationOptions pipeline_options() {
  const vfit::FitOptions defaults;
  vfit::PenetrationOptions po;
  po.clearance = defaults.clearance;
  po.smoothness = defaults.smoothness;
  po.max_iterations = defaults.penetration_iterations;
  return po;
}

// Runs removal and returns the median of its own wall times (PenetrationReport::milliseconds).
double run(benchmark::State& state, const Case& c, vfit::PenetrationSolver solver = vfit::PenetrationOptions{}.solver) {
  vfit::PenetrationOptions po = pipeline_options();
  po.solver = solver;
  vfit::PenetrationReport report;
  std::vector<double> ms;
  for (auto _ : state) {
    vfit::Mesh garment = c.garment;
    report = vfit::remove_penetration(garment, *c.index, *c.crossings, po);
    ms.push_back(report.milliseconds);
    benchmark::DoNotOptimize(garment.positions.data());
  }
  std::nth_element(ms.begin(), ms.begin() + std::ptrdiff_t(ms.size() / 2), ms.end());
  state.counters["inside_before"] = double(report.before.inside_count);
  state.counters["crossing_before"] = double(report.before.crossing_edges);
  state.counters["inside_after"] = double(report.after.inside_count);
  state.counters["crossing_after"] = double(report.after.crossing_edges);
  state.counters["max_depth_after_mm"] = report.after.max_depth * 1e3;
  state.counters["rounds"] = report.iterations;
  state.counters["detection_ms"] = report.detection_ms; // the last iteration's breakdown
  state.counters["system_ms"] = report.system_ms;
  state.counters["solve_ms"] = report.solve_ms;
  state.counters["region_builds"] = report.region_builds;
  state.counters["vertices_per_s"] =
      benchmark::Counter(double(c.garment.vertex_count()), benchmark::Counter::kIsIterationInvariantRate);
  return ms.empty() ? 0.0 : ms[ms.size() / 2];
}

void BM_RemoveTable1(benchmark::State& state) {
  const vfit::Table1Row& row = vfit::table1_rows().at(std::size_t(state.range(0)));
  static std::map<std::int64_t, std::unique_ptr<Case>> cache;
  auto& c = cache[state.range(0)];
  if (!c) c = make_case(row.body_pose, vfit::make_garment(vfit::table1_garment_options(row)), row.garment);
  state.SetLabel(row.garment + " on " + row.body_pose);
  const double median_ms = run(state, *c);
  state.counters["paper_ms"] = row.paper_penetration_ms;
  state.counters["median_ms"] = median_ms;
  state.counters["speedup"] = median_ms > 0 ? row.paper_penetration_ms / median_ms : 0.0; // paper ms / our median ms
}
BENCHMARK(BM_RemoveTable1)->DenseRange(0, 8)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);

void BM_RemoveScaled(benchmark::State& state) {
  static std::map<std::int64_t, std::unique_ptr<Case>> cache;
  auto& c = cache[state.range(0)];
  if (!c) {
    vfit::GarmentOptions go;
    go.type = vfit::GarmentType::TEE;
    go.pose = vfit::RestPose::TPOSE;
    go.target_vertices = std::size_t(state.range(0));
    c = make_case("arms_down", vfit::make_garment(go), "tee");
  }
  state.SetLabel(state.range(1) == 0 ? "cholesky" : "conjugate gradients");
  run(state, *c, state.range(1) == 0 ? vfit::PenetrationSolver::CHOLESKY : vfit::PenetrationSolver::CONJUGATE_GRADIENT);
}
BENCHMARK(BM_RemoveScaled)
    ->ArgsProduct({{10'000, 100'000, 1'000'000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

vfit::GarmentOptions catalogue_options(vfit::GarmentType type, const std::string& size, std::size_t vertices) {
  vfit::GarmentOptions o;
  o.type = type;
  o.size = size;
  o.target_vertices = vertices;
  return o;
}

void BM_InferLayerOrder(benchmark::State& state) {
  static std::map<std::int64_t, std::vector<vfit::Mesh>> cache;
  auto& pair = cache[state.range(0)];
  if (pair.empty())
    for (const auto& [type, size] : {std::pair<vfit::GarmentType, std::string>{vfit::GarmentType::TEE, "M"},
                                     std::pair<vfit::GarmentType, std::string>{vfit::GarmentType::TROUSERS, "P2"}})
      pair.push_back(vfit::make_garment(catalogue_options(type, size, std::size_t(state.range(0)))).mesh);
  const vfit::Mesh* garments[] = {&pair[0], &pair[1]};
  const std::size_t given[] = {1, 0}; // bottoms first
  vfit::LayerOrder found;
  for (auto _ : state) {
    found = vfit::infer_layer_order(garments, given);
    benchmark::DoNotOptimize(found.order.data());
  }
  if (!found.votes.empty()) {
    state.counters["tee_under"] = double(found.votes[0].first_under);
    state.counters["tee_over"] = double(found.votes[0].first_over);
  }
  state.counters["tee_first"] = found.order[0] == 0 ? 1 : 0;
  state.counters["vertices"] = double(pair[0].vertex_count() + pair[1].vertex_count());
}
BENCHMARK(BM_InferLayerOrder)
    ->Arg(10'000)
    ->Arg(100'000)
    ->Arg(1'000'000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

} // namespace

BENCHMARK_MAIN();
