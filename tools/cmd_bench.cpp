// SPDX-License-Identifier: Apache-2.0
// `vfit bench table1`: the timing study against seed 000's Table 1 (the nine garment/body
// pairs rebuilt from the catalogue), and a resolution sweep of one garment with the fitted
// growth exponent of each stage.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <thread>

#include <nlohmann/json.hpp>
#include <tbb/info.h>

#include "commands.h"
#include "vfit/engine/fit/pipeline.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/table1.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {
namespace {

// The paper's three columns and their sum, from one pipeline run (no simulation: Table 1 has
// none). Deformation is everything between segmentation and penetration removal: part
// skeletons, driving and the coarse move (the paper's skeleton extraction, driving, Laplacian
// deformation and move).
struct ColumnTimes {
  double segmentation = 0, deformation = 0, penetration = 0;
  double total() const { return segmentation + deformation + penetration; }
};

ColumnTimes columns(const FitStageTimes& t) {
  return {t.segmentation_ms, t.skeletons_ms + t.driving_ms + t.coarse_move_ms, t.penetration_ms};
}

struct Stats {
  double median = 0, min = 0;
};

Stats stats(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return {n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]), v.front()};
}

// Runs the pipeline `runs` times on one garment (with the cloth simulation when `simulate`);
// returns each column's timings.
std::map<std::string, std::vector<double>> time_fit(const Body& body, const Garment& garment, const std::string& name,
                                                    int runs, FitReport* last_report, bool simulate = false) {
  FitOptions options;
  options.simulate = simulate;
  options.garment_units = Units::M;
  std::map<std::string, std::vector<double>> out;
  for (int r = 0; r < runs; ++r) {
    const FitResult result = fit_garments(body, {FitGarmentInput{name, garment.mesh}}, options);
    const ColumnTimes c = columns(result.report.garments.front().timings);
    out["segmentation"].push_back(c.segmentation);
    out["deformation"].push_back(c.deformation);
    out["penetration"].push_back(c.penetration);
    out["total"].push_back(c.total());
    if (last_report) *last_report = result.report;
  }
  return out;
}

nlohmann::ordered_json machine_json(const FitReport& report) {
  return {{"cpu_model", report.cpu_model},
          {"hardware_threads", std::thread::hardware_concurrency()},
          {"tbb_threads", tbb::info::default_concurrency()}};
}

int run_table1(Args& args) {
  const std::optional<std::string> runs_value = args.value("runs");
  const int runs = runs_value ? Args::to_int("--runs", *runs_value, 1, 1000) : 5;
  const std::optional<std::string> rows_value = args.value("rows");
  const int row_limit = rows_value ? Args::to_int("--rows", *rows_value, 1, 9) : 9;
  // --garment NAME: only the pairs of that garment (e.g. "Shorts 1"), for profiling one row.
  const std::optional<std::string> only = args.value("garment");
  if (only &&
      std::none_of(table1_rows().begin(), table1_rows().end(), [&](const Table1Row& r) { return r.garment == *only; }))
    throw Error("--garment", 0, "no Table-1 pair has the garment '" + *only + "'");
  const std::optional<std::string> json_path = args.value("json");
  const bool quiet = args.flag("quiet");
  const bool simulate = !args.flag("no-simulation");
  // --min-speedup X: exit 1 when a row's total is under X times the paper's (a regression check).
  const std::optional<std::string> bar_value = args.value("min-speedup");
  double bar = 0;
  if (bar_value) {
    char* end = nullptr;
    bar = std::strtod(bar_value->c_str(), &end);
    if (end == bar_value->c_str() || *end != '\0' || !(bar > 0))
      throw Error("--min-speedup", 0, "expected a positive number, got '" + *bar_value + "'");
  }
  args.positionals(1, 1);

  MannequinOptions mo;
  mo.pose = RestPose::APOSE;
  const Body rest = make_mannequin(mo);
  std::map<std::string, Body> posed;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  FitReport report;
  double paper_sum = 0, ours_sum = 0;
  std::vector<std::string> under_bar; // rows whose total is under --min-speedup
  std::printf("%-14s %6s %6s %6s | %-22s | %-22s | %-22s | %-22s | %s\n", "garment", "V", "F", "paperF",
              "segmentation ms", "deformation ms", "penetration ms", "total ms", "simulation ms");
  std::printf("%-14s %6s %6s %6s | %-22s | %-22s | %-22s | %-22s | %s\n", "", "", "", "", "paper  ours(min)  x",
              "paper  ours(min)  x", "paper  ours(min)  x", "paper  ours(min)  x", "ours (outcome)");
  for (const Table1Row& row : table1_rows()) {
    if (static_cast<int>(rows.size()) >= row_limit) break;
    if (only && row.garment != *only) continue;
    if (!posed.contains(row.body_pose))
      posed.emplace(row.body_pose, pose_body(rest, named_pose(row.body_pose, rest.rest_pose)));
    if (!quiet)
      std::cerr << "vfit: bench: " << row.garment << " (" << row.vertices << " vertices) on " << row.body_pose << "\n";
    const Garment garment = make_garment(table1_garment_options(row));
    const auto times = time_fit(posed.at(row.body_pose), garment, row.garment, runs, &report);
    nlohmann::ordered_json j;
    j["garment"] = row.garment;
    j["image"] = row.image;
    j["body_pose"] = row.body_pose;
    j["vertices"] = garment.mesh.vertex_count();
    j["faces"] = garment.mesh.face_count();
    j["paper_faces"] = row.paper_faces;
    const std::pair<const char*, double> paper[] = {{"segmentation", row.paper_segmentation_ms},
                                                    {"deformation", row.paper_deformation_ms},
                                                    {"penetration", row.paper_penetration_ms},
                                                    {"total", row.paper_total_ms}};
    std::printf("%-14s %6zu %6zu %6zu", row.garment.c_str(), garment.mesh.vertex_count(), garment.mesh.face_count(),
                row.paper_faces);
    for (const auto& [stage, paper_ms] : paper) {
      const Stats s = stats(times.at(stage));
      j[stage] = {{"paper_ms", paper_ms}, {"median_ms", s.median}, {"min_ms", s.min}, {"speedup", paper_ms / s.median}};
      std::printf(" | %6.0f %6.2f(%6.2f) %5.0fx", paper_ms, s.median, s.min, paper_ms / s.median);
    }
    // The simulation to rest, in its own column (not in the total: the paper's table has no
    // simulation): one more fit with it on, after the timed runs.
    if (simulate) {
      FitReport simulated;
      time_fit(posed.at(row.body_pose), garment, row.garment, 1, &simulated, true);
      const GarmentFitReport& g = simulated.garments.front();
      j["simulation"] = {
          {"ms", g.timings.simulation_ms}, {"outcome", to_string(g.simulation)}, {"steps", g.simulation_steps}};
      std::printf(" | %8.1f (%s)", g.timings.simulation_ms, to_string(g.simulation).c_str());
    }
    std::printf("\n");
    paper_sum += row.paper_total_ms;
    ours_sum += stats(times.at("total")).median;
    if (const double x = row.paper_total_ms / stats(times.at("total")).median; bar_value && x < bar) {
      char line[200];
      std::snprintf(line, sizeof line, "%s: total %.2f ms, %.0fx the paper's %.0f ms", row.garment.c_str(),
                    stats(times.at("total")).median, x, row.paper_total_ms);
      under_bar.push_back(line);
    }
    rows.push_back(j);
  }
  const std::string which = rows.size() == table1_rows().size()
                                ? "all nine rows"
                                : std::to_string(rows.size()) + (rows.size() == 1 ? " row" : " rows");
  std::printf("%s: paper %.0f ms, ours %.1f ms (medians of %d runs), %.0fx\n", which.c_str(), paper_sum, ours_sum, runs,
              paper_sum / ours_sum);
  std::printf("machine: %s, %d TBB threads; paper: Intel 4 x 2.5 GHz\n", report.cpu_model.c_str(),
              tbb::info::default_concurrency());
  if (json_path) {
    nlohmann::ordered_json out;
    out["study"] = "seed 000 Table 1";
    out["runs"] = runs;
    out["machine"] = machine_json(report);
    out["rows"] = rows;
    out["total"] = {{"paper_ms", paper_sum}, {"median_ms", ours_sum}, {"speedup", paper_sum / ours_sum}};
    write_file_atomically(*json_path, out.dump(2) + "\n");
  }
  for (const std::string& row : under_bar)
    std::fprintf(stderr, "vfit: bench: under the bar of %gx: %s\n", bar, row.c_str());
  return under_bar.empty() ? 0 : 1;
}

// Least-squares slope of log(time) against log(vertices): time ∝ vertices^slope.
double growth_exponent(const std::vector<double>& vertices, const std::vector<double>& ms) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = double(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const double x = std::log(vertices[i]), y = std::log(std::max(ms[i], 1e-6));
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  const double den = n * sxx - sx * sx;
  return den > 0 ? (n * sxy - sx * sy) / den : NAN;
}

int run_sweep(Args& args) {
  const std::optional<std::string> runs_value = args.value("runs"), max_value = args.value("max-vertices");
  const int runs = runs_value ? Args::to_int("--runs", *runs_value, 1, 1000) : 3;
  const int max_vertices = max_value ? Args::to_int("--max-vertices", *max_value, 1000, 1000000) : 100000;
  const std::string type = args.value("garment").value_or("tee");
  const std::optional<std::string> json_path = args.value("json");
  const bool quiet = args.flag("quiet");
  args.positionals(1, 1);

  MannequinOptions mo;
  mo.pose = RestPose::APOSE;
  const Body body = pose_body(make_mannequin(mo), named_pose("arms_down", RestPose::APOSE));
  std::vector<double> sizes;
  for (double v = 1000; v <= max_vertices * 1.0001; v *= std::sqrt(10.0))
    sizes.push_back(std::round(v / 100) * 100);
  const char* stages[] = {"segmentation", "deformation", "penetration", "total"};
  std::map<std::string, std::vector<double>> medians;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  FitReport report;
  std::printf("%-9s %14s %14s %14s %14s   (median ms of %d runs)\n", "vertices", "segmentation", "deformation",
              "penetration", "total", runs);
  for (double v : sizes) {
    if (!quiet) std::cerr << "vfit: bench: " << type << " at " << v << " vertices\n";
    GarmentOptions go;
    go.type = parse_garment_type(type);
    go.target_vertices = static_cast<std::size_t>(v);
    go.pose = RestPose::TPOSE;
    const Garment garment = make_garment(go);
    const auto times = time_fit(body, garment, type, runs, &report);
    nlohmann::ordered_json j;
    j["vertices"] = garment.mesh.vertex_count();
    std::printf("%-9zu", garment.mesh.vertex_count());
    for (const char* s : stages) {
      const double m = stats(times.at(s)).median;
      medians[s].push_back(m);
      j[s] = {{"median_ms", m}, {"min_ms", stats(times.at(s)).min}};
      std::printf(" %14.2f", m);
    }
    std::printf("\n");
    rows.push_back(j);
  }
  nlohmann::ordered_json exponents;
  std::printf("growth exponent (time ∝ vertices^k):");
  for (const char* s : stages) {
    const double k = growth_exponent(sizes, medians[s]);
    exponents[s] = k;
    std::printf(" %s %.2f", s, k);
  }
  std::printf("\n");
  if (json_path) {
    nlohmann::ordered_json out;
    out["study"] = "resolution sweep";
    out["garment"] = type;
    out["runs"] = runs;
    out["machine"] = machine_json(report);
    out["rows"] = rows;
    out["growth_exponent"] = exponents;
    write_file_atomically(*json_path, out.dump(2) + "\n");
  }
  return 0;
}

} // namespace

int run_bench(Args& args) {
  // The study's name is the first positional; each study asks for its own options.
  Args peek = args;
  const std::vector<std::string> pos = [&] {
    peek.value("runs");
    peek.value("json");
    peek.value("max-vertices");
    peek.value("garment");
    peek.value("rows");
    peek.value("min-speedup");
    peek.flag("quiet");
    peek.flag("no-simulation");
    return peek.positionals(1, 1);
  }();
  if (pos[0] == "table1") return run_table1(args);
  if (pos[0] == "sweep") return run_sweep(args);
  throw Error("vfit bench", 0, "unknown study '" + pos[0] + "' (expected table1 or sweep)");
}

} // namespace vfit::cli
