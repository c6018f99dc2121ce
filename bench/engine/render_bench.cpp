// SPDX-License-Identifier: Apache-2.0
// Ray-casting renderer throughput: primary rays per second for the three standard views of the
// mannequin wearing a tee, at 512² per view, with and without 2×2 supersampling; and the raw
// ray caster on the same rays, serial and TBB.
#include <limits>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include "vfit/engine/view/render.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/kernels/ray_caster.h"

namespace vfit {
namespace {

struct Scene {
  Body body;
  Garment tee;
};

const Scene& scene() {
  static const Scene s = [] {
    MannequinOptions mo;
    GarmentOptions go;
    go.body = mo.measurements;
    go.pose = mo.pose;
    return Scene{make_mannequin(mo), make_garment(go)};
  }();
  return s;
}

// render_views(): 3 views × 512² pixels × supersampling² rays, everything included (BVH build,
// normals, shading, outlines, resolve). Argument: supersampling.
void BM_render_three_views(benchmark::State& state) {
  const Scene& s = scene();
  const Mesh* meshes[] = {&s.body.mesh, &s.tee.mesh};
  RenderOptions o;
  o.size = 512;
  o.supersampling = static_cast<int>(state.range(0));
  std::size_t rays = 0;
  for (auto _ : state) {
    const Rendering r = render_views(meshes, o);
    rays += r.ray_count;
    benchmark::DoNotOptimize(r.views.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}
BENCHMARK(BM_render_three_views)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// RayCaster::intersect alone on the front view's 512² orthographic rays. Argument: threads
// (0 = serial reference).
void BM_cast_front_rays(benchmark::State& state) {
  const Scene& s = scene();
  const RayCastMesh cast[] = {{s.body.mesh.positions, s.body.mesh.triangles},
                              {s.tee.mesh.positions, s.tee.mesh.triangles}};
  const RayCaster caster(cast);
  const Mesh* meshes[] = {&s.body.mesh, &s.tee.mesh};
  RenderOptions o;
  o.size = 512;
  o.views = {RenderView::FRONT};
  o.supersampling = 1;
  const ViewCamera camera = render_views(meshes, o).views[0].camera;
  const std::size_t n = 512;
  std::vector<float> origins(3 * n * n), directions(3 * n * n);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < n; ++i) {
      std::array<float, 3> org, dir;
      camera.ray(i + 0.5f, j + 0.5f, org, dir);
      std::copy(org.begin(), org.end(), origins.begin() + 3 * (j * n + i));
      std::copy(dir.begin(), dir.end(), directions.begin() + 3 * (j * n + i));
    }
  const int threads = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::max(1, threads));
  RayHits hits;
  const float inf = std::numeric_limits<float>::infinity();
  for (auto _ : state) {
    if (threads == 0) {
      caster.intersect_serial(origins, directions, 0.0f, inf, hits);
    } else {
      caster.intersect(origins, directions, 0.0f, inf, hits);
    }
    benchmark::DoNotOptimize(hits.meshes.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n * n));
}
BENCHMARK(BM_cast_front_rays)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace
} // namespace vfit

BENCHMARK_MAIN();
