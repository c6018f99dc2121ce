// SPDX-License-Identifier: Apache-2.0
// `vfit garment`: generates a catalogue garment and its ground-truth part labels.
#include <chrono>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "body_args.h"
#include "commands.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {

/// The labels file written beside a garment mesh: out.obj → out.labels.json.
std::filesystem::path labels_path(const std::filesystem::path& mesh_path) {
  std::filesystem::path p = mesh_path;
  p.replace_extension(".labels.json");
  return p;
}

int run_garment(Args& args) {
  const bool quiet = args.flag("quiet");
  GarmentOptions o;
  o.body = measurements_from_args(args);
  o.size = args.value("size").value_or("M");
  if (auto p = args.value("pose")) o.pose = parse_rest_pose("--pose", *p);
  if (auto n = args.value("vertices"))
    o.target_vertices = static_cast<std::size_t>(Args::to_int("--vertices", *n, 1000, 2000000));
  const auto out = args.value("out");
  const auto pos = args.positionals(1, 1);
  o.type = parse_garment_type(pos[0]);
  if (!out) throw Error("vfit garment", 0, "--out FILE is required");
  mesh_format_from_path(*out);
  const auto t0 = std::chrono::steady_clock::now();
  const Garment g = make_garment(o);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json labels;
  labels["garment"] = garment_type_name(g.type);
  labels["size"] = g.size;
  labels["ease_m"] = {{"chest", g.ease.chest}, {"waist", g.ease.waist}, {"hip", g.ease.hip}, {"thigh", g.ease.thigh}};
  labels["pose"] = g.pose == RestPose::TPOSE ? "tpose" : "apose";
  labels["part_names"] = nlohmann::json::array();
  for (int p = 0; p < GARMENT_PART_COUNT; ++p)
    labels["part_names"].push_back(garment_part_name(static_cast<GarmentPart>(p)));
  std::vector<int> parts(g.vertex_parts.size());
  for (std::size_t v = 0; v < parts.size(); ++v)
    parts[v] = int(g.vertex_parts[v]);
  labels["vertex_parts"] = parts;
  write_mesh(*out, g.mesh, garment_type_name(g.type));
  write_file_atomically(labels_path(*out), labels.dump() + "\n");
  if (!quiet) {
    const TopologyReport t = analyse_topology(g.mesh.triangle_view(), g.mesh.vertex_count());
    std::printf("%s size %s: %zu vertices, %zu faces, %zu openings, built in %.0f ms\nwrote %s and %s\n",
                garment_type_name(g.type).c_str(), g.size.c_str(), g.mesh.vertex_count(), g.mesh.face_count(),
                t.boundary_loops, ms, out->c_str(), labels_path(*out).c_str());
  }
  return 0;
}

} // namespace vfit::cli
