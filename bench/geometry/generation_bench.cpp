// SPDX-License-Identifier: Apache-2.0
// Generation time of the built-in mannequin and catalogue garments per size (vertices/s).
#include <benchmark/benchmark.h>

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/garment/catalogue.h"

namespace {

void BM_mannequin(benchmark::State& state) {
  vfit::MannequinOptions o;
  o.target_vertices = static_cast<std::size_t>(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::make_mannequin(o));
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_mannequin)->Arg(1000)->Arg(7000)->Arg(20000)->Arg(100000)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_garment(benchmark::State& state) {
  vfit::GarmentOptions o;
  o.type = static_cast<vfit::GarmentType>(state.range(0));
  o.target_vertices = static_cast<std::size_t>(state.range(1));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::make_garment(o));
  state.SetItemsProcessed(state.iterations() * state.range(1));
  state.SetLabel(vfit::garment_type_name(o.type));
}
BENCHMARK(BM_garment)
    ->ArgsProduct({{int(vfit::GarmentType::TEE), int(vfit::GarmentType::TROUSERS), int(vfit::GarmentType::DRESS)},
                   {1000, 10000, 100000}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

} // namespace

BENCHMARK_MAIN();
