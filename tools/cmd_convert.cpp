// SPDX-License-Identifier: Apache-2.0
#include <iostream>

#include "commands.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {

int run_convert(Args& args) {
  const bool to_metres = args.flag("to-metres");
  const bool quiet = args.flag("quiet");
  ReadOptions options;
  options.repair = args.flag("repair");
  std::optional<Units> units;
  if (auto u = args.value("units")) units = parse_units(*u);
  const auto files = args.positionals(2, 2);
  const std::filesystem::path in = files[0], out = files[1];
  mesh_format_from_path(out); // an unknown output format fails before any work
  std::error_code ec;
  if (in == out || std::filesystem::equivalent(in, out, ec))
    throw Error(out.string(), 0, "refusing to overwrite the input file; choose another output path");
  ParsedMesh parsed = read_mesh(in, options);
  if (to_metres) {
    Units from = Units::M;
    if (units) {
      from = *units;
    } else {
      const MeshStats stats = mesh_stats(parsed.mesh);
      auto detected = detect_mesh_units(stats.largest_extent, stats.max_abs_coordinate);
      if (!detected) throw Error(in.string(), 0, "cannot detect units; state them with --units");
      from = *detected;
      if (from != Units::M)
        parsed.warnings.push_back(in.string() + ": units detected as " + units_name(from) + "; converting to m");
    }
    scale_positions(parsed.mesh.positions, metres_per_unit(from));
  }
  if (!quiet)
    for (const auto& w : parsed.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
  write_mesh(out, parsed.mesh, in.stem().string());
  if (!quiet)
    std::cout << "wrote " << out.string() << " (" << parsed.mesh.vertex_count() << " vertices, "
              << parsed.mesh.face_count() << " faces)\n";
  return 0;
}

} // namespace vfit::cli
