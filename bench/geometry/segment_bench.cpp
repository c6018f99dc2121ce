// Garment segmentation (seed 000 §4) speed: per catalogue type over vertex counts, and the
// Table-1 twins (the paper: 159–987 ms per garment on an Intel 4 × 2.5 GHz). Serial by
// design: one garment is a few ms. Reports vertices/s; garments are generated once, untimed.
#include <map>

#include <Eigen/Geometry>

#include <benchmark/benchmark.h>

#include "geometry/garment/catalogue.h"
#include "geometry/garment/segment.h"
#include "geometry/garment/table1.h"
#include "geometry/garment/thick_shell.h"

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
  if (it == cache.end()) it = cache.emplace(state.range(0), vfit::make_garment(vfit::table1_garment_options(row))).first;
  for (auto _ : state) benchmark::DoNotOptimize(vfit::segment_garment(it->second.mesh).vertex_parts.data());
  state.SetItemsProcessed(state.iterations() * std::int64_t(row.vertices));
  state.SetLabel(row.garment);
  state.counters["paper_ms"] = row.paper_segmentation_ms;
}
BENCHMARK(BM_segment_table1)->DenseRange(0, 8)->Unit(benchmark::kMillisecond);

// A garment modelled with thickness: the tee and a copy 3 mm inside it, wound the other way and
// stitched at every opening (one closed surface).
vfit::Mesh solidified(const vfit::Mesh& sheet) {
  const std::size_t nv = sheet.vertex_count(), nf = sheet.face_count();
  std::vector<Eigen::Vector3f> normal(nv, Eigen::Vector3f::Zero());
  auto at = [&](std::int32_t v) { return Eigen::Vector3f::Map(&sheet.positions[3 * std::size_t(v)]); };
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t* t = &sheet.triangles[3 * f];
    const Eigen::Vector3f n = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
    for (int k = 0; k < 3; ++k) normal[std::size_t(t[k])] += n;
  }
  vfit::Mesh m;
  m.positions = sheet.positions;
  for (std::size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3f p = at(std::int32_t(v)) - 0.003f * normal[v].normalized();
    m.positions.insert(m.positions.end(), {p.x(), p.y(), p.z()});
  }
  const auto n = std::int32_t(nv);
  m.triangles = sheet.triangles;
  std::map<std::pair<std::int32_t, std::int32_t>, int> uses;
  for (std::size_t i = 0; i < 3 * nf; ++i) {
    const std::int32_t a = sheet.triangles[i], b = sheet.triangles[i - i % 3 + (i + 1) % 3];
    ++uses[{std::min(a, b), std::max(a, b)}];
  }
  for (std::size_t f = 0; f < nf; ++f) {
    const std::int32_t* t = &sheet.triangles[3 * f];
    m.triangles.insert(m.triangles.end(), {t[0] + n, t[2] + n, t[1] + n});
  }
  for (std::size_t i = 0; i < 3 * nf; ++i) {
    const std::int32_t a = sheet.triangles[i], b = sheet.triangles[i - i % 3 + (i + 1) % 3];
    if (uses[{std::min(a, b), std::max(a, b)}] == 1) m.triangles.insert(m.triangles.end(), {b, a, a + n, b, a + n, b + n});
  }
  return m;
}

// find_thick_shell() on the plain tee (the cost every garment pays: one sheet is told apart
// before any ray) and on the tee solidified (the rays and the carrying set-up).
void BM_find_thick_shell(benchmark::State& state) {
  const vfit::Mesh& tee = catalogue_mesh(vfit::GarmentType::TEE, std::size_t(state.range(0)));
  static std::map<std::size_t, vfit::Mesh> thick;
  const bool solid = state.range(1) != 0;
  if (solid && !thick.contains(tee.vertex_count())) thick.emplace(tee.vertex_count(), solidified(tee));
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
BENCHMARK(BM_find_thick_shell)
    ->ArgsProduct({{10000, 100000}, {0, 1}})
    ->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
