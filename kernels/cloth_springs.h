// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The springs of a mass-spring cloth (seed 000 §6.3, eq. 22; seed 004 §2) and their forces:
/// structural springs on the mesh edges, bending springs across each pair of adjacent
/// triangles (which also carry shear, see SpringKind); forces evaluated per particle by a gather over a CSR
/// particle→spring adjacency (no atomics), serial and TBB, plus a per-spring scatter oracle.
/// The per-spring math lives in cloth_math.h, shared with the OpenCL kernels.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "spring_adjacency.h"

namespace vfit {

/// What a spring models. Values are stable (stored per spring).
/// There is no separate shear family: on a triangle mesh in-plane shear is resisted by the
/// structural springs (a triangulated quad's diagonal is an edge) and by the bending spring
/// across that diagonal (the quad's other diagonal), as Provot's shear springs are on a grid.
enum class SpringKind : std::int8_t {
  STRUCTURAL = 0, ///< a mesh edge: stretch
  BENDING = 1,    ///< the two vertices opposite a shared edge: resists folding (and shear)
};

/// Which spring families build_cloth_springs() creates.
struct SpringTopologyOptions {
  bool bending = true; ///< one spring per edge shared by exactly two triangles
};

/// Springs of a cloth, one row per spring. Stiffness and damping are filled by the caller
/// (e.g. from a fabric) before the adjacency is built.
struct ClothSprings {
  std::vector<std::int32_t> ends;  ///< #S × 2 particle indices (i < j)
  std::vector<float> rest_lengths; ///< #S rest lengths L (m), the initial lengths
  std::vector<float> stiffness;    ///< #S Hooke constants k (N/m)
  std::vector<float> damping;      ///< #S damping of the stretch rate c (N·s/m)
  std::vector<SpringKind> kinds;   ///< #S

  std::size_t size() const { return rest_lengths.size(); }
};

/// Builds the springs of a triangle mesh. positions: #V × 3 (m); triangles: #F × 3 indices in
/// [0, #V) (validated by the caller; assert only). Structural springs come first, in order of
/// first appearance of each undirected edge; then bending springs (one per edge shared by
/// exactly two triangles whose opposite vertices differ and are not already joined by an
/// edge or an earlier bending spring). Rest lengths are the initial lengths (seed 000: "the rest length of the
/// tension spring is the initial edge length"); a spring of zero rest length is kept (it pulls
/// its ends together). Stiffness and damping are sized #S and zero.
ClothSprings build_cloth_springs(std::span<const float> positions, std::span<const std::int32_t> triangles,
                                 const SpringTopologyOptions& options = {});

/// Builds the adjacency of `springs` over `particle_count` particles, CSR and sliced rows.
/// Rebuild it after changing the springs' parameters.
SpringAdjacency build_spring_adjacency(const ClothSprings& springs, std::size_t particle_count);

/// Particles per TBB task in the gather drivers (each particle visits ~12 springs); a multiple
/// of CLOTH_SLICE_WIDTH.
inline constexpr std::size_t CLOTH_PARTICLE_GRAIN = 2048;
static_assert(CLOTH_PARTICLE_GRAIN % CLOTH_SLICE_WIDTH == 0, "a task covers whole slices");

/// Spring forces by a per-spring scatter: the oracle for the gather. positions, velocities:
/// #V × 3 (m, m/s); forces (out, resized to #V × 3, N): Σ over the springs of each particle
/// of vfit_spring_force, accumulated in ascending spring order from zero.
void spring_forces_scatter(std::span<const float> positions, std::span<const float> velocities,
                           const ClothSprings& springs, std::vector<float>& forces);

/// Spring forces by a per-particle gather over `adjacency` (serial range kernel run over all
/// particles). Same shapes and units as spring_forces_scatter(), and the same bits.
void spring_forces_serial(std::span<const float> positions, std::span<const float> velocities,
                          const SpringAdjacency& adjacency, std::vector<float>& forces);

/// TBB driver of spring_forces_serial() (grain CLOTH_PARTICLE_GRAIN); bit-identical to it for
/// any thread count, since each particle's sum is computed by one task in one order.
void spring_forces_tbb(std::span<const float> positions, std::span<const float> velocities,
                       const SpringAdjacency& adjacency, std::vector<float>& forces);

/// Elastic potential energy Σ_s ½·k_s·(l_s − L_s)² (J) of the springs at `positions` (#V × 3,
/// m), in double: −∂E/∂x_i is the Hooke part of the spring force on particle i.
double spring_energy(std::span<const float> positions, const ClothSprings& springs);

/// Largest ratio l_s / max(L_s, min_rest_length) over the springs where that denominator is
/// > 0, and at least 1 (1 at rest; 0 with no springs): the runaway-stretch measure of divergence detection.
/// min_rest_length (m) keeps a sliver edge of a generated mesh (rest length of microns, whose
/// tenfold stretch is a fraction of a millimetre) from reading as runaway; 0 uses L_s as is.
/// `parallel`: by TBB over blocks of SPRING_STRETCH_GRAIN springs (the same value: a maximum).
double max_spring_stretch(std::span<const float> positions, const ClothSprings& springs, float min_rest_length = 0.0f,
                          bool parallel = false);

/// Springs per block of max_spring_stretch()'s parallel scan.
inline constexpr std::size_t SPRING_STRETCH_GRAIN = 8192;

} // namespace vfit
