// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Garment segmentation (seed 000 §4): which part of the body each vertex of a garment covers,
/// and what kind of garment it is.
///
/// §4.1 coarse: geodesic distance from one source (the centre of the highest opening around
/// the vertical mid-line: the collar of a top, the waistband of a bottom) is the Morse
/// function; its discrete Reeb graph (K bands, components per band by union-find, arcs between
/// bands) is reported, and its branches (sleeves, legs) are the superlevel-set components that
/// end in an opening of their own, found by a merge tree at vertex resolution so that the
/// saddles (armpits, crotch) are vertices rather than bands.
/// §4.2 refinement: sleeves end at boundary planes S1, S2 normal to each upper arm's axis near
/// the armpit key points P1, P2 (eq. 1–2, generalised from vertical planes to slanted arms)
/// and above the arm's underside; trouser legs end at the planes through the crotch point Pt
/// with slope k_l (eq. 3–4). Where the catalogue's joints are needed (the shoulder joint
/// inboard of the armpit, the body's crotch above the cloth's), offsets calibrated on the
/// catalogue's mannequin stand in for them.
///
/// Input conventions: the mesh as given, in any length unit (every threshold is relative to the
/// garment's size), upright with Y up, facing +Z so that +X is the wearer's left, left/right
/// symmetric about the vertical plane through its bounding box's centre. A garment lying
/// down or turned sideways is not rotated first: it is misread or rejected.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "garment.h"
#include "reeb_graph.h"
#include "vfit/geometry/garment/straighten.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {

struct SegmentOptions {
  int reeb_levels = 0;  ///< K bands of the Reeb graph; 0: about one band per 3 mean edge lengths, in [8, 64]
  double leg_slope = 1; ///< k_l of seed 000 eq. 4: rise of the leg boundary planes per unit of |x − Pt(x)|
};

/// A boundary plane: the part lies where (p − point)·normal > 0 (mesh units; normal is unit).
struct BoundaryPlane {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
};

/// Key points of §4.2 (mesh units). Unset when the garment has no such feature.
struct SegmentationKeyPoints {
  Eigen::Vector3d source = Eigen::Vector3d::Zero(); ///< centre of the source opening (collar or waistband)
  std::optional<Eigen::Vector3d>
      p1; ///< right armpit (−X side): the saddle where the right sleeve (or armhole) meets the torso
  std::optional<Eigen::Vector3d> p2;     ///< left armpit (+X side)
  std::optional<BoundaryPlane> s1;       ///< right sleeve's boundary plane S1 (eq. 2, generalised)
  std::optional<BoundaryPlane> s2;       ///< left sleeve's boundary plane S2
  std::optional<Eigen::Vector3d> crotch; ///< Pt of eq. 3: x = mean x of the coarse torso; y = the crotch (the height
                                         ///< saddle where the legs part) raised to the body's crotch
  std::optional<double> waist_height;    ///< dresses: where the skirt starts (y)
};

/// Wall-clock time per stage (ms).
struct SegmentationTimings {
  double graph_ms = 0;    ///< edge graph, components, boundary loops
  double geodesic_ms = 0; ///< distance from the source
  double reeb_ms = 0;     ///< Reeb graph and merge tree
  double classify_ms = 0; ///< branches → type and coarse labels (tops: their refinement too)
  double refine_ms = 0;   ///< legs' boundary planes and final labels
  double total_ms = 0;
};

struct GarmentSegmentation {
  GarmentType type = GarmentType::TEE;
  std::vector<GarmentPart> vertex_parts; ///< #V final labels (§4.2)
  std::vector<GarmentPart> coarse_parts; ///< #V labels of the Reeb-graph branches alone (§4.1)
  std::vector<double> geodesic;          ///< #V distance from the source (mesh units; +∞ off the main component)
  SegmentationKeyPoints key_points;
  ReebGraph reeb_graph;
  SegmentationTimings timings;
  std::vector<std::string> warnings; ///< e.g. "sleeveless top", extra components or openings
};

/// Segments a garment mesh (#V × 3 positions, #F × 3 triangles, any orientation of faces).
///
/// Types: two legs (branches that merge only with each other and reach the garment's bottom)
/// → TROUSERS, or SHORTS when the legs are shorter than the hips are wide. Otherwise the arm
/// openings (the largest off-centre opening on each side) decide: a sleeve when a branch ends
/// in it, or when it hangs below its armpit (the height saddle between it and the hem) by half
/// its radius → TEE, or LONG_SLEEVE when the sleeves reach further than half the torso's height
/// past their planes (open-front jackets included). Two armholes → DRESS when the garment
/// reaches more than twice the armhole depth below them (TORSO above the waist, found as the
/// lowest of the narrowest girths, SKIRT below), else a sleeveless top reported as TEE with a
/// warning (all TORSO). No side openings, two level ones, one above the other, at most 5 waist
/// diameters apart → SKIRT (all SKIRT): an upright open tube is taken for a skirt.
///
/// Only the largest connected component is segmented; vertices of other components (buttons,
/// trims) are labelled TORSO and named in a warning. Openings shorter than 5 % of the
/// garment's largest extent (pockets, button holes) are ignored.
///
/// Throws vfit::Error("garment", …) for what is not a recognisable garment: no faces, a bad
/// index, a closed surface, a single opening (a sheet, a detached collar), no opening around
/// the mid-line (lying down), a lone tube that is not an upright skirt, a single leg, or
/// openings that make neither a top, nor trousers, nor a skirt.
GarmentSegmentation segment_garment(const Mesh& garment, const SegmentOptions& options = {});

/// A garment's segmentation and the up axis and facing it was found with (segment_upright()).
struct UprightSegmentation {
  UpAxis up = UpAxis::POS_Y;     ///< the file's up axis, turned to +Y
  Facing facing = Facing::POS_Z; ///< where the garment's front faced once upright, turned to +Z
  /// False when the garment was turned a quarter (its left–right axis was Z) and nothing told
  /// its front from its back (bottoms, sleeveless tops): its front is then taken to face +X.
  bool front_known = true;
  /// The small rotation that straightened it once turned to +Y, before its facing was read
  /// (estimate_tilt()); identity for a garment stored upright or when the straightened
  /// garment was not recognised (it is then segmented as it stood).
  GarmentTilt tilt;
  GarmentSegmentation segmentation;
};

/// Segments `mesh` (#V × 3 positions in metres) after rotating it from its file's up axis to
/// +Y (rotate_to_y_up()): `up` when given; else the axis detect_up_axis() reads from the
/// surface (+Y when it cannot tell), and the other of +Y and +Z when the segmentation does not
/// recognise the garment so, and last the first axis tried turned upside down (−Y or −Z: the
/// surface does not give the sign). (The segmentation alone cannot choose: it recognises some
/// garments lying on their side, e.g. trousers as a long-sleeve top, and an upside-down tee as
/// a sleeveless top.) On return `mesh` is rotated into our frame. Throws vfit::Error naming
/// `name` with the segmentation's error for the first axis tried ("not a recognisable
/// garment: ...") when none is recognised, leaving `mesh` as given. Once turned to +Y, a garment
/// standing a little off upright (leaning, rolled, or turned about +Y by under 45°) is
/// straightened about its bounding box's middle (estimate_tilt(), apply_tilt()); when the
/// straightened garment is not recognised, it is segmented as it stood. Once upright, the
/// garment is turned about +Y to face +Z: `facing` when
/// given; else a garment whose left–right axis is Z (lateral_axis_is_z()) is turned a quarter,
/// its front taken to be away from its top edge's lean along X (top_edge_lean()), and a
/// garment segmented as a top with sleeves whose top edge leans forward (toward +Z, by 0.04 of
/// its depth or more: every measured top leans back by 0.06 or more) faced −Z and is turned
/// round and segmented again. Costs the detection (linear, a few ms at 10^5 triangles) and one
/// segmentation per axis tried, plus one for a top turned round.
UprightSegmentation segment_upright(const std::string& name, Mesh& mesh, std::optional<UpAxis> up = std::nullopt,
                                    std::optional<Facing> facing = std::nullopt, const SegmentOptions& options = {});

} // namespace vfit
