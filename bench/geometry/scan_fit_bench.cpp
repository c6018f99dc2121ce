// SPDX-License-Identifier: Apache-2.0
// Scan fit (geometry/body/scan_fit.h): time per scan and Ceres iterations per stage, on a
// 15,000-vertex synthetic scan (the tall mannequin in its A-pose rest, posed: an elbow and a
// knee bent, the head turned). The scan and the fit's template are built before timing (once per
// process: about 4 s and 3 s on first use). Bar: ≤ 1 s per 15k-vertex scan on 2 cores.
#include <numbers>

#include <benchmark/benchmark.h>

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/scan_fit.h"

namespace {

using namespace vfit;

const Mesh& bench_scan() {
  static const Mesh scan = [] {
    MannequinOptions o;
    o.measurements = body_preset("tall");
    o.pose = RestPose::APOSE;
    o.target_vertices = 15000;
    const Body body = make_mannequin(o);
    constexpr double DEG = std::numbers::pi / 180.0;
    Pose p;
    p.axis_angle.row(idx(Joint::LEFT_ELBOW)) = 40 * DEG * Eigen::RowVector3d(-1, -1, 0).normalized();
    p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 25 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::HEAD)) << 0, 20 * DEG, 0;
    return pose_body(body, p).mesh;
  }();
  return scan;
}

// Args: Ceres threads (1 = serial, 2 = the bar's two cores), and the pose search's limb
// alternatives (ScanPoseSearchOptions::limb_alternatives; 1 = the plain best candidate, to
// compare the cost of refining the others in one run).
void BM_ScanFit(benchmark::State& state) {
  const Mesh& scan = bench_scan();
  scan_fit_template();        // built once per process, outside the timing
  mannequin_keypoint_model(); // the shape basis, likewise
  ScanFitOptions options;
  options.threads = static_cast<int>(state.range(0));
  options.search.limb_alternatives = static_cast<std::size_t>(state.range(1));
  ScanFit fit;
  for (auto _ : state) {
    fit = fit_scan(scan, "bench scan", options);
    benchmark::DoNotOptimize(fit.joints.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(scan.vertex_count())); // scan vertices/s
  for (const ScanFitStage& s : fit.stages) {
    state.counters[s.name + "_iterations"] = s.iterations;
    state.counters[s.name + "_candidates"] = s.candidates;
    state.counters[s.name + "_ms"] = s.ms;
    state.counters[s.name + "_cpu_ms"] = s.cpu_ms; // all threads: the work, which a busy machine inflates less
  }
  state.counters["total_cpu_ms"] = fit.total_cpu_ms;
  state.counters["repivoted_limbs"] = fit.repivoted_limbs;
  state.counters["mean_mm"] = 1000 * fit.stages.back().mean_distance;
  state.counters["p95_mm"] = 1000 * fit.stages.back().p95_distance;
}
BENCHMARK(BM_ScanFit)->Args({1, 4})->Args({2, 4})->Args({2, 1})->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
