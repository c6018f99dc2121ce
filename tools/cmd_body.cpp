// `vfit body`: builds a body and writes its mesh, joints and rigged glTF.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "body_args.h"
#include "commands.h"
#include "geometry/body/mannequin.h"
#include "geometry/body/pose_io.h"
#include "geometry/mesh/atomic_write.h"
#include "geometry/mesh/mesh_io.h"
#include "kernels/error.h"

namespace vfit::cli {

std::string joints_json(const JointPositions& joints) {
  nlohmann::ordered_json j;
  for (int k = 0; k < JOINT_COUNT; ++k)
    j["joints"][std::string(joint_name(k))] = {joints(k, 0), joints(k, 1), joints(k, 2)};
  return j.dump(2) + "\n";
}

int run_body(Args& args) {
  const bool quiet = args.flag("quiet");
  const std::string source = args.value("from").value_or("mannequin");
  BodyRequest request = body_request_from_args(args, source);
  const auto out = args.value("out");
  const auto joints_out = args.value("joints");
  const auto pose_arg = args.value("pose");
  const auto rigged = args.value("rigged");
  if (rigged && mesh_format_from_path(*rigged) != MeshFormat::GLB) throw Error(*rigged, 0, "--rigged writes a .glb file");
  if (out) mesh_format_from_path(*out);
  args.positionals(0, 0);
  const auto t0 = std::chrono::steady_clock::now();
  const LoadedBody loaded = load_body(request);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Pose pose;
  if (pose_arg) {
    std::error_code ec;
    pose = std::filesystem::is_regular_file(*pose_arg, ec) ? read_pose_json(*pose_arg) : named_pose(*pose_arg, loaded.rest.rest_pose);
  }
  const Body body = loaded.posed(pose);
  if (!quiet)
    for (const auto& w : loaded.warnings) std::cerr << "vfit: warning: " << w << "\n";
  if (out) write_mesh(*out, body.mesh, "body");
  if (joints_out) write_file_atomically(*joints_out, joints_json(body.joints));
  if (rigged) {
    const MeshSkin skin = body_skin(loaded.rest);
    const NamedMesh named{"body", &loaded.rest.mesh, &skin};
    write_meshes_glb(*rigged, std::span<const NamedMesh>(&named, 1));
  }
  if (!quiet) {
    std::printf("%s body: %zu vertices, %zu faces, loaded in %.0f ms\n", loaded.kind.c_str(), body.mesh.vertex_count(),
                body.mesh.face_count(), ms);
    const MeasuredBody got = measure_body(loaded.rest.mesh, loaded.rest.joints);
    const bool requested = source == "mannequin";
    std::printf("%-16s %10s %10s %8s\n", "measurement", requested ? "requested" : "", "measured", requested ? "error" : "");
    for (std::string_view n : BodyMeasurements::names()) {
      if (requested)
        std::printf("%-16s %9.4f m %9.4f m %7.2f%%\n", std::string(n).c_str(), request.mannequin.measurements[n], got.values[n],
                    100.0 * (got.values[n] / request.mannequin.measurements[n] - 1.0));
      else
        std::printf("%-16s %10s %9.4f m\n", std::string(n).c_str(), "", got.values[n]);
    }
  }
  return 0;
}

} // namespace vfit::cli
