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
  MannequinOptions options;
  options.measurements = measurements_from_args(args);
  if (auto p = args.value("pose-rest")) {
    if (*p == "tpose") options.pose = RestPose::TPOSE;
    else if (*p == "apose") options.pose = RestPose::APOSE;
    else throw Error("--pose-rest", 0, "expected tpose or apose, got '" + *p + "'");
  }
  if (auto n = args.value("vertices")) options.target_vertices = static_cast<std::size_t>(Args::to_int("--vertices", *n, 1000, 2000000));
  const auto out = args.value("out");
  const auto joints_out = args.value("joints");
  const auto pose_arg = args.value("pose");
  const auto rigged = args.value("rigged");
  if (rigged && mesh_format_from_path(*rigged) != MeshFormat::GLB) throw Error(*rigged, 0, "--rigged writes a .glb file");
  args.positionals(0, 0);
  const auto t0 = std::chrono::steady_clock::now();
  const Body rest = make_mannequin(options);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Pose pose;
  if (pose_arg) {
    std::error_code ec;
    pose = std::filesystem::is_regular_file(*pose_arg, ec) ? read_pose_json(*pose_arg) : named_pose(*pose_arg, options.pose);
  }
  const Body body = pose_body(rest, pose);
  if (out) write_mesh(*out, body.mesh, "body");
  if (joints_out) write_file_atomically(*joints_out, joints_json(body.joints));
  if (rigged) {
    const MeshSkin skin = body_skin(rest);
    const NamedMesh named{"body", &rest.mesh, &skin};
    write_meshes_glb(*rigged, std::span<const NamedMesh>(&named, 1));
  }
  if (!quiet) {
    const MeasuredBody got = measure_body(rest.mesh, rest.joints);
    std::printf("mannequin: %zu vertices, %zu faces, built in %.0f ms\n", body.mesh.vertex_count(), body.mesh.face_count(), ms);
    std::printf("%-16s %10s %10s %8s\n", "measurement", "requested", "measured", "error");
    for (std::string_view n : BodyMeasurements::names())
      std::printf("%-16s %9.4f m %9.4f m %7.2f%%\n", std::string(n).c_str(), options.measurements[n], got.values[n],
                  100.0 * (got.values[n] / options.measurements[n] - 1.0));
  }
  return 0;
}

} // namespace vfit::cli
