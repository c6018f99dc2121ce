// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Fit feedback from a fitted (or settled) garment: per-vertex strain and ease, summaries per
/// region, and a size verdict: tight, good, loose, or falls off (seed 000 Fig. 13: trousers P1
/// to P4 on one body). This is what a person reads off a fitting: where it pulls, where it hangs,
/// and whether it stays up.

#include <span>
#include <string>
#include <vector>

#include "vfit/geometry/body/body.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/proximity.h"

namespace vfit {

/// The size verdict, worst first: a garment that falls off is not also judged tight or loose.
enum class SizeVerdict { FALLS_OFF, TIGHT, LOOSE, GOOD };

/// "falls off" | "tight" | "loose" | "good".
std::string size_verdict_name(SizeVerdict verdict);

/// One region of the garment: a band of the torso around a body landmark (chest, waist, hip),
/// the sleeves, the thighs, or the hem.
struct RegionFeedback {
  std::string name;         ///< "chest", "waist", "hip", "thigh", "sleeves", "hem"
  std::size_t vertices = 0; ///< garment vertices in the region
  double mean_strain = 0;   ///< mean of the vertices' strain (1 = 100 % stretch)
  double max_strain = 0;    ///< largest vertex strain
  double mean_ease_mm = 0;  ///< mean distance to the body (mm; negative inside)
  double min_ease_mm = 0;   ///< smallest distance to the body (mm)
  /// Girth ease (m): the convex-hull perimeter of the garment's horizontal section at the
  /// landmark minus the body's (a tape measure around each); NaN where the garment has no closed
  /// section around the landmark (the region is then judged by nothing but strain).
  double girth_ease = 0;
  /// True when girth_ease was estimated as 2π × the mean distance to the body, for a judged
  /// region with no closed section around its landmark.
  bool girth_ease_estimated = false;
  /// The region's own verdict: tight, loose or good by girth ease against the thresholds of
  /// FitFeedbackOptions, or tight by strain.
  SizeVerdict verdict = SizeVerdict::GOOD;
};

/// Thresholds of the verdict. Girth ease bars follow pattern makers' minimum wearing ease
/// (about 5 cm at bust and hip, 2.5 cm at waist and thigh): less is tight; more than
/// `loose_factor` times it is loose. Measured ease includes the cloth's clearance from the skin
/// (3 mm on the catalogue's garments: about 2 cm of girth), so a garment cut with no ease at all
/// still measures ~2 cm: tight.
struct FitFeedbackOptions {
  double min_ease_chest = 0.05, min_ease_waist = 0.025, min_ease_hip = 0.05, min_ease_thigh = 0.025; ///< m
  double loose_factor = 4.0;
  /// Mean strain of a region above which it is tight whatever its girth (cloth stretched 3 %).
  double tight_strain = 0.03;
  /// A bottom falls off when its waistband's girth reaches the body's hip girth (nothing holds
  /// it up), when the simulation left its waistband below the hip line (it slid past the
  /// hips), or when it slid down by more than this during the simulation (m). A garment that
  /// settles by a few centimetres onto the hips stays up.
  double slide_limit = 0.10;
};

/// Per-vertex values and summaries.
struct FitFeedback {
  /// #V strain: mean over the vertex's edges of |e| / |e_rest| − 1 (0 at rest; > 0 stretched).
  std::vector<float> strain;
  /// #V ease (m): signed distance to the body surface (negative inside).
  std::vector<float> ease;
  std::vector<RegionFeedback> regions;
  SizeVerdict verdict = SizeVerdict::GOOD;
  std::string reason; ///< one sentence naming the region and numbers behind the verdict
  /// For bottoms: the waistband's girth (m) and how far it moved down during the simulation
  /// (m; 0 without a pre-simulation state).
  double waistband_girth = 0, waistband_drop = 0;
};

/// Judges a fitted garment on a body.
/// - rest: the garment as modelled (its edge lengths are the rest lengths; same topology as
///   `fitted`).
/// - fitted: the garment on the body (m).
/// - parts: #V part labels (segmentation or ground truth); type: the garment's type.
/// - body: the posed body (closed mesh, outward; canonical joints). Landmark heights come from
///   measure_body() when the body is upright in a rest-like pose, else from its joints.
/// - before_simulation: #V × 3 positions before the cloth simulation (empty when there was
///   none): a bottom whose waistband dropped by more than slide_limit, or below the hip line,
///   falls off; girth ease is measured on these positions (the garment as placed), strain and
///   distance on `fitted`.
/// Throws vfit::Error when the sizes disagree.
FitFeedback fit_feedback(const Mesh& rest, const Mesh& fitted, std::span<const GarmentPart> parts, GarmentType type,
                         const Body& body, std::span<const float> before_simulation = {},
                         const FitFeedbackOptions& options = {});

/// The same, with the body's proximity index already built (a caller fitting several garments
/// onto one body builds it once); `body_index` must index `body.mesh`.
FitFeedback fit_feedback(const Mesh& rest, const Mesh& fitted, std::span<const GarmentPart> parts, GarmentType type,
                         const Body& body, const ProximityIndex& body_index,
                         std::span<const float> before_simulation = {}, const FitFeedbackOptions& options = {});

/// A warning naming the garment's torn edges, or "" when there is none: edges of `fitted`
/// (positions in metres) longer than twice their length in `modelled` (#V × 3, m, the same
/// vertices as modelled) and by more than 2 cm. Cloth does not stretch so: such edges were pulled
/// through or around something the size verdict cannot see (a tee's front pushed out through
/// forearms lying on it, elbows_bent; a collar point drawn out 44 cm, a corpus shirt on
/// arms_down). The absolute part leaves out the slivers of a model (an edge of 0.1 mm
/// at twice its length).
std::string torn_cloth_warning(const Mesh& fitted, std::span<const float> modelled);

/// The edges torn_cloth_warning() counts: how many distinct edges of `fitted` are longer than
/// twice their length in `modelled` (#V × 3, m) and by more than 2 cm, and the largest such
/// elongation (m; 0 when none). Never throws for matching sizes.
struct TornCloth {
  std::size_t edges = 0;
  double worst = 0;
};
TornCloth torn_cloth(const Mesh& fitted, std::span<const float> modelled);

} // namespace vfit
