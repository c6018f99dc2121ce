// SPDX-License-Identifier: Apache-2.0
// Keypoint fit (geometry/body/keypoint_fit.h): time per image and Ceres iterations per stage,
// on synthetic BODY_25 keypoints of the mannequin (3 px noise, fixed seed). The body model is
// built before timing (once per process). Bar: ≤ 200 ms per image on 2 cores.
#include <random>

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include "vfit/geometry/body/keypoint_fit.h"

namespace {

using namespace vfit;

Pose bench_pose(int which) {
  Pose p;
  const double arm = which == 0 ? 1.2 : -0.8; // 0: standing, 1: arms raised and walking
  p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0, 0, -arm;
  p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) << 0, 0, arm;
  if (which == 1) {
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << -0.4, 0, 0;
    p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 0.6, 0, 0;
    p.axis_angle.row(0) << 0, 0.5, 0;
  }
  p.translation << 0.1, -0.2, -3.2;
  return p;
}

// which: 0 standing, 1 arms raised + walking, 2 standing with both wrist keypoints missing (the
// hidden-elbow prior's path).
Keypoints bench_keypoints(int which) {
  const KeypointBodyModel& model = mannequin_keypoint_model();
  const PinholeCamera cam{1200.0, Eigen::Vector2d(500, 500)};
  const auto posed = model.posed_points({0.5, -0.3, 0.2, 0.1}, bench_pose(which == 1 ? 1 : 0));
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 3.0);
  nlohmann::json arr = nlohmann::json::array();
  for (int i = 0; i < 25; ++i) {
    const Eigen::Vector2d px = cam.project(posed.row(keypoint_body_point(KeypointLayout::BODY_25, i)).transpose());
    const bool missing = which == 2 && (i == 4 || i == 7); // BODY_25 right and left wrists
    for (double v : {px.x() + noise(rng), px.y() + noise(rng), missing ? 0.0 : 0.9})
      arr.push_back(v);
  }
  const nlohmann::json doc = {{"image_size", {1000, 1000}}, {"people", {{{"pose_keypoints_2d", arr}}}}};
  return parse_keypoints(doc.dump(), "bench");
}

// Args: keypoints (0 standing, 1 arms raised + walking, turned, 2 standing without wrists), Ceres
// threads (1 = serial).
void BM_KeypointFit(benchmark::State& state) {
  const Keypoints kp = bench_keypoints(static_cast<int>(state.range(0)));
  KeypointFitOptions options;
  options.threads = static_cast<int>(state.range(1));
  KeypointFit fit;
  for (auto _ : state) {
    fit = fit_keypoints(kp, options);
    benchmark::DoNotOptimize(fit.pose.axis_angle.data());
  }
  state.SetItemsProcessed(state.iterations()); // images/s
  for (const KeypointFitStage& s : fit.stages) {
    state.counters[s.name + "_iterations"] = s.iterations;
    state.counters[s.name + "_ms"] = s.ms;
  }
  state.counters["reprojection_px"] = fit.mean_reprojection_px;
}
BENCHMARK(BM_KeypointFit)->ArgsProduct({{0, 1, 2}, {1, 2}})->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
