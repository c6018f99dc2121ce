// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Internal to segment_garment(): the branches the merge tree found, and the §4.2 refinements
/// that turn them into final labels (seed 000 eq. 1–4). Not part of the public API.

#include <cstdint>
#include <optional>
#include <vector>

#include "garment.h"
#include "surface_graph.h"

namespace vfit {
struct GarmentSegmentation; // segment.h
}

namespace vfit::segment_detail {

/// What segment_garment() knows about the garment once it has its Morse function.
struct GarmentFrame {
  const SurfaceGraph* graph = nullptr;
  const std::vector<double>* f = nullptr; ///< geodesic distance from the source, #V
  std::vector<char> main;                 ///< #V: 1 on the segmented (largest) component
  double mid_x = 0;                       ///< the vertical symmetry plane x = mid_x
  double half_width = 0;                  ///< largest |x − mid_x| of the main component
  double min_y = 0, max_y = 0;            ///< its height range
  double extent = 0;                      ///< its largest bounding-box side
  int source = -1;                        ///< index into graph->loops
};

/// A sleeve or leg: a superlevel-set component of f that ends in an opening of its own.
struct Limb {
  int side = 0;                       ///< +1 wearer's left (+X), −1 right
  int loop = -1;                      ///< index into graph->loops: the cuff or leg hem
  std::int32_t saddle = -1;           ///< where it joins the rest (armpit, crotch)
  double saddle_value = 0;            ///< f(saddle)
  std::int32_t birth = -1;            ///< its vertex of largest f
  bool joins_trunk = false;           ///< merges into a torso that goes on, not only into a twin
  bool reaches_bottom = false;        ///< its opening reaches the bottom of the garment
  std::vector<std::int32_t> vertices; ///< the branch: its component of {f > f(saddle)}
};

/// An arm opening of a top (a cuff or an armhole) and where it meets the torso.
struct Arm {
  int side = 0;                  ///< +1 wearer's left (+X), −1 right
  int loop = -1;                 ///< index into graph->loops
  std::int32_t armpit = -1;      ///< key point P1 (right) or P2 (left)
  double length = 0;             ///< geodesic distance from the opening to the armpit
  bool branch = false;           ///< the Reeb graph has a branch ending in it (then it is a sleeve)
  std::vector<double> from_cuff; ///< #V geodesic distance from the opening (+∞ far away)
};

/// The arm opening on each side of a top: the largest off-centre opening other than the
/// source, with its armpit — the saddle of the Reeb branch that ends in it when there is one,
/// else the height saddle between it and the garment's bottom (`bottom`: the hem's vertices,
/// or the lowest band). Empty when a side has no such opening.
std::vector<Arm> find_arms(const GarmentFrame& frame, const std::vector<int>& openings, const std::vector<Limb>& limbs,
                           const std::vector<std::int32_t>& bottom);

/// The vertex at which a sweep upwards in height first joins the vertex sets `a` and `b`: the
/// lowest point of the highest path between them (a crotch, a hanging sleeve's armpit),
/// through vertices flagged in `within` (#V; all when null); −1 when they are not connected.
std::int32_t height_saddle(const GarmentFrame& frame, const std::vector<std::int32_t>& a,
                           const std::vector<std::int32_t>& b, const std::vector<char>* within = nullptr);

/// Sleeves (eq. 1–2, generalised to slanted arms): each sleeve ends at a plane S normal to the
/// upper arm's axis — the cuff's area vector for a short sleeve, the line through ring
/// centroids of the upper half for a long one (which may bend at the elbow) — where that
/// axis reaches the armpit's distance from the mid-plane (P1, P2 as mirror images, averaged),
/// moved inboard to the shoulder joint; and at the arm's underside, a plane through the
/// armpit, so a slanted sleeve does not take in the chest. A sleeve is what lies past both
/// planes on its side, connected to its cuff. Fills parts, key points and TEE/LONG_SLEEVE.
void refine_sleeves(const GarmentFrame& frame, const std::vector<Arm>& sleeves, GarmentSegmentation& out);

/// Legs (eq. 3–4): Pt(x) = mean x of the coarse torso, Pt(y) = the crotch (the height saddle
/// between the two leg openings) raised to where the body's crotch sits; legs lie below
/// y = Pt(y) + k·|x − Pt(x)|, split at x = Pt(x), each kept to its largest connected piece.
/// Fills parts, key points and TROUSERS (legs longer than the hips are wide) or SHORTS.
void refine_legs(const GarmentFrame& frame, const std::vector<Limb>& legs, double slope, GarmentSegmentation& out);

/// Height of a dress's waist: the lowest of the narrowest horizontal slabs between `top` and
/// `bottom` (y), where the skirt starts to widen.
double narrowest_girth_height(const GarmentFrame& frame, double top, double bottom);

/// Keeps, for each part in `limbs`, only its largest edge-connected piece; the rest becomes
/// `fallback`.
void keep_largest_pieces(const GarmentFrame& frame, const std::vector<GarmentPart>& limbs, GarmentPart fallback,
                         std::vector<GarmentPart>& parts);

} // namespace vfit::segment_detail
