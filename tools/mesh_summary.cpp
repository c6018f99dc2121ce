// SPDX-License-Identifier: Apache-2.0
#include "mesh_summary.h"

#include <chrono>
#include <cstdio>

#include "vfit/kernels/error.h"

namespace vfit::cli {
namespace {

std::string format_name(MeshFormat f) {
  switch (f) {
  case MeshFormat::OBJ: return "OBJ";
  case MeshFormat::PLY: return "PLY";
  case MeshFormat::OFF: return "OFF";
  case MeshFormat::STL: return "STL";
  case MeshFormat::GLB: return "glTF binary";
  case MeshFormat::GLTF: return "glTF";
  }
  return "?";
}

std::string fmt(const char* f, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

std::string yes_no(bool b) { return b ? "yes" : "no"; }

} // namespace

MeshSummary summarise_mesh(const std::filesystem::path& path, const ReadOptions& options, std::optional<Units> stated) {
  MeshSummary s;
  s.path = path.string();
  s.format = format_name(mesh_format_from_path(path));
  const auto t0 = std::chrono::steady_clock::now();
  s.parsed = read_mesh(path, options);
  s.read_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::error_code ec;
  s.bytes = std::filesystem::file_size(path, ec);
  s.topology = analyse_topology(s.parsed.mesh.triangle_view(), s.parsed.mesh.vertex_count());
  s.stats = mesh_stats(s.parsed.mesh);
  if (stated) {
    s.units = *stated;
    s.units_stated = true;
  } else {
    auto detected = detect_mesh_units(s.stats.largest_extent, s.stats.max_abs_coordinate);
    if (!detected)
      throw Error(s.path, 0,
                  "cannot detect units from the largest extent " + fmt("%g", s.stats.largest_extent) +
                      " (not a human-scale object in m, dm, cm or mm); state them with --units");
    s.units = *detected;
    if (s.units != Units::M)
      s.parsed.warnings.push_back(s.path + ": units detected as " + units_name(s.units) + " from the largest extent " +
                                  fmt("%.4g", s.stats.largest_extent) + " (use --units to state them)");
  }
  return s;
}

nlohmann::json summary_json(const MeshSummary& s) {
  const Mesh& m = s.parsed.mesh;
  const TopologyReport& t = s.topology;
  const double k = metres_per_unit(s.units);
  nlohmann::json j;
  j["file"] = s.path;
  j["format"] = s.format;
  j["bytes"] = s.bytes;
  j["vertices"] = m.vertex_count();
  j["faces"] = m.face_count();
  j["edges"] = t.edges;
  j["unreferenced_vertices"] = t.unreferenced_vertices;
  j["has_uvs"] = m.has_uvs();
  j["has_normals"] = m.has_normals();
  j["labels"] = m.label_names;
  j["units"] = units_name(s.units);
  j["units_detected"] = !s.units_stated;
  j["bbox_min"] = s.stats.bbox_min;
  j["bbox_max"] = s.stats.bbox_max;
  j["extent"] = {s.stats.bbox_max[0] - s.stats.bbox_min[0], s.stats.bbox_max[1] - s.stats.bbox_min[1],
                 s.stats.bbox_max[2] - s.stats.bbox_min[2]};
  j["largest_extent_m"] = s.stats.largest_extent * k;
  j["surface_area_m2"] = s.stats.surface_area * k * k;
  j["mean_edge_length_m"] = s.stats.mean_edge_length * k;
  j["zero_area_faces"] = s.stats.zero_area_faces;
  j["components"] = t.components;
  j["boundary_edges"] = t.boundary_edges;
  j["boundary_loops"] = t.boundary_loops;
  j["non_manifold_edges"] = t.non_manifold_edges;
  j["non_manifold_vertices"] = t.non_manifold_vertices;
  j["inconsistent_edges"] = t.inconsistent_edges;
  j["manifold"] = t.manifold();
  j["oriented"] = t.oriented();
  j["watertight"] = t.watertight();
  j["euler_characteristic"] = t.euler_characteristic;
  j["read_ms"] = s.read_ms;
  j["warnings"] = s.parsed.warnings;
  return j;
}

std::string summary_text(const MeshSummary& s) {
  const Mesh& m = s.parsed.mesh;
  const TopologyReport& t = s.topology;
  const double k = metres_per_unit(s.units);
  const auto& lo = s.stats.bbox_min;
  const auto& hi = s.stats.bbox_max;
  std::string out;
  auto line = [&](const std::string& key, const std::string& value) {
    out += key;
    out.append(key.size() < 22 ? 22 - key.size() : 1, ' ');
    out += value + "\n";
  };
  line("file", s.path + " (" + s.format + ", " + fmt("%.1f", double(s.bytes) / 1024.0) + " KiB, read in " +
                   fmt("%.1f", s.read_ms) + " ms)");
  line("vertices",
       std::to_string(m.vertex_count()) +
           (t.unreferenced_vertices ? " (" + std::to_string(t.unreferenced_vertices) + " unreferenced)" : ""));
  line("faces", std::to_string(m.face_count()) + " triangles" +
                    (s.stats.zero_area_faces ? " (" + std::to_string(s.stats.zero_area_faces) + " of zero area)" : ""));
  line("edges", std::to_string(t.edges));
  line("attributes", std::string("uvs ") + yes_no(m.has_uvs()) + ", normals " + yes_no(m.has_normals()) + ", labels " +
                         (m.has_labels() ? std::to_string(m.label_names.size()) : std::string("none")));
  line("bounding box", "[" + fmt("%.4g", lo[0]) + ", " + fmt("%.4g", lo[1]) + ", " + fmt("%.4g", lo[2]) + "] .. [" +
                           fmt("%.4g", hi[0]) + ", " + fmt("%.4g", hi[1]) + ", " + fmt("%.4g", hi[2]) + "]");
  line("extent", fmt("%.4g", hi[0] - lo[0]) + " x " + fmt("%.4g", hi[1] - lo[1]) + " x " + fmt("%.4g", hi[2] - lo[2]) +
                     " " + units_name(s.units) + " = " + fmt("%.3f", (hi[0] - lo[0]) * k) + " x " +
                     fmt("%.3f", (hi[1] - lo[1]) * k) + " x " + fmt("%.3f", (hi[2] - lo[2]) * k) + " m");
  line("units", units_name(s.units) + (s.units_stated ? " (stated)" : " (detected from the extent)"));
  line("surface area", fmt("%.4g", s.stats.surface_area * k * k) + " m^2");
  line("components", std::to_string(t.components));
  line("boundary loops",
       std::to_string(t.boundary_loops) + " (" + std::to_string(t.boundary_edges) + " boundary edges)");
  line("manifold", yes_no(t.manifold()) + " (" + std::to_string(t.non_manifold_edges) + " non-manifold edges, " +
                       std::to_string(t.non_manifold_vertices) + " non-manifold vertices)");
  line("oriented", yes_no(t.oriented()) + (t.inconsistent_edges ? " (" + std::to_string(t.inconsistent_edges) +
                                                                      " edges with flipped neighbours)"
                                                                : ""));
  line("watertight", yes_no(t.watertight()));
  line("euler characteristic", std::to_string(t.euler_characteristic));
  return out;
}

} // namespace vfit::cli
