// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Straightening a garment stored a little off upright (tilted forward, rolled sideways, or
/// turned about its up axis by less than an eighth of a turn), on top of the axis-aligned cases
/// that rotate_to_y_up() and rotate_to_face_z() handle. Conventions: Y up, facing +Z (mesh.h).

#include <span>

#include <Eigen/Core>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// How far a garment, already turned to its file's up axis, stands off upright, read from its
/// own geometry (estimate_tilt()).
struct GarmentTilt {
  /// Applied to positions about `centre` (p → centre + rotation·(p − centre)): makes the
  /// garment upright. Identity when nothing was found or all is within the dead bands.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(); ///< middle of the bounding box (mesh units)
  double side_degrees = 0;  ///< the rotation squaring its left–right axis with X (or Z, turned a quarter)
  double pitch_degrees = 0; ///< then the rotation about that axis that stands it up
  double degrees = 0;       ///< the angle of `rotation`
  bool changed() const { return degrees != 0; }
};

/// Estimates the small rotation that makes `mesh` (#V × 3, any unit, roughly Y up, its
/// left–right axis roughly X or Z) upright, in two steps:
/// 1. Its left–right axis: of the principal axes of its surface (area-weighted), the one across
///    which it is most mirror-symmetric (mirror_asymmetry() in that frame, by 0.02 over the
///    next), taken when its spread differs from the others' by 0.1 of the total or more. Turned
///    onto the nearest of ±X, ±Z when 4° or more away from it (and less than 45°). Upright
///    corpus and catalogue garments read 0.0-3.5° (their own asymmetry). A garment as wide as
///    it is tall or deep (the catalogue's, a round skirt: spreads within 0.1) is not turned.
/// 2. Its lean about that axis, from two cues that do not rely on each other: the line from its
///    highest opening's centre to the centre of its lowest openings (a top's neck to its hem,
///    a bottom's waist to its leg hems), and the normal of its largest flat opening within 40°
///    of +Y (flat: its vertices within 0.12 of its radius, rms, of a plane). Upright garments
///    read up to 9.3° on one cue and 20° on the other, from their cut (a skirt hangs back over
///    the seat, a neckline dips at the front), never both past 8.2° the same way; so the lean is
///    corrected only when both cues lean 9° or more the same way, by the smaller (under 45°).
///    A garment without both cues (an open-front jacket's single loop) keeps its lean, and so
///    does one leaning less than 9° (a cue's own reading of up to 9.3° cannot be told from it).
/// Axis-aligned garments stay exactly as given. Linear in the mesh size.
GarmentTilt estimate_tilt(const Mesh& mesh);

/// Rotates `positions` (#V × 3) by `tilt` (estimate_tilt()).
void apply_tilt(std::span<float> positions, const GarmentTilt& tilt);

} // namespace vfit
