// SPDX-License-Identifier: Apache-2.0
// `vfit fit`: fits garments onto a body (the pipeline of engine/fit/pipeline.h) and writes the
// fitted meshes, a JSON report and pictures. Everything is computed before anything is
// written, and every file is written atomically, so bad input leaves no partial output. The
// one exception, --debug DIR, writes each stage's meshes as the stage finishes, and only once
// every garment has been recognised as one. Progress lines go to stderr when it is a terminal.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

#include <unistd.h>

#include "body_args.h"
#include "commands.h"
#include "dressed_scene.h"
#include "fit_debug.h"
#include "vfit/engine/cloth/fabric.h"
#include "vfit/engine/engine.h"
#include "vfit/engine/fit/fit_report_json.h"
#include "vfit/engine/fit/pipeline.h"
#include "vfit/engine/view/render.h"
#include "vfit/geometry/body/keypoint_fit.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {
namespace {

using Clock = std::chrono::steady_clock;

double to_double(const std::string& option, const std::string& value, double lo, double hi) {
  double x = 0;
  std::size_t used = 0;
  try {
    x = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || !std::isfinite(x) || x < lo || x > hi)
    throw Error(option, 0,
                "expected a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + value + "'");
  return x;
}

// All garments in one mesh, one face label per garment (groups in OBJ); UVs kept when every
// garment has them.
Mesh merge_garments(const std::vector<FittedGarment>& garments) {
  Mesh merged;
  bool uvs = true;
  for (const FittedGarment& g : garments)
    uvs = uvs && !g.mesh.uv_triangles.empty();
  for (std::size_t k = 0; k < garments.size(); ++k) {
    const Mesh& m = garments[k].mesh;
    const auto v0 = static_cast<std::int32_t>(merged.vertex_count());
    const auto t0 = static_cast<std::int32_t>(merged.uvs.size() / 2);
    merged.positions.insert(merged.positions.end(), m.positions.begin(), m.positions.end());
    for (std::int32_t i : m.triangles)
      merged.triangles.push_back(i + v0);
    if (uvs) {
      merged.uvs.insert(merged.uvs.end(), m.uvs.begin(), m.uvs.end());
      for (std::int32_t i : m.uv_triangles)
        merged.uv_triangles.push_back(i + t0);
    }
    merged.face_labels.insert(merged.face_labels.end(), m.face_count(), static_cast<std::int32_t>(k));
    merged.label_names.push_back(std::filesystem::path(garments[k].name).stem().string());
  }
  return merged;
}

void print_table(const FitReport& report, double body_ms) {
  std::printf("%-14s", "stage (ms)");
  for (const GarmentFitReport& g : report.garments)
    std::printf(" %14.14s", std::filesystem::path(g.name).stem().string().c_str());
  std::printf(" %10s\n", "all");
  const auto all = report.timings.named();
  for (std::size_t s = 0; s < all.size(); ++s) {
    std::printf("%-14s", all[s].first.c_str());
    for (const GarmentFitReport& g : report.garments)
      std::printf(" %14.1f", g.timings.named()[s].second);
    std::printf(" %10.1f\n", all[s].second);
  }
  std::printf("body %zu vertices (loaded in %.1f ms, index %.1f ms); backend %s, %d threads, %s\n",
              report.body_vertices, body_ms, report.body_index_ms, report.backend.c_str(), report.threads,
              report.cpu_model.c_str());
  for (const GarmentFitReport& g : report.garments) {
    std::printf("%s: %s, %zu vertices; move %s; driving %s; inside %zu -> %zu (max %.2f -> %.2f mm); crossing edges "
                "%zu -> %zu; inside inner layers %zu -> %zu, through them %zu -> %zu; simulation %s\n",
                g.name.c_str(), garment_type_name(g.type).c_str(), g.vertices, to_string(g.coarse_move.rule).c_str(),
                g.driving.c_str(), g.before.inside_count, g.after.inside_count, g.before.max_depth * 1e3,
                g.after.max_depth * 1e3, g.before.crossing_edges, g.after.crossing_edges, g.before.layer_inside_count,
                g.after.layer_inside_count, g.before.layer_crossing_edges, g.after.layer_crossing_edges,
                g.simulation_status.c_str());
  }
  for (const GarmentFitReport& g : report.garments)
    std::printf("%s: %s (%s)\n", std::filesystem::path(g.name).stem().string().c_str(),
                size_verdict_name(g.verdict).c_str(), g.verdict_reason.c_str());
  std::printf("verdict: %s\n", size_verdict_name(report.verdict).c_str());
}

// With several bodies, each body's outputs are its own files, named by a tag per body: the body
// file's stem ("mannequin" for the built-in one), with its position in the list (from 1) added
// when two bodies would share a tag.
std::vector<std::string> body_tags(const std::vector<std::string>& sources) {
  std::vector<std::string> tags;
  std::map<std::string, int> count;
  for (const std::string& s : sources)
    tags.push_back(s == "mannequin" ? s : std::filesystem::path(s).stem().string());
  for (const std::string& t : tags)
    ++count[t];
  for (std::size_t k = 0; k < tags.size(); ++k)
    if (count[tags[k]] > 1) tags[k] += "_" + std::to_string(k + 1);
  return tags;
}

// `path` for one body's output: fit.glb -> fit.<tag>.glb; unchanged for an empty tag (one body).
std::string per_body_path(const std::string& path, const std::string& tag) {
  if (tag.empty()) return path;
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + "." + tag + p.extension().string())).string();
}

// One line per finished stage: "vfit: tee.obj: segmentation 1.2 ms (tee)".
void print_progress(const FitProgress& p) {
  std::string detail = p.detail;
  constexpr std::size_t MAX_DETAIL = 100; // keep a progress line on one terminal line or two
  if (detail.size() > MAX_DETAIL) detail = detail.substr(0, MAX_DETAIL - 3) + "...";
  std::fprintf(stderr, "vfit: %s: %s %.1f ms%s%s%s\n", std::filesystem::path(p.name).filename().string().c_str(),
               p.stage.c_str(), p.ms, detail.empty() ? "" : " (", detail.c_str(), detail.empty() ? "" : ")");
  std::fflush(stderr);
}

} // namespace

int run_fit(Args& args) {
  const bool quiet = args.flag("quiet");
  // Progress on stderr when a person is watching it (a terminal), or when asked for.
  const bool progress_asked = args.flag("progress");
  const bool progress = !quiet && (progress_asked || isatty(STDERR_FILENO) == 1);
  const auto debug_dir = args.value("debug");
  std::vector<std::string> sources = args.values("body");
  if (sources.empty()) sources.push_back("mannequin");
  // The body flags apply to every --body.
  const BodyRequest body_flags = body_request_from_args(args, sources[0]);
  if (body_flags.joints_file && sources.size() > 1)
    throw Error("--joints-in", 0, "gives the joints of one body; give one --body");
  const auto pose_arg = args.value("pose");
  const auto keypoints_file = args.value("keypoints");
  bool image_size_token = false;
  KeypointOptions kp_options = keypoint_options_from_args(args, image_size_token);
  if (keypoints_file && pose_arg) throw Error("--keypoints", 0, "the pose comes from the keypoints; drop --pose");
  if (keypoints_file && (sources.size() > 1 || sources[0] != "mannequin"))
    throw Error("--keypoints", 0, "fits the built-in mannequin; drop --body");
  if (debug_dir && sources.size() > 1) throw Error("--debug", 0, "writes the stages of one body; give one --body");
  const auto garment_files = args.values("garment");
  const auto out = args.value("out");
  const auto report_file = args.value("report");
  const auto render_file = args.value("render");
  FitOptions options;
  options.simulate = !args.flag("no-simulation");
  if (auto b = args.value("backend")) {
    if (*b == "serial")
      options.backend = Backend::SERIAL;
    else if (*b == "tbb")
      options.backend = Backend::TBB;
    else
      throw Error("--backend", 0, "expected serial or tbb, got '" + *b + "'");
  }
  const int threads = thread_limit(); // --threads N (main()), 0: every core
  if (auto f = args.value("fabric")) options.fabric = *f;
  if (auto c = args.value("clearance")) options.clearance = to_double("--clearance", *c, 0, 0.05);
  if (auto s = args.value("max-sim-seconds"))
    options.max_simulated_seconds = to_double("--max-sim-seconds", *s, 0, 600);
  if (auto m = args.value("cloth-proxy")) {
    if (*m == "auto")
      options.cloth_proxy = ClothProxyMode::AUTO;
    else if (*m == "on")
      options.cloth_proxy = ClothProxyMode::ON;
    else if (*m == "off")
      options.cloth_proxy = ClothProxyMode::OFF;
    else
      throw Error("--cloth-proxy", 0, "expected auto, on or off, got '" + *m + "'");
  }
  if (auto n = args.value("proxy-vertices"))
    options.cloth_proxy_vertices = static_cast<std::size_t>(Args::to_int("--proxy-vertices", *n, 100, 2000000));
  if (auto u = args.value("garment-units")) options.garment_units = parse_units(*u, "--garment-units");
  if (auto g = args.value("garment-scale")) {
    options.garment_scale = to_double("--garment-scale", *g, 1e-6, 1e6);
    if (options.garment_units) throw Error("--garment-scale", 0, "give --garment-units or --garment-scale, not both");
  }
  if (auto up = args.value("garment-up"); up && *up != "auto") options.garment_up = parse_up_axis(*up);
  if (auto facing = args.value("garment-facing"); facing && *facing != "auto")
    options.garment_facing = parse_facing(*facing);
  if (auto order = args.value("layer-order")) {
    if (*order == "auto")
      options.layer_order = LayerOrderRule::AUTO;
    else if (*order == "type")
      options.layer_order = LayerOrderRule::TYPE;
    else if (*order == "given")
      options.layer_order = LayerOrderRule::GIVEN;
    else
      throw Error("--layer-order", 0, "expected auto, type or given, got '" + *order + "'");
  }
  std::optional<FitDebugFiles> debug_files; // --debug: the fit's snapshots as files
  if (debug_dir) {
    if (debug_dir->empty()) throw Error("--debug", 0, "expected a folder");
    options.observer = &debug_files.emplace(*debug_dir);
  }
  if (progress) options.progress = print_progress;
  int render_size = 512;
  if (auto s = args.value("render-size")) render_size = Args::to_int("--render-size", *s, 16, 8192);
  finish_image_size(args, args.positionals(0, image_size_token ? 1 : 0), kp_options);

  if (garment_files.empty()) throw Error("vfit fit", 0, "at least one --garment FILE is required");
  if (out) {
    const std::string ext = lower_extension(*out);
    if (ext != ".obj" && ext != ".ply" && ext != ".glb") throw Error(*out, 0, "--out writes .obj, .ply or .glb");
  }
  if (report_file && lower_extension(*report_file) != ".json")
    throw Error(*report_file, 0, "--report writes a .json file");
  if (render_file && lower_extension(*render_file) != ".png")
    throw Error(*render_file, 0, "--render writes a .png file");
  if (options.simulate) (void)fabric_preset(options.fabric);
  // Outputs are checked before the fit, so that none is written when another cannot be.
  {
    std::vector<std::string> inputs = garment_files;
    inputs.insert(inputs.end(), sources.begin(), sources.end());
    for (const auto& f : {keypoints_file, pose_arg, body_flags.joints_file, body_flags.rig_mapping_file})
      if (f) inputs.push_back(*f);
    const std::vector<std::string> tags = body_tags(sources);
    for (const auto& [file, option] : {std::pair{out, "--out"}, {report_file, "--report"}, {render_file, "--render"}})
      if (file)
        for (const std::string& tag : tags)
          check_output_path(per_body_path(*file, sources.size() > 1 ? tag : ""), option, inputs);
  }

  // Read every garment before the (slower) body, so a missing file fails at once.
  std::vector<FitGarmentInput> garments;
  ReadOptions read_options;
  read_options.repair = body_flags.repair;                       // --repair, read with the body's flags
  std::map<std::string, std::vector<std::string>> read_warnings; // for the report
  for (const std::string& f : garment_files) {
    ParsedMesh parsed = read_mesh(f, read_options);
    if (!quiet)
      for (const auto& w : parsed.warnings)
        std::cerr << "vfit: warning: " << w << "\n";
    read_warnings[f] = parsed.warnings;
    garments.push_back({f, std::move(parsed.mesh)});
  }

  // A photo's keypoints give the mannequin its measurements and pose (the camera's translation
  // dropped: the body stands in its own frame).
  std::optional<KeypointFit> keypoint_fit;
  double keypoint_ms = 0;
  if (keypoints_file) {
    const auto t0 = Clock::now();
    Keypoints kp;
    keypoint_fit = fit_keypoint_file(*keypoints_file, kp_options, quiet, &kp);
    keypoint_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (progress)
      std::fprintf(stderr, "vfit: keypoints: %zu, fitted in %.1f ms, mean reprojection error %.2f px\n",
                   kp.points.size(), keypoint_fit->total_ms, keypoint_fit->mean_reprojection_px);
  }
  // Every body is loaded (and checked) before any fit, so a bad body file fails at once.
  const Engine engine({options.backend, "", threads});
  std::vector<LoadedBody> loaded;
  std::vector<Body> bodies;
  std::vector<double> body_ms;
  for (const std::string& source : sources) {
    const auto t0 = Clock::now();
    BodySource body_source{body_flags, keypoint_fit, pose_arg.value_or("")};
    body_source.request.source = source;
    SourcedBody made = engine.make_body(body_source);
    loaded.push_back(std::move(made.loaded));
    bodies.push_back(std::move(made.body));
    body_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() + keypoint_ms);
    if (progress)
      std::fprintf(stderr, "vfit: body: %s, %zu vertices, %.1f ms\n", loaded.back().kind.c_str(),
                   bodies.back().mesh.vertex_count(), body_ms.back());
    if (!quiet)
      for (const auto& w : loaded.back().warnings)
        std::cerr << "vfit: warning: " << (sources.size() > 1 ? source + ": " : "") << w << "\n";
  }

  std::vector<const Body*> body_list;
  for (const Body& b : bodies)
    body_list.push_back(&b);
  std::vector<FitResult> results = engine.fit(body_list, garments, options);
  const std::vector<std::string> tags = body_tags(sources);
  // Every output of every body is made before any is written: an error leaves no file behind.
  std::vector<std::pair<std::string, std::string>> files; // path, bytes
  for (std::size_t b = 0; b < results.size(); ++b) {
    const FitResult& result = results[b];
    const Body& body = bodies[b];
    const std::string tag = sources.size() > 1 ? tags[b] : "";
    if (!quiet)
      for (const GarmentFitReport& g : result.report.garments)
        for (const auto& w : g.warnings)
          std::cerr << "vfit: warning: " << (tag.empty() ? "" : tag + ": ") << g.name << ": " << w << "\n";

    std::optional<Image> picture;
    double render_ms = -1;
    if (render_file) {
      const auto t0 = Clock::now();
      std::vector<const Mesh*> meshes = {&body.mesh};
      for (const FittedGarment& g : result.garments)
        meshes.push_back(&g.mesh);
      RenderOptions ro;
      ro.size = render_size;
      picture = compose_views(render_views(meshes, ro));
      render_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    }

    if (out) {
      const std::string path = per_body_path(*out, tag);
      files.emplace_back(path, lower_extension(path) == ".glb"
                                   ? fitted_scene_glb(body, result.garments)
                                   : encode_mesh(path, merge_garments(result.garments), "garments"));
    }
    if (report_file) {
      FitReportContext context = fit_report_context(body, loaded[b]);
      context.body_ms = body_ms[b];
      context.render_ms = render_ms;
      context.read_warnings = read_warnings;
      files.emplace_back(per_body_path(*report_file, tag), fit_report_json(result.report, options, context));
    }
    if (picture) files.emplace_back(per_body_path(*render_file, tag), encode_png(*picture));
  }
  for (const auto& [path, bytes] : files)
    write_file_atomically(path, bytes);
  if (!quiet)
    for (std::size_t b = 0; b < results.size(); ++b) {
      if (sources.size() > 1) std::printf("%sbody %s (%s)\n", b > 0 ? "\n" : "", tags[b].c_str(), sources[b].c_str());
      print_table(results[b].report, body_ms[b]);
    }
  return 0;
}

} // namespace vfit::cli
