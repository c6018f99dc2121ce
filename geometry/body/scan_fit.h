// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Pose and shape of a body scan, and the scan rigged from them (seed 001 §5.2, eq. 3–4):
///   argmin_{θ, s, β, t} Σ ‖M(θ, s, β) + t − Y‖ + E_pose(θ) + E_shape(β)
/// with M the template body (the built-in mannequin, T-pose) posed by linear blend skinning
/// (eq. 3) and Y the scan. Solved ICP-style: correspondences in both directions (scan point →
/// closest template point, template vertex → closest scan point), far and opposite-facing pairs
/// rejected, Geman–McClure weights (iteratively reweighted), then Levenberg–Marquardt with
/// Ceres over θ, t, s and β; alternated a bounded number of rounds. Then each scan vertex takes
/// the skin weights of its closest template point facing its way on its own body part,
/// interpolated barycentrically (seed 001 §5.2; transfer_skin_weights(), scan_skin_transfer.h),
/// so the scan becomes a rigged Body.
/// Conventions: metres, Y up, the body facing +Z, +X = the body's left.

#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "body.h"
#include "keypoint_fit.h"
#include "measurements.h"
#include "scan_pose_search.h"

namespace vfit {

/// Settings of fit_scan().
struct ScanFitOptions {
  int icp_rounds = 10;                 ///< correspondence / solve alternations (bounded)
  int iterations_per_round = 8;        ///< Levenberg–Marquardt iterations per solve, at most
  std::size_t scan_samples = 1200;     ///< scan vertices used as correspondence sources (fixed-seed subset)
  std::size_t template_samples = 1200; ///< template vertices used as sources
  /// Pairs farther apart than this (m) are rejected in the first round; the limit shrinks to
  /// half of it by the last round as the fit closes in.
  double reject_distance = 0.10;
  int threads = 2;              ///< threads of the Ceres solves, clamped to [1, 2] (the result does not depend on it)
  ScanPoseSearchOptions search; ///< stage 2, the starting pose's search (scan_pose_search.h)
};

/// One stage of the fit.
struct ScanFitStage {
  /// "template" (building the template and shape basis: first use only), "init", "search"
  /// (search_scan_pose()), "icp", "weights", "joints"
  std::string name;
  int iterations = 0;       ///< Ceres iterations (all rounds together), or 0
  int candidates = 0;       ///< candidate poses scored ("search"), or 0
  double ms = 0;            ///< wall time
  double mean_distance = 0; ///< mean distance (m) from the scan's vertices to the posed template after the stage
  double p95_distance = 0;  ///< its 95th percentile (m)
  /// The joints after the stage (m): the posed template's for "init", "search" and "icp", the
  /// final ScanFit::joints for "joints"; zero for the others.
  JointPositions joints = JointPositions::Zero();
  /// CPU time (ms) of the whole process during the stage, all its threads together: the work
  /// done, which a busy machine does not inflate as it does the wall time.
  double cpu_ms = 0;
};

/// The fitted body and the rigged scan.
struct ScanFit {
  /// T-pose-relative pose (SMPL layout) and translation in the scan's frame: the template's
  /// joints in the scan are posed_joints(rest_joints, pose).
  Pose pose;
  /// Shape: a global scale s of the template (stature and girths together) and the keypoint
  /// model's β (keypoint_fit.h; β[0], stature, is held at 0 since s carries it; β[1] leg, β[2]
  /// arm length, β[3] shoulder width, in population σ). The elbows' shift along the arm (see
  /// fit_scan()) is a rig's convention, not part of β: it shows in rest_joints only.
  double scale = 1.0;                                  ///< s (dimensionless; 1 = the template's size)
  KeypointShape shape{};                               ///< β (population σ; β[0] = 0, see above)
  BodyMeasurements measurements;                       ///< of the fitted shape (the mannequin's, scaled)
  JointPositions rest_joints = JointPositions::Zero(); ///< T-pose joints of the fitted shape (m)
  /// The joints in the scan (m): estimate_joints() run on the scan unposed into the fitted
  /// template's A-pose (inverse LBS of the spine and limbs; the collars, neck and head keep
  /// their fitted rotations, the upper arms pointing down as in the A-pose), each joint carried
  /// back by the mean of the skinning transforms of its parent's bone and its own; where that
  /// estimation fails, the template's posed joints posed_joints(rest_joints, pose).
  JointPositions joints = JointPositions::Zero();
  bool joints_estimated_unposed = false; ///< `joints` come from the unposed scan
  /// Limbs (arms, legs) unposed a second time about their estimated root joint instead of the
  /// template's, because that unstretched their seam with the torso (scan_fit.cpp, stage 5); 0–4.
  int repivoted_limbs = 0;
  /// The scan as a rigged body: its own mesh in its own (the fitted) pose, `joints` as the
  /// rest joints and per-vertex weights interpolated from the template; pose it with
  /// pose_body() by rotations relative to this pose. rest_pose from classify_rest_pose().
  Body rigged;
  bool initialised_from_joints = false; ///< estimate_joints() worked on the scan (else an A-pose start)
  std::vector<ScanFitStage> stages;     ///< the stages run, in order
  double total_ms = 0;                  ///< wall time of the whole fit (ms)
  double total_cpu_ms = 0;              ///< CPU time of the whole fit (ms), all threads, as ScanFitStage::cpu_ms
  /// One line each: e.g. the A-pose fallback start, or a poor fit (the scan 60 mm or more from
  /// the fitted body at the 95th percentile: a kneeling or sitting scan the fit does not reach).
  std::vector<std::string> warnings;
};

/// The template body of the scan fit: the mannequin of average measurements in T-pose, 3,000
/// vertices, built on first use (about a second) and cached; thread-safe. Its joints are the
/// keypoint model's mean joints (mannequin_keypoint_model()).
const Body& scan_fit_template();

/// Fits the template's pose θ, translation, scale and β to `scan` (a body mesh, or a point
/// cloud: a Mesh without faces, then only scan → template correspondences are used and the
/// rigged result has no faces), in metres, upright (Y up), in any pose the pose prior allows.
/// Start: estimate_joints() on the scan (A- or T-pose scans) and the skeleton fitted to those
/// joints; where that fails, the A-pose scaled to the scan's height, with a warning. Then
/// search_scan_pose() (scan_pose_search.h) tries each part's orientation in turn, so a scan in
/// another pose (walking, arms raised, a knee bent, legs apart) starts near its own. After the
/// ICP rounds and the skin weights, the joints are re-estimated on the unposed scan (ScanFit::joints). Shape
/// model: the template's rest vertices v = s (v₀ + Σ_k w_k ΔJ_k(β)) follow their joints'
/// displacement ΔJ(β) from the keypoint model, so β changes limb lengths and s everything; a
/// fifth number moves both elbows along the arm (2 cm per unit, at most 6 cm either way, weakly
/// regularised), so that the template bends where the scan's arm bends (rigs disagree on the
/// elbow's place).
/// Throws vfit::Error (naming `source`) for fewer than 100 points, a non-finite coordinate
/// (naming the vertex), or a scan whose extent along Y is outside 0.8–2.5 m (not in metres,
/// not upright, or not a body). Seed 001 eq. 4 (with eq. 3's LBS for M).
ScanFit fit_scan(const Mesh& scan, const std::string& source, const ScanFitOptions& options = {});

/// Drives a body rigged in a fitted pose to another pose: `rest` is a skeleton's rest joints,
/// `from` the pose (relative to `rest`) the rigged body was captured in, whose rest joints are
/// `rigged_joints` (e.g. ScanFit::rest_joints, ScanFit::pose and ScanFit::joints). Returns the
/// pose, relative to the rigged body, that gives each of its bones the world rotation the bone
/// has in `to` (relative to `rest`): W_j = R_j(to) R_j(from)ᵀ, local rotations W_parentᵀ W_j, and
/// the translation that puts the rigged pelvis where `to` puts the skeleton's. Exact for any
/// rotations; pose_body(rigged, result) then equals posing the skeleton's own body by `to`
/// wherever the rigged body's joints and weights equal the skeleton's. Joints are 24 × 3 (m);
/// no validation, never throws.
Pose relative_pose(const JointPositions& rest, const Pose& from, const Pose& to, const JointPositions& rigged_joints);

/// Skin weights of `points` (#P × 3, m) by barycentric interpolation of `weights` (of `mesh`'s
/// vertices) at each point's closest point on `mesh` (seed 001 §5.2), the 4 largest kept and
/// renormalised; returns #P rows. TBB-parallel. Throws vfit::Error ("skin weight
/// interpolation: …") when `mesh` has no faces or `weights` fails validate_skin_weights()
/// against its vertex count, and vfit::Error ("proximity queries: …") when points.size() is not
/// a multiple of 3 or a point is not finite.
SkinWeights interpolate_skin_weights(const Mesh& mesh, const SkinWeights& weights, std::span<const float> points);

} // namespace vfit
