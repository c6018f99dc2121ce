// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Part skeletons of a segmented garment (seed 000 §5.1): each sleeve and leg is cut out, made
/// watertight, skeletonised by mesh contraction (curve_skeleton.h) on a simplified proxy, and
/// every one of its full-resolution vertices is assigned to one node of a chain that runs
/// from the part's attachment (shoulder, hip) to its open end (cuff, hem).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "curve_skeleton.h"
#include "garment.h"
#include "hole_fill.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

struct PartSkeletonOptions {
  /// Proxy size and contraction weights. The default proxy (800 vertices) bounds the
  /// contraction's cost whatever the part's resolution.
  CurveSkeletonOptions skeleton;
  HoleFillOptions hole_fill;
  /// When set, the part is skeletonised through a proxy and hole_fill.edge_length is 0, its
  /// caps are built at the proxy's spacing, sqrt(2·A / (√3·P)) for a piece of area A and a
  /// proxy of P vertices (equilateral triangles, two per vertex), instead of the rim's: the
  /// proxy's edge collapses then spend no time on cap vertices (a Table-1 shorts' caps had
  /// 1.2× the legs' own vertices). Opt-in: with it, the catalogue trousers' last leg node
  /// missed the hem's centre by more than the hem's radius (curve_skeleton_test), and trousers
  /// driven onto their own pose moved 10.4 mm (skeleton_driving_test's bar: 10 mm).
  bool caps_at_proxy_spacing = false;
};

/// Wall-clock time per stage of one part (ms).
struct PartSkeletonTimings {
  double cut_ms = 0;                    ///< cut the part out, split non-manifold vertices, keep the largest piece
  double fill_ms = 0;                   ///< hole filling at full resolution
  double skeleton_ms = 0;               ///< proxy, contraction, collapse, chain (extract_curve_skeleton)
  CurveSkeletonTimings skeleton_stages; ///< skeleton_ms split by stage
  double map_ms = 0;                    ///< garment vertices → nodes, recentring, orientation
  double total_ms = 0;
};

/// The skeleton of one garment part: a chain of nodes and the part's vertices per node.
struct PartSkeleton {
  GarmentPart part = GarmentPart::LEFT_SLEEVE;
  /// #N node positions (mesh units), from the attachment end (the seam with the rest of the
  /// garment: shoulder or hip) to the open end (cuff or hem); each is the centre of its
  /// vertices' cross-section (seed 000 eq. 12; cross_section_centres(), curve_skeleton.h).
  std::vector<Eigen::Vector3d> nodes;
  /// The first node where the part is a whole tube (index into `nodes`): the node holding the
  /// far end of the part's seam with the rest of the garment (the node of the 95th percentile
  /// of the seam vertices' nodes: a trouser leg's crotch, whose top is cut slantwise up the
  /// hip; a sleeve's armpit). The nodes before it lie in the open wedge above that end, placed
  /// wherever the contraction took them and as far up one side as the label runs (a side
  /// opening, a pocket, a flap), so a limb's axis is measured from this node on. 0 when the
  /// part has no seam or the seam's far end lies past half the chain (no tube to speak of).
  std::size_t tube_start = 0;
  std::vector<std::int32_t> vertices;    ///< the part's garment vertex ids, ascending
  std::vector<std::int32_t> vertex_node; ///< per entry of `vertices`: its node in [0, #N); disjoint sets
  std::size_t proxy_vertices = 0;        ///< vertices the contraction ran on (proxy, or the closed part itself)
  std::size_t piece_vertices = 0;        ///< vertices of the cut-out piece before hole filling
  std::size_t cap_vertices = 0;          ///< vertices the hole-filling caps added to it
  ContractionStats contraction;
  PartSkeletonTimings timings;
};

/// The skeleton of the vertices labelled `part` in `garment` (#V × 3 positions, #F × 3
/// triangles, manifold) with labels `vertex_parts` (#V, e.g. segment_garment()'s). The part's
/// faces (all three vertices labelled) are cut out; vertices where fans of those faces meet
/// only at a point are split, the largest edge-connected piece is kept, hole-filled
/// (hole_fill.h) and skeletonised (extract_curve_skeleton(), on a proxy when large), which
/// gives each of its vertices a node; labelled vertices off the piece take the nearest node.
/// Nodes are recentred on all their vertices, at their cross-sections' centres
/// (cross_section_centres()). The chain starts at the end nearest the
/// centroid of the part's seam vertices (those with a neighbour of another label); a part
/// with no seam keeps the order extract_curve_skeleton() gave. `tube_start` is then the node
/// holding the seam's far end (see PartSkeleton::tube_start). Throws vfit::Error
/// ("part skeleton", …) when the labels do not match the mesh, the part has no face, or the
/// part has an edge shared by more than two faces.
PartSkeleton extract_part_skeleton(const Mesh& garment, std::span<const GarmentPart> vertex_parts, GarmentPart part,
                                   const PartSkeletonOptions& options = {});

/// Skeletons of the sleeves and legs present (LEFT_SLEEVE, RIGHT_SLEEVE, LEFT_LEG, RIGHT_LEG
/// in that order; a part is present when at least one face has it on all three vertices).
/// The torso and skirts are not tubes and get none. The parts are extracted concurrently (one
/// TBB task each); the result does not depend on the thread count.
std::vector<PartSkeleton> extract_limb_skeletons(const Mesh& garment, std::span<const GarmentPart> vertex_parts,
                                                 const PartSkeletonOptions& options = {});

} // namespace vfit
