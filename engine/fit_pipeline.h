#pragma once
/// \file
/// The fitting pipeline (seed 000 §4–6, DESIGN.md "Data flow of `vfit fit`"): body + garments →
/// fitted garments and a FitReport. Per garment: units → segmentation with type detection (§4)
/// → part skeletons (§5.1) → skeleton driving (§5.3–5.4; a slot, reported as skipped until the
/// stage lands) → coarse move (§6.1, eq. 16–17) → penetration removal against the body, its
/// vertices and its edges crossing the body (§6.2, eq. 18–21) → cloth simulation to rest with
/// body collision (§6.3; optional; a garment of more than FitOptions::cloth_proxy_above vertices
/// on a coarse proxy of it, rebuilt from the proxy and cleaned up: engine/cloth_proxy.h, seed
/// 004 §3). Several garments are layered (seed 001 §6.3, eq. 7;
/// engine/layering.h), inner to outer, each resolved against the body and the garments fitted
/// before it (a tee's hem ends outside the trousers' waistband). The order is read from the
/// garments' geometry as given where they overlap in one frame (engine/layer_order.h: a tee
/// under overalls' bib), bottoms before tops elsewhere (FitOptions::layer_order).

#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "engine/cloth/cloth_sim.h"
#include "engine/fit_feedback.h"
#include "engine/penetration.h"
#include "geometry/body/body.h"
#include "geometry/garment/coarse_move.h"
#include "geometry/garment/garment.h"
#include "geometry/garment/segment.h"
#include "geometry/garment/skeleton_driving.h"
#include "geometry/garment/skeleton_parts.h"
#include "geometry/mesh/mesh.h"
#include "geometry/mesh/units.h"
#include "geometry/mesh/up_axis.h"

namespace vfit {

/// One finished stage of one garment, as fit_garments() hands it to FitOptions::progress.
struct FitProgress {
  std::size_t garment = 0; ///< index of the garment in fit_garments()'s input
  std::string name;        ///< FitGarmentInput::name
  /// FitStageTimes::named()'s names: "units", "segmentation", "skeletons", "driving",
  /// "coarse_move", "penetration", "simulation", "feedback", then "total".
  std::string stage;
  /// The stage's wall time when it finished (ms). The report's penetration_ms can end up larger:
  /// the clean-up after simulation and the indexing of the garment as an inner layer come later.
  double ms = 0;
  std::string detail; ///< one short line: the detected type, "skipped: ...", the simulation's outcome, ...
};

/// How the order in which several garments are dressed (inner first) is decided.
enum class LayerOrderRule {
  /// From the garments' geometry as given where it tells (infer_layer_order(), layer_order.h):
  /// for garments of one outfit file, and for garments of several files whose files look like
  /// one frame (same up axis, overlapping, a top above a bottom); bottoms before tops, then the
  /// input order, for the rest. A garment whose place the geometry decided against bottoms-first
  /// says so in its warnings.
  AUTO,
  TYPE,  ///< bottoms (trousers, shorts, skirts) before tops, each group in input order
  GIVEN, ///< the input order, innermost first
};

/// Whether a garment's cloth simulation runs on a coarse proxy of it (engine/cloth_proxy.h;
/// seed 004 §3: the coarse garment simulated, the fine one reconstructed from it and its
/// penetration removed).
enum class ClothProxyMode {
  /// The proxy for garments of more than FitOptions::cloth_proxy_above vertices: there the
  /// full simulation's long CG solves cost minutes (catalogue tee of 10^5 vertices, 3 simulated
  /// s: 114–262 s on a loaded 2-core machine, against 22–27 s on a proxy of 15,000 whose
  /// result ended 6.1 mm from the full one on average, as clean of the body; trousers of 10^5,
  /// to rest: 123–401 against 16–35 s, 3.8 mm apart).
  AUTO,
  OFF, ///< every garment simulated at its own resolution
  ON,  ///< every garment simulated on its proxy (one of at most cloth_proxy_vertices is its own proxy)
};

/// Every option of the pipeline.
struct FitOptions {
  Backend backend = Backend::TBB;       ///< runs the cloth simulation
  bool simulate = true;                 ///< false: stop after penetration removal
  std::string fabric = "cotton_jersey"; ///< fabric_preset() name for the simulation
  double clearance = 0.003;             ///< κ (m): gap left to the body by removal and simulation
  /// Simulated time after which run_to_rest stops (s). 3: `vfit demo`'s garments on the posed
  /// mannequin come to rest after 1.97 (tee M) and 2.59 s (trousers P2), and a garment that
  /// never rests (one sliding off) costs at most 1.5 times the former limit of 2 s.
  double max_simulated_seconds = 3.0;
  double max_wall_seconds = 0;                       ///< also stop the simulation after this wall time (s); 0 = none
  ClothProxyMode cloth_proxy = ClothProxyMode::AUTO; ///< simulate on a coarse proxy (ClothProxyMode)
  /// ClothProxyMode::AUTO: garments of more vertices than this get the proxy. 25,000: the
  /// default proxy then keeps at least 60 % of the vertices. It was 50,000, which made a garment
  /// just below it the slowest to fit: a 49,278-vertex tee (the corpus tee subdivided) on
  /// hm08_body took 20.0 s at full resolution against 3.8 s on the proxy (stop 25, one run;
  /// its simulation 19.3 against 3.3 s, both at rest, verdict good either way, the two results
  /// 14 mm apart on average, 29 mm at the 95th percentile: different friction-held rests), and
  /// a 196,350-vertex one 5.7 s on the proxy.
  std::size_t cloth_proxy_above = 25000;
  /// The proxy's vertex count (build_cloth_proxy()'s target). 15,000: edges of about 7 mm on
  /// the catalogue tee (0.58 m² of cloth), below the scale of a fold on the body, while its
  /// simulation (to rest or 3 simulated s) took 15–54 s of wall time on a loaded 2-core machine.
  std::size_t cloth_proxy_vertices = 15000;
  /// The garments' length unit. Absent: detected per garment against the body it is fitted on
  /// (detect_garment_units(): the unit, inches included, in which the garment's box wraps the
  /// body's torso, torso_depth()), else from its size and position (detect_mesh_units()), with
  /// a warning naming the unit and --garment-units when it is not metres or the body decided it.
  /// fit_garments_onto_bodies() reads the garments once, against its first body.
  std::optional<Units> garment_units;
  /// The garments' up axis in their files (rotate_to_y_up() brings them into our frame). Absent:
  /// detected per garment, +Y or +Z, or upside down (-Y, -Z) when neither is recognised
  /// (segment_upright()), with a warning when it is not +Y.
  std::optional<UpAxis> garment_up;
  /// Where the garments' fronts face once upright (rotate_to_face_z() turns them to +Z).
  /// Absent: detected per garment (segment_upright(): a left–right axis along Z, a top stored
  /// back to front), with a warning when it is not +Z.
  std::optional<Facing> garment_facing;
  SegmentOptions segmentation;
  SkeletonDrivingOptions driving;
  /// Place each driven garment's torso by its contact with the body (SkeletonDriver::drive()
  /// with the body's surface: contact_translation(), and for bottoms the crotch and pocket
  /// search) after the key-joint placement of eq. 16–17. The key joints are estimates from the
  /// garment's cut: a shirt modelled on hm08_body itself was placed 61 mm in front of where it
  /// was modelled (its collar's back 49 mm inside the neck), a jacket 53 mm and a suit jacket
  /// 55 mm; by contact the shirt 1–3 mm (the jackets 10–13 mm: CorpusDriving). Measured with
  /// `vfit fit` (its own rig of hm08_body.obj) on the 63 corpus fits of arms_down, arms_raised
  /// and knee_bent (stop 26): edges torn (over twice their modelled length and by over 2 cm)
  /// 1,128 → 841, the worst 457 → 256 mm, edges through the body after the fit 12 → 0; driving
  /// 91 → 437 ms over the 63. Some fits tear more (the arms_raised tees' underarms, 2–12 →
  /// 18–37 edges; bottoms at the bent knee, 13 → 15), but none as far. false: eq. 16–17 alone.
  bool contact_placement = true;
  PartSkeletonOptions skeletons;
  int penetration_iterations = 25; ///< PenetrationOptions::max_iterations; 0: detection only (no direct rounds either)
  double smoothness = 1.0;         ///< PenetrationOptions::smoothness (λ2/λ1)
  /// k of seed 001 eq. 7 (m): the gap a garment keeps outside the garments fitted before it.
  double layer_clearance = 0.003;
  LayerOrderRule layer_order = LayerOrderRule::AUTO; ///< which garment is dressed over which
  /// Called on the calling thread after each stage of each garment, in pipeline order: for every
  /// garment "units" and "segmentation" (all garments are segmented first, in input order), then,
  /// in processing order (inner to outer, FitOptions::layer_order), "skeletons", "driving", "coarse_move",
  /// "penetration", "simulation" (also when skipped: detail "skipped"), "feedback" and "total" — nine calls per garment
  /// that is fitted. Empty: no calls. An exception it throws aborts the fit.
  std::function<void(const FitProgress&)> progress;
  /// Non-empty: a folder (created when absent) that receives the per-stage debug meshes of
  /// engine/fit_debug.h (FitDebugWriter). Nothing is written until every garment has been
  /// segmented (a mesh that is not a garment leaves no file); then each stage's files are
  /// written as it finishes (the writing counts in the garment's total_ms, in no stage's).
  /// Throws vfit::Error naming the folder or file that cannot be written. Empty: nothing is written.
  std::string debug_dir;
};

/// One garment handed to the pipeline.
struct FitGarmentInput {
  std::string name; ///< names it in the report and in output files (e.g. the file name)
  /// Any length unit; Y up facing +Z, or see FitOptions::garment_up. Vertices at bit-identical
  /// positions (pattern pieces' seams) are welded first (weld_coincident_vertices()), so the
  /// fitted mesh can have fewer vertices than this one (the report says so). An outfit (several
  /// garments in one mesh: after welding, two or more connected pieces with 20 % of the vertices
  /// or more each) is split into its garments, named "<name>#k" in the file's order of pieces by
  /// size (or "<name>:<group>" when one OBJ group holds 90 % of a piece), smaller pieces staying
  /// with the largest; each is reported and fitted as a garment of its own.
  Mesh mesh;
};

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

/// Fits `garments` onto `body` (a closed, outward-oriented mesh in metres with its joints).
/// Throws vfit::Error naming the garment when one is not a garment (segment_garment()'s
/// errors), when its units cannot be detected, or for an unknown fabric; the body is assumed
/// valid (load_body() checked it). A diverged simulation is not an error: it is reported and
/// the garment keeps its pre-simulation shape. Garments are dressed inner to outer
/// (FitOptions::layer_order: by default read from their geometry as given, else bottoms first),
/// each kept outside the ones before it: penetration removal pushes out its vertices inside them and its
/// triangles their edges pass through (engine/layer_piercing.h), and its simulation collides
/// with them as well as with the body. A file holding several garments (an outfit) is split
/// into them; a garment modelled with thickness (geometry/garment/thick_shell.h) is fitted by
/// its inner sheet and returned whole, with a warning.
FitResult fit_garments(const Body& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options = {});

/// Fits the same garments onto each of `bodies` (many bodies, one garment collection: sizes of a
/// design, a crowd, a shop's customers). Each garment is read, converted, segmented, and its
/// part skeletons extracted and its skeleton driver set up (the band Laplacian factored, seed
/// 000 §5.4) once, on the first body; every body then gets its own driving, penetration removal,
/// layering, simulation and feedback. Result k is what fit_garments(*bodies[k], garments,
/// options) returns, bit for bit (the shared stages do not depend on the body, but for a
/// garment unit left to detection, which is read against the first body's torso: bodies whose
/// torsos differ so much that the garment wraps one in another unit are fitted, as the first,
/// in the first's; state FitOptions::garment_units to be free of it); the shared
/// stages' times are reported with the first body, as 0 ms for the others (whose driving line
/// says "shared"), so the reports' totals add up to the whole call. At 10^5–10^6 garment
/// vertices the skeletons and the driver's setup are most of a fit without simulation, and each
/// further body costs only its driving and removal. Throws as fit_garments() does, before any
/// body is fitted, and vfit::Error for a null body or for debug output (FitOptions::debug_dir)
/// with more than one body. No bodies: no results.
std::vector<FitResult> fit_garments_onto_bodies(std::span<const Body* const> bodies,
                                                const std::vector<FitGarmentInput>& garments,
                                                const FitOptions& options = {});

/// The CPU's model name from /proc/cpuinfo, or "unknown".
std::string cpu_model_name();

} // namespace vfit
