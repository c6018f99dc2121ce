// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A body scan made ready for fit_scan() (scan_fit.h), as scanners and other tools write them:
/// triangles wound inconsistently or inside out, holes (under the arms, the soles, the crown),
/// a figure facing −Z or ±X. fit_scan() reads the scan's sides (correspondences facing the
/// same way), starts from the joints estimate_joints() finds (which follows closed cross-sections
/// and needs the feet pointing to +Z), and so fitted such scans 3–28 cm off.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "body.h"
#include "scan_fit.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {

/// The scan prepared for the fit, and what to give back to the rigged scan afterwards.
struct PreparedScan {
  /// The scan (metres, Y up) wound consistently and outward, turned to face +Z, each hole
  /// capped by a fan: the caps' vertices and triangles follow the scan's own. No UVs, normals
  /// or labels (kept below).
  Mesh mesh;
  std::size_t vertex_count = 0, face_count = 0; ///< the scan's own, before the caps
  Mesh attributes;                              ///< the scan's UVs, normals and labels (after any re-winding)
  Facing facing = Facing::POS_Z;                ///< where the scan faced (turned to +Z)
  std::vector<std::string> warnings;            ///< one per change, naming `source`
};

/// Prepares `scan` (metres, Y up; a mesh or a point cloud) for fit_scan():
/// orient_consistently() and orient_outward() (geometry/mesh/orient.h); holes capped
/// (kernels/hole_caps.h); then turned to face +Z: by `facing` when given, else, when
/// estimate_joints() refuses the capped scan as given but accepts it turned to face +Z from −Z,
/// +X or −X (tried in that order), by that turn. A scan the estimator refuses every way (a posed
/// scan, which fit_scan()'s own pose search handles) stays as given. A point cloud is only
/// turned by a stated `facing`. Each change adds a warning naming `source`.
PreparedScan prepare_scan(Mesh scan, const std::string& source, std::optional<Facing> facing = std::nullopt);

/// How well the body fit_scan() fitted covers the scan: the distances (m) from the fitted
/// template's vertices (scan_fit_template() shaped and posed as `fit` says) to the scan's
/// surface, mean and 95th percentile. fit_scan()'s own stage distances go the other way (scan
/// to template), which a limbless shape passes: the template's limbs find nothing there.
/// `scan` is the mesh fit_scan() was given (with faces; a point cloud gives zeros).
struct ScanCoverage {
  double mean = 0, p95 = 0;
};
ScanCoverage scan_fit_coverage(const ScanFit& fit, const Mesh& scan);

/// The rigged scan of fit_scan() on a prepared scan with the caps dropped again (vertices,
/// weights and triangles past the scan's own) and the scan's UVs, normals and labels back.
void restore_scan_surface(Body& rigged, const PreparedScan& prepared);

} // namespace vfit
