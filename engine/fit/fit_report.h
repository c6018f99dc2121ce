// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// What a fit reports (engine/fit/pipeline.h): per garment, the stages' times and outcomes,
/// where it stands against the body before and after each stage that moves it, the simulation's
/// end and the size verdict; the fitted garments themselves.

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "vfit/engine/dress/penetration_types.h"
#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/geometry/garment/coarse_move.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {

/// How the cloth simulation of one garment ended.
enum class SimulationOutcome {
  SKIPPED,    ///< FitOptions::simulate was false
  CONVERGED,  ///< mean displacement per step fell below the rest threshold
  TIME_LIMIT, ///< stopped at max_simulated_seconds / max_wall_seconds, not at rest
  DIVERGED,   ///< the simulation blew up: its result is discarded, the pre-simulation mesh is kept
};

/// "skipped" | "converged" | "time limit" | "diverged".
std::string to_string(SimulationOutcome outcome);

/// Wall-clock milliseconds of each stage. For one garment, or summed over all of them.
struct FitStageTimes {
  double units_ms = 0;        ///< unit detection, conversion to metres, welding (weld.h)
  double segmentation_ms = 0; ///< segment_garment(): type detection and part labels
  double skeletons_ms = 0;    ///< extract_limb_skeletons()
  double driving_ms = 0;      ///< SkeletonDriver setup and drive(): orientation, driving, Laplacian
  double coarse_move_ms = 0;  ///< compute_coarse_move() and the translation (garments not driven)
  double penetration_ms = 0;  ///< remove_penetration() (and any clean-up after simulation)
  double simulation_ms = 0;   ///< ClothSim construction and run_to_rest()
  double feedback_ms = 0;     ///< fit_feedback(): strain, ease, regions, verdict
  double total_ms = 0;        ///< the garment's whole pass

  /// (stage name, ms) in pipeline order: "units", "segmentation", "skeletons", "driving",
  /// "coarse_move", "penetration", "simulation", "feedback", "total".
  std::vector<std::pair<std::string, double>> named() const;
};

/// The coarse proxy a garment's simulation ran on (FitOptions::cloth_proxy).
struct ClothProxyReport {
  bool used = false;         ///< false: simulated at full resolution (or not simulated)
  std::size_t vertices = 0;  ///< the proxy's
  std::size_t triangles = 0; ///< the proxy's
  double build_ms = 0;       ///< build_cloth_proxy(): decimation and the fine garment's embedding
  double simulation_ms = 0;  ///< the proxy's ClothSim construction and run_to_rest()
  double reconstruct_ms = 0; ///< reconstruct_from_proxy() (and the trim carried after it)
};

/// What happened to one garment.
struct GarmentFitReport {
  std::string name;
  GarmentType type = GarmentType::TEE;
  std::size_t vertices = 0, faces = 0;
  Units units = Units::M;        ///< the input's unit (converted to metres)
  UpAxis up = UpAxis::POS_Y;     ///< the input's up axis (rotated to +Y before segmentation)
  Facing facing = Facing::POS_Z; ///< where its front faced once upright (turned to +Z before segmentation)
  std::size_t order = 0;         ///< position in the processing order (0 = first)
  FitStageTimes timings;
  std::size_t skeleton_parts = 0;  ///< limb skeletons extracted
  std::string driving = "skipped"; ///< "driven: ..." with the sub-stage times, or why it was skipped
  CoarseMove coarse_move;
  SizeVerdict verdict = SizeVerdict::GOOD; ///< fit_feedback()'s verdict for this garment
  std::string verdict_reason;              ///< the region and numbers behind it
  std::vector<RegionFeedback> regions;     ///< strain and ease summaries per region
  /// Garments fitted before this one that it was kept outside of (its inner layers).
  std::size_t inner_layers = 0;
  /// After the coarse move, before removal (depths m). Crossing edges are always measured;
  /// layer_inside_count counts vertices inside the inner layers, layer_crossing_edges the inner
  /// layers' edges through this garment.
  PenetrationStats before;
  PenetrationStats after_removal; ///< after remove_penetration()
  /// As the simulation left it, before any clean-up (zeros when not simulated or diverged):
  /// what the cloth's contacts with the body and the inner garments kept out.
  PenetrationStats after_simulation;
  PenetrationStats after; ///< of the returned mesh
  int penetration_iterations = 0;
  SimulationOutcome simulation = SimulationOutcome::SKIPPED;
  std::string simulation_status; ///< ClothStatus text, or why it was skipped
  double simulated_seconds = 0;  ///< s
  int simulation_steps = 0;
  /// The proxy of the simulation; its times are part of timings.simulation_ms (the clean-up
  /// after it, of penetration_ms).
  ClothProxyReport cloth_proxy;
  bool post_simulation_cleanup = false; ///< remove_penetration() ran again on the simulated mesh
  /// The simulated shape was discarded because clean-up could not bring it as far out of the
  /// body as penetration removal had (the pre-simulation mesh is returned).
  bool simulation_discarded = false;
  std::vector<std::string> warnings;
};

/// The report of fit_garments().
struct FitReport {
  std::vector<GarmentFitReport> garments; ///< in input order
  FitStageTimes timings;                  ///< summed over garments; total_ms = whole call
  double body_index_ms = 0;               ///< building the body's proximity and edge-crossing indices once
  /// Reading the layer order from the garments' geometry (LayerOrderRule::AUTO with several
  /// garments; the first body's report, 0 in the others').
  double layer_order_ms = 0;
  std::size_t body_vertices = 0, body_faces = 0;
  std::string backend;   ///< "serial" | "tbb"
  int threads = 0;       ///< TBB worker threads
  std::string cpu_model; ///< /proc/cpuinfo's "model name", or "unknown"
  /// The worst of the garments' size verdicts (falls off, tight, loose, good); GOOD with no garment.
  SizeVerdict verdict = SizeVerdict::GOOD;
};

/// A fitted garment, in metres, in the body's frame.
struct FittedGarment {
  std::string name;
  Mesh mesh;
  GarmentSegmentation segmentation; ///< of the input (positions in metres before the move)
  FitFeedback feedback;             ///< per-vertex strain and ease of the fitted mesh, regions, verdict
};

struct FitResult {
  std::vector<FittedGarment> garments; ///< in input order
  FitReport report;
};

/// The CPU's model name from /proc/cpuinfo, or "unknown".
std::string cpu_model_name();
} // namespace vfit
