// SPDX-License-Identifier: Apache-2.0
// Part skeletons (seed 000 §5.1) speed and centredness: a 6k-vertex tube (proxy or full
// resolution, uniform or cotangent contraction) and the sleeves and legs of catalogue
// garments at 5k / 20k / 100k vertices. With CGAL found at configure time, the same tube
// through CGAL::extract_mean_curvature_flow_skeleton as the reference (about 0.6 s).
// Serial by design. Reports vertices/s; meshes are built once, untimed. Centredness: mean
// distance of the skeleton's nodes to the true axis divided by the tube's radius.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <map>

#include <benchmark/benchmark.h>

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/hole_fill.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/garment/skeleton_driving.h"
#include "vfit/geometry/garment/skeleton_parts.h"
#include "vfit/geometry/garment/table1.h"
#include "vfit/geometry/mesh/primitives.h"

#ifdef VFIT_BENCH_CGAL
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/extract_mean_curvature_flow_skeleton.h>
#endif

namespace {

constexpr float TUBE_RADIUS = 0.05f, TUBE_LENGTH = 0.6f;

// 250 rings × 24 segments = 6,000 vertices, about square faces' aspect 1 : 1.
const vfit::Mesh& tube() {
  static const vfit::Mesh mesh = vfit::make_tube(250, 24, TUBE_RADIUS, TUBE_LENGTH);
  return mesh;
}

// Distance of p to the tube's axis segment, in radii.
double axis_offset(double x, double y, double z) {
  const double along = std::clamp(y, 0.0, double(TUBE_LENGTH));
  return std::sqrt(x * x + z * z + (y - along) * (y - along)) / TUBE_RADIUS;
}

// Args: proxy vertices (0: full resolution), laplacian (0 uniform, 1 cotangent).
void BM_tube_skeleton(benchmark::State& state) {
  const vfit::Mesh& mesh = tube();
  const std::vector<vfit::GarmentPart> parts(mesh.vertex_count(), vfit::GarmentPart::LEFT_SLEEVE);
  vfit::PartSkeletonOptions o;
  o.skeleton.proxy_vertices = std::size_t(state.range(0));
  o.skeleton.contraction.laplacian =
      state.range(1) ? vfit::ContractionLaplacian::COTANGENT : vfit::ContractionLaplacian::UNIFORM;
  vfit::PartSkeleton s;
  for (auto _ : state) {
    s = vfit::extract_part_skeleton(mesh, parts, vfit::GarmentPart::LEFT_SLEEVE, o);
    benchmark::DoNotOptimize(s.nodes.data());
  }
  double offset = 0;
  for (const auto& p : s.nodes)
    offset += axis_offset(p.x(), p.y(), p.z());
  state.SetItemsProcessed(state.iterations() * std::int64_t(mesh.vertex_count()));
  state.SetLabel(state.range(1) ? "cotangent" : "uniform");
  state.counters["centredness"] = offset / double(std::max<std::size_t>(1, s.nodes.size()));
  state.counters["nodes"] = double(s.nodes.size());
  state.counters["iterations"] = s.contraction.iterations;
  state.counters["fill_ms"] = s.timings.fill_ms;
  state.counters["skeleton_ms"] = s.timings.skeleton_ms;
  state.counters["map_ms"] = s.timings.map_ms;
}
BENCHMARK(BM_tube_skeleton)->ArgsProduct({{600, 1500, 0}, {0, 1}})->Unit(benchmark::kMillisecond);

const vfit::Garment& catalogue_garment(vfit::GarmentType type, std::size_t vertices) {
  static std::map<std::pair<int, std::size_t>, vfit::Garment> cache;
  const auto key = std::make_pair(int(type), vertices);
  auto it = cache.find(key);
  if (it == cache.end()) {
    vfit::GarmentOptions o;
    o.type = type;
    o.target_vertices = vertices;
    it = cache.emplace(key, vfit::make_garment(o)).first;
  }
  return it->second;
}

// Sleeves and legs of a catalogue garment (T-pose, ground-truth labels): all its limbs' skeletons.
void BM_garment_limb_skeletons(benchmark::State& state) {
  const auto type = static_cast<vfit::GarmentType>(state.range(0));
  const vfit::Garment& g = catalogue_garment(type, std::size_t(state.range(1)));
  std::vector<vfit::PartSkeleton> limbs;
  for (auto _ : state) {
    limbs = vfit::extract_limb_skeletons(g.mesh, g.vertex_parts);
    benchmark::DoNotOptimize(limbs.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(1));
  state.SetLabel(vfit::garment_type_name(type));
  // The last run's stages summed over the limbs (ms), to see where the time goes.
  vfit::PartSkeletonTimings sum;
  double nodes = 0;
  for (const auto& s : limbs) {
    sum.cut_ms += s.timings.cut_ms;
    sum.fill_ms += s.timings.fill_ms;
    sum.skeleton_ms += s.timings.skeleton_ms;
    sum.map_ms += s.timings.map_ms;
    nodes += double(s.nodes.size());
  }
  state.counters["limbs"] = double(limbs.size());
  state.counters["nodes"] = nodes;
  state.counters["cut_ms"] = sum.cut_ms;
  state.counters["fill_ms"] = sum.fill_ms;
  state.counters["skeleton_ms"] = sum.skeleton_ms;
  state.counters["map_ms"] = sum.map_ms;
}
BENCHMARK(BM_garment_limb_skeletons)
    ->ArgsProduct({{int(vfit::GarmentType::TEE), int(vfit::GarmentType::LONG_SLEEVE), int(vfit::GarmentType::TROUSERS)},
                   {5000, 20000}})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_garment_limb_skeletons)
    ->ArgsProduct({{int(vfit::GarmentType::LONG_SLEEVE), int(vfit::GarmentType::TROUSERS)}, {100000}})
    ->Unit(benchmark::kMillisecond);

// The deformation column of `vfit bench table1` for one Table-1 row (arg: the row's index),
// stage by stage: part skeletons of the segmented garment, the driver's setup (seam distances,
// handles, band factorisation) and drive() onto the row's posed mannequin. The garment, its
// segmentation and the body are built once, untimed. The Dress (row 0) has no limbs.
struct Table1Case {
  vfit::Garment garment;
  vfit::GarmentSegmentation segmentation;
  vfit::Body body;
};
const Table1Case& table1_case(std::size_t row_index) {
  static std::map<std::size_t, Table1Case> cache;
  auto it = cache.find(row_index);
  if (it == cache.end()) {
    const vfit::Table1Row& row = vfit::table1_rows().at(row_index);
    vfit::MannequinOptions mo;
    mo.pose = vfit::RestPose::APOSE;
    const vfit::Body rest = vfit::make_mannequin(mo);
    vfit::Garment g = vfit::make_garment(vfit::table1_garment_options(row));
    vfit::GarmentSegmentation seg = vfit::segment_garment(g.mesh);
    vfit::Body posed = vfit::pose_body(rest, vfit::named_pose(row.body_pose, rest.rest_pose));
    it = cache.emplace(row_index, Table1Case{std::move(g), std::move(seg), std::move(posed)}).first;
  }
  return it->second;
}

// The resolution sweep's case (`vfit bench sweep`): a T-pose catalogue tee at `vertices`,
// driven onto the A-pose mannequin with its arms down.
const Table1Case& sweep_case(std::size_t vertices) {
  static std::map<std::size_t, Table1Case> cache;
  auto it = cache.find(vertices);
  if (it == cache.end()) {
    vfit::MannequinOptions mo;
    mo.pose = vfit::RestPose::APOSE;
    const vfit::Body rest = vfit::make_mannequin(mo);
    vfit::GarmentOptions go;
    go.type = vfit::GarmentType::TEE;
    go.target_vertices = vertices;
    go.pose = vfit::RestPose::TPOSE;
    vfit::Garment g = vfit::make_garment(go);
    vfit::GarmentSegmentation seg = vfit::segment_garment(g.mesh);
    vfit::Body posed = vfit::pose_body(rest, vfit::named_pose("arms_down", rest.rest_pose));
    it = cache.emplace(vertices, Table1Case{std::move(g), std::move(seg), std::move(posed)}).first;
  }
  return it->second;
}

// CPU time of the calling thread (ms). On one core (`taskset -c 0`: TBB then runs every task on
// this thread) it is the stages' whole work, and unlike wall time it does not grow when other
// processes load the machine.
double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * double(t.tv_sec) + 1e-6 * double(t.tv_nsec);
}

// Part skeletons, driver setup and drive() of one case, with the per-limb stages as counters.
void time_deformation(benchmark::State& state, const Table1Case& c, vfit::BandSolver solver = vfit::BandSolver::AUTO) {
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  double skeleton_ms = 0, setup_ms = 0, drive_ms = 0;
  double skeleton_cpu_ms = 0, setup_cpu_ms = 0, drive_cpu_ms = 0;
  vfit::PartSkeletonTimings limb_sum; // per-limb stages summed over limbs and runs
  double iterations = 0, factorisations = 0, proxy = 0, area = 0, pieces = 0, caps = 0, free_vertices = 0;
  double band_iterations = 0, band_fallbacks = 0;
  vfit::SkeletonDrivingOptions options;
  options.band_solver = solver;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    const std::vector<vfit::PartSkeleton> limbs =
        vfit::extract_limb_skeletons(c.garment.mesh, c.segmentation.vertex_parts);
    const auto t1 = Clock::now();
    const double c1 = thread_cpu_ms();
    const vfit::SkeletonDriver driver(c.garment.mesh, c.segmentation, limbs, options);
    const auto t2 = Clock::now();
    const double c2 = thread_cpu_ms();
    const vfit::SkeletonDriving d = driver.drive(c.body.joints);
    const auto t3 = Clock::now();
    const double c3 = thread_cpu_ms();
    skeleton_cpu_ms += c1 - c0;
    setup_cpu_ms += c2 - c1;
    drive_cpu_ms += c3 - c2;
    benchmark::DoNotOptimize(d.positions.data());
    band_iterations += d.laplacian_solve.iterations;
    band_fallbacks += d.laplacian_solve.fell_back ? 1 : 0;
    free_vertices += double(c.garment.mesh.vertex_count() - driver.handles().size());
    for (const vfit::PartSkeleton& s : limbs) {
      iterations += s.contraction.iterations;
      factorisations += s.contraction.factorisations;
      proxy += double(s.proxy_vertices);
      pieces += double(s.piece_vertices);
      caps += double(s.cap_vertices);
      area = std::max(area, s.contraction.final_area_ratio);
      limb_sum.cut_ms += s.timings.cut_ms;
      limb_sum.fill_ms += s.timings.fill_ms;
      limb_sum.map_ms += s.timings.map_ms;
      limb_sum.skeleton_stages.proxy_ms += s.timings.skeleton_stages.proxy_ms;
      limb_sum.skeleton_stages.contraction_ms += s.timings.skeleton_stages.contraction_ms;
      limb_sum.skeleton_stages.graph_ms += s.timings.skeleton_stages.graph_ms;
      limb_sum.skeleton_stages.chain_ms += s.timings.skeleton_stages.chain_ms;
    }
    skeleton_ms += ms(t0, t1);
    setup_ms += ms(t1, t2);
    drive_ms += ms(t2, t3);
  }
  const auto n = double(state.iterations());
  state.SetItemsProcessed(state.iterations() * std::int64_t(c.garment.mesh.vertex_count()));
  state.counters["skeletons_ms"] = skeleton_ms / n;
  state.counters["setup_ms"] = setup_ms / n;
  state.counters["drive_ms"] = drive_ms / n;
  // The same three on this thread's CPU clock: the whole work when run on one core.
  state.counters["skeletons_cpu_ms"] = skeleton_cpu_ms / n;
  state.counters["setup_cpu_ms"] = setup_cpu_ms / n;
  state.counters["drive_cpu_ms"] = drive_cpu_ms / n;
  // Summed over the limbs, which run concurrently: CPU-side cost, not wall time.
  state.counters["cut_ms"] = limb_sum.cut_ms / n;
  state.counters["fill_ms"] = limb_sum.fill_ms / n;
  state.counters["proxy_ms"] = limb_sum.skeleton_stages.proxy_ms / n;
  state.counters["contract_ms"] = limb_sum.skeleton_stages.contraction_ms / n;
  state.counters["graph_ms"] = limb_sum.skeleton_stages.graph_ms / n;
  state.counters["chain_ms"] = limb_sum.skeleton_stages.chain_ms / n;
  state.counters["map_ms"] = limb_sum.map_ms / n;
  state.counters["iterations"] = iterations / n;
  state.counters["factorisations"] = factorisations / n;
  state.counters["proxy_vertices"] = proxy / n;
  state.counters["piece_vertices"] = pieces / n; // summed over the limbs
  state.counters["cap_vertices"] = caps / n;
  state.counters["band_vertices"] = free_vertices / n; // the Laplacian's unknowns
  state.counters["band_cg_iterations"] =
      band_iterations / n; // 0: every piece factored (AUTO below 25,000 free vertices a piece)
  state.counters["band_fallbacks"] =
      band_fallbacks / n; // share of runs where an unconverged piece was factored instead
  state.counters["worst_area_ratio"] = area;
}

void BM_table1_deformation(benchmark::State& state) {
  const auto row_index = std::size_t(state.range(0));
  time_deformation(state, table1_case(row_index));
  state.SetLabel(vfit::table1_rows().at(row_index).garment);
}
BENCHMARK(BM_table1_deformation)->DenseRange(1, 8)->Unit(benchmark::kMillisecond);

// The deformation column of `vfit bench sweep` (arg: the tee's vertex count), stage by stage,
// to see which stage grows faster than the vertex count.
void BM_sweep_deformation(benchmark::State& state) {
  time_deformation(state, sweep_case(std::size_t(state.range(0))));
  state.SetLabel("tee");
}
BENCHMARK(BM_sweep_deformation)
    ->Arg(10000)
    ->Arg(31600)
    ->Arg(100000)
    ->Arg(316200)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond);

// The same with the band solver forced (arg 0: the tee's vertex count; arg 1: the BandSolver,
// 1 DIRECT, 2 SUPERNODAL, 3 MULTIGRID: two-grid CG), to compare them at one size back to back.
void BM_sweep_deformation_solver(benchmark::State& state) {
  const auto solver = static_cast<vfit::BandSolver>(state.range(1));
  time_deformation(state, sweep_case(std::size_t(state.range(0))), solver);
  state.SetLabel(solver == vfit::BandSolver::DIRECT       ? "tee, simplicial LDLT"
                 : solver == vfit::BandSolver::SUPERNODAL ? "tee, supernodal"
                                                          : "tee, two-grid CG");
}
BENCHMARK(BM_sweep_deformation_solver)
    ->ArgsProduct({{31600, 100000, 316200}, {1, 2, 3}})
    ->Unit(benchmark::kMillisecond);

#ifdef VFIT_BENCH_CGAL
// CGAL's mean curvature flow skeleton of the same tube, closed by our hole filling (CGAL needs
// a closed mesh too), with its default parameters.
void BM_tube_skeleton_cgal(benchmark::State& state) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
  const vfit::FilledMesh closed = vfit::fill_holes(tube());
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> handles;
  for (std::size_t v = 0; v < closed.mesh.vertex_count(); ++v)
    handles.push_back(sm.add_vertex(Kernel::Point_3(closed.mesh.positions[3 * v], closed.mesh.positions[3 * v + 1],
                                                    closed.mesh.positions[3 * v + 2])));
  for (std::size_t f = 0; f < closed.mesh.face_count(); ++f)
    sm.add_face(handles[std::size_t(closed.mesh.triangles[3 * f])],
                handles[std::size_t(closed.mesh.triangles[3 * f + 1])],
                handles[std::size_t(closed.mesh.triangles[3 * f + 2])]);
  using Skeletonization = CGAL::Mean_curvature_flow_skeletonization<SurfaceMesh>;
  Skeletonization::Skeleton skeleton;
  for (auto _ : state) {
    skeleton.clear();
    CGAL::extract_mean_curvature_flow_skeleton(sm, skeleton);
    benchmark::DoNotOptimize(&skeleton);
  }
  double offset = 0;
  std::size_t nodes = 0;
  for (auto v : CGAL::make_range(vertices(skeleton))) {
    const auto& p = skeleton[v].point;
    offset += axis_offset(p.x(), p.y(), p.z());
    ++nodes;
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(tube().vertex_count()));
  state.SetLabel("CGAL");
  state.counters["centredness"] = offset / double(std::max<std::size_t>(1, nodes));
  state.counters["nodes"] = double(nodes);
}
BENCHMARK(BM_tube_skeleton_cgal)->Unit(benchmark::kMillisecond);
#endif

} // namespace

BENCHMARK_MAIN();
