#pragma once
/// \file
/// The mass-spring cloth's RK4 integration on an OpenCL device (see cloth_rk4.h for the math,
/// shared through cloth_math.h). Agrees with rk4_step_serial() within float tolerance: the
/// device's sqrt and division may differ from the host's by an ulp, and those differences grow
/// with the steps (tests/opencl states the bound).

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace vfit {

class OpenClContext;
struct SpringAdjacency;
struct ClothParticles;

/// Precompute/solve object: the constructor uploads the adjacency (with the springs'
/// constants) and the particles' inverse masses once; set_state() uploads positions and
/// velocities; step() runs RK4 steps entirely on the device (four stage kernels each, no
/// transfers); get_state() reads the state back.
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

} // namespace vfit
