// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// What a fit is asked to do (engine/fit/pipeline.h): the options of every stage, the garments
/// handed in, and the two ways a fit reports as it goes — a progress line per finished stage
/// (FitOptions::progress) and per-stage snapshots of the garment (FitObserver), which tools/
/// writes as debug meshes.

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/garment/skeleton_driving.h"
#include "vfit/geometry/garment/skeleton_parts.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/geometry/mesh/up_axis.h"
#include "vfit/kernels/backend.h"

namespace vfit {

/// Per-stage snapshots of a fit, for debugging: a garment as each stage left it. Called on the
/// calling thread in pipeline order. The default implementations do nothing.
class FitObserver {
public:
  virtual ~FitObserver() = default;
  /// First call, once every garment is segmented: the body the garments are fitted onto and the
  /// garments' names (index = the `garment` of the calls that follow; an outfit file gives one
  /// name per garment in it).
  virtual void start(const Mesh& body, std::span<const std::string> garment_names) { (void)body, (void)garment_names; }
  /// Garment `garment` (its index among the garments fitted: an outfit file counts one per
  /// garment in it; `name` names it) after stage `number` ("segmentation" 1, "driving" 3,
  /// "coarse_move" 4, "penetration" 5, "simulation" 6): `mesh` in metres, `vertex_parts` its
  /// segmentation labels (#V), `note` the stage's one-line outcome.
  virtual void garment(std::size_t garment, const std::string& name, int number, const std::string& stage,
                       const Mesh& mesh, std::span<const GarmentPart> vertex_parts, const std::string& note) {
    (void)garment, (void)name, (void)number, (void)stage, (void)mesh, (void)vertex_parts, (void)note;
  }
  /// The garment's limb skeletons (stage 2, "skeletons"), node positions in `mesh`'s frame (m).
  virtual void skeletons(std::size_t garment, const std::string& name, int number, const Mesh& mesh,
                         std::span<const GarmentPart> vertex_parts, std::span<const PartSkeleton> skeletons) {
    (void)garment, (void)name, (void)number, (void)mesh, (void)vertex_parts, (void)skeletons;
  }
};

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
  /// The proxy for garments of more than FitOptions::cloth_proxy_above vertices, where the
  /// full simulation's long CG solves cost minutes (docs/benchmarks.md).
  AUTO,
  OFF, ///< every garment simulated at its own resolution
  ON,  ///< every garment simulated on its proxy (one of at most cloth_proxy_vertices is its own proxy)
};

/// Every option of the pipeline.
struct FitOptions {
  Backend backend = Backend::TBB;       ///< runs the cloth simulation (SERIAL or TBB)
  bool simulate = true;                 ///< false: stop after penetration removal
  std::string fabric = "cotton_jersey"; ///< fabric_preset() name for the simulation
  double clearance = 0.003;             ///< κ (m): gap left to the body by removal and simulation
  /// Simulated time after which run_to_rest stops (s). 3: `vfit demo`'s garments on the posed
  /// mannequin come to rest within it, and a garment that never rests (one sliding off) is
  /// stopped there.
  double max_simulated_seconds = 3.0;
  double max_wall_seconds = 0;                       ///< also stop the simulation after this wall time (s); 0 = none
  ClothProxyMode cloth_proxy = ClothProxyMode::AUTO; ///< simulate on a coarse proxy (ClothProxyMode)
  /// ClothProxyMode::AUTO: garments of more vertices than this get the proxy. 25,000: the
  /// default proxy then keeps at least 60 % of the vertices, and a garment just above it fits
  /// several times faster on the proxy than at full resolution (docs/benchmarks.md).
  std::size_t cloth_proxy_above = 25000;
  /// The proxy's vertex count (build_cloth_proxy()'s target). 15,000: edges of about 7 mm on
  /// the catalogue tee (0.58 m² of cloth), below the scale of a fold on the body.
  std::size_t cloth_proxy_vertices = 15000;
  /// The garments' length unit. Absent: detected per garment against the body it is fitted on
  /// (detect_garment_units(): the unit, inches included, in which the garment's box wraps the
  /// body's torso, torso_depth()), else from its size and position (detect_mesh_units()), with
  /// a warning naming the unit and --garment-units when it is not metres or the body decided it.
  /// fit_garments_onto_bodies() reads the garments once, against its first body.
  std::optional<Units> garment_units;
  /// Metres per unit of the garments' files, for an exporter's scale that is no length unit
  /// (e.g. 0.0127: half-inch units). Overrides detection; not with garment_units.
  std::optional<double> garment_scale;
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
  /// garment's cut: a shirt modelled on the corpus body itself was placed several centimetres
  /// in front of where it was modelled, and by contact within a few millimetres of it
  /// (CorpusDriving; docs/benchmarks.md has the corpus study). false: eq. 16–17 alone.
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
  /// Receives each garment's per-stage snapshots (FitObserver), on the calling thread, once
  /// every garment has been segmented (a mesh that is not a garment leaves no snapshot); the
  /// time the observer takes counts in the garment's total_ms, in no stage's. Not owned; null:
  /// no snapshots. An exception it throws aborts the fit.
  FitObserver* observer = nullptr;
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

} // namespace vfit
