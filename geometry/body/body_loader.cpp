// SPDX-License-Identifier: Apache-2.0
#include "body_loader.h"

#include "mannequin_cache.h"

#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

#include "gltf_body.h"
#include "joint_estimation.h"
#include "json_input.h"
#include "rig_mapping.h"
#include "scan_fit.h"
#include "scan_input.h"
#include "smpl_model.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/mesh_stats.h"
#include "vfit/geometry/mesh/orient.h"
#include "vfit/geometry/mesh/weld.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/hole_caps.h"

namespace vfit {

LoadedBody::LoadedBody() = default;
LoadedBody::~LoadedBody() = default;
LoadedBody::LoadedBody(LoadedBody&&) noexcept = default;
LoadedBody& LoadedBody::operator=(LoadedBody&&) noexcept = default;

Body LoadedBody::posed(const Pose& pose) const {
  if (!m_smpl) return pose_body(rest, pose);
  Body out = rest;
  out.mesh.positions = m_smpl->posed_mesh(m_betas, pose).positions;
  out.joints = m_smpl->posed_joints(m_betas, pose);
  return out;
}

JointPositions read_joints_json(const std::filesystem::path& path) {
  const std::string file = path.string();
  const nlohmann::json j = json_input::read_file(path);
  const nlohmann::json& joints = j.contains("joints") ? j["joints"] : j;
  if (!joints.is_object()) throw Error(file, 0, "expected {\"joints\": {\"pelvis\": [x, y, z], ...}}");
  JointPositions out = JointPositions::Zero();
  std::vector<bool> seen(JOINT_COUNT, false);
  for (const auto& [name, value] : joints.items()) {
    const auto jj = joint_from_name(name);
    if (!jj) throw Error(file, 0, "unknown joint '" + name + "' (expected the 24 SMPL joint names)");
    out.row(*jj) = json_input::vec3(value, file, name).transpose();
    seen[*jj] = true;
  }
  for (int k = 0; k < JOINT_COUNT; ++k)
    if (!seen[k]) throw Error(file, 0, "joint '" + std::string(joint_name(k)) + "' is missing");
  return out;
}

LoadedBody load_body(const BodyRequest& r) {
  LoadedBody out;
  if (r.source == "mannequin") {
    out.rest = cached_mannequin(r.mannequin);
    out.kind = "mannequin";
    return out;
  }
  const std::filesystem::path path = r.source;
  std::string ext = path.extension().string();
  for (char& c : ext)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".npz") {
    auto model = std::make_shared<SmplModel>(SmplModel::load(path));
    out.rest = model->rest_body(r.betas);
    out.m_smpl = std::move(model);
    out.m_betas = r.betas;
    out.kind = "smpl";
    return out;
  }
  if (ext == ".glb" || ext == ".gltf") {
    // A rigged glTF body when it has a skin; a plain mesh otherwise.
    const std::string bytes = read_file_bytes(path);
    if (bytes.find("\"skins\"") != std::string::npos) {
      std::optional<RigMapping> mapping;
      if (r.rig_mapping_file) mapping = load_rig_mapping(*r.rig_mapping_file);
      out.rest = parse_gltf_body(bytes, path.string(), mapping, &out.warnings);
      out.kind = "gltf-rig";
      return out;
    }
  }
  ReadOptions read_options;
  read_options.repair = r.repair;
  ParsedMesh parsed = read_mesh(path, read_options);
  out.warnings = parsed.warnings;
  const MeshStats stats = mesh_stats(parsed.mesh);
  Units units = Units::M;
  if (r.units) {
    units = *r.units;
  } else {
    const auto detected = detect_body_units(stats.largest_extent, stats.max_abs_coordinate);
    if (!detected) throw Error(path.string(), 0, "cannot detect the body's units; state them with --units");
    units = *detected;
    if (const std::string w = body_units_warning(stats.largest_extent, stats.max_abs_coordinate, units); !w.empty())
      out.warnings.push_back(path.string() + ": " + w);
  }
  scale_positions(parsed.mesh.positions, metres_per_unit(units));
  if (const WeldReport weld = weld_coincident_vertices(parsed.mesh); weld.changed())
    out.warnings.push_back(path.string() + ": welded " + std::to_string(weld.welded) +
                           " coincident vertices, dropped " + std::to_string(weld.unreferenced) +
                           " unused vertices and " + std::to_string(weld.collapsed) + " collapsed triangles");
  if (const OrientReport orient = orient_consistently(parsed.mesh); orient.changed())
    out.warnings.push_back(path.string() + ": turned over " + std::to_string(orient.flipped) + " of " +
                           std::to_string(parsed.mesh.face_count()) +
                           " triangles wound against their neighbours (inconsistent orientation)");
  if (orient_outward(parsed.mesh))
    out.warnings.push_back(path.string() + ": wound inside out (negative enclosed volume): every triangle turned over");
  UpAxis up = UpAxis::POS_Y;
  if (r.up) {
    up = *r.up;
  } else if (detect_body_up_axis(parsed.mesh.positions, parsed.mesh.triangles) == UpAxis::POS_Z) {
    up = UpAxis::POS_Z;
    out.warnings.push_back(path.string() + ": stored with +z up (detected), rotated to +y up (force with --up)");
  }
  rotate_to_y_up(parsed.mesh.positions, up);
  if (r.facing) rotate_to_face_z(parsed.mesh.positions, *r.facing);
  if (r.joints_file) {
    out.rest.mesh = std::move(parsed.mesh);
    out.rest.joints = read_joints_json(*r.joints_file);
    rotate_to_y_up(std::span<double>(out.rest.joints.data(), std::size_t(out.rest.joints.size())), up);
    if (r.facing)
      rotate_to_face_z(std::span<double>(out.rest.joints.data(), std::size_t(out.rest.joints.size())), *r.facing);
    out.rest.weights = estimate_skin_weights(out.rest.mesh, out.rest.joints);
    out.rest.source = path.string();
    out.kind = "mesh+joints";
    return out;
  }
  // A scan is rarely closed, and the estimator follows the body's cross-sections, which holes
  // break open (a corpus body with 2 % of its triangles missing lost its torso above the
  // waist): when the body as given is refused and has holes, its joints are estimated on a copy
  // with each hole capped by a fan (hole_caps.h), and the body as given is rigged with them.
  std::size_t capped_holes = 0;
  auto rig = [&](Mesh body) {
    try {
      return rig_bare_body(body, path.string());
    } catch (const Error& original) {
      const HoleCaps caps = build_hole_caps(body.triangles, body.vertex_count());
      if (caps.loop_count() == 0) throw;
      Mesh capped = body;
      capped_positions(body.positions, caps, capped.positions);
      capped.triangles.insert(capped.triangles.end(), caps.triangles.begin(), caps.triangles.end());
      capped.uvs.clear();
      capped.uv_triangles.clear();
      capped.normals.clear();
      capped.normal_triangles.clear();
      capped.face_labels.clear();
      Body from_capped;
      try {
        from_capped = rig_bare_body(std::move(capped), path.string());
      } catch (const Error&) {
        throw original; // the body as given says best what is wrong with it
      }
      Body b;
      b.joints = from_capped.joints;
      b.rest_pose = from_capped.rest_pose;
      b.weights = estimate_skin_weights(body, b.joints);
      b.mesh = std::move(body);
      b.source = path.string();
      capped_holes = caps.loop_count();
      return b;
    }
  };
  std::optional<Error> first;
  if (r.facing) {
    try {
      out.rest = rig(parsed.mesh);
    } catch (const Error& e) {
      first = e;
    }
  } else {
    // The estimator reads the facing from the feet and refuses a body facing elsewhere than +Z
    // (other tools export figures facing -Z or +X): the body turned each other way is tried,
    // and when none is accepted, the error is the one for the body as given.
    try {
      out.rest = rig(parsed.mesh);
    } catch (const Error& e) {
      first = e;
      for (Facing f : {Facing::NEG_Z, Facing::POS_X, Facing::NEG_X}) {
        Mesh turned = parsed.mesh;
        rotate_to_face_z(turned.positions, f);
        try {
          out.rest = rig(std::move(turned));
        } catch (const Error&) {
          continue;
        }
        out.warnings.push_back(path.string() + ": faced " + facing_name(f) +
                               " (detected: its feet), turned to face +z (force with --facing)");
        first.reset();
        break;
      }
    }
  }
  if (first) {
    // Not in a pose the estimator reads (it needs an A- or T-pose): a posed body, e.g. a scan
    // of someone walking, is rigged by fitting the mannequin to it (fit_scan(), as vfit body
    // --scan), kept when the fitted mannequin lies on it; else the estimator's error stands.
    // Both ways: the scan's vertices to the fitted mannequin (fit_scan()'s own distances), and
    // the mannequin's to the scan (a limbless shape leaves the mannequin's limbs on nothing).
    // Measured (mean / 95th percentile, each way): the corpus body walking 11 / 34 and 12 / 40 mm;
    // a limbless pillar of a body's size 21 / 75 and 27 / 91 mm; a sphere or a cube 240 mm and up.
    constexpr double MAX_MEAN_DISTANCE = 0.020, MAX_P95_DISTANCE = 0.060; // m
    try {
      const PreparedScan prepared = prepare_scan(parsed.mesh, path.string(), r.facing);
      ScanFit fit = fit_scan(prepared.mesh, path.string());
      const ScanFitStage& last = fit.stages.back();
      const ScanCoverage back = scan_fit_coverage(fit, prepared.mesh);
      if (last.mean_distance <= MAX_MEAN_DISTANCE && last.p95_distance <= MAX_P95_DISTANCE &&
          back.mean <= MAX_MEAN_DISTANCE && back.p95 <= MAX_P95_DISTANCE) {
        restore_scan_surface(fit.rigged, prepared);
        out.rest = std::move(fit.rigged);
        out.warnings.insert(out.warnings.end(), prepared.warnings.begin(), prepared.warnings.end());
        out.warnings.push_back(path.string() + ": the joint estimator refused it (" + first->what() +
                               "); rigged by fitting the mannequin to it as a scan (mean distance " +
                               std::to_string(static_cast<int>(std::lround(1000 * last.mean_distance))) + " mm)");
        first.reset();
      }
    } catch (const Error&) {
      // the estimator's error below says more
    }
  }
  if (first) throw *first;
  if (capped_holes > 0)
    out.warnings.push_back(path.string() + ": joints estimated with its " + std::to_string(capped_holes) +
                           " holes capped");
  out.kind = "scan";
  return out;
}

} // namespace vfit
