// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The built-in garment catalogue: tee, long-sleeve shirt, trousers, shorts, dress and skirt,
/// generated around the built-in mannequin's rest pose for given body measurements, size
/// (ease), garment pose and vertex count. Each is a single open manifold surface with its real
/// openings (neck, cuffs, hem, waist) as boundary loops, outward normals, UVs, and per-vertex
/// ground-truth part labels for segmentation tests (seed 000 §4, Table 1, Fig. 13).

#include <cstddef>
#include <optional>
#include <string>

#include "garment.h"
#include "vfit/geometry/body/measurements.h"

namespace vfit {

struct GarmentOptions {
  GarmentType type = GarmentType::TEE;
  BodyMeasurements body;              ///< the body the garment is sized for
  std::string size = "M";             ///< XS … XXL, or P1 … P4 (trousers and shorts)
  std::optional<Ease> ease;           ///< overrides the size's ease when set
  RestPose pose = RestPose::TPOSE;    ///< TPOSE or APOSE (independent of any body's pose)
  std::size_t target_vertices = 5000; ///< the mesh has exactly this many (1,000 – 2,000,000)
};

/// Generates a catalogue garment: the mannequin's distance function grown by the ease
/// (girth ease / 2π plus 3 mm clearance; skirts hang as a flared elliptic tube from the hips;
/// legs grown into each other at the hem, as shorts P4's, are cut apart at the mid-plane)
/// → marching tetrahedra → cut at the openings → decimated (openings locked) to the exact
/// vertex count → relaxed on the surface → part labels (sleeves beyond the plane through the
/// shoulder joint normal to the arm; legs below planes through the crotch of slope 1, as seed
/// 000 eq. 3–4) → UVs (one cylindrical chart per part, seams at the back).
/// Throws vfit::Error for an unknown size, implausible measurements or a vertex count outside
/// [1,000, 2,000,000].
Garment make_garment(const GarmentOptions& options);

/// Number of boundary loops a catalogue garment of this type has (tee 4: neck, two cuffs, hem;
/// dress 4: neck, two armholes, hem; trousers and shorts 3; skirt 2).
std::size_t expected_openings(GarmentType type);

} // namespace vfit
