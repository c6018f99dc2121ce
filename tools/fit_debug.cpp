// SPDX-License-Identifier: Apache-2.0
#include "fit_debug.h"

#include <cctype>
#include <charconv>
#include <cstdio>
#include <map>
#include <system_error>
#include <vector>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

// A node band's shade: every other node of a chain is drawn at this fraction of the part's colour.
constexpr double DARK_BAND = 0.5;

constexpr GarmentPart ALL_PARTS[] = {GarmentPart::TORSO,    GarmentPart::LEFT_SLEEVE, GarmentPart::RIGHT_SLEEVE,
                                     GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG,   GarmentPart::SKIRT};

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

void append_float(std::string& out, float x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

std::string numbered(const std::string& stem, int number, const std::string& what) {
  char nn[16];
  std::snprintf(nn, sizeof nn, "%02d", number);
  return stem + "_" + nn + "_" + what;
}

// ASCII PLY with per-vertex colours: small enough for debug meshes, readable by eye and by any viewer.
std::string coloured_ply(const Mesh& mesh, std::span<const Rgb> colours, const std::vector<std::string>& comments) {
  std::string out = "ply\nformat ascii 1.0\n";
  for (const std::string& c : comments)
    out += "comment " + one_line(c) + "\n";
  out += "element vertex " + std::to_string(mesh.vertex_count()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "element face " + std::to_string(mesh.face_count()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  out.reserve(out.size() + mesh.vertex_count() * 40 + mesh.face_count() * 24);
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    for (int c = 0; c < 3; ++c) {
      append_float(out, mesh.positions[3 * v + c]);
      out += ' ';
    }
    out += std::to_string(colours[v][0]) + ' ' + std::to_string(colours[v][1]) + ' ' + std::to_string(colours[v][2]) +
           '\n';
  }
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    out += "3 " + std::to_string(mesh.triangles[3 * f]) + ' ' + std::to_string(mesh.triangles[3 * f + 1]) + ' ' +
           std::to_string(mesh.triangles[3 * f + 2]) + '\n';
  return out;
}

std::vector<Rgb> label_colours(const Mesh& mesh, std::span<const GarmentPart> parts,
                               const std::filesystem::path& path) {
  if (!parts.empty() && parts.size() != mesh.vertex_count())
    throw Error(path.string(), 0,
                std::to_string(parts.size()) + " vertex labels for " + std::to_string(mesh.vertex_count()) +
                    " vertices");
  std::vector<Rgb> colours(mesh.vertex_count(), garment_part_colour(GarmentPart::TORSO));
  for (std::size_t v = 0; v < parts.size(); ++v)
    colours[v] = garment_part_colour(parts[v]);
  return colours;
}

} // namespace

Rgb garment_part_colour(GarmentPart part) {
  switch (part) {
  case GarmentPart::TORSO: return {170, 170, 170};
  case GarmentPart::LEFT_SLEEVE: return {220, 50, 40};
  case GarmentPart::RIGHT_SLEEVE: return {40, 90, 220};
  case GarmentPart::LEFT_LEG: return {245, 150, 30};
  case GarmentPart::RIGHT_LEG: return {40, 170, 70};
  case GarmentPart::SKIRT: return {150, 70, 200};
  }
  return {255, 255, 255};
}

std::string debug_file_stem(const std::string& name) {
  std::string stem = std::filesystem::path(name).stem().string();
  for (char& c : stem)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  return stem.empty() ? "garment" : stem;
}

FitDebugWriter::FitDebugWriter(std::filesystem::path dir) : m_dir(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(m_dir, ec);
  if (ec || !std::filesystem::is_directory(m_dir))
    throw Error(m_dir.string(), 0, "cannot create the debug folder" + (ec ? ": " + ec.message() : std::string()));
  std::string legend =
      "vfit fit debug output: the garment after each stage of the pipeline (metres, body frame).\n"
      "Files: body.ply (the posed body); <garment>_01_segmentation.ply (input, converted to metres);\n"
      "<garment>_02_skeletons.obj (one polyline per sleeve/leg, attachment -> open end);\n"
      "<garment>_02_skeleton_nodes.ply (limb vertices banded by skeleton node);\n"
      "<garment>_03_driving.ply; <garment>_04_coarse_move.ply; <garment>_05_penetration.ply;\n"
      "<garment>_06_simulation.ply (only when simulated). Each PLY's comments say what the stage did.\n"
      "Vertex colours (segmentation label, RGB):\n";
  for (GarmentPart p : ALL_PARTS) {
    const Rgb c = garment_part_colour(p);
    legend += "  " + garment_part_name(p) + ": " + std::to_string(c[0]) + " " + std::to_string(c[1]) + " " +
              std::to_string(c[2]) + "\n";
  }
  write_file_atomically(m_dir / "legend.txt", legend);
}

void FitDebugWriter::write_body(const Mesh& body) const { write_mesh(m_dir / "body.ply", body, "body"); }

std::filesystem::path FitDebugWriter::write_garment(const std::string& stem, int number, const std::string& stage,
                                                    const Mesh& mesh, std::span<const GarmentPart> vertex_parts,
                                                    const std::string& note) const {
  const std::filesystem::path path = m_dir / (numbered(stem, number, stage) + ".ply");
  const std::vector<Rgb> colours = label_colours(mesh, vertex_parts, path);
  write_file_atomically(
      path, coloured_ply(mesh, colours,
                         {"vfit fit debug: " + stem + " after stage " + std::to_string(number) + " (" + stage + ")",
                          note, "vertex colours: segmentation labels, see legend.txt"}));
  return path;
}

void FitDebugWriter::write_skeletons(const std::string& stem, int number, const Mesh& mesh,
                                     std::span<const GarmentPart> vertex_parts,
                                     std::span<const PartSkeleton> skeletons) const {
  const std::filesystem::path obj_path = m_dir / (numbered(stem, number, "skeletons") + ".obj");
  std::string obj = "# vfit fit debug: part skeletons of " + stem + " (m), attachment end first\n";
  if (skeletons.empty()) obj += "# no limb skeletons\n";
  std::size_t first = 1; // OBJ indices are 1-based and global over the file
  for (const PartSkeleton& s : skeletons) {
    obj += "o " + garment_part_name(s.part) + "\n";
    for (const Eigen::Vector3d& n : s.nodes) {
      obj += "v ";
      for (int c = 0; c < 3; ++c) {
        append_float(obj, static_cast<float>(n[c]));
        obj += c < 2 ? ' ' : '\n';
      }
    }
    if (s.nodes.size() >= 2) {
      obj += "l";
      for (std::size_t k = 0; k < s.nodes.size(); ++k)
        obj += " " + std::to_string(first + k);
      obj += "\n";
    }
    first += s.nodes.size();
  }
  write_file_atomically(obj_path, obj);

  const std::filesystem::path ply_path = m_dir / (numbered(stem, number, "skeleton_nodes") + ".ply");
  std::vector<Rgb> colours = label_colours(mesh, vertex_parts, ply_path);
  for (const PartSkeleton& s : skeletons) {
    const Rgb base = garment_part_colour(s.part);
    for (std::size_t i = 0; i < s.vertices.size() && i < s.vertex_node.size(); ++i) {
      const auto v = static_cast<std::size_t>(s.vertices[i]);
      if (v >= colours.size()) continue;
      const bool dark = s.vertex_node[i] % 2 == 1;
      for (int c = 0; c < 3; ++c)
        colours[v][c] = static_cast<std::uint8_t>(dark ? DARK_BAND * base[c] : base[c]);
    }
  }
  write_file_atomically(ply_path,
                        coloured_ply(mesh, colours,
                                     {"vfit fit debug: " + stem + " skeleton nodes",
                                      "limb vertices banded by node (dark = odd node index), others by label"}));
}

FitDebugFiles::FitDebugFiles(std::filesystem::path dir) : m_dir(std::move(dir)) {}

void FitDebugFiles::start(const Mesh& body, std::span<const std::string> garment_names) {
  m_writer.emplace(m_dir);
  m_writer->write_body(body);
  std::map<std::string, int> count;
  for (const std::string& name : garment_names)
    ++count[debug_file_stem(name)];
  m_stems.clear();
  for (std::size_t i = 0; i < garment_names.size(); ++i) {
    std::string stem = debug_file_stem(garment_names[i]);
    if (count[stem] > 1) stem += "_" + std::to_string(i);
    m_stems.push_back(std::move(stem));
  }
}

void FitDebugFiles::garment(std::size_t garment, const std::string& name, int number, const std::string& stage,
                            const Mesh& mesh, std::span<const GarmentPart> vertex_parts, const std::string& note) {
  if (!m_writer || garment >= m_stems.size()) throw Error(name, 0, "debug snapshot before the fit started");
  m_writer->write_garment(m_stems[garment], number, stage, mesh, vertex_parts, note);
}

void FitDebugFiles::skeletons(std::size_t garment, const std::string& name, int number, const Mesh& mesh,
                              std::span<const GarmentPart> vertex_parts, std::span<const PartSkeleton> skeletons) {
  if (!m_writer || garment >= m_stems.size()) throw Error(name, 0, "debug snapshot before the fit started");
  m_writer->write_skeletons(m_stems[garment], number, mesh, vertex_parts, skeletons);
}

} // namespace vfit
