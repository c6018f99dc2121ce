// SPDX-License-Identifier: Apache-2.0
// Mesh I/O throughput: OBJ parsing in MB/s against the speed of reading the same file's bytes
// (the "disk speed" bound: from the page cache), plus OBJ writing and full read_mesh
// (parse + validation), for 10^4–10^6-vertex meshes.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/obj_format.h"
#include "vfit/geometry/mesh/orient.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/weld.h"

namespace {

struct Fixture {
  vfit::Mesh mesh;
  std::string obj;
  std::filesystem::path file;
};

const Fixture& fixture(std::int64_t vertices) {
  static std::map<std::int64_t, Fixture> cache;
  auto it = cache.find(vertices);
  if (it != cache.end()) return it->second;
  const int rings = std::max(2, int(std::lround(std::sqrt(double(vertices) / 2.0))));
  Fixture f;
  f.mesh = vfit::make_uv_sphere(rings, 2 * rings, 0.8f);
  f.obj = vfit::write_obj(f.mesh);
  f.file = std::filesystem::temp_directory_path() / ("vfit_bench_" + std::to_string(vertices) + ".obj");
  vfit::write_file_atomically(f.file, f.obj);
  return cache.emplace(vertices, std::move(f)).first->second;
}

void BM_read_bytes(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::read_file_bytes(f.file));
  state.SetBytesProcessed(state.iterations() * std::int64_t(f.obj.size()));
}
BENCHMARK(BM_read_bytes)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_parse_obj(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(1)));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::read_obj(f.obj, "bench.obj"));
  state.SetBytesProcessed(state.iterations() * std::int64_t(f.obj.size()));
  state.SetItemsProcessed(state.iterations() * std::int64_t(f.mesh.vertex_count()));
  state.counters["threads"] = double(state.range(1));
}
BENCHMARK(BM_parse_obj)->ArgsProduct({{10000, 100000, 1000000}, {1, 2}})->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_read_mesh_obj(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::read_mesh(f.file));
  state.SetBytesProcessed(state.iterations() * std::int64_t(f.obj.size()));
}
BENCHMARK(BM_read_mesh_obj)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_write_obj(benchmark::State& state) {
  const Fixture& f = fixture(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(vfit::write_obj(f.mesh));
  state.SetBytesProcessed(state.iterations() * std::int64_t(f.obj.size()));
}
BENCHMARK(BM_write_obj)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();

// weld_coincident_vertices() on a clean mesh (the fit pipeline runs it on every garment; it
// finds nothing and changes nothing) and on the same sphere with every triangle's corners
// unshared (3 copies per vertex, as some exporters write: everything to weld).
void BM_weld(benchmark::State& state) {
  const vfit::Mesh& clean = fixture(state.range(0)).mesh;
  vfit::Mesh input = clean;
  if (state.range(1)) {
    input.positions.clear();
    for (std::size_t i = 0; i < clean.triangles.size(); ++i) {
      const auto v = std::size_t(clean.triangles[i]);
      input.positions.insert(input.positions.end(), clean.positions.begin() + std::ptrdiff_t(3 * v),
                             clean.positions.begin() + std::ptrdiff_t(3 * v + 3));
      input.triangles[i] = std::int32_t(i);
    }
  }
  for (auto _ : state) {
    state.PauseTiming();
    vfit::Mesh m = input;
    state.ResumeTiming();
    benchmark::DoNotOptimize(vfit::weld_coincident_vertices(m));
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(input.vertex_count()));
}
BENCHMARK(BM_weld)->ArgsProduct({{10000, 100000, 1000000}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

// orient_consistently() on a consistently wound mesh (the fit pipeline runs it on every garment
// and body mesh: nothing to turn) and with every third triangle turned over.
void BM_orient(benchmark::State& state) {
  vfit::Mesh input = fixture(state.range(0)).mesh;
  if (state.range(1))
    for (std::size_t f = 0; f < input.face_count(); f += 3)
      std::swap(input.triangles[3 * f + 1], input.triangles[3 * f + 2]);
  for (auto _ : state) {
    state.PauseTiming();
    vfit::Mesh m = input;
    state.ResumeTiming();
    benchmark::DoNotOptimize(vfit::orient_consistently(m));
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(input.face_count()));
}
BENCHMARK(BM_orient)->ArgsProduct({{10000, 100000, 1000000}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
