// SPDX-License-Identifier: Apache-2.0
// Garment segmentation (seed 000 §4) speed: per catalogue type over vertex counts, and the
// Table-1 twins (the paper: 159–987 ms per garment on an Intel 4 × 2.5 GHz). Serial by
// design: one garment is a few ms. Reports vertices/s; garments are generated once, untimed.
#include <map>

#include <benchmark/benchmark.h>

#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/garment/table1.h"
#include "vfit/geometry/garment/thick_shell.h"
#include "vfit/geometry/mesh/primitives.h"

namespace {

const vfit::Mesh& catalogue_mesh(vfit::GarmentType type, std::size_t vertices) {
  static std::map<std::pair<int, std::size_t>, vfit::Garment> cache;
  const auto key = std::make_pair(int(type), vertices);
  auto it = cache.find(key);
  if (it == cache.end()) {
    vfit::GarmentOptions o;
    o.type = type;
    o.pose = vfit::RestPose::APOSE;
    o.target_vertices = vertices;
    it = cache.emplace(key, vfit::make_garment(o)).first;
  }
  return it->second.mesh;
}

void BM_segment(benchmark::State& state) {
  const auto type = static_cast<vfit::GarmentType>(state.range(0));
  const vfit::Mesh& mesh = catalogue_mesh(type, std::size_t(state.range(1)));
  vfit::SegmentationTimings stages;
  for (auto _ : state) {
    vfit::GarmentSegmentation s = vfit::segment_garment(mesh);
    stages = s.timings;
    benchmark::DoNotOptimize(s.vertex_parts.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(1));
  state.SetLabel(vfit::garment_type_name(type));
  // The last run's stages (ms), to see where the time goes.
  state.counters["graph_ms"] = stages.graph_ms;
  state.counters["geodesic_ms"] = stages.geodesic_ms;
  state.counters["reeb_ms"] = stages.reeb_ms;
  state.counters["classify_ms"] = stages.classify_ms;
  state.counters["refine_ms"] = stages.refine_ms;
}
BENCHMARK(BM_segment)
    ->ArgsProduct({{int(vfit::GarmentType::TEE), int(vfit::GarmentType::LONG_SLEEVE), int(vfit::GarmentType::TROUSERS),
                    int(vfit::GarmentType::SHORTS), int(vfit::GarmentType::DRESS), int(vfit::GarmentType::SKIRT)},
                   {1000, 5000, 20000}})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_segment)
    ->ArgsProduct({{int(vfit::GarmentType::TEE), int(vfit::GarmentType::TROUSERS)}, {100000}})
    ->Unit(benchmark::kMillisecond);

// The nine garments of Table 1 at the paper's vertex counts; the paper's ms as a counter.
void BM_segment_table1(benchmark::State& state) {
  const vfit::Table1Row& row = vfit::table1_rows().at(std::size_t(state.range(0)));
  static std::map<std::int64_t, vfit::Garment> cache;
  auto it = cache.find(state.range(0));
  if (it == cache.end())
    it = cache.emplace(state.range(0), vfit::make_garment(vfit::table1_garment_options(row))).first;
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::segment_garment(it->second.mesh).vertex_parts.data());
  state.SetItemsProcessed(state.iterations() * std::int64_t(row.vertices));
  state.SetLabel(row.garment);
  state.counters["paper_ms"] = row.paper_segmentation_ms;
}
BENCHMARK(BM_segment_table1)->DenseRange(0, 8)->Unit(benchmark::kMillisecond);

// find_thick_shell() on the plain tee (the cost every garment pays: one sheet is told apart
// before any ray) and on the tee solidified (the rays and the carrying set-up).
void BM_find_thick_shell(benchmark::State& state) {
  const vfit::Mesh& tee = catalogue_mesh(vfit::GarmentType::TEE, std::size_t(state.range(0)));
  static std::map<std::size_t, vfit::Mesh> thick;
  const bool solid = state.range(1) != 0;
  if (solid && !thick.contains(tee.vertex_count()))
    thick.emplace(tee.vertex_count(), vfit::make_solidified(tee, 0.003f, true));
  const vfit::Mesh& mesh = solid ? thick.at(tee.vertex_count()) : tee;
  std::size_t sheet_vertices = 0;
  for (auto _ : state) {
    const auto shell = vfit::find_thick_shell(mesh);
    sheet_vertices = shell ? shell->sheet.vertex_count() : 0;
    benchmark::DoNotOptimize(sheet_vertices);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(mesh.vertex_count()));
  state.counters["sheet_vertices"] = double(sheet_vertices);
  state.SetLabel(solid ? "solidified tee" : "tee");
}
BENCHMARK(BM_find_thick_shell)->ArgsProduct({{10000, 100000}, {0, 1}})->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
