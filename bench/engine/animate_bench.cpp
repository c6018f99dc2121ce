// A dressed character stepped frame by frame (engine/animate/dressed_character.h): the demo
// outfit (catalogue trousers P2 and tee M, A-pose) on the A-pose mannequin, posed through a
// procedural walk by linear blend skinning, and the per-frame penetration measure.
//   build/release/bench/vfit_animate_bench
// Arguments: garment vertices each (5,000 is the demo outfit's). Counters: frames per second
// (step alone), garment vertices.
#include <cmath>
#include <map>
#include <numbers>

#include <benchmark/benchmark.h>

#include "engine/animate/dressed_character.h"
#include "geometry/body/mannequin.h"
#include "geometry/body/pose_io.h"
#include "geometry/garment/catalogue.h"

namespace vfit {
namespace {

struct Outfit {
  Body body;
  std::vector<FittedGarment> garments;
  std::vector<Pose> walk;
  explicit Outfit(std::size_t vertices) {
    MannequinOptions mo;
    mo.pose = RestPose::APOSE;
    body = make_mannequin(mo);
    for (const auto& [type, size] : {std::pair{GarmentType::TROUSERS, "P2"}, std::pair{GarmentType::TEE, "M"}}) {
      GarmentOptions o;
      o.type = type;
      o.size = size;
      o.pose = RestPose::APOSE;
      o.target_vertices = vertices;
      FittedGarment g;
      g.name = garment_type_name(type);
      g.mesh = make_garment(o).mesh;
      g.segmentation.type = type;
      garments.push_back(std::move(g));
    }
    // One second of a procedural walk at 30 fps: hips, knees and shoulders swinging.
    for (int k = 0; k < 30; ++k) {
      const double phase = 2 * std::numbers::pi * k / 30.0, swing = 0.45 * std::sin(phase);
      Pose p;
      p.axis_angle.row(idx(Joint::LEFT_HIP)) << -swing, 0, 0;
      p.axis_angle.row(idx(Joint::RIGHT_HIP)) << swing, 0, 0;
      p.axis_angle.row(idx(Joint::LEFT_KNEE)) << 0.6 * std::max(0.0, std::sin(phase + 1.0)), 0, 0;
      p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 0.6 * std::max(0.0, -std::sin(phase + 1.0)), 0, 0;
      p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << swing, 0, 0;
      p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) << -swing, 0, 0;
      walk.push_back(p);
    }
  }
};

const Outfit& outfit(std::size_t vertices) {
  static std::map<std::size_t, Outfit> cache;
  auto it = cache.find(vertices);
  if (it == cache.end()) it = cache.emplace(vertices, Outfit(vertices)).first;
  return it->second;
}

void BM_step(benchmark::State& state) {
  const Outfit& o = outfit(std::size_t(state.range(0)));
  DressedCharacter character(o.body, o.garments);
  std::size_t k = 0;
  for (auto _ : state) {
    character.step(o.walk[k++ % o.walk.size()]);
    benchmark::DoNotOptimize(character.garment_positions(0).data());
  }
  state.counters["fps"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["garment_vertices"] = double(2 * state.range(0));
}
BENCHMARK(BM_step)->Arg(5000)->Arg(50000)->Unit(benchmark::kMillisecond);

void BM_step_and_measure(benchmark::State& state) {
  const Outfit& o = outfit(std::size_t(state.range(0)));
  DressedCharacter character(o.body, o.garments);
  std::size_t k = 0;
  for (auto _ : state) {
    character.step(o.walk[k++ % o.walk.size()]);
    benchmark::DoNotOptimize(character.measure().inside);
  }
}
BENCHMARK(BM_step_and_measure)->Arg(5000)->Unit(benchmark::kMillisecond);

} // namespace
} // namespace vfit

BENCHMARK_MAIN();
