// SPDX-License-Identifier: Apache-2.0
#include "units.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <vector>

#include "vfit/kernels/error.h"

namespace vfit {

std::string units_name(Units units) {
  switch (units) {
  case Units::M: return "m";
  case Units::DM: return "dm";
  case Units::CM: return "cm";
  case Units::MM: return "mm";
  case Units::IN: return "in";
  }
  return "m";
}

Units parse_units(std::string_view name, std::string_view option) {
  std::string s(name);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  if (s == "m" || s == "metre" || s == "metres" || s == "meter" || s == "meters") return Units::M;
  if (s == "dm" || s == "decimetre" || s == "decimetres" || s == "decimeter" || s == "decimeters") return Units::DM;
  if (s == "cm" || s == "centimetre" || s == "centimetres" || s == "centimeter" || s == "centimeters") return Units::CM;
  if (s == "mm" || s == "millimetre" || s == "millimetres" || s == "millimeter" || s == "millimeters") return Units::MM;
  if (s == "in" || s == "inch" || s == "inches") return Units::IN;
  throw Error(std::string(option), 0, "unknown unit '" + std::string(name) + "' (expected m, dm, cm, mm or in)");
}

double metres_per_unit(Units units) {
  switch (units) {
  case Units::M: return 1.0;
  case Units::DM: return 0.1;
  case Units::CM: return 0.01;
  case Units::MM: return 0.001;
  case Units::IN: return 0.0254;
  }
  return 1.0;
}

std::optional<Units> detect_units(double largest_extent) {
  // A garment or body spans roughly 0.3–2.5 m at its largest; each unit is tried in turn and
  // the first one that puts the extent below 3 m wins.
  if (!std::isfinite(largest_extent) || largest_extent <= 0.0) return std::nullopt;
  if (largest_extent < 3.0) return Units::M;
  if (largest_extent < 30.0) return Units::DM;
  if (largest_extent < 300.0) return Units::CM;
  if (largest_extent < 3000.0) return Units::MM;
  return std::nullopt;
}

std::optional<Units> detect_mesh_units(double largest_extent, double max_abs_coordinate) {
  if (!std::isfinite(max_abs_coordinate) || !std::isfinite(largest_extent)) return std::nullopt;
  // The units in which the object has a garment's or a body's size.
  constexpr double SMALLEST = 0.15, LARGEST = 2.6; // m: a collar or crop top; a tall body's arm span
  std::vector<Units> plausible;
  for (Units u : {Units::M, Units::DM, Units::CM, Units::MM}) {
    const double metres = largest_extent * metres_per_unit(u);
    if (metres >= SMALLEST && metres <= LARGEST) plausible.push_back(u);
  }
  if (plausible.size() == 1) return plausible[0];
  // None, or two a factor of ten apart: where the object sits decides.
  const std::optional<Units> by_position = detect_units(std::max(largest_extent, max_abs_coordinate));
  if (plausible.empty() || !by_position) return by_position;
  if (std::find(plausible.begin(), plausible.end(), *by_position) != plausible.end()) return by_position;
  return plausible.front();
}

std::optional<Units> detect_body_units(double largest_extent, double max_abs_coordinate) {
  constexpr double SHORTEST = 1.2, TALLEST = 2.3; // m: an adult's height (check_measurements())
  if (std::isfinite(largest_extent) && std::isfinite(max_abs_coordinate))
    for (Units u : {Units::M, Units::DM, Units::CM, Units::MM, Units::IN}) {
      const double metres = largest_extent * metres_per_unit(u);
      if (metres >= SHORTEST && metres <= TALLEST) return u;
    }
  return detect_mesh_units(largest_extent, max_abs_coordinate);
}

std::string body_units_warning(double largest_extent, double max_abs_coordinate, Units units) {
  const std::optional<Units> alone = detect_mesh_units(largest_extent, max_abs_coordinate);
  if (units == Units::M && (!alone || *alone == Units::M)) return "";
  std::string w = "units detected as " + units_name(units);
  if (alone && *alone != units) {
    char line[200];
    std::snprintf(line, sizeof line,
                  " (%.3g m tall, an adult's height; in %s it would be %.3g m: state --units %s if so)",
                  largest_extent * metres_per_unit(units), units_name(*alone).c_str(),
                  largest_extent * metres_per_unit(*alone), units_name(*alone).c_str());
    w += line;
  }
  return w + "; converted to metres";
}

std::optional<Units> detect_garment_units(double largest_extent, double smallest_extent, double max_abs_coordinate,
                                          double torso_depth) {
  constexpr double SMALLEST = 0.15, LARGEST = 2.6;  // m: as detect_mesh_units()
  constexpr double TIGHTEST = 0.77, LOOSEST = 1.93; // garment's smallest extent / torso depth (units.h)
  if (std::isfinite(largest_extent) && std::isfinite(smallest_extent) && std::isfinite(max_abs_coordinate) &&
      std::isfinite(torso_depth) && torso_depth > 0.0)
    for (Units u : {Units::M, Units::DM, Units::CM, Units::MM, Units::IN}) {
      const double metres = largest_extent * metres_per_unit(u);
      const double wrap = smallest_extent * metres_per_unit(u) / torso_depth;
      if (metres >= SMALLEST && metres <= LARGEST && wrap >= TIGHTEST && wrap <= LOOSEST) return u;
    }
  return detect_mesh_units(largest_extent, max_abs_coordinate);
}

void scale_positions(std::span<float> positions, double factor) {
  for (float& x : positions)
    x = static_cast<float>(x * factor);
}

} // namespace vfit
