// SPDX-License-Identifier: Apache-2.0
// Closest-point queries: queries/s for ProximityIndex (serial entry, TBB at 1 and 2 threads),
// for raw Embree rtcPointQuery with a minimal callback over the same scene set-up and queries
// (the floor our wrapper adds to), for brute force (10^3 queries only), for CGAL's AABB_tree
// (when CGAL was found at configure time) and for OpenClProximity (the flat-BVH OpenCL path;
// PoCL on the CPU here), 10^3–10^6 queries against the 7k-vertex mannequin and a 100k-triangle
// sphere. Also the mannequin with three holes (the hole-cap side fallback), and build vs
// refit times.
// Ratios (counters): each peer's row carries `ours_ratio` = ProximityIndex's queries/s over the
// peer's on the same queries and mesh, measured earlier in the same run: the serial entry for
// brute force, the TBB entry at the same thread count for raw Embree and CGAL, at 2 threads for
// OpenCL and the open body. On the raw-Embree row ours_ratio ≥ 0.8 is the bar.
// Throughput is per wall-clock second (UseRealTime): the parallel runs work off the main thread.
// Queries: points of the surface moved by N(0, 2 cm) in each axis, like garment vertices near
// a body; fixed seed.
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <chrono>

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/opencl_proximity.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/proximity.h"

#ifdef VFIT_BENCH_CGAL
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#endif

namespace {
using std::sqrt;
#include "vfit/kernels/closest_point_math.h"

constexpr float NO_LIMIT = std::numeric_limits<float>::infinity();

// Mesh 0: the default mannequin (7,000 vertices); mesh 1: a UV sphere of 100,488 triangles.
const vfit::Mesh& mesh(std::int64_t id) {
  static const vfit::Mesh mannequin = vfit::make_mannequin(vfit::MannequinOptions{}).mesh;
  static const vfit::Mesh sphere = vfit::make_uv_sphere(159, 318, 1.0f);
  return id == 0 ? mannequin : sphere;
}

const std::vector<float>& queries(std::int64_t mesh_id, std::int64_t count) {
  static std::map<std::pair<std::int64_t, std::int64_t>, std::vector<float>> cache;
  auto& q = cache[{mesh_id, count}];
  if (!q.empty()) return q;
  const vfit::Mesh& m = mesh(mesh_id);
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

void name(benchmark::State& state) {
  state.SetLabel(state.range(0) == 0 ? "mannequin" : "sphere100k");
  state.SetItemsProcessed(state.iterations() * state.range(1));
}

// Queries/s of ProximityIndex per (mesh, count, threads; 0 = the serial entry), recorded by its
// benchmarks for the peers' ratio counters.
std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, double>& our_rates() {
  static std::map<std::tuple<std::int64_t, std::int64_t, std::int64_t>, double> rates;
  return rates;
}

// Wall-clock seconds of a benchmark loop, for the rates (the State's own timer is not exposed).
struct LoopClock {
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  double rate(benchmark::State& state) const {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return s > 0 ? double(state.iterations()) * double(state.range(1)) / s : 0.0;
  }
};

void record_ours(benchmark::State& state, const LoopClock& clock, std::int64_t threads) {
  our_rates()[{state.range(0), state.range(1), threads}] = clock.rate(state);
}

// ours_ratio on a peer's row: ProximityIndex's queries/s over the peer's.
void ratio_to_ours(benchmark::State& state, const LoopClock& clock, std::int64_t threads) {
  const auto it = our_rates().find({state.range(0), state.range(1), threads});
  const double peer = clock.rate(state);
  if (it != our_rates().end() && peer > 0) state.counters["ours_ratio"] = it->second / peer;
}

void BM_proximity_serial(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  const vfit::ProximityIndex index(m.position_view(), m.triangle_view());
  const auto& q = queries(state.range(0), state.range(1));
  vfit::ClosestHits hits;
  const LoopClock clock;
  for (auto _ : state) {
    index.closest_points_serial(q, NO_LIMIT, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  record_ours(state, clock, 0);
  name(state);
}
BENCHMARK(BM_proximity_serial)
    ->ArgsProduct({{0, 1}, {1000, 10000, 100000, 1000000}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_proximity_tbb(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(2)));
  const vfit::ProximityIndex index(m.position_view(), m.triangle_view());
  const auto& q = queries(state.range(0), state.range(1));
  vfit::ClosestHits hits;
  const LoopClock clock;
  for (auto _ : state) {
    index.closest_points(q, NO_LIMIT, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  record_ours(state, clock, state.range(2));
  name(state);
  state.counters["threads"] = double(state.range(2));
}
BENCHMARK(BM_proximity_tbb)
    ->ArgsProduct({{0, 1}, {1000, 10000, 100000, 1000000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Raw Embree: the same scene set-up as ProximityIndex (robust, dynamic two-level, REFIT geometry), a
// callback that only measures the triangle and shrinks the radius, and the distance kept.
struct RawScene {
  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = rtcNewScene(device);
  const vfit::Mesh* mesh;
  explicit RawScene(const vfit::Mesh& m) : mesh(&m) {
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_DYNAMIC);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m.vertex_count()));
    auto* t = static_cast<std::int32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(std::int32_t), m.face_count()));
    std::copy(m.positions.begin(), m.positions.end(), v);
    std::copy(m.triangles.begin(), m.triangles.end(), t);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) throw std::runtime_error("Embree set-up failed");
  }
  ~RawScene() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
};

struct RawQuery {
  const vfit::Mesh* mesh;
  vfit_vec3 q;
  float best2;
};

vfit_vec3 corner(const vfit::Mesh& m, unsigned f, int k) {
  const float* p = m.positions.data() + 3 * std::size_t(m.triangles[3 * std::size_t(f) + k]);
  return vfit_vec3{p[0], p[1], p[2]};
}

bool raw_callback(RTCPointQueryFunctionArguments* args) {
  auto* s = static_cast<RawQuery*>(args->userPtr);
  const vfit::Mesh& m = *s->mesh;
  const vfit_closest_point c = vfit_closest_point_on_triangle(s->q, corner(m, args->primID, 0),
                                                              corner(m, args->primID, 1), corner(m, args->primID, 2));
  if (c.distance2 >= s->best2) return false;
  s->best2 = c.distance2;
  args->query->radius = std::sqrt(c.distance2);
  return true;
}

void BM_raw_embree(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(2)));
  const RawScene raw(m);
  const auto& q = queries(state.range(0), state.range(1));
  std::vector<float> distances(q.size() / 3);
  const LoopClock clock;
  for (auto _ : state) {
    vfit::parallel_for_range(distances.size(), vfit::PROXIMITY_QUERY_GRAIN, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        RawQuery s{&m, vfit_vec3{q[3 * i], q[3 * i + 1], q[3 * i + 2]}, NO_LIMIT};
        RTCPointQuery query{s.q.x, s.q.y, s.q.z, 0.0f, NO_LIMIT};
        RTCPointQueryContext context;
        rtcInitPointQueryContext(&context);
        rtcPointQuery(raw.scene, &query, &context, raw_callback, &s);
        distances[i] = std::sqrt(s.best2);
      }
    });
    benchmark::DoNotOptimize(distances.data());
  }
  ratio_to_ours(state, clock, state.range(2));
  name(state);
  state.counters["threads"] = double(state.range(2));
}
BENCHMARK(BM_raw_embree)
    ->ArgsProduct({{0, 1}, {1000, 10000, 100000, 1000000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_brute_force(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  const vfit::ProximityIndex index(m.position_view(), m.triangle_view());
  const auto& q = queries(state.range(0), state.range(1));
  vfit::ClosestHits hits;
  const LoopClock clock;
  for (auto _ : state) {
    index.closest_points_brute_force(q, NO_LIMIT, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  ratio_to_ours(state, clock, 0);
  name(state);
}
BENCHMARK(BM_brute_force)->ArgsProduct({{0, 1}, {1000}})->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef VFIT_BENCH_CGAL
// CGAL's AABB_tree (double precision, its kd-tree hint for distance queries built before the
// loop) on the same triangles and queries: closest point and primitive per query. Serial at
// 1 thread; at 2 through the same TBB driver (queries on a built tree are const).
void BM_cgal_aabb_tree(benchmark::State& state) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using Triangles = std::vector<Kernel::Triangle_3>;
  using Primitive = CGAL::AABB_triangle_primitive<Kernel, Triangles::const_iterator>;
  using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
  const vfit::Mesh& m = mesh(state.range(0));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(2)));
  Triangles triangles;
  auto point = [&](std::int32_t v) {
    return Kernel::Point_3(m.positions[3 * std::size_t(v)], m.positions[3 * std::size_t(v) + 1],
                           m.positions[3 * std::size_t(v) + 2]);
  };
  for (std::size_t f = 0; f < m.face_count(); ++f)
    triangles.emplace_back(point(m.triangles[3 * f]), point(m.triangles[3 * f + 1]), point(m.triangles[3 * f + 2]));
  Tree tree(triangles.begin(), triangles.end());
  tree.build();
  tree.accelerate_distance_queries();
  const auto& q = queries(state.range(0), state.range(1));
  std::vector<float> distances(q.size() / 3);
  // One query first, so the lazily built search structure exists before threads share the tree.
  benchmark::DoNotOptimize(tree.closest_point(Kernel::Point_3(q[0], q[1], q[2])));
  const LoopClock clock;
  for (auto _ : state) {
    vfit::parallel_for_range(distances.size(), vfit::PROXIMITY_QUERY_GRAIN, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const Kernel::Point_3 p(q[3 * i], q[3 * i + 1], q[3 * i + 2]);
        const auto hit = tree.closest_point_and_primitive(p);
        distances[i] = float(std::sqrt(CGAL::squared_distance(p, hit.first)));
      }
    });
    benchmark::DoNotOptimize(distances.data());
  }
  ratio_to_ours(state, clock, state.range(2));
  name(state);
  state.counters["threads"] = double(state.range(2));
}
BENCHMARK(BM_cgal_aabb_tree)
    ->ArgsProduct({{0, 1}, {1000, 10000, 100000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
#endif

// OpenClProximity on the first OpenCL device (VFIT_OPENCL_DEVICE selects another); skipped
// when none is installed. Includes the query upload and the answers' read-back. ours_ratio is
// against ProximityIndex at 2 threads.
void BM_opencl(benchmark::State& state) {
  if (vfit::list_opencl_devices().empty()) {
    state.SkipWithError("no OpenCL device");
    return;
  }
  const vfit::Mesh& m = mesh(state.range(0));
  const vfit::ProximityIndex index(m.position_view(), m.triangle_view());
  vfit::OpenClContext context;
  vfit::OpenClProximity gpu(context, index);
  const auto& q = queries(state.range(0), state.range(1));
  vfit::ClosestHits hits;
  gpu.closest_points(q, NO_LIMIT, hits); // warm-up: the program build on first use
  const LoopClock clock;
  for (auto _ : state) {
    gpu.closest_points(q, NO_LIMIT, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  ratio_to_ours(state, clock, 2);
  name(state);
  state.SetLabel(std::string(state.range(0) == 0 ? "mannequin" : "sphere100k") + " " + context.device().device_name);
  state.counters["nodes"] = double(gpu.node_count());
}
BENCHMARK(BM_opencl)
    ->ArgsProduct({{0, 1}, {1000, 10000, 100000, 1000000}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The hole-cap fallback's cost: the mannequin with three holes cut (triangles whose centroid
// lies within 4 cm of vertices 0, #V/3 and 2#V/3), same queries, TBB at 2 threads. ours_ratio
// is the closed mannequin's queries/s over the open one's (the slowdown of an open body).
void BM_proximity_open_body(benchmark::State& state) {
  static const vfit::Mesh open = [] {
    vfit::Mesh m = mesh(0);
    std::vector<std::int32_t> kept;
    for (std::size_t f = 0; f < m.face_count(); ++f) {
      bool cut = false;
      for (std::size_t v : {std::size_t(0), m.vertex_count() / 3, 2 * m.vertex_count() / 3}) {
        float d2 = 0;
        for (int k = 0; k < 3; ++k) {
          float c = 0;
          for (int j = 0; j < 3; ++j)
            c += m.positions[3 * std::size_t(m.triangles[3 * f + j]) + k] / 3.0f;
          d2 += (c - m.positions[3 * v + k]) * (c - m.positions[3 * v + k]);
        }
        cut |= d2 < 0.04f * 0.04f;
      }
      if (!cut)
        kept.insert(kept.end(), m.triangles.begin() + 3 * std::ptrdiff_t(f),
                    m.triangles.begin() + 3 * std::ptrdiff_t(f) + 3);
    }
    m.triangles = kept;
    return m;
  }();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const vfit::ProximityIndex index(open.position_view(), open.triangle_view());
  const auto& q = queries(0, state.range(1));
  vfit::ClosestHits hits;
  const LoopClock clock;
  for (auto _ : state) {
    index.closest_points(q, NO_LIMIT, hits);
    benchmark::DoNotOptimize(hits.signed_distances.data());
  }
  ratio_to_ours(state, clock, 2);
  name(state);
  state.counters["holes"] = double(index.hole_count());
}
BENCHMARK(BM_proximity_open_body)->ArgsProduct({{0}, {10000, 100000}})->Unit(benchmark::kMillisecond)->UseRealTime();

// Index construction vs refit after the vertices move (items: vertices).
void BM_build(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  for (auto _ : state) {
    vfit::ProximityIndex index(m.position_view(), m.triangle_view());
    benchmark::DoNotOptimize(&index);
  }
  state.SetLabel(state.range(0) == 0 ? "mannequin" : "sphere100k");
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.vertex_count()));
}
BENCHMARK(BM_build)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_refit(benchmark::State& state) {
  const vfit::Mesh& m = mesh(state.range(0));
  vfit::ProximityIndex index(m.position_view(), m.triangle_view());
  std::vector<float> moved = m.positions;
  float shift = 0.0f;
  for (auto _ : state) {
    shift += 1e-3f; // a small rigid-plus-stretch motion each frame
    for (std::size_t i = 0; i < moved.size(); ++i)
      moved[i] = m.positions[i] * (1.0f + shift) + shift;
    index.refit(moved);
  }
  state.SetLabel(state.range(0) == 0 ? "mannequin" : "sphere100k");
  state.SetItemsProcessed(state.iterations() * std::int64_t(m.vertex_count()));
}
BENCHMARK(BM_refit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
