// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Length units of mesh files and their detection from a mesh's extent.

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace vfit {

/// IN (inches, 0.0254 m: US garment CAD) is detected only against what a size means: a body's
/// adult height (detect_body_units()) or the body a garment is fitted on
/// (detect_garment_units()); detect_units() and detect_mesh_units() never give it (a lone
/// mesh's inches fall in the ranges of decimetres and centimetres).
enum class Units { M, DM, CM, MM, IN };

/// "m" | "dm" | "cm" | "mm" | "in".
std::string units_name(Units units);

/// Parses "m" | "dm" | "cm" | "mm" | "in" (also "metres", "meters", "inches", ...); throws
/// vfit::Error naming `option` (the flag or field that gave the value) otherwise.
Units parse_units(std::string_view name, std::string_view option = "--units");

/// Metres per unit: 1, 0.1, 0.01, 0.001, 0.0254.
double metres_per_unit(Units units);

/// Units inferred from the largest bounding-box extent of a garment or body, assuming a
/// human-scale object whose largest extent lies in [0.3, 3) m: extent < 3 → m, < 30 → dm,
/// < 300 → cm, < 3000 → mm. nullopt for extent ≤ 0, non-finite, or ≥ 3000 (the caller must
/// then ask for explicit units). Ambiguous near the boundaries (a 25 cm garment stored in
/// dm reads as m): callers show a warning and accept an explicit unit.
std::optional<Units> detect_units(double largest_extent);

/// Units of a mesh from its largest extent and its largest absolute coordinate: the unit in
/// which the extent is a garment's or a body's size (0.15–2.6 m) when exactly one is; when two
/// are (extents a factor of ten apart both plausible: 1.5–2.6 units), or none, the unit that
/// detect_units() gives the larger of extent and coordinate: a small piece (a 27 cm collar)
/// sits where it is worn, far from the origin in the file's units (6 dm up). So a metre-unit
/// garment placed metres from the origin stays in metres. nullopt as detect_units(), or for a
/// non-finite argument.
std::optional<Units> detect_mesh_units(double largest_extent, double max_abs_coordinate);

/// Units of a whole body from its largest extent (its height, or a T-pose's arm span) and its
/// largest absolute coordinate: the unit, inches included, in which the extent is an adult's
/// height, 1.2-2.3 m (check_measurements()' range), when one is; no two units can both be
/// (2.3 / 1.2 < 2.54, the nearest ratio of two units). Otherwise (a child, a T-pose's span past
/// 2.3 m) detect_mesh_units(). So a body 65.6 units tall is read as 1.67 m in inches, not as a
/// 0.66 m child in cm: its shape cannot tell the two apart, and the caller's warning names the
/// alternative (detect_mesh_units()'s unit when it differs) and --units. nullopt as
/// detect_mesh_units().
std::optional<Units> detect_body_units(double largest_extent, double max_abs_coordinate);

/// The warning for a body whose units detect_body_units() gave as `units`: "" for metres read as
/// metres alone; "units detected as cm; converted to metres" otherwise, and, when
/// detect_mesh_units() would have read it otherwise (an adult 65.6 units tall: 1.67 m in inches or
/// 0.66 m in cm), the height in both units and --units.
std::string body_units_warning(double largest_extent, double max_abs_coordinate, Units units);

/// Units of a garment fitted onto a body whose torso is `torso_depth` m deep (torso_depth() in
/// geometry/body/measurements.h), from the garment's box in file units: its largest and smallest
/// extents and its largest absolute coordinate. Every garment the pipeline fits (a top, a dress,
/// trousers, shorts, a skirt) wraps the torso or the hips, so its box's smallest extent (its
/// depth, or a pair of shorts' height) is near the torso's depth: measured 0.85 × (MakeHuman's
/// shorts on hm08, their height) to 1.74 × (the catalogue's XXL dress on the mannequin) over the
/// corpus's 21 garments and the catalogue's 6 types in sizes XS-XXL. The band accepted,
/// 0.77-1.93 ×, is that range with about 10 % either side: 2.5 × wide, under the 2.54 × between
/// the nearest two units, so at most one unit falls in it. Among the units, inches included, in
/// which the largest extent is a garment's size (0.15-2.6 m, as detect_mesh_units()), the one
/// whose smallest extent falls in the band; when none does (a flat pattern, a piece smaller than
/// the torso, no body: `torso_depth` ≤ 0 or not finite) detect_mesh_units(), which never gives
/// inches. A garment outside the band in its true unit can fall in it in the next unit (shorts
/// in cm 0.3 × the torso's depth read as inches): the caller's warning names the unit chosen and
/// --garment-units. nullopt as detect_mesh_units().
std::optional<Units> detect_garment_units(double largest_extent, double smallest_extent, double max_abs_coordinate,
                                          double torso_depth);

/// Multiplies every coordinate in `positions` (#V × 3) by `factor`.
void scale_positions(std::span<float> positions, double factor);

} // namespace vfit
