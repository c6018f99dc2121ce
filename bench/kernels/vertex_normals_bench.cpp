// SPDX-License-Identifier: Apache-2.0
// Area-weighted vertex normals: vertices/s for the serial reference, TBB (1 and all threads)
// Throughput is per wall-clock second (UseRealTime): the parallel backends work off the main thread.
// and OpenCL (PoCL on the CPU, or a GPU where the ICD has one), 10^3–10^6 vertices.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/opencl_vertex_normals.h"
#include "vfit/kernels/vertex_normals.h"

namespace {

// A sphere with about `vertices` vertices (segments = 2·rings), cached per size.
const vfit::Mesh& sphere(std::int64_t vertices) {
  static std::map<std::int64_t, vfit::Mesh> cache;
  auto it = cache.find(vertices);
  if (it != cache.end()) return it->second;
  const int rings = std::max(2, int(std::lround(std::sqrt(double(vertices) / 2.0))));
  return cache.emplace(vertices, vfit::make_uv_sphere(rings, 2 * rings, 1.0f)).first->second;
}

void sizes(benchmark::internal::Benchmark* b) {
  for (std::int64_t n : {1000, 10000, 100000, 1000000})
    b->Arg(n);
  b->Unit(benchmark::kMicrosecond)->UseRealTime();
}

void BM_normals_serial(benchmark::State& state) {
  const vfit::Mesh& m = sphere(state.range(0));
  std::vector<float> n;
  for (auto _ : state) {
    vfit::vertex_normals_serial(m.position_view(), m.triangle_view(), n);
    benchmark::DoNotOptimize(n.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.vertex_count()));
  state.counters["vertices"] = double(m.vertex_count());
}
BENCHMARK(BM_normals_serial)->Apply(sizes);

void BM_normals_tbb(benchmark::State& state) {
  const vfit::Mesh& m = sphere(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(1)));
  const auto adj = vfit::build_vertex_face_adjacency(m.triangle_view(), m.vertex_count());
  std::vector<float> scratch, n;
  for (auto _ : state) {
    vfit::vertex_normals_tbb(m.position_view(), m.triangle_view(), adj, scratch, n);
    benchmark::DoNotOptimize(n.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.vertex_count()));
  state.counters["threads"] = double(state.range(1));
}
BENCHMARK(BM_normals_tbb)
    ->ArgsProduct({{1000, 10000, 100000, 1000000}, {1, 2}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

void BM_normals_opencl(benchmark::State& state) {
  if (vfit::list_opencl_devices().empty()) {
    state.SkipWithError("no OpenCL device");
    return;
  }
  static std::unique_ptr<vfit::OpenClContext> ctx = std::make_unique<vfit::OpenClContext>();
  const vfit::Mesh& m = sphere(state.range(0));
  vfit::OpenClVertexNormals kernel(*ctx, m.triangle_view(), m.vertex_count());
  std::vector<float> n;
  kernel.compute(m.position_view(), n); // builds the program once, outside the timing
  for (auto _ : state) {
    // Includes the upload of positions and the read-back of normals.
    kernel.compute(m.position_view(), n);
    benchmark::DoNotOptimize(n.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.vertex_count()));
  state.SetLabel(ctx->device().device_name);
}
BENCHMARK(BM_normals_opencl)->Apply(sizes);

// The default OpenCL device's memory bandwidth: a device-to-device copy of range(0) MiB
// (OpenClContext::copy_bandwidth_gbps, best of 5 per iteration). The baseline for the device
// kernels' model traffic (vfit_cloth_bench's BM_rk4_opencl* report model_GBps): run both in one
// command and divide.
void BM_opencl_copy(benchmark::State& state) {
  if (vfit::list_opencl_devices().empty()) {
    state.SkipWithError("no OpenCL device");
    return;
  }
  static std::unique_ptr<vfit::OpenClContext> ctx = std::make_unique<vfit::OpenClContext>();
  const std::size_t bytes = std::size_t(state.range(0)) << 20;
  double best = 0;
  for (auto _ : state)
    best = std::max(best, ctx->copy_bandwidth_gbps(bytes));
  state.counters["copy_GBps"] = best;
  state.SetLabel(ctx->device().device_name);
}
BENCHMARK(BM_opencl_copy)->Arg(16)->Arg(256)->Arg(1024)->Iterations(3)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
