// SPDX-License-Identifier: Apache-2.0
/* Mass-spring cloth math (seed 000 §6.3, eq. 22–24), written once in the C subset that both
 * C++ and OpenCL C accept: included by cloth_springs.cpp / cloth_rk4.cpp (the serial and TBB
 * reference) and by cloth.cl (the OpenCL kernels), so every backend evaluates the same
 * expressions in the same order.
 *
 * Conventions: positions in m, velocities in m/s, forces in N, stiffness k in N/m, spring
 * damping c in N·s/m, global damping μ in 1/s (a force −μ·m·v, i.e. a per-mass drag rate),
 * inverse masses in 1/kg. A particle with inverse mass 0 is pinned: it neither accelerates nor
 * moves, whatever the forces on it. */
#ifndef VFIT_CLOTH_MATH_H
#define VFIT_CLOTH_MATH_H

#include "closest_point_math.h" /* vfit_vec3, VFIT_INLINE, vfit_v3_sub, vfit_v3_dot */

/* Springs shorter than this (m) have no direction: they exert no force. Far below any cloth
 * edge (≥ 0.1 mm) yet far above the float noise of coincident points. */
#define VFIT_SPRING_MIN_LENGTH 1e-9f

/* The scalar t of the spring force f_i = t·d of vfit_spring_force_relative below, from the
 * components of d = x_j − x_i (m) and dv = v_j − v_i (m/s), on operands of type T: float, or
 * in OpenCL C a float vector (cloth.cl's kernel for CPU devices evaluates 16 springs at once
 * with it). ONE_IF(c) turns the comparison c into 1 or 0 of type T. Written once, here, so
 * every backend evaluates the same expressions in the same order. All arguments are names. */
#define VFIT_SPRING_FORCE_SCALE(T, ONE_IF, dx, dy, dz, dvx, dvy, dvz, rest_length, stiffness, damping, t_out)          \
  do {                                                                                                                 \
    T vfit_l_ = sqrt(dx * dx + dy * dy + dz * dz);                                                                     \
    T vfit_m_ = ONE_IF(vfit_l_ > VFIT_SPRING_MIN_LENGTH);                                                              \
    T vfit_safe_l_ = vfit_m_ * vfit_l_ + (1.0f - vfit_m_);                                                             \
    T vfit_w_ = 1.0f / vfit_safe_l_;                                                                                   \
    t_out = (stiffness * (vfit_safe_l_ - rest_length) + damping * (dvx * dx + dvy * dy + dvz * dz) * vfit_w_) *        \
            vfit_w_ * vfit_m_;                                                                                         \
  } while (0)

#define VFIT_ONE_IF_FLOAT(c) ((float)(c))

/* Force on particle i from the spring joining it to particle j, given their relative
 * position d = x_j − x_i (m) and velocity dv = v_j − v_i (m/s):
 *   f_i = (k·(l − L) + c·(dv·u))·u,   u = d/l,  l = |d|,
 * Hooke's force plus damping of the stretch rate along the spring (eq. 22's f^s + f^ds, or
 * f^b + f^db for a bending spring), evaluated as f_i = t·d with w = 1/l and
 * t = (k·(l − L) + c·(dv·d)·w)·w: one square root and one division per spring (the divider
 * bounds a CPU's gather). No select: a spring shorter than VFIT_SPRING_MIN_LENGTH is handled
 * by the 0/1 factor m (a select lets a compiler branch, and a loop with a branch does not
 * vectorise); safe_l = 1 keeps its t finite, so its force is ±0. NaN inputs give NaN. */
VFIT_INLINE vfit_vec3 vfit_spring_force_relative(vfit_vec3 d, vfit_vec3 dv, float rest_length, float stiffness,
                                                 float damping) {
  float t;
  VFIT_SPRING_FORCE_SCALE(float, VFIT_ONE_IF_FLOAT, d.x, d.y, d.z, dv.x, dv.y, dv.z, rest_length, stiffness, damping,
                          t);
  vfit_vec3 f;
  f.x = t * d.x;
  f.y = t * d.y;
  f.z = t * d.z;
  return f;
}

/* Force on particle i (at xi, moving at vi) from the spring joining it to particle j:
 * vfit_spring_force_relative(x_j − x_i, v_j − v_i, …). Exactly antisymmetric in float:
 * swapping i and j negates d and dv bit for bit and leaves l, w, dv·d and t unchanged, so
 * f_j == −f_i exactly and a per-particle gather equals a per-spring scatter. */
VFIT_INLINE vfit_vec3 vfit_spring_force(vfit_vec3 xi, vfit_vec3 xj, vfit_vec3 vi, vfit_vec3 vj, float rest_length,
                                        float stiffness, float damping) {
  return vfit_spring_force_relative(vfit_v3_sub(xj, xi), vfit_v3_sub(vj, vi), rest_length, stiffness, damping);
}

/* Acceleration of a particle (eq. 22–23): a = f_springs/m + g − μ·v, or +0 when pinned
 * (inv_mass == 0). gravity in m/s², global_damping μ in 1/s. Selects, not a branch, so a loop
 * over particles vectorises. */
VFIT_INLINE vfit_vec3 vfit_particle_acceleration(vfit_vec3 spring_force, vfit_vec3 v, float inv_mass, vfit_vec3 gravity,
                                                 float global_damping) {
  int pinned = inv_mass == 0.0f;
  vfit_vec3 a;
  a.x = pinned ? 0.0f : spring_force.x * inv_mass + gravity.x - global_damping * v.x;
  a.y = pinned ? 0.0f : spring_force.y * inv_mass + gravity.y - global_damping * v.y;
  a.z = pinned ? 0.0f : spring_force.z * inv_mass + gravity.z - global_damping * v.z;
  return a;
}

/* Classical RK4 (eq. 23–24 integrated with Runge–Kutta 4) of the first-order system
 * x' = v, v' = a(x, v), split into four stages s = 0..3. Stage s was evaluated at the stage
 * state (xs, vs) and gave acceleration a; the stage's slopes are (vs, a). Their weighted sum
 * (weights 1, 2, 2, 1) accumulates into (acc_x, acc_v), which stage 0 starts from zero. */
VFIT_INLINE float vfit_rk4_weight(int stage) { return (stage == 0 || stage == 3) ? 1.0f : 2.0f; }

/* Fraction of the step h at which stage s + 1 is evaluated: 1/2, 1/2, 1. */
VFIT_INLINE float vfit_rk4_next_fraction(int stage) { return stage == 2 ? 1.0f : 0.5f; }

/* One particle's RK4 stage update. Inputs: the step start (x0, v0), the stage slopes (vs, a),
 * the running sums (*acc_x, *acc_v), the step h (s), the stage s. For s < 3 it writes the next
 * stage state x0 + α·h·vs, v0 + α·h·a (α from vfit_rk4_next_fraction) to (*next_x, *next_v);
 * for s == 3 it writes the step's result x0 + h/6·Σ, v0 + h/6·Σ there instead. */
VFIT_INLINE void vfit_rk4_stage_update(vfit_vec3 x0, vfit_vec3 v0, vfit_vec3 vs, vfit_vec3 a, float h, int stage,
                                       vfit_vec3* acc_x, vfit_vec3* acc_v, vfit_vec3* next_x, vfit_vec3* next_v) {
  float w = vfit_rk4_weight(stage);
  vfit_vec3 sx, sv;
  if (stage == 0) {
    sx.x = vs.x;
    sx.y = vs.y;
    sx.z = vs.z;
    sv.x = a.x;
    sv.y = a.y;
    sv.z = a.z;
  } else {
    sx.x = acc_x->x + w * vs.x;
    sx.y = acc_x->y + w * vs.y;
    sx.z = acc_x->z + w * vs.z;
    sv.x = acc_v->x + w * a.x;
    sv.y = acc_v->y + w * a.y;
    sv.z = acc_v->z + w * a.z;
  }
  *acc_x = sx;
  *acc_v = sv;
  float t = stage == 3 ? h / 6.0f : vfit_rk4_next_fraction(stage) * h;
  vfit_vec3 px = stage == 3 ? sx : vs;
  vfit_vec3 pv = stage == 3 ? sv : a;
  next_x->x = x0.x + t * px.x;
  next_x->y = x0.y + t * px.y;
  next_x->z = x0.z + t * px.z;
  next_v->x = v0.x + t * pv.x;
  next_v->y = v0.y + t * pv.y;
  next_v->z = v0.z + t * pv.z;
}

/* Body contact response of one particle (seed 004 §2: position pushed out, velocity changed by
 * friction and restitution). n: the body's outward unit normal at the closest point; depth:
 * thickness − signed distance (m), > 0 when the particle is closer than the thickness;
 * body_v: the body's velocity at the contact (m/s); friction μ_f (Coulomb, ≥ 0); restitution e
 * in [0, 1]. Moves *x out by depth along n; if the particle approaches the body, its normal
 * relative velocity becomes −e times itself and its tangential relative velocity shrinks by
 * μ_f times the normal velocity change (stopping, never reversing). */
VFIT_INLINE void vfit_contact_response(vfit_vec3* x, vfit_vec3* v, vfit_vec3 n, float depth, vfit_vec3 body_v,
                                       float friction, float restitution) {
  if (!(depth > 0.0f)) return;
  x->x += depth * n.x;
  x->y += depth * n.y;
  x->z += depth * n.z;
  vfit_vec3 rel = vfit_v3_sub(*v, body_v);
  float vn = vfit_v3_dot(rel, n);
  if (!(vn < 0.0f)) return;
  vfit_vec3 vt;
  vt.x = rel.x - vn * n.x;
  vt.y = rel.y - vn * n.y;
  vt.z = rel.z - vn * n.z;
  float dvn = -(1.0f + restitution) * vn; /* > 0 */
  float vt_len = sqrt(vfit_v3_dot(vt, vt));
  float scale = 0.0f;
  if (vt_len > 0.0f) {
    scale = 1.0f - friction * dvn / vt_len;
    if (scale < 0.0f) scale = 0.0f;
  }
  float vn_new = -restitution * vn;
  v->x = body_v.x + vn_new * n.x + scale * vt.x;
  v->y = body_v.y + vn_new * n.y + scale * vt.y;
  v->z = body_v.z + vn_new * n.z + scale * vt.z;
}

/* ---- Implicit Euler (Baraff & Witkin 1998, as seed 004 §2) ----
 * A symmetric 3×3 block, stored as its upper triangle. */
typedef struct {
  float xx, xy, xz, yy, yz, zz;
} vfit_sym3;

/* Jacobian blocks of one spring (the force on i from the spring joining it to j, as
 * vfit_spring_force):
 *   ∂f_i/∂x_j = −∂f_i/∂x_i = K = k·(u·uᵀ + max(0, 1 − L/l)·(I − u·uᵀ)),
 *   ∂f_i/∂v_j = −∂f_i/∂v_i = D = c·u·uᵀ.
 * K is Hooke's force derivative; its transverse term k·(1 − L/l) is negative for a compressed
 * spring (l < L) and would make the implicit system indefinite, so it is clamped at zero there
 * (Choi & Ko 2002's buckling fix, as most cloth codes do); pass clamp_compression = 0 for the
 * exact derivative. The derivative of the damping force with respect to x is dropped (Baraff &
 * Witkin §5: it is not symmetric and small). This returns S = h·D + h²·K, the spring's block of
 * the implicit matrix A = M − h·∂f/∂v − h²·∂f/∂x (added to A_ii and A_jj, subtracted at A_ij);
 * h = 1, c = 0 gives K itself. Symmetric in i and j bit for bit (u·uᵀ does not change sign).
 * Springs shorter than VFIT_SPRING_MIN_LENGTH give a zero block. */
VFIT_INLINE vfit_sym3 vfit_spring_system_block(vfit_vec3 xi, vfit_vec3 xj, float rest_length, float stiffness,
                                               float damping, float h, int clamp_compression) {
  vfit_sym3 b;
  b.xx = 0.0f;
  b.xy = 0.0f;
  b.xz = 0.0f;
  b.yy = 0.0f;
  b.yz = 0.0f;
  b.zz = 0.0f;
  vfit_vec3 d = vfit_v3_sub(xj, xi);
  float l = sqrt(vfit_v3_dot(d, d));
  if (!(l > VFIT_SPRING_MIN_LENGTH)) return b;
  vfit_vec3 u;
  u.x = d.x / l;
  u.y = d.y / l;
  u.z = d.z / l;
  float transverse = stiffness * (1.0f - rest_length / l);
  if (clamp_compression && transverse < 0.0f) transverse = 0.0f;
  /* S = a·u·uᵀ + t·I with a = h·c + h²·(k − transverse), t = h²·transverse. */
  float t = h * h * transverse;
  float a = h * damping + h * h * (stiffness - transverse);
  b.xx = a * u.x * u.x + t;
  b.xy = a * u.x * u.y;
  b.xz = a * u.x * u.z;
  b.yy = a * u.y * u.y + t;
  b.yz = a * u.y * u.z;
  b.zz = a * u.z * u.z + t;
  return b;
}

/* Everything the implicit step's assembly needs from one spring, given the relative position
 * d = x_j − x_i (m) and velocity dv = v_j − v_i (m/s), from one square root and one division
 * (where the three calls below take three square roots and seven divisions):
 *   *force = vfit_spring_force_relative(d, dv, L, k, c),
 *   *stiffness_dv = K·dv, K = vfit_spring_system_block(xi, xj, L, k, 0, 1, 1),
 *   *block = vfit_spring_system_block(xi, xj, L, k, c, h, 1),
 * the same formulas (compression clamped), so the same values up to float rounding. Like
 * vfit_spring_force_relative it has no select on the length (a loop over springs vectorises):
 * springs shorter than VFIT_SPRING_MIN_LENGTH give ±0. */
VFIT_INLINE void vfit_spring_implicit_terms_relative(vfit_vec3 d, vfit_vec3 dv, float rest_length, float stiffness,
                                                     float damping, float h, vfit_vec3* force, vfit_vec3* stiffness_dv,
                                                     vfit_sym3* block) {
  float l = sqrt(vfit_v3_dot(d, d));
  float m = (float)(l > VFIT_SPRING_MIN_LENGTH);
  float safe_l = m * l + (1.0f - m);
  float w = 1.0f / safe_l;
  vfit_vec3 u;
  u.x = m * (d.x * w);
  u.y = m * (d.y * w);
  u.z = m * (d.z * w);
  float rate = vfit_v3_dot(dv, u);
  float s = stiffness * (safe_l - rest_length) + damping * rate;
  force->x = s * u.x;
  force->y = s * u.y;
  force->z = s * u.z;
  float transverse = m * (stiffness * (1.0f - rest_length * w));
  transverse = transverse < 0.0f ? 0.0f : transverse;
  /* K·w = (k − t)·u·(u·w) + t·w */
  float along = (stiffness - transverse) * rate;
  stiffness_dv->x = along * u.x + transverse * dv.x;
  stiffness_dv->y = along * u.y + transverse * dv.y;
  stiffness_dv->z = along * u.z + transverse * dv.z;
  float t = h * h * transverse;
  float a = h * damping + h * h * (stiffness - transverse);
  block->xx = a * u.x * u.x + t;
  block->xy = a * u.x * u.y;
  block->xz = a * u.x * u.z;
  block->yy = a * u.y * u.y + t;
  block->yz = a * u.y * u.z;
  block->zz = a * u.z * u.z + t;
}

/* S·d for a spring's block in its rank-one form S = a·u·uᵀ + t·I (u: the spring's unit
 * direction; a = h·c + h²·(k − t'), t = h²·t' as vfit_spring_system_block's, kg): a·u·(u·d) + t·d.
 * The implicit product applies each spring to a difference d = p_i − p_j this way, where the
 * block's six rounded entries (2⁻²⁴·a each) would act on every direction of d. */
VFIT_INLINE vfit_vec3 vfit_spring_rank_one_apply(vfit_vec3 u, float a, float t, vfit_vec3 d) {
  float along = a * vfit_v3_dot(u, d);
  vfit_vec3 r;
  r.x = along * u.x + t * d.x;
  r.y = along * u.y + t * d.y;
  r.z = along * u.z + t * d.z;
  return r;
}

/* S·p for a symmetric block S. */
VFIT_INLINE vfit_vec3 vfit_sym3_apply(vfit_sym3 s, vfit_vec3 p) {
  vfit_vec3 r;
  r.x = s.xx * p.x + s.xy * p.y + s.xz * p.z;
  r.y = s.xy * p.x + s.yy * p.y + s.yz * p.z;
  r.z = s.xz * p.x + s.yz * p.y + s.zz * p.z;
  return r;
}

/* Inverse of a symmetric positive definite block by its adjugate; the zero block when the
 * determinant is not positive (a singular row: the caller's preconditioner then skips it). */
VFIT_INLINE vfit_sym3 vfit_sym3_inverse(vfit_sym3 s) {
  vfit_sym3 r;
  float cxx = s.yy * s.zz - s.yz * s.yz;
  float cxy = s.xz * s.yz - s.xy * s.zz;
  float cxz = s.xy * s.yz - s.xz * s.yy;
  float det = s.xx * cxx + s.xy * cxy + s.xz * cxz;
  if (!(det > 0.0f)) {
    r.xx = 0.0f;
    r.xy = 0.0f;
    r.xz = 0.0f;
    r.yy = 0.0f;
    r.yz = 0.0f;
    r.zz = 0.0f;
    return r;
  }
  float inv = 1.0f / det;
  r.xx = cxx * inv;
  r.xy = cxy * inv;
  r.xz = cxz * inv;
  r.yy = (s.xx * s.zz - s.xz * s.xz) * inv;
  r.yz = (s.xy * s.xz - s.xx * s.yz) * inv;
  r.zz = (s.xx * s.yy - s.xy * s.xy) * inv;
  return r;
}

#endif
