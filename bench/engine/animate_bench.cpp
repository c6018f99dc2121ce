// SPDX-License-Identifier: Apache-2.0
// A dressed character stepped frame by frame (engine/animate/dressed_character.h): the demo
// outfit (catalogue trousers P2 and tee M, A-pose) on the A-pose mannequin through a walk cycle
// (walk_cycle(), pose_io.h): a whole frame (skinning, cloth, blend, clean-up, layering) at
// 30 and 60 frames per second, skinning alone, and a frame with the per-frame measure.
//   build/release/bench/vfit_animate_bench
// Arguments: garment vertices each (5,000 is the demo outfit's), frames per second. Counters:
// frames per second, each stage's mean time (ms), CG iterations and contacts per frame.
#include <map>

#include <benchmark/benchmark.h>

#include "vfit/engine/animate/dressed_character.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"

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
    walk = walk_cycle(RestPose::APOSE).frames; // one second at 30 fps
  }
};

const Outfit& outfit(std::size_t vertices) {
  static std::map<std::size_t, Outfit> cache;
  auto it = cache.find(vertices);
  if (it == cache.end()) it = cache.emplace(vertices, Outfit(vertices)).first;
  return it->second;
}

void run_frames(benchmark::State& state, const AnimationOptions& options, double fps) {
  const Outfit& o = outfit(std::size_t(state.range(0)));
  DressedCharacter character(o.body, o.garments, options);
  // The same one-second walk, sampled at the frame rate.
  const std::vector<Pose> walk = walk_cycle(RestPose::APOSE, fps, std::size_t(fps)).frames;
  std::size_t k = 0;
  FrameReport sum;
  for (auto _ : state) {
    sum.add(character.step(walk[k++ % walk.size()], 1.0 / fps));
    benchmark::DoNotOptimize(character.garment_positions(0).data());
  }
  const double n = double(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.counters["lbs_ms"] = sum.lbs_ms / n;
  state.counters["physics_ms"] = sum.physics_ms / n;
  state.counters["blend_ms"] = sum.blend_ms / n;
  state.counters["cleanup_ms"] = sum.cleanup_ms / n;
  state.counters["layering_ms"] = sum.layering_ms / n;
  state.counters["cg_iterations"] = double(sum.solver_iterations) / n;
  state.counters["contacts"] = double(sum.contacts) / n;
  state.counters["fps"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["garment_vertices"] = double(2 * state.range(0));
}

void BM_step(benchmark::State& state) { run_frames(state, AnimationOptions{}, double(state.range(1))); }
BENCHMARK(BM_step)->Args({5000, 30})->Args({5000, 60})->Args({50000, 30})->Unit(benchmark::kMillisecond);

// Linear blend skinning alone (the physics and the clean-up off).
void BM_step_lbs(benchmark::State& state) {
  AnimationOptions o;
  o.physics = false;
  o.clean_up = false;
  run_frames(state, o, 30);
}
BENCHMARK(BM_step_lbs)->Arg(5000)->Arg(50000)->Unit(benchmark::kMillisecond);

void BM_step_and_measure(benchmark::State& state) {
  const Outfit& o = outfit(std::size_t(state.range(0)));
  DressedCharacter character(o.body, o.garments);
  std::size_t k = 0;
  for (auto _ : state) {
    character.step(o.walk[k++ % o.walk.size()], 1.0 / 30);
    benchmark::DoNotOptimize(character.measure().inside);
  }
}
BENCHMARK(BM_step_and_measure)->Arg(5000)->Unit(benchmark::kMillisecond);

} // namespace
} // namespace vfit

BENCHMARK_MAIN();
