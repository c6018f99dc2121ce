// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/prepare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <type_traits>

#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/geometry/mesh/orient.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/geometry/mesh/weld.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit::fitting {
namespace {

// Whether every triangle of `m` lies in one piece (then welding cannot make two).
bool one_piece(const Mesh& m) {
  const std::vector<std::int32_t> piece = vertex_piece_labels(m.triangles, m.vertex_count());
  for (std::size_t i = 1; i < m.triangles.size(); ++i)
    if (piece[std::size_t(m.triangles[i])] != piece[std::size_t(m.triangles[0])]) return false;
  return true;
}

// The sizes a garment can have on a body whose torso is `depth` deep (m): from a collar, about
// half the torso's depth across, to a T-pose's arm span or a gown, about ten depths (a 1.7 m
// mannequin's torso is about 0.24 m deep: 0.12-2.4 m). Without a body, 0.05-10 m.
std::pair<double, double> garment_size_range(double depth) {
  if (!(depth > 0)) return {0.05, 10.0};
  return {0.5 * depth, 10.0 * depth};
}

// "; in cm it would be 0.731 m across" for each unit that would give a size in `range`.
std::string plausible_units(double extent_in_file_units, std::pair<double, double> range) {
  std::string out;
  for (const Units u : {Units::M, Units::DM, Units::CM, Units::MM, Units::IN}) {
    const double m = extent_in_file_units * metres_per_unit(u);
    if (m >= range.first && m <= range.second) {
      char line[80];
      std::snprintf(line, sizeof line, "%s %.3g m across in %s", out.empty() ? "; it would be" : " or", m,
                    units_name(u).c_str());
      out += line;
    }
  }
  return out;
}

} // namespace

Units garment_units(const Mesh& mesh, const std::string& name, const FitOptions& options, double body_torso_depth,
                    std::string* note, bool* differs_alone) {
  if (options.garment_units) {
    if (note) *note = "as stated";
    return *options.garment_units;
  }
  // The surface's extent (mesh_stats): a stray vertex no face uses does not set the units.
  const MeshStats stats = mesh_stats(mesh);
  float smallest = stats.largest_extent;
  for (int a = 0; a < 3; ++a)
    smallest = std::min(smallest, stats.bbox_max[a] - stats.bbox_min[a]);
  const auto units = detect_garment_units(stats.largest_extent, smallest, stats.max_abs_coordinate, body_torso_depth);
  if (!units) {
    char line[200];
    const auto range = garment_size_range(body_torso_depth);
    std::snprintf(line, sizeof line,
                  "cannot detect the garment's length unit: it is %.4g file units across, and in no length unit a "
                  "garment's size on this body (%.2g-%.2g m across, its torso %.3g m deep)",
                  stats.largest_extent, range.first, range.second, body_torso_depth);
    throw Error(name, 0,
                line + plausible_units(stats.largest_extent, range) +
                    "; state its unit with --garment-units or its scale (metres per unit) with --garment-scale");
  }
  if (note) {
    char line[240];
    const double depth = smallest * metres_per_unit(*units);
    std::snprintf(line, sizeof line, "detected: %.3g m across, %.3g m deep around a torso %.3g m deep",
                  stats.largest_extent * metres_per_unit(*units), depth, body_torso_depth);
    *note = line;
    // Read without the body, the unit would differ: say what that would have made of it.
    const auto alone = detect_mesh_units(stats.largest_extent, stats.max_abs_coordinate);
    if (alone && *alone != *units) {
      if (differs_alone) *differs_alone = true;
      std::snprintf(line, sizeof line, "; in %s it would be %.3g m across", units_name(*alone).c_str(),
                    stats.largest_extent * metres_per_unit(*alone));
      *note += line;
    }
  }
  return *units;
}

SplitInputs split_outfits(const std::vector<FitGarmentInput>& inputs, const FitOptions& options,
                          double body_torso_depth) {
  SplitInputs out;
  for (const FitGarmentInput& input : inputs) {
    // The usual garment is one piece as given: no copy, no weld (read_garment() welds it).
    const std::size_t source = static_cast<std::size_t>(&input - inputs.data());
    if (one_piece(input.mesh)) {
      out.garments.push_back(input);
      out.notes.emplace_back();
      out.source.push_back(source);
      continue;
    }
    Mesh m = input.mesh;
    weld_seams(m);
    const std::size_t nv = m.vertex_count(), nf = m.face_count();
    const std::vector<std::int32_t> piece_of = vertex_piece_labels(m.triangles, nv);
    std::vector<std::size_t> size(nv, 0); // by piece root: referenced vertices
    std::vector<char> used(nv, 0);
    for (std::int32_t v : m.triangles)
      used[static_cast<std::size_t>(v)] = 1;
    for (std::size_t v = 0; v < nv; ++v)
      if (used[v]) ++size[static_cast<std::size_t>(piece_of[v])];
    std::vector<std::pair<std::size_t, std::int32_t>> big;
    for (std::size_t root = 0; root < nv; ++root)
      if (size[root] > 0 && static_cast<double>(size[root]) >= OUTFIT_SHARE * static_cast<double>(nv))
        big.emplace_back(size[root], static_cast<std::int32_t>(root));
    // A garment modelled with thickness as two separate sheets (a shell and its lining) is one
    // garment, not an outfit: read_garment() fits its inner sheet.
    bool thick = false;
    if (big.size() >= 2) {
      Mesh metres = m;
      scale_positions(metres.positions, options.garment_scale
                                            ? *options.garment_scale
                                            : metres_per_unit(garment_units(m, input.name, options, body_torso_depth)));
      thick = find_thick_shell(metres).has_value();
    }
    if (big.size() < 2 || thick) {
      out.garments.push_back(input);
      out.notes.emplace_back();
      out.source.push_back(source);
      continue;
    }
    std::stable_sort(big.begin(), big.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<std::size_t> garment_of(nv, 0); // by piece root: index into big (small pieces: 0)
    for (std::size_t g = 0; g < big.size(); ++g)
      garment_of[static_cast<std::size_t>(big[g].second)] = g;
    for (std::size_t g = 0; g < big.size(); ++g) {
      Mesh piece;
      piece.uvs = m.uvs;
      piece.normals = m.normals;
      piece.label_names = m.label_names;
      auto garment_index = [&](std::int32_t v) {
        return garment_of[static_cast<std::size_t>(piece_of[static_cast<std::size_t>(v)])];
      };
      // The piece's vertices and triangles keep their order in the file.
      std::vector<std::int32_t> remap(nv, -1);
      for (std::size_t v = 0; v < nv; ++v)
        if (used[v] && garment_index(static_cast<std::int32_t>(v)) == g) {
          remap[v] = static_cast<std::int32_t>(piece.vertex_count());
          piece.positions.insert(piece.positions.end(), m.positions.begin() + std::ptrdiff_t(3 * v),
                                 m.positions.begin() + std::ptrdiff_t(3 * v + 3));
        }
      std::map<std::int32_t, std::size_t> labels;
      for (std::size_t f = 0; f < nf; ++f) {
        if (garment_index(m.triangles[3 * f]) != g) continue;
        for (int k = 0; k < 3; ++k) {
          const auto v = static_cast<std::size_t>(m.triangles[3 * f + std::size_t(k)]);
          piece.triangles.push_back(remap[v]);
          if (m.has_uvs()) piece.uv_triangles.push_back(m.uv_triangles[3 * f + std::size_t(k)]);
          if (m.has_normals()) piece.normal_triangles.push_back(m.normal_triangles[3 * f + std::size_t(k)]);
        }
        if (m.has_labels()) {
          piece.face_labels.push_back(m.face_labels[f]);
          ++labels[m.face_labels[f]];
        }
      }
      // Named by its group when one group holds nearly all of it (OBJ `g`/`o`), else numbered.
      std::string suffix = "#" + std::to_string(g + 1);
      for (const auto& [label, count] : labels)
        if (static_cast<double>(count) >= 0.9 * static_cast<double>(piece.face_count()) && label >= 0 &&
            static_cast<std::size_t>(label) < m.label_names.size() &&
            !m.label_names[static_cast<std::size_t>(label)].empty())
          suffix = ":" + m.label_names[static_cast<std::size_t>(label)];
      out.garments.push_back({input.name + suffix, std::move(piece)});
      out.notes.push_back("one of " + std::to_string(big.size()) + " garments in " + input.name +
                          " (its connected pieces with " + std::to_string(static_cast<int>(100 * OUTFIT_SHARE)) +
                          " % of the vertices or more), fitted on its own");
      out.source.push_back(source);
    }
  }
  return out;
}

void prepare_garment(const FitGarmentInput& input, const FitOptions& options, double body_torso_depth,
                     FittedGarment& out, GarmentFitReport& report, std::optional<ShellGarment>& shell, Mesh* as_given) {
  report.name = input.name;
  out.name = input.name;
  out.mesh = input.mesh;
  Mesh& mesh = out.mesh;
  report.vertices = mesh.vertex_count();
  report.faces = mesh.face_count();

  const double file_extent = mesh_stats(mesh).largest_extent;
  std::string how; // how the unit was had, for the messages below
  if (options.garment_scale) {
    if (options.garment_units) throw Error(input.name, 0, "--garment-units and --garment-scale both given: state one");
    if (!(*options.garment_scale > 0) || !std::isfinite(*options.garment_scale))
      throw Error(input.name, 0, "--garment-scale must be a positive number of metres per unit");
    scale_positions(mesh.positions, *options.garment_scale);
    report.units = Units::M;
    char line[120];
    std::snprintf(line, sizeof line, "scaled by %.6g (as stated)", *options.garment_scale);
    how = line;
    report.warnings.push_back("garment " + how + " into metres");
  } else {
    std::string units_note;
    bool by_body = false; // the body, not the garment's size alone, decided its unit
    report.units = garment_units(mesh, input.name, options, body_torso_depth, &units_note, &by_body);
    how = "in " + units_name(report.units) + (options.garment_units ? " (as stated)" : " (as detected)");
    if (report.units != Units::M || by_body) {
      scale_positions(mesh.positions, metres_per_unit(report.units));
      report.warnings.push_back("garment in " + units_name(report.units) + " (" + units_note +
                                "), converted to metres" +
                                (options.garment_units ? "" : "; state its unit with --garment-units"));
    }
  }
  {
    // Outside the sizes a garment has on this body: a wrong unit or scale, stated or read,
    // would be fitted as a speck or a tent and judged as such.
    const auto range = garment_size_range(body_torso_depth);
    const double extent = mesh_stats(mesh).largest_extent;
    if (!(extent >= range.first && extent <= range.second)) {
      char line[240];
      std::snprintf(line, sizeof line,
                    "%.4g m across %s: not a garment's size on this body (%.2g-%.2g m across, its torso %.3g m deep)",
                    extent, how.c_str(), range.first, range.second, body_torso_depth);
      throw Error(input.name, 0,
                  line + plausible_units(file_extent, range) +
                      "; state its unit with --garment-units or its scale (metres per unit) with --garment-scale");
    }
  }
  // Pattern pieces exported with their own copies of the seams' vertices (bit-identical, or
  // rounded a few µm apart): one surface again.
  const WeldReport weld = weld_seams(mesh);
  if (weld.changed()) {
    report.warnings.push_back("welded " + std::to_string(weld.welded) + " vertices shared by pieces (seams), dropped " +
                              std::to_string(weld.unreferenced) + " unused vertices and " +
                              std::to_string(weld.collapsed) +
                              " collapsed triangles: " + std::to_string(mesh.vertex_count()) + " vertices, " +
                              std::to_string(mesh.face_count()) + " triangles");
    report.vertices = mesh.vertex_count();
    report.faces = mesh.face_count();
  }
  // Triangles wound against their neighbours (hand edits, some exporters): turned to agree.
  if (const OrientReport orient = orient_consistently(mesh); orient.changed())
    report.warnings.push_back("turned over " + std::to_string(orient.flipped) + " of " +
                              std::to_string(mesh.face_count()) +
                              " triangles wound against their neighbours (inconsistent orientation)");
  if (as_given) *as_given = mesh;
  // Modelled with thickness: the inner sheet is fitted, the rest follows it (thick_shell.h).
  shell.reset();
  if (std::optional<ThickShell> found = find_thick_shell(mesh)) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "modelled with thickness (%.1f mm between two sheets): its inner sheet (%zu of %zu vertices) is "
                  "fitted, the rest placed at its offsets from it",
                  1e3 * found->thickness, found->sheet.vertex_count(), mesh.vertex_count());
    report.warnings.push_back(line);
    shell.emplace(ShellGarment{std::move(*found), std::move(mesh)});
    mesh = shell->shell.sheet;
  }
}

void segment_upright_garment(const FitOptions& options, FittedGarment& out, GarmentFitReport& report) {
  Mesh& mesh = out.mesh;
  UprightSegmentation upright =
      segment_upright(out.name, mesh, options.garment_up, options.garment_facing, options.segmentation);
  out.segmentation = std::move(upright.segmentation);
  report.up = upright.up;
  report.facing = upright.facing;
  if (report.up != UpAxis::POS_Y && !options.garment_up)
    report.warnings.push_back("garment stored with " + up_axis_name(report.up) +
                              " up (detected), rotated to +y up (force with --garment-up)");
  if (upright.tilt.changed()) {
    char line[240];
    std::snprintf(line, sizeof line,
                  "garment stood %.1f deg off upright (its left-right axis %.1f deg off, from its symmetry; leaning "
                  "%.1f deg, from its openings): straightened",
                  upright.tilt.degrees, upright.tilt.side_degrees, upright.tilt.pitch_degrees);
    report.warnings.push_back(line);
  }
  if (report.facing != Facing::POS_Z && !options.garment_facing)
    report.warnings.push_back("garment faced " + facing_name(report.facing) + " (detected" +
                              (upright.front_known ? "" : "; its front and back could not be told apart") +
                              "), turned to face +z (force with --garment-facing)");
  report.type = out.segmentation.type;
  for (const auto& w : out.segmentation.warnings)
    report.warnings.push_back("segmentation: " + w);
}

void restore_shell(const ShellGarment& sg, const DressingBody& body, const DressOptions& options, FittedGarment& out,
                   GarmentFitReport& report) {
  const ThickShell& shell = sg.shell;
  Mesh whole = sg.whole;
  whole.positions = place_thick_shell(shell, out.mesh.positions);
  std::vector<std::int32_t> source(shell.whole_vertex_count, -1); // whole vertex → sheet vertex it copies
  for (std::size_t k = 0; k < shell.sheet_vertices.size(); ++k)
    source[std::size_t(shell.sheet_vertices[k])] = std::int32_t(k);
  for (std::size_t k = 0; k < shell.carried.size(); ++k) {
    const float u = shell.carried_barycentric[2 * k], v = shell.carried_barycentric[2 * k + 1];
    const int corner = (1 - u - v >= u && 1 - u - v >= v) ? 0 : (u >= v ? 1 : 2);
    source[std::size_t(shell.carried[k])] =
        shell.sheet.triangles[3 * std::size_t(shell.carried_triangle[k]) + std::size_t(corner)];
  }
  auto spread = [&](auto& values) {
    if (values.size() != shell.sheet_vertices.size()) return;
    std::remove_reference_t<decltype(values)> all(source.size());
    for (std::size_t v = 0; v < source.size(); ++v)
      all[v] = values[std::size_t(source[v])];
    values = std::move(all);
  };
  spread(out.feedback.strain);
  spread(out.feedback.ease);
  spread(out.segmentation.vertex_parts);
  spread(out.segmentation.coarse_parts);
  spread(out.segmentation.geodesic);
  out.mesh = std::move(whole);
  const Dresser dresser(body, out.mesh, options);
  report.after = dresser.measure(out.mesh);
  // The outer sheet can meet the body where the inner one faces away from it: a sleeve's outside
  // against the torso under an arm hanging down. Removal then runs on the whole mesh.
  if (report.after.inside_count > 0 || report.after.crossing_edges > 0 || report.after.layer_inside_count > 0 ||
      report.after.layer_crossing_edges > 0)
    report.after = dresser.remove(out.mesh).after;
  // Ease (fit_feedback.h: the signed distance to the body) of the whole mesh as it now lies.
  if (out.feedback.ease.size() == source.size()) {
    ClosestHits hits;
    body.index().closest_points(out.mesh.positions, INFINITY, hits);
    for (std::size_t v = 0; v < source.size(); ++v)
      out.feedback.ease[v] = hits.signed_distances[v];
  }
}

} // namespace vfit::fitting
