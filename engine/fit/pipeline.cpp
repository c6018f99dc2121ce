// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

#include "vfit/engine/cloth/cloth_proxy.h"
#include "vfit/engine/cloth/cloth_sim.h"
#include "vfit/engine/cloth/fabric.h"
#include "vfit/engine/dress/dresser.h"
#include "vfit/engine/fit/dressing_order.h"
#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/engine/fit/prepare.h"
#include "vfit/engine/fit/trim.h"
#include "vfit/geometry/body/measurements.h"
#include "vfit/geometry/garment/coarse_move.h"
#include "vfit/geometry/garment/skeleton_driving.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

using namespace fitting;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Layer points farther than this (m) from a vertex are not its inner layer (LayerObstacle::reach).
constexpr double LAYER_REACH = 0.05;

// Where one garment's stages report: the progress callback and, once every garment is
// segmented, the observer's snapshots.
struct StageSink {
  const FitOptions& options;
  std::size_t garment; // index among the garments fitted
  bool snapshots = false;

  void done(const std::string& name, const char* stage, double ms, std::string detail = {}) const {
    if (options.progress) options.progress({garment, name, stage, ms, std::move(detail)});
  }
  void snapshot(int number, const char* stage, const FittedGarment& g, const std::string& note) const {
    if (snapshots) options.observer->garment(garment, g.name, number, stage, g.mesh, g.segmentation.vertex_parts, note);
  }
};

std::string penetration_note(const PenetrationStats& before, const PenetrationStats& after) {
  char line[160];
  std::snprintf(line, sizeof line, "inside %zu -> %zu (max %.2f -> %.2f mm), crossing edges %zu -> %zu",
                before.inside_count, after.inside_count, before.max_depth * 1e3, after.max_depth * 1e3,
                before.crossing_edges, after.crossing_edges);
  return line;
}

// Penetration removal and its clean-up policy as the fit's options ask for them.
DressOptions dress_options(const FitOptions& options) {
  DressOptions d;
  d.removal.clearance = options.clearance;
  d.removal.smoothness = options.smoothness;
  d.removal.max_iterations = options.penetration_iterations;
  if (options.penetration_iterations == 0) d.removal.direct_rounds = 0; // detection only
  d.clearance = options.clearance;
  return d;
}

// A warning when the fitted garment still offends the body or its inner layers (vertices
// inside, edges through), or "" when it does not. Removal leaves an edge crossing where clearing
// it would tear the cloth (its direct rounds' pushes are limited: a tee's front between forearms
// folded onto the belly keeps edges through the forearms) or when its rounds run out, and a
// caller looking only at the verdict would not know. `removed`: removal ran.
std::string penetration_left_warning(const PenetrationStats& after, bool removed) {
  if (after.inside_count == 0 && after.crossing_edges == 0 && after.layer_inside_count == 0 &&
      after.layer_crossing_edges == 0)
    return "";
  char line[400];
  std::snprintf(line, sizeof line,
                "after the fit %zu vertices are inside the body (up to %.1f mm) and %zu edges pass through it; %zu "
                "vertices are inside the garments under it and %zu of their edges through it%s",
                after.inside_count, 1e3 * after.max_depth, after.crossing_edges, after.layer_inside_count,
                after.layer_crossing_edges,
                removed ? ": removal could not clear them without tearing the cloth or ran out of rounds (check the "
                          "fit where the body's limbs press on it)"
                        : " (penetration removal was off)");
  return line;
}

// What driving a garment needs whatever the body (seed 000 §5.1–5.4): its part skeletons and the
// driver set up on them (the band's Laplacian factored once), or why it has none. Built on the
// first body a garment is fitted to and reused for the others.
struct LimbRig {
  std::vector<PartSkeleton> skeletons;
  std::optional<SkeletonDriver> driver;
  std::string skipped;     // "skipped: …" when there is no driver
  std::string warning;     // the skeletons' failure, reported with every body
  double skeletons_ms = 0; // extraction
  double setup_ms = 0;     // the driver's construction (wall, as driving_ms counts it)
};

// One garment on one body, from the skeletons on: what the stages hand each other.
struct GarmentState {
  FittedGarment& out;
  GarmentFitReport& report;
  const StageSink& sink;
  const LimbRig& rig;
  bool rig_is_new;                      // built for this body, whose report carries its time
  std::vector<float> as_modelled;       // positions before driving: rest lengths for the feedback
  std::vector<float> before_simulation; // empty: not simulated, diverged, or discarded
  bool driven = false;
};

// ---------------------------------------------------------------------------------------------
// The stages, in pipeline order.

// prepare: metres, welded, wound consistently, the inner sheet of a thick garment.
void prepare(const FitGarmentInput& input, const FitOptions& options, double body_torso_depth, const StageSink& sink,
             FittedGarment& out, GarmentFitReport& report, std::optional<ShellGarment>& shell, Mesh* as_given) {
  const auto t0 = Clock::now();
  prepare_garment(input, options, body_torso_depth, out, report, shell, as_given);
  report.timings.units_ms = ms_since(t0);
  sink.done(input.name, "units", report.timings.units_ms, units_name(report.units));
}

// segment: upright, facing +Z, type and part labels (seed 000 §4).
void segment(const FitOptions& options, const StageSink& sink, FittedGarment& out, GarmentFitReport& report) {
  const auto t0 = Clock::now();
  segment_upright_garment(options, out, report);
  report.timings.segmentation_ms = ms_since(t0);
  sink.done(out.name, "segmentation", report.timings.segmentation_ms,
            garment_type_name(report.type) +
                (report.up == UpAxis::POS_Y ? "" : " (" + up_axis_name(report.up) + " up)"));
}

// skeletons: the limbs' skeletons (seed 000 §5.1) and the driver set up on them.
LimbRig skeletons(const FitOptions& options, const StageSink& sink, const FittedGarment& out) {
  LimbRig rig;
  auto t0 = Clock::now();
  try {
    rig.skeletons = extract_limb_skeletons(out.mesh, out.segmentation.vertex_parts, options.skeletons);
  } catch (const Error& e) {
    // The coarse move has a fallback without skeletons; a part that cannot be skeletonised
    // costs the garment its driving, not its fit.
    rig.warning = std::string("part skeletons failed: ") + e.what();
  }
  rig.skeletons_ms = ms_since(t0);
  sink.done(out.name, "skeletons", rig.skeletons_ms, std::to_string(rig.skeletons.size()) + " limb skeletons");
  if (sink.snapshots)
    options.observer->skeletons(sink.garment, out.name, 2, out.mesh, out.segmentation.vertex_parts, rig.skeletons);
  t0 = Clock::now();
  if (!rig.skeletons.empty()) {
    try {
      rig.driver.emplace(out.mesh, out.segmentation, rig.skeletons, options.driving);
    } catch (const Error& e) {
      rig.skipped = std::string("skipped: ") + e.what();
    }
  } else {
    rig.skipped = "skipped: no limb skeletons";
  }
  rig.setup_ms = ms_since(t0);
  return rig;
}

// drive: orientation, limbs onto the body's bones, Laplacian continuity (seed 000 §5.2–5.4),
// with the translation of eq. 16–17 and the torso's contact placement. Garments it cannot drive
// (skirts, dresses, sleeveless tops: no key joints) keep their own pose for place().
void drive(GarmentState& g, const Body& body, const ProximityIndex& body_index, const FitOptions& options) {
  const auto t0 = Clock::now();
  g.as_modelled = g.out.mesh.positions;
  if (g.rig.driver) {
    try {
      const SkeletonDriving d = g.rig.driver->drive(body.joints, options.contact_placement ? &body_index : nullptr);
      g.out.mesh.positions = d.positions;
      g.driven = true;
      char line[200];
      std::snprintf(line, sizeof line,
                    "driven: %zu limbs (orientation %.1f, factorisation %.1f beside it, driving %.1f, Laplacian %.1f, "
                    "setup %.1f ms%s)",
                    d.limbs.size(), d.timings.orientation_ms, d.timings.factorisation_ms, d.timings.driving_ms,
                    d.timings.laplacian_ms, g.rig.driver->setup_ms(), g.rig_is_new ? "" : ", shared");
      g.report.driving = line;
    } catch (const Error& e) {
      g.report.driving = std::string("skipped: ") + e.what();
    }
  } else {
    g.report.driving = g.rig.skipped;
  }
  g.report.timings.driving_ms = ms_since(t0) + (g.rig_is_new ? g.rig.setup_ms : 0.0);
  g.sink.done(g.out.name, "driving", g.report.timings.driving_ms, g.report.driving);
  g.sink.snapshot(3, "driving", g.out, g.report.driving);
}

// place: the coarse move of eq. 16–17 (seed 000 §6.1) for a garment that was not driven.
void place(GarmentState& g, const Body& body) {
  const auto t0 = Clock::now();
  if (g.driven) {
    g.report.coarse_move.rule = CoarseMoveRule::IN_DRIVING;
  } else {
    g.report.coarse_move =
        compute_coarse_move(g.report.type, g.out.segmentation.key_points, g.rig.skeletons, body.joints);
    translate_positions(g.out.mesh.positions, g.report.coarse_move.translation);
  }
  g.report.timings.coarse_move_ms = ms_since(t0);
  const Eigen::Vector3d& moved = g.report.coarse_move.translation;
  const std::string note = to_string(g.report.coarse_move.rule) + ", translation (" + std::to_string(moved.x()) + ", " +
                           std::to_string(moved.y()) + ", " + std::to_string(moved.z()) + ") m";
  g.sink.done(g.out.name, "coarse_move", g.report.timings.coarse_move_ms, note);
  g.sink.snapshot(4, "coarse_move", g.out, note);
}

// dress: penetration removal against the body and the inner garments (seed 000 §6.2; seed 001
// eq. 7), once before the simulation.
void dress(GarmentState& g, const Dresser& dresser, std::size_t inner_layers) {
  const auto t0 = Clock::now();
  g.report.inner_layers = inner_layers;
  const PenetrationReport removal = dresser.remove(g.out.mesh);
  g.report.timings.penetration_ms = ms_since(t0);
  g.report.before = removal.before;
  g.report.after_removal = removal.after;
  g.report.penetration_iterations = removal.iterations;
  const std::string note = penetration_note(removal.before, removal.after);
  g.sink.done(g.out.name, "penetration", g.report.timings.penetration_ms, note);
  g.sink.snapshot(5, "penetration", g.out, note);
}

// The cloth to rest (seed 000 §6.3), on a coarse proxy for a large garment (seed 004 §3),
// colliding with the body and the inner garments; trim pieces pinned and carried.
void run_cloth(GarmentState& g, const DressingBody& body, const FitOptions& options) {
  GarmentFitReport& report = g.report;
  Mesh& mesh = g.out.mesh;
  ClothOptions co;
  co.fabrics = {fabric_preset(options.fabric)};
  co.backend = options.backend;
  co.contact_thickness = static_cast<float>(options.clearance);
  const TrimPieces trim = trim_pieces(mesh);
  const bool use_proxy = options.cloth_proxy == ClothProxyMode::ON || (options.cloth_proxy == ClothProxyMode::AUTO &&
                                                                       mesh.vertex_count() > options.cloth_proxy_above);
  std::optional<ClothProxy> proxy;
  if (use_proxy) {
    // The proxy stands for the largest piece; the trim stays out of it and follows that piece
    // afterwards (carry_trim), as it does when pinned in the full simulation.
    const auto tp = Clock::now();
    proxy.emplace(build_cloth_proxy(mesh.positions, trim.vertices.empty() ? mesh.triangles : trim.main_triangles,
                                    options.cloth_proxy_vertices));
    report.cloth_proxy.used = true;
    report.cloth_proxy.vertices = proxy->vertex_count();
    report.cloth_proxy.triangles = proxy->triangles.size() / 3;
    report.cloth_proxy.build_ms = ms_since(tp);
  }
  const auto ts = Clock::now();
  ClothSim sim(proxy ? std::span<const float>(proxy->positions) : std::span<const float>(mesh.positions),
               proxy ? std::span<const std::int32_t>(proxy->triangles) : std::span<const std::int32_t>(mesh.triangles),
               co);
  if (!proxy && !trim.vertices.empty()) sim.pin(trim.vertices);
  if (body.layers().empty()) {
    sim.set_body(body.mesh().positions, body.mesh().triangles);
  } else {
    std::vector<float> positions;
    std::vector<std::int32_t> triangles;
    body.collision_surface(positions, triangles);
    sim.set_body(positions, triangles);
  }
  ClothRestOptions ro;
  ro.max_simulated_seconds = options.max_simulated_seconds;
  ro.max_wall_seconds = options.max_wall_seconds;
  const ClothRestReport rest = sim.run_to_rest(ro);
  if (proxy) report.cloth_proxy.simulation_ms = ms_since(ts);
  report.simulation_status = to_string(rest.status);
  report.simulated_seconds = rest.simulated_seconds;
  report.simulation_steps = rest.steps;
  if (rest.status != ClothStatus::OK) {
    report.simulation = SimulationOutcome::DIVERGED;
    report.warnings.push_back(std::string("simulation ") + to_string(rest.status) +
                              ": its result is discarded, the mesh after penetration removal is kept");
    return;
  }
  report.simulation = rest.converged ? SimulationOutcome::CONVERGED : SimulationOutcome::TIME_LIMIT;
  g.before_simulation = mesh.positions;
  const auto p = sim.positions();
  const auto tr = Clock::now();
  if (proxy)
    reconstruct_from_proxy(*proxy, p, mesh.positions);
  else
    std::copy(p.begin(), p.end(), mesh.positions.begin());
  carry_trim(trim, g.before_simulation, mesh.positions);
  if (proxy) report.cloth_proxy.reconstruct_ms = ms_since(tr);
}

// simulate: the cloth (run_cloth()), then the clean-up policy after it (Dresser::
// after_simulation(): removal again where the simulation left the garment in the body or an
// inner garment, the simulated shape discarded when that fails).
void simulate(GarmentState& g, const DressingBody& body, const Dresser& dresser, const FitOptions& options) {
  GarmentFitReport& report = g.report;
  if (!options.simulate) {
    report.simulation = SimulationOutcome::SKIPPED;
    report.simulation_status = "skipped (--no-simulation)";
  } else {
    const auto t0 = Clock::now();
    run_cloth(g, body, options);
    report.timings.simulation_ms = ms_since(t0);
  }
  const auto t0 = Clock::now();
  const SettledReport settled = dresser.after_simulation(g.out.mesh, g.before_simulation, report.after_removal);
  if (!g.before_simulation.empty()) {
    report.after_simulation = settled.simulated;
    report.post_simulation_cleanup = settled.cleaned;
    if (settled.discarded) {
      g.before_simulation.clear();
      report.simulation_discarded = true;
      report.warnings.push_back(settled.warning);
    }
    report.timings.penetration_ms += ms_since(t0);
  }
  report.after = settled.after;
  if (std::string left = penetration_left_warning(report.after, options.penetration_iterations > 0); !left.empty())
    report.warnings.push_back(left);
  if (options.simulate) {
    const std::string note =
        report.simulation_status + (report.simulation_discarded ? ", discarded" : "") +
        (report.cloth_proxy.used ? ", on a proxy of " + std::to_string(report.cloth_proxy.vertices) + " vertices"
                                 : std::string()) +
        "; " + penetration_note(report.after_removal, report.after);
    g.sink.done(g.out.name, "simulation", report.timings.simulation_ms, note);
    g.sink.snapshot(6, "simulation", g.out, note);
  } else {
    g.sink.done(g.out.name, "simulation", 0, "skipped");
  }
}

// feedback: strain against the garment as modelled, ease against the body, the size verdict.
void feedback(GarmentState& g, const Body& body, const ProximityIndex& body_index) {
  const auto t0 = Clock::now();
  Mesh rest = g.out.mesh;
  rest.positions = g.as_modelled;
  g.out.feedback = fit_feedback(rest, g.out.mesh, g.out.segmentation.vertex_parts, g.report.type, body, body_index,
                                g.before_simulation);
  g.report.verdict = g.out.feedback.verdict;
  g.report.verdict_reason = g.out.feedback.reason;
  g.report.regions = g.out.feedback.regions;
  if (std::string torn = torn_cloth_warning(g.out.mesh, g.as_modelled); !torn.empty())
    g.report.warnings.push_back(torn);
  g.report.timings.feedback_ms = ms_since(t0);
  g.sink.done(g.out.name, "feedback", g.report.timings.feedback_ms, size_verdict_name(g.report.verdict));
}

// One segmented garment on one body: drive → place → dress → simulate → feedback.
void fit_garment(const DressingBody& body, const Body& posed, const FitOptions& options, const StageSink& sink,
                 const LimbRig& rig, bool rig_is_new, FittedGarment& out, GarmentFitReport& report) {
  const auto t0 = Clock::now();
  GarmentState g{out, report, sink, rig, rig_is_new, {}, {}, false};
  if (!rig.warning.empty()) report.warnings.push_back(rig.warning);
  report.timings.skeletons_ms = rig_is_new ? rig.skeletons_ms : 0.0;
  report.skeleton_parts = rig.skeletons.size();
  if (!rig_is_new)
    sink.done(out.name, "skeletons", 0.0, std::to_string(rig.skeletons.size()) + " limb skeletons, shared");

  drive(g, posed, body.index(), options);
  place(g, posed);
  const Dresser dresser(body, out.mesh, dress_options(options));
  dress(g, dresser, body.layers().size());
  simulate(g, body, dresser, options);
  feedback(g, posed, body.index());

  report.timings.total_ms = report.timings.units_ms + report.timings.segmentation_ms + ms_since(t0) +
                            (rig_is_new ? rig.skeletons_ms + rig.setup_ms : 0.0);
}

} // namespace

std::vector<FitResult> fit_garments_onto_bodies(std::span<const Body* const> bodies,
                                                const std::vector<FitGarmentInput>& inputs, const FitOptions& options) {
  const auto t_total = Clock::now();
  for (std::size_t b = 0; b < bodies.size(); ++b)
    if (!bodies[b]) throw Error("body " + std::to_string(b), 0, "null body");
  if (bodies.size() > 1 && options.observer)
    throw Error("fit observer", 0, "snapshots take one body, not " + std::to_string(bodies.size()));
  // read: the garments as given. prepare and segment run once for all the bodies: units are
  // detected against the first.
  const double body_torso_depth = bodies.empty() ? 0.0 : torso_depth(bodies[0]->mesh, bodies[0]->joints);
  const SplitInputs split = split_outfits(inputs, options, body_torso_depth);
  const std::vector<FitGarmentInput>& garments = split.garments;
  (void)fabric_preset(options.fabric); // unknown fabric: fail before any work, simulated or not
  std::vector<FitResult> results(bodies.size());
  if (bodies.empty()) return results;

  std::vector<StageSink> sinks;
  for (std::size_t i = 0; i < garments.size(); ++i)
    sinks.push_back({options, i});
  // The type is known after segmentation, so every garment is prepared and segmented first
  // (once, whatever the bodies), then dressed in dressing order.
  std::vector<FittedGarment> segmented(garments.size());
  std::vector<std::optional<ShellGarment>> shells(garments.size());
  std::vector<GarmentFitReport> segmented_reports(garments.size());
  // The garments as given, for reading their layer order from their geometry.
  const bool by_geometry = options.layer_order == LayerOrderRule::AUTO && garments.size() > 1;
  std::vector<Mesh> as_given(by_geometry ? garments.size() : 0);
  for (std::size_t i = 0; i < garments.size(); ++i) {
    FittedGarment& out = segmented[i];
    GarmentFitReport& report = segmented_reports[i];
    report.name = out.name = garments[i].name;
    prepare(garments[i], options, body_torso_depth, sinks[i], out, report, shells[i],
            by_geometry ? &as_given[i] : nullptr);
    segment(options, sinks[i], out, report);
    if (!split.notes[i].empty()) report.warnings.insert(report.warnings.begin(), split.notes[i]);
  }
  // Snapshots start once every garment is known to be one, so a mesh that is not a garment
  // leaves none behind.
  if (options.observer) {
    std::vector<std::string> names;
    for (const FitGarmentInput& g : garments)
      names.push_back(g.name);
    options.observer->start(bodies[0]->mesh, names);
    for (std::size_t i = 0; i < garments.size(); ++i) {
      sinks[i].snapshots = true;
      const GarmentFitReport& r = segmented_reports[i];
      sinks[i].snapshot(1, "segmentation", segmented[i],
                        "type " + garment_type_name(r.type) + ", units " + units_name(r.units));
    }
  }
  const auto t_order = Clock::now();
  const std::vector<std::size_t> order = dressing_order(options, split, as_given, segmented_reports);
  const double layer_order_ms = ms_since(t_order);
  std::vector<std::optional<LimbRig>> rigs(garments.size());
  const DressOptions shell_dress = dress_options(options);

  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const auto t_body = Clock::now();
    const Body& posed = *bodies[b];
    FitResult& result = results[b];
    FitReport& report = result.report;
    report.backend = options.backend == Backend::SERIAL ? "serial" : "tbb";
    report.threads = parallel_thread_count();
    report.cpu_model = cpu_model_name();
    report.body_vertices = posed.mesh.vertex_count();
    report.body_faces = posed.mesh.face_count();
    auto t0 = Clock::now();
    DressingBody body(posed.mesh, options.layer_clearance, LAYER_REACH);
    report.body_index_ms = ms_since(t0);
    report.layer_order_ms = b == 0 ? layer_order_ms : 0;

    // Each body starts from the garments as segmented; preparing and segmenting them is the
    // first body's time, shared by the others (their reports say 0 ms for those stages).
    result.garments = segmented;
    report.garments = segmented_reports;
    if (b > 0)
      for (GarmentFitReport& gr : report.garments)
        gr.timings.units_ms = gr.timings.segmentation_ms = 0;
    for (std::size_t k = 0; k < order.size(); ++k) {
      const std::size_t i = order[k];
      FittedGarment& g = result.garments[i];
      GarmentFitReport& gr = report.garments[i];
      gr.order = k;
      const bool rig_is_new = !rigs[i];
      if (rig_is_new) rigs[i] = skeletons(options, sinks[i], segmented[i]);
      fit_garment(body, posed, options, sinks[i], *rigs[i], rig_is_new, g, gr);
      if (shells[i]) {
        t0 = Clock::now();
        restore_shell(*shells[i], body, shell_dress, g, gr);
        const double ms = ms_since(t0);
        gr.timings.penetration_ms += ms;
        gr.timings.total_ms += ms;
      }
      // Layering (seed 001 §6.3): the garments after this one are kept outside of it.
      if (k + 1 < order.size()) {
        t0 = Clock::now();
        body.add_layer(g.mesh);
        const double layer_ms = ms_since(t0);
        gr.timings.penetration_ms += layer_ms;
        gr.timings.total_ms += layer_ms;
      }
      sinks[i].done(g.name, "total", gr.timings.total_ms, penetration_note(gr.before, gr.after));
    }

    for (const GarmentFitReport& g : report.garments) {
      report.timings.units_ms += g.timings.units_ms;
      report.timings.segmentation_ms += g.timings.segmentation_ms;
      report.timings.skeletons_ms += g.timings.skeletons_ms;
      report.timings.driving_ms += g.timings.driving_ms;
      report.timings.coarse_move_ms += g.timings.coarse_move_ms;
      report.timings.penetration_ms += g.timings.penetration_ms;
      report.timings.simulation_ms += g.timings.simulation_ms;
      report.timings.feedback_ms += g.timings.feedback_ms;
      report.verdict = std::min(report.verdict, g.verdict); // FALLS_OFF < TIGHT < LOOSE < GOOD
    }
    report.timings.total_ms = ms_since(b == 0 ? t_total : t_body);
  }
  return results;
}

FitResult fit_garments(const Body& body, const std::vector<FitGarmentInput>& inputs, const FitOptions& options) {
  const Body* bodies[] = {&body};
  return std::move(fit_garments_onto_bodies(bodies, inputs, options).front());
}

} // namespace vfit
