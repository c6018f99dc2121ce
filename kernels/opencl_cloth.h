// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The mass-spring cloth's RK4 integration on an OpenCL device (see cloth_rk4.h for the math,
/// shared through cloth_math.h). Agrees with rk4_step_serial() within float tolerance: the
/// device's sqrt and division may differ from the host's by an ulp, and those differences grow
/// with the steps (tests/opencl states the bound). Also the implicit Euler system's product
/// (OpenClImplicitMultiply) of cloth_implicit.h, for conjugate gradients on the device.

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace vfit {

class OpenClContext;
struct SpringAdjacency;
struct ClothParticles;
struct ImplicitSystem;

/// Precompute/solve object: the constructor uploads the adjacency's sliced rows (with the
/// springs' constants) and the particles' inverse masses once; set_state() uploads positions
/// and velocities; step() runs RK4 steps entirely on the device (four stage kernels each, no
/// transfers); get_state() reads the state back. On a CPU device (PoCL) each stage runs one
/// work-item per slice of 16 particles in float16 arithmetic, the C++ gather's scheme
/// (cloth.cl's cloth_rk4_stage_slices): PoCL runs a one-particle-per-work-item kernel with a
/// spring loop inside scalar. Other devices run one work-item per particle over the same sliced
/// rows (coalesced across a slice).
class OpenClClothRk4 {
public:
  /// adjacency and particles as for rk4_step_serial() (#V particles).
  OpenClClothRk4(OpenClContext& context, const SpringAdjacency& adjacency, const ClothParticles& particles);
  ~OpenClClothRk4();
  OpenClClothRk4(const OpenClClothRk4&) = delete;
  OpenClClothRk4& operator=(const OpenClClothRk4&) = delete;

  /// positions (m), velocities (m/s): #V × 3 each.
  void set_state(std::span<const float> positions, std::span<const float> velocities);
  /// `count` RK4 steps of h (s) each.
  void step(float h, int count = 1);
  /// Blocks until the steps are done; resizes the outputs to #V × 3.
  void get_state(std::vector<float>& positions, std::vector<float>& velocities);
  /// Spring forces (N, #V × 3, resized) of the current device state: spring_forces_serial().
  void spring_forces(std::vector<float>& forces);
  /// Blocks until every enqueued command has finished (for timing).
  void finish();

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// The implicit Euler system's matrix–vector product on an OpenCL device: out = filtered A·p of
/// kernels/cloth_implicit.h (implicit_system_multiply(), same order of operations, the
/// kernel cloth_implicit_multiply of cloth.cl: D_i·p_i + Σ_e S_e·(p_i − p_j), each S_e in its
/// rank-one form), the product a conjugate-gradient iteration spends most of its time in.
/// Precompute/solve object: the constructor uploads the CSR adjacency and its slice offsets
/// once; set_system() uploads one step's blocks (#V × 6 particle blocks, 5 × #slots sliced
/// spring floats and #V filter flags: 20 bytes per slot plus 25 per particle);
/// multiply() runs on vectors that stay on the device; the host entry uploads p and reads the
/// product back (12 bytes per particle each way). Implicit Euler as seed 004 §2 uses it (Baraff &
/// Witkin 1998); the seed gives no equation for it. Sizes are not checked: every span and
/// system must match the adjacency's #V and #entries (shorter ones are undefined behaviour).
/// OpenCL failures throw std::runtime_error ("OpenCL: <what>: … failed with code N"), not
/// vfit::Error. A system of zero particles makes every call a no-op.
class OpenClImplicitMultiply {
public:
  /// adjacency: the springs' CSR adjacency the systems are assembled over (#V particles,
  /// #entries = neighbors.size()); `context` must outlive the object. Allocates the device
  /// buffers and builds the `cloth` program on first use in that context.
  OpenClImplicitMultiply(OpenClContext& context, const SpringAdjacency& adjacency);
  ~OpenClImplicitMultiply();
  OpenClImplicitMultiply(const OpenClImplicitMultiply&) = delete;
  OpenClImplicitMultiply& operator=(const OpenClImplicitMultiply&) = delete;

  /// Uploads a system assembled by assemble_implicit_system() over the same adjacency: its
  /// particle_blocks (#V × 6, kg), sliced_springs (5 × #slots, component-major: u, a, t) and
  /// free flags (#V); the other blocks, the preconditioner and rhs are not used. Blocks until
  /// uploaded.
  void set_system(const ImplicitSystem& system);
  /// out = filtered A·p: p is #V × 3 (e.g. m/s); out is resized to #V × 3 (kg·p's units);
  /// rows of pinned particles (free = 0) are 0 and their entries of p ignored, as in
  /// implicit_system_multiply(). Blocks until read back. Requires set_system() first.
  void multiply(std::span<const float> p, std::vector<float>& out);
  /// Uploads p (#V × 3) to the device vector the device-resident product reads; blocks.
  void set_vector(std::span<const float> p);
  /// The product of the uploaded vector into the device's output vector, `count` times (for
  /// timing the kernel alone; read nothing back). Enqueues only: call finish() to wait.
  /// count ≤ 0 enqueues nothing.
  void multiply_on_device(int count = 1);
  /// Blocks until every enqueued command has finished.
  void finish();

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
