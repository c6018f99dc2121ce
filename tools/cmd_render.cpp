// SPDX-License-Identifier: Apache-2.0
// `vfit render`: PNG pictures (front, side, back) of a body and the garments on it.
#include <chrono>
#include <cmath>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "vfit/engine/view/render.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {
namespace {

// A glTF file read as one mesh carries each glTF mesh as a face label; split it back into one
// mesh per label (vertices renumbered in order of first use), in label order.
std::vector<Mesh> split_by_label(const Mesh& m) {
  if (!m.has_labels() || m.label_names.size() < 2) return {m};
  std::vector<Mesh> parts(m.label_names.size());
  std::vector<std::map<std::size_t, std::int32_t>> renumber(parts.size());
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    const std::size_t l = static_cast<std::size_t>(m.face_labels[f]);
    for (int c = 0; c < 3; ++c) {
      const std::size_t v = static_cast<std::size_t>(m.triangles[3 * f + c]);
      auto [it, added] = renumber[l].try_emplace(v, static_cast<std::int32_t>(parts[l].vertex_count()));
      if (added)
        parts[l].positions.insert(parts[l].positions.end(), m.positions.begin() + std::ptrdiff_t(3 * v),
                                  m.positions.begin() + std::ptrdiff_t(3 * v + 3));
      parts[l].triangles.push_back(it->second);
    }
  }
  std::erase_if(parts, [](const Mesh& p) { return p.face_count() == 0; });
  return parts;
}

bool is_gltf(const std::string& path) {
  const MeshFormat f = mesh_format_from_path(path);
  return f == MeshFormat::GLB || f == MeshFormat::GLTF;
}

float finite_number(const nlohmann::json& v, const std::string& file, const std::string& key) {
  if (!v.is_number() || !std::isfinite(v.get<double>())) throw Error(file, 0, "'" + key + "': not a finite number");
  return v.get<float>();
}

// {"mesh": 1, "name": "strain", "values": [one per vertex], "min": ..., "max": ...}; mesh
// defaults to the first garment (1) when there is one, else the body (0).
RenderScalar read_scalar(const std::string& file, std::size_t mesh_count) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file_bytes(file));
  } catch (const nlohmann::json::exception& e) {
    throw Error(file, 0, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) throw Error(file, 0, "expected an object with \"values\"");
  RenderScalar s;
  s.mesh = mesh_count > 1 ? 1 : 0;
  if (j.contains("mesh")) {
    if (!j["mesh"].is_number_unsigned()) throw Error(file, 0, "'mesh': expected a mesh index ≥ 0");
    s.mesh = j["mesh"].get<std::size_t>();
  }
  if (j.contains("name")) {
    if (!j["name"].is_string()) throw Error(file, 0, "'name': expected a string");
    s.name = j["name"].get<std::string>();
  }
  if (!j.contains("values") || !j["values"].is_array()) throw Error(file, 0, "'values': expected an array of numbers");
  const auto& values = j["values"];
  s.values.reserve(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i].is_null()) {
      s.values.push_back(std::nanf("")); // no value: drawn grey
      continue;
    }
    if (!values[i].is_number()) throw Error(file, 0, "'values'[" + std::to_string(i) + "]: not a number");
    s.values.push_back(values[i].get<float>());
  }
  if (j.contains("min")) s.min = finite_number(j["min"], file, "min");
  if (j.contains("max")) s.max = finite_number(j["max"], file, "max");
  return s;
}

std::filesystem::path view_path(const std::filesystem::path& out, RenderView view) {
  std::filesystem::path p = out;
  p.replace_filename(out.stem().string() + "_" + render_view_name(view) + out.extension().string());
  return p;
}

} // namespace

int run_render(Args& args) {
  const bool quiet = args.flag("quiet");
  const bool separate = args.flag("separate");
  RenderOptions o;
  if (args.flag("perspective")) o.projection = Projection::PERSPECTIVE;
  if (args.flag("no-outlines")) o.outlines = false;
  if (auto s = args.value("size")) o.size = Args::to_int("--size", *s, 16, 8192);
  if (auto s = args.value("supersampling")) o.supersampling = Args::to_int("--supersampling", *s, 1, 4);
  if (auto v = args.value("views")) o.views = parse_render_views(*v);
  const auto scalar_file = args.value("scalar");
  const auto out = args.value("out");
  const auto files = args.positionals(1, 64);
  if (!out) throw Error("vfit render", 0, "--out FILE.png is required");
  std::string ext = std::filesystem::path(*out).extension().string();
  for (char& c : ext)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png") throw Error(*out, 0, "the output must be a .png file");

  std::vector<Mesh> meshes;
  for (const auto& f : files) {
    ParsedMesh parsed = read_mesh(f);
    for (const auto& w : parsed.warnings)
      if (!quiet) std::cerr << "vfit: warning: " << w << "\n";
    if (files.size() == 1 && is_gltf(f)) {
      meshes = split_by_label(parsed.mesh);
    } else {
      meshes.push_back(std::move(parsed.mesh));
    }
  }
  if (scalar_file) o.scalar = read_scalar(*scalar_file, meshes.size());

  std::vector<const Mesh*> pointers;
  pointers.reserve(meshes.size());
  for (const Mesh& m : meshes)
    pointers.push_back(&m);
  const auto t0 = std::chrono::steady_clock::now();
  const Rendering r = render_views(pointers, o);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::vector<std::pair<std::filesystem::path, Image>> written;
  if (separate) {
    for (std::size_t k = 0; k < r.views.size(); ++k)
      written.emplace_back(view_path(*out, r.views[k].view), compose_view(r, k));
  } else {
    written.emplace_back(*out, compose_views(r));
  }
  for (const auto& [path, image] : written)
    write_png(path, image);
  if (!quiet)
    for (const auto& [path, image] : written)
      std::cout << "wrote " << path.string() << " (" << image.width << " x " << image.height << " px, " << meshes.size()
                << " meshes, " << r.ray_count << " rays in " << static_cast<long>(std::lround(ms)) << " ms)\n";
  return 0;
}

} // namespace vfit::cli
