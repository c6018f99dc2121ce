// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Horizontal cross-sections of a mesh: the closed loops where the plane y = h cuts it, and the
/// convex-hull perimeter that body measurements use for girths (seed 004 §1).

#include <array>
#include <vector>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// One loop of a cross-section: its points (x, z) in order.
using SectionLoop = std::vector<std::array<double, 2>>;

/// The loops where the plane y = `height` cuts the mesh (m). Each crossing edge contributes one
/// point; open chains (at mesh boundaries) are returned as they are. Vertices exactly on the
/// plane are nudged up by 1e-9 m so every crossing is strict.
std::vector<SectionLoop> horizontal_section(const Mesh& mesh, double height);

/// True when (x, z) lies inside the closed loop (even-odd rule).
bool loop_contains(const SectionLoop& loop, double x, double z);

/// Perimeter of the convex hull of the loop's points (a tape measure around the section).
double convex_hull_perimeter(const SectionLoop& loop);

/// The convex-hull perimeter of the section loop at `height` that contains (x, z); 0 when no
/// loop contains it. With several nested loops, the outermost.
double girth_around(const Mesh& mesh, double height, double x, double z);

} // namespace vfit
