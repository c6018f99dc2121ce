// SPDX-License-Identifier: Apache-2.0
#include "fit_report_json.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/geometry/garment/coarse_move.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/geometry/mesh/up_axis.h"
#include "vfit/kernels/version.h"

namespace vfit {
namespace {

nlohmann::ordered_json stats_json(const PenetrationStats& s) {
  return {{"inside_count", s.inside_count},
          {"max_depth_mm", s.max_depth * 1e3},
          {"mean_depth_mm", s.mean_depth * 1e3},
          {"near_count", s.near_count},
          {"crossing_edges", s.crossing_edges},
          {"layer_inside_count", s.layer_inside_count},
          {"layer_max_depth_mm", s.layer_max_depth * 1e3},
          {"layer_crossing_edges", s.layer_crossing_edges}};
}

// Over all garments: counts add up, the deepest vertex is the deepest of any garment.
PenetrationStats combined(const FitReport& report, PenetrationStats GarmentFitReport::*which) {
  PenetrationStats total;
  double depth_sum = 0;
  for (const GarmentFitReport& g : report.garments) {
    const PenetrationStats& s = g.*which;
    total.inside_count += s.inside_count;
    total.near_count += s.near_count;
    total.crossing_edges += s.crossing_edges;
    total.layer_inside_count += s.layer_inside_count;
    total.layer_crossing_edges += s.layer_crossing_edges;
    total.max_depth = std::max(total.max_depth, s.max_depth);
    total.layer_max_depth = std::max(total.layer_max_depth, s.layer_max_depth);
    depth_sum += s.mean_depth * static_cast<double>(s.inside_count);
  }
  if (total.inside_count > 0) total.mean_depth = depth_sum / static_cast<double>(total.inside_count);
  return total;
}

nlohmann::ordered_json timings_json(const FitStageTimes& t) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  for (const auto& [stage, ms] : t.named())
    j[stage] = ms;
  return j;
}

} // namespace

FitReportContext fit_report_context(const Body& body, const LoadedBody& loaded) {
  FitReportContext context;
  context.body_source = body.source;
  context.body_kind = loaded.kind;
  context.body_warnings = loaded.warnings;
  return context;
}

std::string fit_report_json(const FitReport& report, const FitOptions& options, const FitReportContext& context) {
  nlohmann::ordered_json j;
  j["vfit"] = {{"version", version()}, {"commit", git_commit()}};
  nlohmann::ordered_json timings = timings_json(report.timings);
  timings["body"] = context.body_ms;
  timings["body_index"] = report.body_index_ms;
  if (report.garments.size() > 1) timings["layer_order"] = report.layer_order_ms;
  if (context.render_ms >= 0) timings["render"] = context.render_ms;
  j["timings_ms"] = timings;
  j["penetration"] = {{"before", stats_json(combined(report, &GarmentFitReport::before))},
                      {"after", stats_json(combined(report, &GarmentFitReport::after))}};
  j["verdict"] = size_verdict_name(report.verdict);
  j["machine"] = {{"cpu_model", report.cpu_model}, {"threads", report.threads}, {"backend", report.backend}};
  j["body"] = {{"source", context.body_source},
               {"kind", context.body_kind},
               {"vertices", report.body_vertices},
               {"faces", report.body_faces},
               {"warnings", context.body_warnings}};
  j["options"] = {{"simulate", options.simulate},
                  {"fabric", options.fabric},
                  {"clearance_m", options.clearance},
                  {"layer_clearance_m", options.layer_clearance},
                  {"max_simulated_seconds", options.max_simulated_seconds},
                  {"cloth_proxy", options.cloth_proxy == ClothProxyMode::ON    ? "on"
                                  : options.cloth_proxy == ClothProxyMode::OFF ? "off"
                                                                               : "auto"},
                  {"cloth_proxy_above", options.cloth_proxy_above},
                  {"cloth_proxy_vertices", options.cloth_proxy_vertices}};
  j["garments"] = nlohmann::ordered_json::array();
  for (const GarmentFitReport& g : report.garments) {
    nlohmann::ordered_json gj;
    gj["name"] = g.name;
    gj["type"] = garment_type_name(g.type);
    gj["vertices"] = g.vertices;
    gj["faces"] = g.faces;
    gj["units"] = units_name(g.units);
    gj["up_axis"] = up_axis_name(g.up);
    gj["facing"] = facing_name(g.facing);
    gj["order"] = g.order;
    gj["inner_layers"] = g.inner_layers;
    gj["timings_ms"] = timings_json(g.timings);
    gj["skeleton_parts"] = g.skeleton_parts;
    gj["driving"] = g.driving;
    const Eigen::Vector3d& t = g.coarse_move.translation;
    gj["coarse_move"] = {{"rule", to_string(g.coarse_move.rule)}, {"translation_m", {t.x(), t.y(), t.z()}}};
    gj["penetration"] = {{"before", stats_json(g.before)}, {"after_removal", stats_json(g.after_removal)}};
    if (g.simulation != SimulationOutcome::SKIPPED && g.simulation != SimulationOutcome::DIVERGED)
      gj["penetration"]["after_simulation"] = stats_json(g.after_simulation);
    gj["penetration"]["after"] = stats_json(g.after);
    gj["penetration"]["iterations"] = g.penetration_iterations;
    const ClothProxyReport& cp = g.cloth_proxy;
    gj["cloth_proxy"] = {
        {"used", cp.used},
        {"vertices", cp.vertices},
        {"triangles", cp.triangles},
        {"timings_ms", {{"build", cp.build_ms}, {"simulation", cp.simulation_ms}, {"reconstruct", cp.reconstruct_ms}}}};
    gj["simulation"] = {{"outcome", to_string(g.simulation)},
                        {"status", g.simulation_status},
                        {"simulated_seconds", g.simulated_seconds},
                        {"steps", g.simulation_steps},
                        {"post_simulation_cleanup", g.post_simulation_cleanup},
                        {"discarded", g.simulation_discarded}};
    gj["verdict"] = size_verdict_name(g.verdict);
    gj["verdict_reason"] = g.verdict_reason;
    gj["regions"] = nlohmann::ordered_json::array();
    for (const RegionFeedback& r : g.regions) {
      nlohmann::ordered_json rj = {{"name", r.name},
                                   {"vertices", r.vertices},
                                   {"mean_strain", r.mean_strain},
                                   {"max_strain", r.max_strain},
                                   {"mean_ease_mm", r.mean_ease_mm},
                                   {"min_ease_mm", r.min_ease_mm},
                                   {"verdict", size_verdict_name(r.verdict)}};
      rj["girth_ease_m"] =
          std::isfinite(r.girth_ease) ? nlohmann::ordered_json(r.girth_ease) : nlohmann::ordered_json();
      if (r.girth_ease_estimated) rj["girth_ease_estimated"] = true;
      gj["regions"].push_back(rj);
    }
    std::vector<std::string> warnings;
    for (const auto& [file, notes] : context.read_warnings)
      if (g.name == file || g.name.starts_with(file + "#")) warnings = notes;
    warnings.insert(warnings.end(), g.warnings.begin(), g.warnings.end());
    gj["warnings"] = warnings;
    j["garments"].push_back(gj);
  }
  return j.dump(2) + "\n";
}

} // namespace vfit
