// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Fabric constants of the mass-spring cloth (seed 000 §6.3; seed 004 §2) and the presets.
///
/// The stretch stiffness is a spring constant (N/m) that does not depend on the mesh
/// resolution: on a lattice of equilateral triangles with springs k on the edges the sheet's
/// 2D Young's modulus is E₂ = 2k/√3 (and Poisson's ratio 1/3), so k ≈ 0.87·E₂ whatever the
/// edge length. Bending springs (across adjacent triangles) are a resolution-dependent proxy of
/// bending rigidity; their constant is chosen per fabric to order the presets by drape (silk
/// flowing, denim stiff), not measured. Spring damping is given as a damping ratio ζ of each
/// spring's own oscillator, c = 2ζ·√(k·m_red), m_red = m_i·m_j/(m_i + m_j), which keeps its
/// relative effect the same at every resolution.

#include <string>
#include <string_view>
#include <vector>

namespace vfit {

/// Mechanical constants of one fabric.
struct Fabric {
  std::string name;
  double area_density = 0.15;     ///< ρ (kg/m²), the fabric's weight (150 g/m² = 0.15)
  double stretch_stiffness = 400; ///< k of structural springs (N/m)
  double bend_stiffness = 4;      ///< k of bending springs (N/m)
  double damping_ratio = 0.05;    ///< ζ of every spring (dimensionless)
};

/// The built-in presets, in this order. Densities are typical catalogue weights; stiffnesses are
/// small-strain orders of magnitude (woven fabrics stiffer than knits, denim stiffest), chosen
/// for simulation, not measurements of a particular cloth:
/// - "cotton_jersey": 150 g/m², k 400 N/m, bend 4 N/m (a T-shirt knit: light, stretchy)
/// - "denim": 400 g/m² (≈ 12 oz/yd²), k 3000 N/m, bend 60 N/m (heavy twill, stiff)
/// - "silk": 70 g/m² (charmeuse), k 800 N/m, bend 1 N/m (light, flowing)
/// - "wool": 250 g/m² (suiting), k 1200 N/m, bend 20 N/m
/// All use ζ = 0.05.
const std::vector<Fabric>& fabric_presets();

/// The preset named `name` (case-sensitive, as listed above). Throws vfit::Error naming the
/// unknown fabric and the known ones.
const Fabric& fabric_preset(std::string_view name);

} // namespace vfit
