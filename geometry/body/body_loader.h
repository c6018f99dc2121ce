// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// One entry point for every kind of body a user brings (seed 000 §3, seed 001 §5): the
/// built-in mannequin, an SMPL-format model file with shape β, a rigged glTF body, or a plain
/// mesh with no skeleton (a scan) whose joints are given in a JSON file or estimated.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "body.h"
#include "mannequin.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {

class SmplModel;

struct BodyRequest {
  /// "mannequin", or a file: .npz (SMPL format), .glb/.gltf (rigged, or plain), .obj/.ply/...
  std::string source = "mannequin";
  MannequinOptions mannequin;                  ///< for "mannequin"
  std::vector<double> betas;                   ///< for SMPL-format files (missing ones are 0)
  std::optional<std::string> rig_mapping_file; ///< explicit bone → joint mapping for glTF rigs
  std::optional<std::string> joints_file;      ///< {"joints": {"pelvis": [x, y, z], ...}} for plain meshes
  std::optional<Units> units;                  ///< a plain mesh's units (detected when absent)
  /// A plain mesh's up axis in its file (with its joints file, if any): rotated to +Y by
  /// rotate_to_y_up(). Absent: detect_body_up_axis() on the mesh (+Y when it cannot tell), with a
  /// warning when it turns the body.
  std::optional<UpAxis> up;
  /// Where a plain mesh's front faces once upright (with its joints file, if any): turned to +Z
  /// by rotate_to_face_z(). Absent: +Z, and when joint estimation refuses the body as given
  /// (its feet must point to +Z), the body turned to face +Z from −Z, +X and −X in turn, the
  /// first that the estimator accepts kept with a warning (no joints file only).
  std::optional<Facing> facing;
  /// A plain mesh file: drop degenerate and duplicate faces (read_mesh()'s ReadOptions::repair,
  /// with warnings) instead of failing on them.
  bool repair = false;
};

/// A body ready for fitting: rigged, in metres, in its rest pose, plus how to pose it.
class LoadedBody {
public:
  Body rest;                         ///< rest-pose mesh, joints, weights
  std::vector<std::string> warnings; ///< unit conversion, joint estimation notes, ...
  std::string kind;                  ///< "mannequin" | "smpl" | "gltf-rig" | "mesh+joints" | "scan"

  /// The body in `pose`: SMPL's own model (pose blend shapes included) for SMPL-format files,
  /// linear blend skinning otherwise.
  Body posed(const Pose& pose) const;

  LoadedBody();
  ~LoadedBody();
  LoadedBody(LoadedBody&&) noexcept;
  LoadedBody& operator=(LoadedBody&&) noexcept;

private:
  friend LoadedBody load_body(const BodyRequest& request);
  std::shared_ptr<const SmplModel> m_smpl;
  std::vector<double> m_betas;
};

/// Loads the requested body. A plain mesh is converted to metres, welded
/// (weld_coincident_vertices()), re-wound (orient.h), turned upright (BodyRequest::up) and to
/// face +Z (BodyRequest::facing), each with a warning when it changes something; its joints are
/// estimated (estimate_joints(), with its holes capped when it has any), and a body in a pose the
/// estimator does not read (not an A- or T-pose) is rigged by fit_scan() instead when the fitted
/// mannequin lies on it and it on the mannequin (scan_fit_coverage(): mean distance ≤ 20 mm,
/// 95th percentile ≤ 60 mm, both ways), with a warning.
/// Throws vfit::Error naming the file and the problem (missing file, unknown format, no
/// recognisable skeleton, joints file incomplete, ...).
LoadedBody load_body(const BodyRequest& request);

/// Reads a joints JSON file {"joints": {"<canonical name>": [x, y, z], ...}} (all 24, metres).
JointPositions read_joints_json(const std::filesystem::path& path);

} // namespace vfit
