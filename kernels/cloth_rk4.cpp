// SPDX-License-Identifier: Apache-2.0
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
                            vfit_vec3{v0.c[0][l], v0.c[1][l], v0.c[2][l]}, slope_x, a, h, STAGE, &ax, &av, &nx, &nv);
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

// How far stage s may run, by itself, from either end of a region [a, b) of the slices: an end
// sweeping up from a runs it on slices at or above low[s], whose neighbour ranges
// (SpringAdjacency::slice_neighbor_first/_last) start at or above low[s − 1]; an end sweeping
// down from b on slices below high[s], whose ranges end below high[s − 1]. low[0] = a,
// high[0] = b; a region starting at slice 0 (ending at the last) has nothing below (above) it,
// so low[s] = 0 (high[s] = #slices) without a scan.
struct EndBounds {
  std::size_t low[4], high[4];
};

EndBounds end_bounds(const SpringAdjacency& adj, std::size_t a, std::size_t b) {
  EndBounds e{};
  e.low[0] = a;
  e.high[0] = b;
  for (int s = 1; s < 4; ++s) {
    std::size_t low = e.low[s - 1], high = e.high[s - 1];
    if (a > 0)
      for (std::size_t k = e.low[s - 1]; k < b; ++k)
        if (static_cast<std::size_t>(adj.slice_neighbor_first[k]) < e.low[s - 1]) low = k + 1;
    if (b < adj.slice_count())
      for (std::size_t k = e.high[s - 1]; k-- > a;)
        if (static_cast<std::size_t>(adj.slice_neighbor_last[k]) >= e.high[s - 1]) high = k;
    e.low[s] = std::min(low, b);
    e.high[s] = std::max(high, a);
  }
  return e;
}

// Takes the next WAVE_SLICES slices (fewer at the meeting point) of a region's unclaimed range,
// packed in `word` as lo << 32 | hi, from its bottom (up) or its top: [first, last). False once
// the range is empty. The two ends of a region meet wherever they get to, so a busy or late
// thread leaves more of the region to the other instead of holding up the step.
bool claim(std::atomic<std::uint64_t>& word, bool up, std::size_t& first, std::size_t& last) {
  std::uint64_t cur = word.load(std::memory_order_relaxed);
  for (;;) {
    const std::size_t lo = cur >> 32, hi = cur & 0xffffffffu;
    if (lo >= hi) return false;
    std::size_t next_lo = lo, next_hi = hi;
    if (up) {
      first = lo;
      last = next_lo = std::min(hi, lo + WAVE_SLICES);
    } else {
      last = hi;
      first = next_hi = hi - std::min(hi - lo, WAVE_SLICES);
    }
    if (word.compare_exchange_weak(cur, (std::uint64_t(next_lo) << 32) | next_hi, std::memory_order_relaxed))
      return true;
  }
}

// Phase 1 of rk4_step for one end of a region: stage 0 on the slices it claims, each later stage
// s following stage s − 1 as closely as the neighbours allow (a slice runs stage s once this end
// has run stage s − 1 on its whole neighbour range), so a slice's spring rows and states are
// read by its four stages while they are still in the cache, instead of once per full pass. The
// end stops when it can claim nothing and no stage advances. done[s] = [from, to): the slices on
// which it ran stage s (empty: from ≥ to).
void run_end(const StagePass (&pass)[4], const SpringAdjacency& adj, const ClothParticles& particles, float h,
             const EndBounds& bounds, bool up, std::atomic<std::uint64_t>& word, std::size_t (&done)[4][2]) {
  // Up: stage s done on [bounds.low[s], front[s]); down: on [front[s], bounds.high[s]).
  std::size_t front[4];
  for (int s = 0; s < 4; ++s)
    front[s] = up ? bounds.low[s] : bounds.high[s];
  for (bool claims = true;;) {
    bool progress = false;
    std::size_t first = 0, last = 0;
    if (claims && claim(word, up, first, last)) {
      run_stage(0, pass[0], adj, particles, h, first, last);
      front[0] = up ? last : first;
      progress = true;
    } else {
      claims = false;
    }
    for (int s = 1; s < 4; ++s) {
      std::size_t e = front[s];
      if (up) {
        while (e < front[s - 1] && static_cast<std::size_t>(adj.slice_neighbor_last[e]) < front[s - 1])
          ++e;
        run_stage(s, pass[s], adj, particles, h, front[s], e);
      } else {
        while (e > front[s - 1] && static_cast<std::size_t>(adj.slice_neighbor_first[e - 1]) >= front[s - 1])
          --e;
        run_stage(s, pass[s], adj, particles, h, e, front[s]);
      }
      progress |= e != front[s];
      front[s] = e;
    }
    if (!claims && !progress) break;
  }
  for (int s = 0; s < 4; ++s) {
    done[s][0] = up ? bounds.low[s] : front[s];
    done[s][1] = up ? front[s] : bounds.high[s];
  }
}

// Most regions a step keeps its claims for on the stack (rk4_step_chunked() may ask for more:
// those take a heap array).
constexpr std::size_t STACK_REGIONS = 32;

// One RK4 step, the stages as a wavefront swept by `ends` ends (one per thread).
//
// Stage s reads the states stage s − 1 wrote (x, v at stage 0) at a slice's neighbours, and
// writes the slice's own rows: the next state (a buffer that stage s − 1 or s + 1 also uses:
// stage_x[s % 2], or x, v at stage 3), the running sums. So stage s may run on a slice once
// stage s − 1 has run on every slice in its neighbour range (the values it reads are there), and
// once stage s − 1 has run on every slice whose range holds it (stage s + 1 − 2 = s − 1 has
// read the buffer stage s overwrites; by symmetry of the springs, the same slices). Each slice's
// arithmetic is that of the plain stage-by-stage passes whatever the order, so the bits do not
// depend on the schedule, the number of ends or where they meet.
//
// The slices are split into ⌈ends / 2⌉ contiguous regions, sized by their ends; ends 2r and
// 2r + 1 sweep region r, one up from its bottom and one down from its top, claiming stage 0
// slices as they go (claim()) until they meet (the last region has one end when `ends` is odd).
// Phase 1, all ends in parallel (run_end): each runs stage s only where its own stage s − 1 covers
// the neighbour range, so no end reads another's stage states or overwrites what another still
// reads (stage 0 reads x, v, which an end writes at stage 3 only on slices all of whose
// neighbours are its own). Phase 2: the slices of each stage s ≥ 1 that phase 1 left (within a
// few neighbour ranges of the meeting points and region boundaries), stage by stage, each stage
// in parallel: by then every slice has run stage s − 1.
template <typename ForEach>
void rk4_step_wavefront(const StagePass (&pass)[4], const SpringAdjacency& adjacency, const ClothParticles& particles,
                        float h, Rk4Workspace& w, std::size_t ends, const ForEach& for_each) {
  const std::size_t slices = adjacency.slice_count();
  assert(slices < (std::size_t(1) << 32) && "claims pack slice indices in 32 bits");
  ends = std::max<std::size_t>(1, std::min(ends, slices));
  const std::size_t regions = (ends + 1) / 2;
  const auto region = [&](std::size_t r, std::size_t& a, std::size_t& b) {
    a = slices * std::min(2 * r, ends) / ends;
    b = slices * std::min(2 * r + 2, ends) / ends;
  };
  std::atomic<std::uint64_t> stack_words[STACK_REGIONS];
  std::unique_ptr<std::atomic<std::uint64_t>[]> heap_words;
  if (regions > STACK_REGIONS) heap_words.reset(new std::atomic<std::uint64_t>[regions]);
  std::atomic<std::uint64_t>* words = heap_words ? heap_words.get() : stack_words;
  for (std::size_t r = 0; r < regions; ++r) {
    std::size_t a = 0, b = 0;
    region(r, a, b);
    words[r].store((std::uint64_t(a) << 32) | b, std::memory_order_relaxed);
  }
  w.chunk_stages.assign(8 * 2 * regions, 0); // per end and stage, the slices phase 1 covered
  for_each(ends, [&](std::size_t k) {
    std::size_t a = 0, b = 0;
    region(k / 2, a, b);
    std::size_t done[4][2];
    run_end(pass, adjacency, particles, h, end_bounds(adjacency, a, b), k % 2 == 0, words[k / 2], done);
    for (int s = 0; s < 4; ++s) {
      w.chunk_stages[8 * k + 2 * s] = done[s][0];
      w.chunk_stages[8 * k + 2 * s + 1] = done[s][1];
    }
  });
  if (ends == 1) return; // the one end covered every slice: its neighbours are all its own
  // A region's leftovers of stage s: [a, b) less the up end's [u0, u1) and the down end's
  // [d0, d1) (u1 ≤ d0: they lie either side of the meeting point): [a, u0), [d1, b) and the gap
  // [u1, d0) at the meeting point, a few neighbour ranges wide on each side of it, run as two
  // halves so the region's two threads share it.
  for (int stage = 1; stage < 4; ++stage)
    for_each(4 * regions, [&](std::size_t t) {
      const std::size_t r = t / 4;
      std::size_t a = 0, b = 0;
      region(r, a, b);
      const std::size_t* up = &w.chunk_stages[8 * (2 * r) + 2 * stage];
      const std::size_t* down = &w.chunk_stages[8 * (2 * r + 1) + 2 * stage]; // zeros: no down end
      const bool up_ran = up[0] < up[1], down_ran = down[0] < down[1];
      const std::size_t u0 = up_ran ? up[0] : a, u1 = up_ran ? up[1] : a;
      const std::size_t d0 = down_ran ? down[0] : b, d1 = down_ran ? down[1] : b;
      const std::size_t mid = u1 + (d0 - u1) / 2;
      switch (t % 4) {
      case 0: run_stage(stage, pass[stage], adjacency, particles, h, a, u0); break;
      case 1: run_stage(stage, pass[stage], adjacency, particles, h, u1, mid); break;
      case 2: run_stage(stage, pass[stage], adjacency, particles, h, mid, d0); break;
      default: run_stage(stage, pass[stage], adjacency, particles, h, d1, b); break;
      }
    });
}

// Runs kernel(k) for k in [0, count): in order, or as TBB tasks of one k each.
struct SerialForEach {
  template <typename Kernel> void operator()(std::size_t count, const Kernel& kernel) const {
    for (std::size_t k = 0; k < count; ++k)
      kernel(k);
  }
};
struct TbbForEach {
  template <typename Kernel> void operator()(std::size_t count, const Kernel& kernel) const {
    parallel_for_range(count, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t k = b; k < e; ++k)
        kernel(k);
    });
  }
};

// One RK4 step of all particles: the four stage passes over every slice each (PASSES, on the TBB
// threads), or the wavefront of `ends` ends run by for_each (WAVEFRONT; AUTO is resolved by the
// caller).
template <typename ForEach>
void rk4_step(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
              const ClothParticles& particles, float h, Rk4Workspace& w, Rk4Schedule schedule, std::size_t ends,
              const ForEach& for_each) {
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
  if (schedule == Rk4Schedule::PASSES) {
    for (int stage = 0; stage < 4; ++stage)
      parallel_for_range(
          adjacency.slice_count(), CLOTH_PARTICLE_GRAIN / CLOTH_SLICE_WIDTH,
          [&](std::size_t b, std::size_t e) { run_stage(stage, pass[stage], adjacency, particles, h, b, e); });
    return;
  }
  rk4_step_wavefront(pass, adjacency, particles, h, w, ends, for_each);
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
  rk4_step(positions, velocities, adjacency, particles, h, workspace, Rk4Schedule::WAVEFRONT, 1, SerialForEach{});
}

void rk4_step_chunked(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                      const ClothParticles& particles, float h, Rk4Workspace& workspace, std::size_t chunks) {
  rk4_step(positions, velocities, adjacency, particles, h, workspace, Rk4Schedule::WAVEFRONT, chunks, TbbForEach{});
}

void rk4_step_tbb(std::span<float> positions, std::span<float> velocities, const SpringAdjacency& adjacency,
                  const ClothParticles& particles, float h, Rk4Workspace& workspace, Rk4Schedule schedule) {
  // One wavefront end per thread that may run (the arena's, capped by a tbb::global_control),
  // each of at least CLOTH_PARTICLE_GRAIN particles.
  const auto threads = std::max<std::size_t>(
      1, std::min(static_cast<std::size_t>(std::max(1, parallel_thread_count())),
                  tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  const std::size_t ends =
      std::min(threads, std::max<std::size_t>(1, adjacency.slice_count() / (CLOTH_PARTICLE_GRAIN / CLOTH_SLICE_WIDTH)));
  if (schedule == Rk4Schedule::AUTO) schedule = threads == 1 ? Rk4Schedule::WAVEFRONT : RK4_AUTO_SCHEDULE_THREADED;
  rk4_step(positions, velocities, adjacency, particles, h, workspace, schedule, ends, TbbForEach{});
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
