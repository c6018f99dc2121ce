// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The starting pose of a scan fit (scan_fit.h) for a scan in any pose: a coarse search over
/// each body part's orientation in turn (global placement, torso, thighs, knees, upper arms,
/// elbows, scale), every candidate scored by a truncated two-sided point distance between the
/// posed template and the scan. Seed 001 eq. 4 is local (ICP converges to the nearest minimum);
/// this search puts the limbs into the right basin first, so that a walking, sitting or
/// arms-raised scan does not start from an A-pose whose limbs lie on the wrong side of the scan's.
/// Conventions: metres, Y up, the body facing +Z, +X = the body's left.

#include <span>
#include <vector>

#include "body.h"

namespace vfit {

/// Settings of search_scan_pose().
struct ScanPoseSearchOptions {
  std::size_t scan_samples = 700;      ///< scan points scored (fixed-seed even subset)
  std::size_t scan_grid_points = 4000; ///< scan points the template's points are matched to
  std::size_t template_samples = 700;  ///< template vertices scored
  /// Distances are truncated here (m): a part farther than this off the scan counts the same
  /// wherever it is, so a wrong limb cannot outweigh the rest of the body.
  double cap = 0.08;
  int passes = 2; ///< sweeps over all parts (each keeps only improvements)
  /// Then, by each of these steps (degrees) in turn, the spine is leaned sideways (a third of
  /// the step at each spine joint) and each limb joint (shoulders, elbows, hips, knees) turned
  /// about its parent's three axes, keeping improvements.
  std::vector<double> refine_steps_deg = {16, 8, 4};
  /// After each arm's candidate sweep, this many of its best-scoring candidates that place the
  /// arm differently (elbow or wrist more than `alternative_separation` apart) are each refined
  /// (shoulder and elbow turned by `alternative_steps_deg`, as above) and the best refined one
  /// is kept: on the candidate grid (20-45° apart) an arm near its true pose can score worse
  /// than one in a wrong place that happens to cover part of the scan's arm (an upper arm
  /// hanging against the torso earns little, the torso lying as near), and a few degrees
  /// decide. 1 keeps the plain best candidate.
  std::size_t limb_alternatives = 4;
  /// In the last sweep, each arm also tries, per upper-arm direction, forearms aimed at the scan
  /// points (more than cap / 2 from the rest of the template) a forearm to a forearm and hand from
  /// its elbow: the 3 directions most of them share. The fixed forearm directions lie up to ~35°
  /// apart; an arm hanging against the torso with its forearm held out got no candidate within
  /// 7 cm and lost to a wrong arm (seed 11's random 4 in the corpus scan test: elbow 40 cm off).
  bool aimed_forearms = true;
  double alternative_separation = 0.08; ///< m
  /// With the scan's normals: a template point more than `inside_slack` (m) behind the nearest
  /// scan point's surface counts as that distance plus `inside_factor` × the depth beyond it
  /// (within the cap), so a limb pushed into the torso no longer scores as if it lay on it (an
  /// arm with its forearm folded back into the chest tied with the true one to 0.3 %). The slack
  /// leaves the template's own misfit (its shape is not the scan's) alone.
  double inside_slack = 0.02;
  double inside_factor = 2.0;
  std::vector<double> alternative_steps_deg = {16, 8, 4}; ///< degrees: each alternative's refinement steps, in turn
};

/// The result of search_scan_pose().
struct ScanPoseSearch {
  Pose pose;              ///< T-pose-relative pose and translation (m) of the template
  double log_scale = 0;   ///< log of the template's global scale
  double start_score = 0; ///< score of the starting pose (m: mean truncated distance, both ways)
  double score = 0;       ///< score of the returned pose (m)
  int evaluations = 0;    ///< candidate poses scored
};

/// Evenly spread indices into [0, n): min(n, max(count, 1)) of them, i·n/m for i < m (the
/// fixed-seed sample both the search and the scan fit score with); empty when n = 0.
std::vector<std::size_t> spread_indices(std::size_t n, std::size_t count);

/// Searches the pose of `tmpl` (a body in T-pose whose rest joints and weights pose it by LBS)
/// scaled by exp(log_scale) that best covers `scan` (#P × 3, m; a mesh's vertices or a point
/// cloud), starting from `start`. Score: mean over scan samples of min(d, cap) to the posed
/// template's vertices plus the same from template samples to the scan's points, so a part is
/// rewarded both for explaining scan points and for lying on the scan; with `scan_normals` (#P
/// unit outward normals, one per scan point; any other count is ignored), a template point deep
/// behind the scan's surface counts more (ScanPoseSearchOptions::inside_slack). Each part is
/// tried in a fixed set of orientations (upper arms over 36 directions and 3 twists, elbows
/// 0–120°, thighs over 24 directions, knees 0–100°, torso bend and twist, global yaw ±30°, x/z
/// shifts, scale ±15 %), in the last sweep also forearms aimed at the scan points the rest of
/// the body leaves unexplained, every candidate placed on the scan's floor (lowest points
/// level); after each arm's sweep its options.limb_alternatives best distinct placements are
/// refined and the best refined one kept; then, by options.refine_steps_deg in turn, the spine
/// is leaned sideways (which the torso candidates do not try) and each limb joint turned about
/// its parent's axes. A candidate replaces the current value only when it scores better, so the
/// result never scores worse than `start`. Deterministic, and the same at any thread count
/// (each part's candidates are scored side by side, each score a function of its candidate
/// alone). Needs at least one scan point; never throws for finite input.
ScanPoseSearch search_scan_pose(const Body& tmpl, std::span<const float> scan, const Pose& start, double log_scale,
                                const ScanPoseSearchOptions& options = {},
                                std::span<const Eigen::Vector3d> scan_normals = {});

} // namespace vfit
