#pragma once
/// \file
/// Length units of mesh files and their detection from a mesh's extent.

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace vfit {

/// IN (inches, 0.0254 m: US garment CAD) is never detected, only stated: a garment's inches
/// fall in the ranges of decimetres and centimetres.
enum class Units { M, DM, CM, MM, IN };

/// "m" | "dm" | "cm" | "mm" | "in".
std::string units_name(Units units);

/// Parses "m" | "dm" | "cm" | "mm" | "in" (also "metres", "meters", "inches", ...); throws
/// vfit::Error otherwise.
Units parse_units(std::string_view name);

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

/// Multiplies every coordinate in `positions` (#V × 3) by `factor`.
void scale_positions(std::span<float> positions, double factor);

} // namespace vfit
