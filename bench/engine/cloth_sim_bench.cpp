// SPDX-License-Identifier: Apache-2.0
// ClothSim's body broad phases and backends:
// - BM_body_queries: closest-point queries/s of the Embree BVH (ProximityIndex) and of seed 004's
//   spatial hash (SpatialHash, Teschner et al. 2003) against the default mannequin (7,000
//   vertices), 10^4 and 10^5 particles near the surface (N(0, 2 cm) off it), within the contact
//   search radius (5 cm); serial and TBB at 1 and 2 threads. The hash rows carry
//   `hash_over_bvh`, their queries/s over the BVH's at the same size and threads.
// - BM_hash_cell_size: the hash's serial queries/s with cells of 0.5–4 × the mean edge length.
// - BM_body_update: rebuilding the hash (SpatialHash::update) vs refitting the BVH when the body
//   moves.
// - BM_tee_step: one ClothSim::step(1/60 s) (implicit Euler, contacts after each of its two
//   steps) of a 6,000-vertex tee draped on the A-pose mannequin, with either broad phase;
//   `hash_over_bvh` is the BVH's step time over the hash's (> 1: the hash is faster).
// - BM_rk4_backend: one ClothSim::step of 10 RK4 substeps of a 1 m square of 10^4 and 10^5
//   particles (jersey) pinned at two corners, on TBB (2 threads) and OpenCL (the first device:
//   PoCL on the CPU here), with no body (one upload and one read of the state per step) and
//   with a body (a small sphere far away) and contact_interval = 2 substeps: 5 contact windows
//   per step, each an upload, 2 substeps on the device and a read (the worst case of the
//   host-side contacts; the default 1/240 s window holds hundreds of substeps at these sizes).
//   `opencl_over_tbb` is the TBB step time over OpenCL's (> 1: OpenCL is faster).
// - BM_implicit_multiply: the implicit Euler system's product A·p (the CG's inner kernel) for
//   10^4 and 10^5 particles: the serial host reference, the OpenCL kernel on device-resident
//   vectors, and the OpenCL product with p uploaded and A·p read back per call.
// Fixed seeds; throughput per wall-clock second (UseRealTime).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "vfit/engine/cloth/cloth_sim.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/cloth_implicit.h"
#include "vfit/kernels/cloth_springs.h"
#ifdef VFIT_WITH_OPENCL
#include "vfit/kernels/opencl_cloth.h"
#endif
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/spatial_hash.h"

namespace {

constexpr float SEARCH_RADIUS = 0.05f; // ClothOptions::contact_search_radius

const vfit::Body& mannequin() {
  static const vfit::Body body = [] {
    vfit::MannequinOptions mo;
    mo.pose = vfit::RestPose::APOSE;
    return vfit::make_mannequin(mo);
  }();
  return body;
}

const std::vector<float>& queries(std::int64_t count) {
  static std::map<std::int64_t, std::vector<float>> cache;
  std::vector<float>& q = cache[count];
  if (!q.empty()) return q;
  const vfit::Mesh& m = mannequin().mesh;
  std::mt19937 rng(1234u);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> offset(0.0f, 0.02f);
  for (std::int64_t i = 0; i < count; ++i) {
    const std::size_t f = std::size_t(unit(rng) * float(m.face_count())) % m.face_count();
    float u = unit(rng), v = unit(rng);
    if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
    for (int k = 0; k < 3; ++k) {
      const float a = m.positions[3 * m.triangles[3 * f] + k], b = m.positions[3 * m.triangles[3 * f + 1] + k],
                  c = m.positions[3 * m.triangles[3 * f + 2] + k];
      q.push_back((1 - u - v) * a + u * b + v * c + offset(rng));
    }
  }
  return q;
}

// Seconds per iteration of earlier rows, for the ratios: key (family, size, threads, variant).
std::map<std::tuple<int, std::int64_t, std::int64_t, int>, double>& timings() {
  static std::map<std::tuple<int, std::int64_t, std::int64_t, int>, double> t;
  return t;
}

// range(0): #queries; range(1): 0 = BVH, 1 = hash; range(2): threads (0 = the serial entry).
void BM_body_queries(benchmark::State& state) {
  const vfit::Mesh& m = mannequin().mesh;
  const std::vector<float>& q = queries(state.range(0));
  const bool hash = state.range(1) == 1;
  const std::int64_t threads = state.range(2);
  tbb::global_control control(tbb::global_control::max_allowed_parallelism,
                              std::size_t(std::max<std::int64_t>(1, threads)));
  const vfit::ProximityIndex bvh(m.position_view(), m.triangle_view());
  const vfit::SpatialHash grid(m.position_view(), m.triangle_view());
  vfit::ClosestHits hits;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    if (hash)
      threads == 0 ? grid.closest_points_serial(q, SEARCH_RADIUS, hits) : grid.closest_points(q, SEARCH_RADIUS, hits);
    else
      threads == 0 ? bvh.closest_points_serial(q, SEARCH_RADIUS, hits) : bvh.closest_points(q, SEARCH_RADIUS, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  const double per =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / double(state.iterations());
  timings()[{0, state.range(0), threads, int(hash)}] = per;
  if (hash) {
    state.counters["hash_over_bvh"] = timings()[{0, state.range(0), threads, 0}] / per;
    state.counters["cell_mm"] = 1e3 * grid.cell_size();
    state.counters["entries"] = double(grid.entry_count());
  }
  state.counters["threads"] = double(threads);
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetLabel(hash ? "spatial_hash" : "bvh");
}
BENCHMARK(BM_body_queries)
    ->ArgsProduct({{10000, 100000}, {0, 1}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The cell-size choice: serial hash queries (10^5) with the cell at range(0) % of the mean
// edge length (100 = the default).
void BM_hash_cell_size(benchmark::State& state) {
  const vfit::Mesh& m = mannequin().mesh;
  const std::vector<float>& q = queries(100000);
  const float mean_edge = vfit::SpatialHash(m.position_view(), m.triangle_view()).cell_size();
  const vfit::SpatialHash grid(m.position_view(), m.triangle_view(), mean_edge * float(state.range(0)) / 100.0f);
  vfit::ClosestHits hits;
  for (auto _ : state) {
    grid.closest_points_serial(q, SEARCH_RADIUS, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  state.counters["cell_mm"] = 1e3 * grid.cell_size();
  state.counters["entries"] = double(grid.entry_count());
  state.SetItemsProcessed(state.iterations() * 100000);
}
BENCHMARK(BM_hash_cell_size)->Arg(50)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond)->UseRealTime();

// range(0): 0 = BVH refit, 1 = hash update, of the mannequin moved by 1 mm per iteration.
void BM_body_update(benchmark::State& state) {
  const vfit::Mesh& m = mannequin().mesh;
  vfit::ProximityIndex bvh(m.position_view(), m.triangle_view());
  vfit::SpatialHash grid(m.position_view(), m.triangle_view());
  std::vector<float> moved = m.positions;
  for (auto _ : state) {
    for (std::size_t i = 0; i < moved.size(); i += 3)
      moved[i] += 1e-3f;
    if (state.range(0) == 1)
      grid.update(moved);
    else
      bvh.refit(moved);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.face_count()));
  state.SetLabel(state.range(0) == 1 ? "spatial_hash" : "bvh");
}
BENCHMARK(BM_body_update)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

const vfit::Mesh& tee() {
  static const vfit::Mesh mesh = [] {
    vfit::GarmentOptions go;
    go.type = vfit::GarmentType::TEE;
    go.pose = vfit::RestPose::APOSE;
    go.target_vertices = 6000;
    return vfit::make_garment(go).mesh;
  }();
  return mesh;
}

// range(0): 0 = BVH, 1 = hash. The tee falls for 0.5 s untimed first, so the timed steps have
// contacts on the shoulders.
void BM_tee_step(benchmark::State& state) {
  const bool hash = state.range(0) == 1;
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, 2);
  vfit::ClothOptions o;
  o.broad_phase = hash ? vfit::ClothBroadPhase::SPATIAL_HASH : vfit::ClothBroadPhase::BVH;
  vfit::ClothSim sim(tee().position_view(), tee().triangle_view(), o);
  sim.set_body(mannequin().mesh.position_view(), mannequin().mesh.triangle_view());
  for (int f = 0; f < 30; ++f)
    sim.step(1.0 / 60.0);
  std::size_t contacts = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state)
    contacts += sim.step(1.0 / 60.0).contacts;
  const double per =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / double(state.iterations());
  timings()[{1, 0, 2, int(hash)}] = per;
  if (hash) state.counters["hash_over_bvh"] = timings()[{1, 0, 2, 0}] / per;
  state.counters["contacts_per_step"] = double(contacts) / double(state.iterations());
  state.counters["vertices"] = double(tee().vertex_count());
  state.SetItemsProcessed(state.iterations() * std::int64_t(tee().vertex_count()));
  state.SetLabel(hash ? "spatial_hash" : "bvh");
}
BENCHMARK(BM_tee_step)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// range(0): particles (a square grid of about that many); range(1): 0 = TBB, 1 = OpenCL;
// range(2): 1 = with a body (contact windows, each an upload and a read of the state).
void BM_rk4_backend(benchmark::State& state) {
  const bool opencl = state.range(1) == 1;
  const bool with_body = state.range(2) == 1;
  if (opencl && vfit::list_opencl_devices().empty()) {
    state.SkipWithError("no OpenCL device");
    return;
  }
  const int side = int(std::lround(std::sqrt(double(state.range(0)))));
  const vfit::Mesh grid = vfit::make_grid(side, side, 1.0f, 1.0f);
  tbb::global_control control(tbb::global_control::max_allowed_parallelism, 2);
  vfit::ClothOptions o;
  o.integrator = vfit::ClothIntegrator::RK4;
  o.backend = opencl ? vfit::Backend::OPENCL : vfit::Backend::TBB;
  vfit::ClothSim probe(grid.position_view(), grid.triangle_view(), o);
  probe.pin(std::vector<std::int32_t>{0, side - 1});
  const double dt = 10 * probe.stable_substep();
  o.contact_interval = 2 * probe.stable_substep();
  vfit::ClothSim sim(grid.position_view(), grid.triangle_view(), o);
  sim.pin(std::vector<std::int32_t>{0, side - 1});
  const vfit::Mesh ball = vfit::make_uv_sphere(8, 16, 0.1f);
  if (with_body) {
    std::vector<float> far = ball.positions;
    for (std::size_t i = 1; i < far.size(); i += 3)
      far[i] -= 10.0f;
    sim.set_body(far, ball.triangle_view());
  }
  vfit::ClothStepReport r = sim.step(dt); // builds the device kernels (untimed)
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state)
    r = sim.step(dt);
  const double per =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / double(state.iterations());
  timings()[{2, state.range(0), state.range(2), int(opencl)}] = per;
  if (opencl) state.counters["opencl_over_tbb"] = timings()[{2, state.range(0), state.range(2), 0}] / per;
  state.counters["particles"] = double(sim.particle_count());
  state.counters["substeps"] = double(r.substeps);
  state.counters["ms_per_substep"] = 1e3 * per / double(r.substeps);
  state.counters["ok"] = r.status == vfit::ClothStatus::OK ? 1.0 : 0.0;
  state.SetItemsProcessed(state.iterations() * std::int64_t(r.substeps) * std::int64_t(sim.particle_count()));
  state.SetLabel(std::string(opencl ? "opencl" : "tbb") + (with_body ? "+body" : ""));
}
BENCHMARK(BM_rk4_backend)->ArgsProduct({{10000, 100000}, {0, 1}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef VFIT_WITH_OPENCL
// range(0): particles; range(1): 0 = serial host, 1 = OpenCL kernel only, 2 = OpenCL with the
// vector's upload and the product's read.
void BM_implicit_multiply(benchmark::State& state) {
  const int mode = int(state.range(1));
  if (mode > 0 && vfit::list_opencl_devices().empty()) {
    state.SkipWithError("no OpenCL device");
    return;
  }
  const int side = int(std::lround(std::sqrt(double(state.range(0)))));
  const vfit::Mesh grid = vfit::make_grid(side, side, 1.0f, 1.0f);
  vfit::ClothSprings springs = vfit::build_cloth_springs(grid.position_view(), grid.triangle_view());
  for (std::size_t e = 0; e < springs.size(); ++e) {
    springs.stiffness[e] = springs.kinds[e] == vfit::SpringKind::BENDING ? 0.5f : 50.0f;
    springs.damping[e] = 1e-4f;
  }
  const vfit::SpringAdjacency adjacency = vfit::build_spring_adjacency(springs, grid.vertex_count());
  vfit::ClothParticles particles;
  particles.inverse_masses.assign(grid.vertex_count(), float(grid.vertex_count()) / 0.15f);
  std::vector<float> x = grid.positions, v(x.size(), 0.0f), p(x.size()), out;
  std::mt19937 rng(99u);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  for (float& q : p)
    q = normal(rng);
  vfit::ImplicitSystem system;
  vfit::assemble_implicit_system(x, v, adjacency, particles, 1.0f / 120.0f, system, false);
  std::unique_ptr<vfit::OpenClContext> ctx;
  std::unique_ptr<vfit::OpenClImplicitMultiply> device;
  if (mode > 0) {
    ctx = std::make_unique<vfit::OpenClContext>();
    device = std::make_unique<vfit::OpenClImplicitMultiply>(*ctx, adjacency);
    device->set_system(system);
    device->multiply(p, out); // builds the kernel (untimed)
    state.SetLabel(ctx->device().device_name);
  }
  for (auto _ : state) {
    if (mode == 0) {
      vfit::implicit_system_multiply(system, adjacency, p, out);
    } else if (mode == 1) {
      device->multiply_on_device(10);
      device->finish();
    } else {
      device->multiply(p, out);
    }
    benchmark::DoNotOptimize(out.data());
  }
  const std::int64_t per_iteration = mode == 1 ? 10 : 1;
  state.counters["entries"] = double(adjacency.neighbors.size());
  state.SetItemsProcessed(state.iterations() * per_iteration * std::int64_t(grid.vertex_count()));
}
BENCHMARK(BM_implicit_multiply)
    ->ArgsProduct({{10000, 100000}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
#endif

} // namespace

BENCHMARK_MAIN();
