#include "cloth_implicit.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "cloth_gather.h"
#include "parallel.h"

namespace vfit {
namespace {
using namespace cloth_detail;

vfit_sym3 load_sym(const float* p, std::size_t i) {
  const float* s = p + 6 * i;
  return vfit_sym3{s[0], s[1], s[2], s[3], s[4], s[5]};
}

void store_sym(float* p, std::size_t i, vfit_sym3 s) {
  float* d = p + 6 * i;
  d[0] = s.xx;
  d[1] = s.xy;
  d[2] = s.xz;
  d[3] = s.yy;
  d[4] = s.yz;
  d[5] = s.zz;
}

void add_sym(vfit_sym3& a, vfit_sym3 b) {
  a.xx += b.xx;
  a.xy += b.xy;
  a.xz += b.xz;
  a.yy += b.yy;
  a.yz += b.yz;
  a.zz += b.zz;
}

std::size_t chunk_count(std::size_t n) { return (n + CLOTH_IMPLICIT_CHUNK - 1) / CLOTH_IMPLICIT_CHUNK; }

// Runs kernel(chunk, begin, end) over the fixed chunks of [0, n): in order, or in parallel.
template <typename Kernel> void run_chunks(std::size_t n, bool parallel, const Kernel& kernel) {
  const std::size_t chunks = chunk_count(n);
  const auto body = [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      kernel(c, c * CLOTH_IMPLICIT_CHUNK, std::min(n, (c + 1) * CLOTH_IMPLICIT_CHUNK));
  };
  if (parallel)
    parallel_for_range(chunks, 1, body);
  else
    body(0, chunks);
}

// Σ over chunks, in chunk order, of partials[stride·c + k].
double chunk_sum(const std::vector<double>& partials, std::size_t chunks, std::size_t stride, std::size_t k) {
  double s = 0;
  for (std::size_t c = 0; c < chunks; ++c)
    s += partials[stride * c + k];
  return s;
}

double dot3(vfit_vec3 a, vfit_vec3 b) { return double(a.x) * b.x + double(a.y) * b.y + double(a.z) * b.z; }

// (A·p)_i for a free particle i: A_ii·p_i − Σ_e S_e·p_j (pinned p_j are zero by the filter).
vfit_vec3 row_times(const ImplicitSystem& s, const SpringAdjacency& adj, const float* p, std::size_t i) {
  vfit_vec3 r = vfit_sym3_apply(load_sym(s.diagonal.data(), i), load3(p, i));
  for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
    const vfit_vec3 t = vfit_sym3_apply(load_sym(s.off_diagonal.data(), std::size_t(e)),
                                        load3(p, static_cast<std::size_t>(adj.neighbors[e])));
    r.x -= t.x;
    r.y -= t.y;
    r.z -= t.z;
  }
  return r;
}

void assemble_range(const float* x, const float* v, const SpringAdjacency& adj, const ClothParticles& particles,
                    float h, ImplicitSystem& s, std::size_t begin, std::size_t end) {
  const float* inv_mass = particles.inverse_masses.data();
  for (std::size_t i = begin; i < end; ++i) {
    const bool is_free = inv_mass[i] != 0.0f;
    s.free[i] = is_free ? 1 : 0;
    const float m = is_free ? 1.0f / inv_mass[i] : 0.0f;
    const float md = m * (1.0f + h * particles.global_damping);
    vfit_sym3 diag{md, 0.0f, 0.0f, md, 0.0f, md};
    const vfit_vec3 xi = load3(x, i), vi = load3(v, i);
    vfit_vec3 f{0.0f, 0.0f, 0.0f}, kv{0.0f, 0.0f, 0.0f}; // spring force, ∂f/∂x·v
    for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
      const auto j = static_cast<std::size_t>(adj.neighbors[e]);
      const vfit_vec3 xj = load3(x, j), vj = load3(v, j);
      const float L = adj.rest_lengths[e], k = adj.stiffness[e], c = adj.damping[e];
      vfit_vec3 fs, ks;
      vfit_sym3 block;
      vfit_spring_implicit_terms(xi, xj, vi, vj, L, k, c, h, &fs, &ks, &block);
      f.x += fs.x;
      f.y += fs.y;
      f.z += fs.z;
      kv.x += ks.x;
      kv.y += ks.y;
      kv.z += ks.z;
      store_sym(s.off_diagonal.data(), std::size_t(e), block);
      add_sym(diag, block);
    }
    store_sym(s.diagonal.data(), i, diag);
    if (!is_free) {
      store_sym(s.preconditioner.data(), i, vfit_sym3{0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f});
      store3(s.rhs.data(), i, vfit_vec3{0.0f, 0.0f, 0.0f});
      continue;
    }
    store_sym(s.preconditioner.data(), i, vfit_sym3_inverse(diag));
    // b = h·(f + m·g − μ·m·v + h·∂f/∂x·v)
    const float g[3] = {particles.gravity[0], particles.gravity[1], particles.gravity[2]};
    const float mu = particles.global_damping;
    store3(s.rhs.data(), i,
           vfit_vec3{h * (f.x + m * g[0] - mu * m * vi.x + h * kv.x), h * (f.y + m * g[1] - mu * m * vi.y + h * kv.y),
                     h * (f.z + m * g[2] - mu * m * vi.z + h * kv.z)});
  }
}

void resize_system(ImplicitSystem& s, std::size_t nv, std::size_t entries) {
  s.off_diagonal.resize(6 * entries);
  s.diagonal.resize(6 * nv);
  s.preconditioner.resize(6 * nv);
  s.rhs.resize(3 * nv);
  s.free.resize(nv);
}

bool contact_row(const ImplicitContactSprings& c, std::size_t i) {
  const vfit_vec3 n = load3(c.normals.data(), i);
  return vfit_v3_dot(n, n) > 0.0f;
}

// Adds (sign = 1) or removes (sign = −1) particle i's contact spring: h²·k·n·nᵀ on its diagonal
// block (and its preconditioner block) and (−h·k·g₀ − h²·k·n·v₀)·n on its right-hand side.
void add_contact_spring(ImplicitSystem& s, const ImplicitContactSprings& c, const float* v, float h, std::size_t i,
                        float sign) {
  const vfit_vec3 n = load3(c.normals.data(), i);
  const float k = c.stiffness[i];
  const float a = sign * h * h * k;
  vfit_sym3 d = load_sym(s.diagonal.data(), i);
  d.xx += a * n.x * n.x;
  d.xy += a * n.x * n.y;
  d.xz += a * n.x * n.z;
  d.yy += a * n.y * n.y;
  d.yz += a * n.y * n.z;
  d.zz += a * n.z * n.z;
  store_sym(s.diagonal.data(), i, d);
  store_sym(s.preconditioner.data(), i, vfit_sym3_inverse(d));
  const float along = sign * (-h * k * c.gaps[i]) - a * vfit_v3_dot(n, load3(v, i));
  const vfit_vec3 b = load3(s.rhs.data(), i);
  store3(s.rhs.data(), i, vfit_vec3{b.x + along * n.x, b.y + along * n.y, b.z + along * n.z});
}

// λ = −h·k·(g₀ + h·n·v₁) (N·s), v₁ = v₀ + Δv: the contact spring's impulse over the step.
float contact_impulse(const ImplicitContactSprings& c, const float* v, const float* dv, float h, std::size_t i) {
  const vfit_vec3 n = load3(c.normals.data(), i), v0 = load3(v, i), d = load3(dv, i);
  const vfit_vec3 v1{v0.x + d.x, v0.y + d.y, v0.z + d.z};
  return -h * c.stiffness[i] * (c.gaps[i] + h * vfit_v3_dot(n, v1));
}

ImplicitSolveReport implicit_step(std::span<float> positions, std::span<float> velocities,
                                  const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                                  const ImplicitSolveOptions& options, ImplicitWorkspace& w, bool parallel,
                                  const ImplicitConstraints* constraints,
                                  const ImplicitContactSprings* contact_springs) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && velocities.size() == 3 * nv && "state and adjacency sizes differ");
  assemble_implicit_system(positions, velocities, adjacency, particles, h, w.system, parallel);
  const bool springs = contact_springs != nullptr && !contact_springs->empty();
  if (springs) {
    assert(contact_springs->normals.size() == 3 * nv && contact_springs->gaps.size() == nv &&
           contact_springs->stiffness.size() == nv && "one contact spring row per particle");
    w.contact_active.assign(nv, 0);
    run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        if (w.system.free[i] && contact_springs->stiffness[i] > 0.0f && contact_row(*contact_springs, i)) {
          w.contact_active[i] = 1;
          add_contact_spring(w.system, *contact_springs, velocities.data(), h, i, 1.0f);
        }
    });
  }
  ImplicitSolveReport report = solve_implicit_system(adjacency, options, w, parallel, constraints);
  if (springs) {
    // One-sided: remove the springs that pulled and solve again from this answer.
    const std::size_t chunks = chunk_count(nv);
    w.partials.assign(chunks, 0.0);
    w.normal_impulses.assign(nv, 0.0f);
    run_chunks(nv, parallel, [&](std::size_t c, std::size_t b, std::size_t e) {
      double removed = 0;
      for (std::size_t i = b; i < e; ++i) {
        if (!w.contact_active[i]) continue;
        if (contact_impulse(*contact_springs, velocities.data(), w.dv.data(), h, i) < 0.0f) {
          w.contact_active[i] = 0;
          add_contact_spring(w.system, *contact_springs, velocities.data(), h, i, -1.0f);
          removed += 1;
        }
      }
      w.partials[c] = removed;
    });
    if (chunk_sum(w.partials, chunks, 1, 0) > 0 && contact_springs->release_iterations > 0) {
      ImplicitSolveOptions again = options;
      again.warm_start = true;
      again.max_iterations = contact_springs->release_iterations;
      report.iterations += solve_implicit_system(adjacency, again, w, parallel, constraints).iterations;
    }
    run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i)
        if (w.contact_active[i])
          w.normal_impulses[i] = contact_impulse(*contact_springs, velocities.data(), w.dv.data(), h, i);
    });
  }
  float* x = positions.data();
  float* v = velocities.data();
  const float* dv = w.dv.data();
  const unsigned char* is_free = w.system.free.data();
  run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      if (!is_free[i]) continue;
      for (std::size_t k = 3 * i; k < 3 * i + 3; ++k) {
        v[k] += dv[k];
        x[k] += h * v[k];
      }
    }
  });
  return report;
}
} // namespace

void assemble_implicit_system(std::span<const float> positions, std::span<const float> velocities,
                              const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                              ImplicitSystem& system, bool parallel) {
  const std::size_t nv = adjacency.particle_count();
  assert(positions.size() == 3 * nv && velocities.size() == 3 * nv && "state and adjacency sizes differ");
  assert(particles.inverse_masses.size() == nv && "one inverse mass per particle");
  resize_system(system, nv, adjacency.neighbors.size());
  run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
    assemble_range(positions.data(), velocities.data(), adjacency, particles, h, system, b, e);
  });
}

void implicit_system_multiply(const ImplicitSystem& system, const SpringAdjacency& adjacency, std::span<const float> p,
                              std::vector<float>& out) {
  const std::size_t nv = adjacency.particle_count();
  assert(p.size() == 3 * nv && "one 3-vector per particle");
  // The filter: pinned entries of p read as zero.
  std::vector<float> filtered(p.begin(), p.end());
  for (std::size_t i = 0; i < nv; ++i)
    if (!system.free[i]) store3(filtered.data(), i, vfit_vec3{0.0f, 0.0f, 0.0f});
  out.assign(3 * nv, 0.0f);
  for (std::size_t i = 0; i < nv; ++i)
    if (system.free[i]) store3(out.data(), i, row_times(system, adjacency, filtered.data(), i));
}

ImplicitSolveReport solve_implicit_system(const SpringAdjacency& adjacency, const ImplicitSolveOptions& options,
                                          ImplicitWorkspace& w, bool parallel, const ImplicitConstraints* constraints) {
  const std::size_t nv = adjacency.particle_count();
  const std::size_t chunks = chunk_count(nv);
  const ImplicitSystem& s = w.system;
  const bool constrained = constraints != nullptr && !constraints->empty();
  assert((!constrained || (constraints->normals.size() == 3 * nv && constraints->targets.size() == nv)) &&
         "one constraint row per particle");
  const float* normals = constrained ? constraints->normals.data() : nullptr;
  const bool warm = options.warm_start && w.dv.size() == 3 * nv && !constrained;
  for (auto* buf : {&w.dv, &w.r, &w.z, &w.p, &w.q})
    if (!warm || buf != &w.dv) buf->assign(3 * nv, 0.0f);
  w.partials.assign(2 * chunks, 0.0);
  float* dv = w.dv.data();
  float* r = w.r.data();
  float* z = w.z.data();
  float* p = w.p.data();
  float* q = w.q.data();
  double* part = w.partials.data();
  const float* precond = s.preconditioner.data();
  // B&W's filter S_i: 0 for a pinned particle, I − n·nᵀ for a contact, I otherwise.
  const auto filter = [&](std::size_t i, vfit_vec3 a) {
    if (!s.free[i]) return vfit_vec3{0.0f, 0.0f, 0.0f};
    if (normals == nullptr) return a;
    const vfit_vec3 n = load3(normals, i);
    const float an = vfit_v3_dot(a, n);
    return vfit_vec3{a.x - an * n.x, a.y - an * n.y, a.z - an * n.z};
  };

  // Δv₀ = the constrained components, or the previous answer with a warm start (zero otherwise),
  // so r₀ = S·(b − A·Δv₀).
  if (constrained) {
    run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 n = load3(normals, i);
        const float t = s.free[i] ? constraints->targets[i] : 0.0f;
        store3(dv, i, vfit_vec3{t * n.x, t * n.y, t * n.z});
      }
    });
  }
  // r = S·(b − A·Δv₀), z = S·P⁻¹·r; partials: |S·b|², r·z.
  run_chunks(nv, parallel, [&](std::size_t c, std::size_t b, std::size_t e) {
    double bb = 0, rz = 0;
    for (std::size_t i = b; i < e; ++i) {
      const vfit_vec3 bi = filter(i, load3(s.rhs.data(), i));
      vfit_vec3 ri = bi;
      if ((constrained || warm) && s.free[i])
        ri = filter(i, vfit_v3_sub(load3(s.rhs.data(), i), row_times(s, adjacency, dv, i)));
      const vfit_vec3 zi = filter(i, vfit_sym3_apply(load_sym(precond, i), ri));
      store3(r, i, ri);
      store3(z, i, zi);
      bb += dot3(bi, bi);
      rz += dot3(ri, zi);
    }
    part[2 * c] = bb;
    part[2 * c + 1] = rz;
  });
  const double bb = chunk_sum(w.partials, chunks, 2, 0);
  double rz = chunk_sum(w.partials, chunks, 2, 1);
  ImplicitSolveReport report;
  double rr = 0;
  for (std::size_t k = 0; k < 3 * nv; ++k)
    rr += double(r[k]) * r[k];
  // The scale of the relative test: |S·b| (the impulse the free directions must balance; |b|
  // instead, which includes the weight the contacts carry, lets the 6,000-vertex tee drape
  // diverge at steps of 1/60 s), or |r₀| when only the constraints drive the solve; with a warm
  // start |r₀| alone (see ImplicitSolveOptions::warm_start).
  const double scale = warm ? rr : std::max(bb, rr);
  const double stop = options.tolerance * options.tolerance * scale;
  // Two passes over the particles per iteration instead of three: the new search direction
  // p = z + β·p and its product q = S·A·p are formed together, q as S·A·z + β·q (the product is
  // linear), so the product gathers z, which is complete before the pass, and p and q are
  // updated in place row by row. p and q start at zero, so β = 0 gives p = z, q = S·A·z.
  float beta = 0.0f;
  while (scale > 0 && report.iterations < options.max_iterations && rr > stop) {
    // p = z + β·p, q = S·A·z + β·q; partial p·q.
    run_chunks(nv, parallel, [&](std::size_t c, std::size_t b, std::size_t e) {
      double pq = 0;
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 az = s.free[i] ? filter(i, row_times(s, adjacency, z, i)) : vfit_vec3{0.0f, 0.0f, 0.0f};
        const vfit_vec3 zi = load3(z, i), pi = load3(p, i), qi = load3(q, i);
        const vfit_vec3 pn{zi.x + beta * pi.x, zi.y + beta * pi.y, zi.z + beta * pi.z};
        const vfit_vec3 qn{az.x + beta * qi.x, az.y + beta * qi.y, az.z + beta * qi.z};
        store3(p, i, pn);
        store3(q, i, qn);
        pq += dot3(pn, qn);
      }
      part[2 * c] = pq;
    });
    const double pq = chunk_sum(w.partials, chunks, 2, 0);
    if (!(pq > 0)) break; // A is positive definite on the free rows: only a zero p gets here
    const auto alpha = static_cast<float>(rz / pq);
    // Δv += α·p, r −= α·q, z = S·P⁻¹·r; partials r·r, r·z.
    run_chunks(nv, parallel, [&](std::size_t c, std::size_t b, std::size_t e) {
      double rr_c = 0, rz_c = 0;
      for (std::size_t i = b; i < e; ++i) {
        for (std::size_t k = 3 * i; k < 3 * i + 3; ++k) {
          dv[k] += alpha * p[k];
          r[k] -= alpha * q[k];
        }
        const vfit_vec3 ri = load3(r, i);
        const vfit_vec3 zi = filter(i, vfit_sym3_apply(load_sym(precond, i), ri));
        store3(z, i, zi);
        rr_c += dot3(ri, ri);
        rz_c += dot3(ri, zi);
      }
      part[2 * c] = rr_c;
      part[2 * c + 1] = rz_c;
    });
    rr = chunk_sum(w.partials, chunks, 2, 0);
    const double rz_next = chunk_sum(w.partials, chunks, 2, 1);
    ++report.iterations;
    if (rr <= stop) break;
    beta = static_cast<float>(rz_next / rz);
    rz = rz_next;
  }
  if (constrained) {
    // The impulse each constraint applied: (A·Δv − b)·n.
    w.normal_impulses.assign(nv, 0.0f);
    run_chunks(nv, parallel, [&](std::size_t, std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const vfit_vec3 n = load3(normals, i);
        if (!s.free[i] || vfit_v3_dot(n, n) == 0.0f) continue;
        w.normal_impulses[i] = vfit_v3_dot(vfit_v3_sub(row_times(s, adjacency, dv, i), load3(s.rhs.data(), i)), n);
      }
    });
  }
  report.relative_residual = scale > 0 ? std::sqrt(rr / scale) : 0.0;
  report.converged = rr <= stop;
  return report;
}

ImplicitSolveReport implicit_euler_step_serial(std::span<float> positions, std::span<float> velocities,
                                               const SpringAdjacency& adjacency, const ClothParticles& particles,
                                               float h, const ImplicitSolveOptions& options,
                                               ImplicitWorkspace& workspace, const ImplicitConstraints* constraints,
                                               const ImplicitContactSprings* contact_springs) {
  return implicit_step(positions, velocities, adjacency, particles, h, options, workspace, false, constraints,
                       contact_springs);
}

ImplicitSolveReport implicit_euler_step_tbb(std::span<float> positions, std::span<float> velocities,
                                            const SpringAdjacency& adjacency, const ClothParticles& particles, float h,
                                            const ImplicitSolveOptions& options, ImplicitWorkspace& workspace,
                                            const ImplicitConstraints* constraints,
                                            const ImplicitContactSprings* contact_springs) {
  return implicit_step(positions, velocities, adjacency, particles, h, options, workspace, true, constraints,
                       contact_springs);
}

} // namespace vfit
