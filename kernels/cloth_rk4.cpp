#include "cloth_rk4.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include <tbb/global_control.h>

#include "cloth_gather.h"
#include "parallel.h"

namespace vfit {
namespace {
using namespace cloth_detail;

// The arrays one RK4 stage pass reads and writes.
struct StagePass {
  const float* xs; // stage state read by the gather (#V × 3)
  const float* vs;
  const float* x0; // step start
  const float* v0;
  float* acc_x;
  float* acc_v;
  float* next_x; // next stage state, or the result at stage 3 (may alias x0/v0: own row only)
  float* next_v;
};

// One slice's states in structure of arrays: component c of lane l at [c][l].
struct SliceVectors {
  alignas(64) float c[3][CLOTH_SLICE_WIDTH];
};

// out[c][l] = p[3·(first + l) + c] for the lanes l < count; ROW_LOADS (VFIT_CLOTH_AVX512_TARGET
// kernels only): a full slice by load_rows16.
template <bool ROW_LOADS>
VFIT_CLOTH_INLINE void load_slice(const float* p, std::size_t first, std::size_t count, SliceVectors& out) {
  const float* s = p + 3 * first;
#if VFIT_CLOTH_AVX512
  if constexpr (ROW_LOADS)
    if (count == CLOTH_SLICE_WIDTH) {
      load_rows16(s, out.c);
      return;
    }
#endif
  for (std::size_t l = 0; l < count; ++l)
    for (std::size_t c = 0; c < 3; ++c)
      out.c[c][l] = s[3 * l + c];
}

// p[3·(first + l) + c] = in[c][l] for the lanes l < count; ROW_LOADS: a full slice by
// store_rows16.
template <bool ROW_LOADS>
VFIT_CLOTH_INLINE void store_slice(float* p, std::size_t first, std::size_t count, const SliceVectors& in) {
  float* d = p + 3 * first;
#if VFIT_CLOTH_AVX512
  if constexpr (ROW_LOADS)
    if (count == CLOTH_SLICE_WIDTH) {
      store_rows16(d, in.c);
      return;
    }
#endif
  for (std::size_t l = 0; l < count; ++l)
    for (std::size_t c = 0; c < 3; ++c)
      d[3 * l + c] = in.c[c][l];
}

// One stage pass over the slices [begin, end) of the particles: the spring gather fused with
// the stage update. Stage 0 does not read the running sums (it starts them) and stage 3 does not
// write them (it writes the step's result): 48 bytes per particle and step less to move. The
// stage is a template argument so each pass's update folds to its own arithmetic. A slice's
// updates read its rows into structure-of-arrays scratch, update lane by lane there and write
// the rows back, array by array: loops over the 16 lanes that vectorise (the outputs may alias
// the step start, which a loop reading one array and writing another could not rule out), with
// the expressions of cloth_math.h per lane, so the same bits as a particle-by-particle loop.
template <int STAGE, bool ROW_LOADS>
VFIT_CLOTH_INLINE void stage_slices(const StagePass& p, const SpringAdjacency& adj, const ClothParticles& particles,
                                    float h, std::size_t begin, std::size_t end) {
  constexpr std::size_t W = CLOTH_SLICE_WIDTH;
  const std::size_t n = adj.particle_count();
  const vfit_vec3 g{particles.gravity[0], particles.gravity[1], particles.gravity[2]};
  const float mu = particles.global_damping;
  SliceForces forces;
  SliceVectors vs, x0, v0, acc_x, acc_v, next_x, next_v;
  alignas(64) float inv_mass[W];
  for (std::size_t slice = begin; slice < end; ++slice) {
    slice_spring_forces<ROW_LOADS>(p.xs, p.vs, adj, slice, forces);
    const std::size_t first = W * slice, count = std::min(W, n - first);
    std::copy_n(particles.inverse_masses.data() + first, count, inv_mass);
    load_slice<ROW_LOADS>(p.vs, first, count, vs);
    load_slice<ROW_LOADS>(p.x0, first, count, x0);
    load_slice<ROW_LOADS>(p.v0, first, count, v0);
    if (STAGE != 0) {
      load_slice<ROW_LOADS>(p.acc_x, first, count, acc_x);
      load_slice<ROW_LOADS>(p.acc_v, first, count, acc_v);
    }
    for (std::size_t l = 0; l < count; ++l) {
      const vfit_vec3 vsl{vs.c[0][l], vs.c[1][l], vs.c[2][l]};
      const float im = inv_mass[l];
      const vfit_vec3 a =
          vfit_particle_acceleration(vfit_vec3{forces.f[0][l], forces.f[1][l], forces.f[2][l]}, vsl, im, g, mu);
      vfit_vec3 ax{0.0f, 0.0f, 0.0f}, av{0.0f, 0.0f, 0.0f}, nx, nv;
      if (STAGE != 0) {
        ax = vfit_vec3{acc_x.c[0][l], acc_x.c[1][l], acc_x.c[2][l]};
        av = vfit_vec3{acc_v.c[0][l], acc_v.c[1][l], acc_v.c[2][l]};
      }
      // Pinned particles move with their given velocity in no stage: hold them at x0.
      const bool pinned = im == 0.0f;
      const vfit_vec3 slope_x{pinned ? 0.0f : vsl.x, pinned ? 0.0f : vsl.y, pinned ? 0.0f : vsl.z};
      vfit_rk4_stage_update(vfit_vec3{x0.c[0][l], x0.c[1][l], x0.c[2][l]},
                            vfit_vec3{v0.c[0][l], v0.c[1][l], v0.c[2][l]}, slope_x, a, h, STAGE, &ax, &av, &nx,
                            &nv);
      acc_x.c[0][l] = ax.x;
      acc_x.c[1][l] = ax.y;
      acc_x.c[2][l] = ax.z;
      acc_v.c[0][l] = av.x;
      acc_v.c[1][l] = av.y;
      acc_v.c[2][l] = av.z;
      next_x.c[0][l] = nx.x;
      next_x.c[1][l] = nx.y;
      next_x.c[2][l] = nx.z;
      next_v.c[0][l] = nv.x;
      next_v.c[1][l] = nv.y;
      next_v.c[2][l] = nv.z;
    }
    if (STAGE != 3) {
      store_slice<ROW_LOADS>(p.acc_x, first, count, acc_x);
      store_slice<ROW_LOADS>(p.acc_v, first, count, acc_v);
    }
    store_slice<ROW_LOADS>(p.next_x, first, count, next_x);
    store_slice<ROW_LOADS>(p.next_v, first, count, next_v);
  }
}

// The pass compiled for AVX2, AVX-512 and baseline x86-64, neighbours loaded lane by lane.
template <int STAGE>
VFIT_CLOTH_MULTIVERSION void stage_range_lanes(const StagePass& p, const SpringAdjacency& adj,
                                               const ClothParticles& particles, float h, std::size_t begin,
                                               std::size_t end) {
  stage_slices<STAGE, false>(p, adj, particles, h, begin, end);
}

#if VFIT_CLOTH_AVX512
// The pass for AVX-512 CPUs, scattered neighbours loaded a row per load (gather_rows16).
template <int STAGE>
VFIT_CLOTH_AVX512_TARGET void stage_range_rows(const StagePass& p, const SpringAdjacency& adj,
                                               const ClothParticles& particles, float h, std::size_t begin,
                                               std::size_t end) {
  stage_slices<STAGE, true>(p, adj, particles, h, begin, end);
}
#endif

template <int STAGE>
void stage_range(const StagePass& p, const SpringAdjacency& adj, const ClothParticles& particles, float h,
                 std::size_t begin, std::size_t end) {
#if VFIT_CLOTH_AVX512
  if (avx512_available()) {
    stage_range_rows<STAGE>(p, adj, particles, h, begin, end);
    return;
  }
#endif
  stage_range_lanes<STAGE>(p, adj, particles, h, begin, end);
}

// Slices by which stage 0 advances per round of the wavefront (run_wavefront): 256 particles,
// small against the lag the neighbours impose between stages (a garment's spread between
// SpringAdjacency::slice_neighbor_first and _last: about a hundred slices at 10^6 particles).
constexpr std::size_t WAVE_SLICES = 16;

// Runs stage s on slices [b, e).
VFIT_CLOTH_INLINE void run_stage(int stage, const StagePass& pass, const SpringAdjacency& adj,
                                 const ClothParticles& particles, float h, std::size_t b, std::size_t e) {
  if (b >= e) return;
  switch (stage) {
  case 0: stage_range<0>(pass, adj, particles, h, b, e); break;
  case 1: stage_range<1>(pass, adj, particles, h, b, e); break;
  case 2: stage_range<2>(pass, adj, particles, h, b, e); break;
  default: stage_range<3>(pass, adj, particles, h, b, e); break;
  }
}

// The slices [first[s], last[s]) on which a chunk [a, b) of the slices runs stage s by itself
// (E_s in rk4_step's comment): E_0 = [a, b), and E_s the widest interval of E_(s−1) whose
// slices' neighbour ranges (SpringAdjacency::slice_neighbor_first/_last) lie inside E_(s−1).
// Empty intervals have first == last.
struct ChunkStages {
  std::size_t first[4], last[4];
};

ChunkStages chunk_stages(const SpringAdjacency& adj, std::size_t a, std::size_t b) {
  ChunkStages c{};
  c.first[0] = a;
  c.last[0] = b;
  for (int s = 1; s < 4; ++s) {
    const std::size_t lo = c.first[s - 1], hi = c.last[s - 1];
    std::size_t first = lo, last = hi;
    for (std::size_t k = lo; k < hi; ++k) {
      if (static_cast<std::size_t>(adj.slice_neighbor_first[k]) < lo) first = k + 1;
      if (static_cast<std::size_t>(adj.slice_neighbor_last[k]) >= hi) last = std::min(last, k);
    }
    if (first >= last) first = last = lo;
    c.first[s] = first;
    c.last[s] = last;
  }
  return c;
}

// Phase 1 of rk4_step on one chunk: stage s on E_s, all four stages in one sweep, stage s
// following stage s − 1 as closely as the neighbours allow (a slice runs stage s once stage
// s − 1 has covered its neighbour range), so a slice's spring rows and states are read by its
// four stages while they are still in the cache, instead of once per full pass.
void run_wavefront(const StagePass (&pass)[4], const SpringAdjacency& adj, const ClothParticles& particles, float h,
                   const ChunkStages& c) {
  std::size_t front[4];
  for (int s = 0; s < 4; ++s)
    front[s] = c.first[s];
  const auto pending = [&] {
    for (int s = 0; s < 4; ++s)
      if (front[s] < c.last[s]) return true;
    return false;
  };
  while (pending()) {
    const std::size_t e0 = std::min(c.last[0], front[0] + WAVE_SLICES);
    run_stage(0, pass[0], adj, particles, h, front[0], e0);
    front[0] = e0;
    for (int s = 1; s < 4; ++s) {
      std::size_t e = front[s];
      while (e < c.last[s] && static_cast<std::size_t>(adj.slice_neighbor_last[e]) < front[s - 1])
        ++e;
      run_stage(s, pass[s], adj, particles, h, front[s], e);
      front[s] = e;
    }
  }
}

// One RK4 step over the slices split into `chunks` contiguous chunks.
//
// Stage s reads the states stage s − 1 wrote (x, v at stage 0) at a slice's neighbours, and
// writes the slice's own rows: the next state (a buffer that stage s − 1 or s + 1 also uses:
// stage_x[s % 2], or x, v at stage 3), the running sums. So stage s may run on a slice once
// stage s − 1 has run on every slice in its neighbour range (the values it reads are there), and
// once stage s − 1 has run on every slice whose range holds it (stage s + 1 − 2 = s − 1 has
// read the buffer stage s overwrites; by symmetry of the springs, the same slices). Each slice's
// arithmetic is that of the plain stage-by-stage passes whatever the order, so the bits do not
// depend on the schedule or the number of chunks.
//
// Phase 1, chunks in parallel: chunk [a, b) runs stage s on E_s (ChunkStages) by run_wavefront;
// E_s's neighbour ranges lie in E_(s−1) of the same chunk, so a chunk reads no other chunk's
// stage states (stage 0 reads x, v, which no chunk writes before its neighbours' E_1 ... E_3 are
// done: a slice of E_3 has every neighbour in its own chunk). Phase 2: the slices of each stage
// s ≥ 1 that phase 1 left (within a few neighbour ranges of a chunk boundary), stage by stage,
// each stage in parallel: by then every slice has run stage s − 1.
template <typename ForEach>
void rk4_step(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
              const ClothParticles& particles, float h, Rk4Workspace& w, std::size_t chunks, const ForEach& for_each) {
  const std::size_t n = positions.size();
  assert(n == 3 * adjacency.particle_count() && velocities.size() == n && "state and adjacency sizes differ");
  assert(particles.inverse_masses.size() == adjacency.particle_count() && "one inverse mass per particle");
  assert(adjacency.slice_neighbor_last.size() == adjacency.slice_count() && "adjacency from build_spring_adjacency");
  for (auto* buf : {&w.acc_x, &w.acc_v, &w.stage_x[0], &w.stage_x[1], &w.stage_v[0], &w.stage_v[1]})
    buf->resize(n);
  float* x = positions.data();
  float* v = velocities.data();
  StagePass pass[4];
  const float* read_x = x;
  const float* read_v = v;
  for (int stage = 0; stage < 4; ++stage) {
    const bool last = stage == 3;
    float* write_x = last ? x : w.stage_x[stage % 2].data();
    float* write_v = last ? v : w.stage_v[stage % 2].data();
    pass[stage] = StagePass{read_x, read_v, x, v, w.acc_x.data(), w.acc_v.data(), write_x, write_v};
    read_x = write_x;
    read_v = write_v;
  }
  const std::size_t slices = adjacency.slice_count();
  chunks = std::max<std::size_t>(1, std::min(chunks, slices));
  w.chunk_stages.resize(4 * 2 * chunks);
  for_each(chunks, [&](std::size_t c) {
    const ChunkStages cs = chunk_stages(adjacency, slices * c / chunks, slices * (c + 1) / chunks);
    run_wavefront(pass, adjacency, particles, h, cs);
    for (int s = 0; s < 4; ++s) {
      w.chunk_stages[8 * c + 2 * s] = cs.first[s];
      w.chunk_stages[8 * c + 2 * s + 1] = cs.last[s];
    }
  });
  if (chunks == 1) return; // E_s is every slice: a slice's neighbours are all in the one chunk
  for (int stage = 1; stage < 4; ++stage)
    for_each(2 * chunks, [&](std::size_t k) {
      const std::size_t c = k / 2, a = slices * c / chunks, b = slices * (c + 1) / chunks;
      const std::size_t first = w.chunk_stages[8 * c + 2 * stage], last = w.chunk_stages[8 * c + 2 * stage + 1];
      if (first == last) { // E_s empty: the whole chunk, run by its first half of k
        if (k % 2 == 0) run_stage(stage, pass[stage], adjacency, particles, h, a, b);
      } else if (k % 2 == 0) {
        run_stage(stage, pass[stage], adjacency, particles, h, a, first);
      } else {
        run_stage(stage, pass[stage], adjacency, particles, h, last, b);
      }
    });
}
} // namespace

void cloth_accelerations_serial(std::span<const float> positions, std::span<const float> velocities,
                                const SpringAdjacency& adjacency, const ClothParticles& particles,
                                std::vector<float>& accelerations) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && "adjacency built for another particle count");
  accelerations.resize(3 * nv);
  const vfit_vec3 g{particles.gravity[0], particles.gravity[1], particles.gravity[2]};
  for (std::size_t i = 0; i < nv; ++i)
    store3(accelerations.data(), i,
           vfit_particle_acceleration(gather_spring_force(positions.data(), velocities.data(), adjacency, i),
                                      load3(velocities.data(), i), particles.inverse_masses[i], g,
                                      particles.global_damping));
}

void rk4_step_serial(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                     const ClothParticles& particles, float h, Rk4Workspace& workspace) {
  rk4_step(positions, velocities, adjacency, particles, h, workspace, 1,
           [](std::size_t count, const auto& kernel) {
             for (std::size_t k = 0; k < count; ++k)
               kernel(k);
           });
}

void rk4_step_chunked(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                      const ClothParticles& particles, float h, Rk4Workspace& workspace, std::size_t chunks) {
  rk4_step(positions, velocities, adjacency, particles, h, workspace, chunks,
           [](std::size_t count, const auto& kernel) {
             parallel_for_range(count, 1, [&](std::size_t b, std::size_t e) {
               for (std::size_t k = b; k < e; ++k)
                 kernel(k);
             });
           });
}

void rk4_step_tbb(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                  const ClothParticles& particles, float h, Rk4Workspace& workspace) {
  // One chunk per thread that may run (the arena's, capped by a tbb::global_control), each of
  // at least CLOTH_PARTICLE_GRAIN particles.
  const auto threads = std::max<std::size_t>(
      1, std::min(static_cast<std::size_t>(std::max(1, parallel_thread_count())),
                  tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  const std::size_t chunks = std::min(threads, std::max<std::size_t>(1, adjacency.slice_count() /
                                                                             (CLOTH_PARTICLE_GRAIN / CLOTH_SLICE_WIDTH)));
  rk4_step_chunked(positions, velocities, adjacency, particles, h, workspace, chunks);
}

Rk4StepBound rk4_stable_step(const SpringAdjacency& adjacency, const ClothParticles& particles) {
  Rk4StepBound b;
  const std::vector<float>& inv = particles.inverse_masses;
  double omega2_max = 0;
  for (std::size_t i = 0; i < adjacency.particle_count(); ++i) {
    if (inv[i] == 0.0f) continue; // pinned: not a degree of freedom
    double omega2 = 0, gamma = particles.global_damping;
    for (std::int32_t e = adjacency.offsets[i]; e < adjacency.offsets[i + 1]; ++e) {
      const double weight = double(inv[i]) + std::sqrt(double(inv[i]) * inv[adjacency.neighbors[e]]);
      omega2 += adjacency.stiffness[e] * weight;
      gamma += adjacency.damping[e] * weight;
    }
    omega2_max = std::max(omega2_max, omega2);
    b.gamma_max = std::max(b.gamma_max, gamma);
  }
  b.omega_max = std::sqrt(omega2_max);
  const double rate = b.omega_max + b.gamma_max;
  b.max_step = rate > 0 ? RK4_STABILITY_RADIUS / rate : std::numeric_limits<double>::infinity();
  return b;
}

} // namespace vfit
