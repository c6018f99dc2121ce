// SPDX-License-Identifier: Apache-2.0
// `vfit body`: builds a body and writes its mesh, joints and rigged glTF.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>

#include "body_args.h"
#include "commands.h"
#include "vfit/geometry/body/keypoint_fit.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/body/scan_fit.h"
#include "vfit/geometry/body/scan_input.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/geometry/mesh/up_axis.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {

std::string joints_json(const JointPositions& joints) {
  nlohmann::ordered_json j;
  for (int k = 0; k < JOINT_COUNT; ++k)
    j["joints"][std::string(joint_name(k))] = {joints(k, 0), joints(k, 1), joints(k, 2)};
  return j.dump(2) + "\n";
}

namespace {

void print_fit(const Keypoints& kp, const KeypointFit& fit) {
  std::printf("keypoints: %zu confident (%s), image %.0f x %.0f px, focal %.0f px%s\n", kp.points.size(),
              std::string(keypoint_layout_name(kp.layout)).c_str(), kp.image_size.x(), kp.image_size.y(), kp.focal,
              kp.focal_given ? "" : " (default: 1.2 x the longer side)");
  std::printf("%-12s %10s %10s %12s\n", "stage", "iterations", "ms", "cost");
  for (const KeypointFitStage& s : fit.stages)
    std::printf("%-12s %10d %10.1f %12.4g\n", s.name.c_str(), s.iterations, s.ms, s.cost);
  std::printf("keypoint fit: %.1f ms, mean reprojection error %.2f px, camera distance %.2f m, height %.3f m\n",
              fit.total_ms, fit.mean_reprojection_px, -fit.pose.translation.z(), fit.measurements.height);
}

// `vfit body --scan FILE`: a bare scan fitted (pose, shape) and rigged by the fit (seed 001 §5.2).
int run_scan(Args& args, const std::string& path) {
  const bool quiet = args.flag("quiet");
  const auto out = args.value("out");
  const auto joints_out = args.value("joints");
  const auto pose_arg = args.value("pose");
  const auto rigged = args.value("rigged");
  const auto pose_out = args.value("pose-out");
  const auto units_arg = args.value("units");
  const auto up_arg = args.value("up");
  const auto facing_arg = args.value("facing");
  for (const char* other : {"from", "keypoints", "joints-in", "betas"})
    if (args.value(other)) throw Error(std::string("--") + other, 0, "cannot be combined with --scan");
  args.positionals(0, 0);
  if (pose_out && std::filesystem::path(*pose_out).extension() != ".json")
    throw Error(*pose_out, 0, "--pose-out writes a .json file");
  if (rigged && mesh_format_from_path(*rigged) != MeshFormat::GLB)
    throw Error(*rigged, 0, "--rigged writes a .glb file");
  if (out) mesh_format_from_path(*out);
  for (const auto& [file, option] :
       {std::pair{out, "--out"}, {joints_out, "--joints"}, {rigged, "--rigged"}, {pose_out, "--pose-out"}})
    if (file) check_output_path(*file, option, {path, pose_arg.value_or("")});

  ReadOptions read_options;
  read_options.allow_point_cloud = true; // a scanner's PLY of vertices only
  ParsedMesh parsed = read_mesh(path, read_options);
  std::optional<Units> units = units_arg ? std::optional<Units>(parse_units(*units_arg)) : std::nullopt;
  if (!units) {
    const MeshStats stats = mesh_stats(parsed.mesh);
    units = detect_body_units(stats.largest_extent, stats.max_abs_coordinate);
    if (!units) throw Error(path, 0, "cannot detect the scan's units; state them with --units");
    if (const std::string w = body_units_warning(stats.largest_extent, stats.max_abs_coordinate, *units); !w.empty())
      parsed.warnings.push_back(path + ": " + w);
  }
  scale_positions(parsed.mesh.positions, metres_per_unit(*units));
  UpAxis up = up_arg ? parse_up_axis(*up_arg) : UpAxis::POS_Y;
  if (!up_arg && detect_body_up_axis(parsed.mesh.positions, parsed.mesh.triangles) == UpAxis::POS_Z) {
    up = UpAxis::POS_Z;
    parsed.warnings.push_back(path + ": stored with +z up (detected), rotated to +y up (force with --up)");
  }
  rotate_to_y_up(parsed.mesh.positions, up);
  const PreparedScan prepared = prepare_scan(
      std::move(parsed.mesh), path,
      facing_arg && *facing_arg != "auto" ? std::optional<Facing>(parse_facing(*facing_arg)) : std::nullopt);
  parsed.warnings.insert(parsed.warnings.end(), prepared.warnings.begin(), prepared.warnings.end());
  ScanFit fit = fit_scan(prepared.mesh, path);
  restore_scan_surface(fit.rigged, prepared);
  if (!quiet) {
    for (const auto& w : parsed.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
    for (const auto& w : fit.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
    std::printf("scan: %zu vertices, %zu faces; start from %s\n", prepared.vertex_count, prepared.face_count,
                fit.initialised_from_joints ? "the joints estimated on the scan"
                                            : "the A-pose (joint estimation failed)");
    std::printf("%-8s %10s %10s %10s %12s %12s\n", "stage", "iterations", "candidates", "ms", "mean (mm)", "95% (mm)");
    for (const ScanFitStage& s : fit.stages)
      std::printf("%-8s %10d %10d %10.1f %12.2f %12.2f\n", s.name.c_str(), s.iterations, s.candidates, s.ms,
                  1000 * s.mean_distance, 1000 * s.p95_distance);
    std::printf("scan fit: %.1f ms; scale %.3f, height %.3f m, arm length %.3f m, shoulder width %.3f m\n",
                fit.total_ms, fit.scale, fit.measurements.height, fit.measurements.arm_length,
                fit.measurements.shoulder_width);
  }
  // --pose: the rigged scan driven to that pose (T-pose-relative, the scan staying where it is).
  Body body = fit.rigged;
  if (pose_arg) {
    Pose to = pose_by_name_or_file(*pose_arg, RestPose::TPOSE);
    to.translation += fit.pose.translation;
    body = pose_body(fit.rigged, relative_pose(fit.rest_joints, fit.pose, to, fit.rigged.joints));
  }
  if (out) write_mesh(*out, body.mesh, "body");
  if (joints_out) write_file_atomically(*joints_out, joints_json(body.joints));
  if (pose_out) write_file_atomically(*pose_out, pose_json(fit.pose));
  if (rigged) {
    const MeshSkin skin = body_skin(fit.rigged);
    const NamedMesh named{"body", &fit.rigged.mesh, &skin};
    write_meshes_glb(*rigged, std::span<const NamedMesh>(&named, 1));
  }
  return 0;
}

} // namespace

int run_body(Args& args) {
  if (const auto scan = args.value("scan")) return run_scan(args, *scan);
  const bool quiet = args.flag("quiet");
  const std::string source = args.value("from").value_or("mannequin");
  BodyRequest request = body_request_from_args(args, source);
  const auto out = args.value("out");
  const auto joints_out = args.value("joints");
  const auto pose_arg = args.value("pose");
  const auto rigged = args.value("rigged");
  const auto keypoints_file = args.value("keypoints");
  const auto pose_out = args.value("pose-out");
  bool image_size_token = false;
  KeypointOptions kp_options = keypoint_options_from_args(args, image_size_token);
  if (keypoints_file && pose_arg) throw Error("--keypoints", 0, "the pose comes from the keypoints; drop --pose");
  if (keypoints_file && source != "mannequin")
    throw Error("--keypoints", 0, "fits the built-in mannequin; drop --from");
  if (pose_out && std::filesystem::path(*pose_out).extension() != ".json")
    throw Error(*pose_out, 0, "--pose-out writes a .json file");
  if (rigged && mesh_format_from_path(*rigged) != MeshFormat::GLB)
    throw Error(*rigged, 0, "--rigged writes a .glb file");
  if (out) mesh_format_from_path(*out);
  {
    std::vector<std::string> inputs = {source};
    for (const auto& f : {keypoints_file, pose_arg, request.joints_file, request.rig_mapping_file})
      if (f) inputs.push_back(*f);
    for (const auto& [file, option] :
         {std::pair{out, "--out"}, {joints_out, "--joints"}, {rigged, "--rigged"}, {pose_out, "--pose-out"}})
      if (file) check_output_path(*file, option, inputs);
  }
  // --image-size W H (two tokens), or WxH / W,H in one.
  finish_image_size(args, args.positionals(0, image_size_token ? 1 : 0), kp_options);
  std::optional<KeypointFit> fit;
  if (keypoints_file) {
    Keypoints kp;
    fit = fit_keypoint_file(*keypoints_file, kp_options, quiet, &kp);
    request.mannequin.measurements = fit->measurements;
    if (!quiet) print_fit(kp, *fit);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const LoadedBody loaded = load_body(request);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Pose pose;
  // The body in its own frame (the camera's translation dropped), ready for `vfit fit`.
  if (fit) pose = pose_from_keypoint_fit(*fit, loaded.rest.rest_pose);
  if (pose_arg) pose = pose_by_name_or_file(*pose_arg, loaded.rest.rest_pose);
  const Body body = loaded.posed(pose);
  if (!quiet)
    for (const auto& w : loaded.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
  if (out) write_mesh(*out, body.mesh, "body");
  if (joints_out) write_file_atomically(*joints_out, joints_json(body.joints));
  if (pose_out) write_file_atomically(*pose_out, pose_json(pose));
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
    std::printf("%-16s %10s %10s %8s\n", "measurement", requested ? "requested" : "", "measured",
                requested ? "error" : "");
    for (std::string_view n : BodyMeasurements::names()) {
      if (requested)
        std::printf("%-16s %9.4f m %9.4f m %7.2f%%\n", std::string(n).c_str(), request.mannequin.measurements[n],
                    got.values[n], 100.0 * (got.values[n] / request.mannequin.measurements[n] - 1.0));
      else
        std::printf("%-16s %10s %9.4f m\n", std::string(n).c_str(), "", got.values[n]);
    }
  }
  return 0;
}

} // namespace vfit::cli
