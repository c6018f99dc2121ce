// SPDX-License-Identifier: Apache-2.0
// `vfit demo`: README's main job. The built-in mannequin in a non-rest pose (arms down, left knee
// bent) is dressed in a catalogue tee and trousers modelled in T-pose, by the same code path as
// `vfit fit`: the garments are written as OBJ files and fitted, with the report and the PNG
// views. Then it reads and validates the corpus meshes when the corpus is there, computes
// vertex normals on every backend and compares them, and writes the built-in and corpus meshes
// (in metres) into one glTF file a viewer can open.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "mesh_summary.h"
#include "vfit/engine/engine.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/opencl_context.h"

namespace vfit::cli {
namespace {

std::optional<std::filesystem::path> find_corpus(const std::optional<std::string>& flag) {
  std::error_code ec;
  if (flag) return std::filesystem::path(*flag);
  if (const char* env = std::getenv("VFIT_CORPUS"); env && *env) return std::filesystem::path(env);
  for (const char* candidate : {"../shared/corpus", "shared/corpus"})
    if (std::filesystem::is_directory(candidate, ec)) return std::filesystem::path(candidate);
  return std::nullopt;
}

double max_angle_degrees(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0;
  for (std::size_t v = 0; v + 2 < a.size(); v += 3) {
    // atan2(|a×b|, a·b) stays accurate for tiny angles, where acos(a·b) would round to ~0.03°.
    const double ax = a[v], ay = a[v + 1], az = a[v + 2], bx = b[v], by = b[v + 1], bz = b[v + 2];
    const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    const double angle = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
    worst = std::max(worst, angle * 180.0 / M_PI);
  }
  return worst;
}

struct Item {
  std::string name;
  Mesh mesh; // in metres
  nlohmann::json summary;
};

} // namespace

int run_demo(Args& args) {
  const bool quiet = args.flag("quiet");
  const std::filesystem::path out_dir = args.value("out").value_or("vfit_demo");
  const auto corpus_flag = args.value("corpus");
  const auto device = args.value("device").value_or("");
  args.positionals(0, 0);
  auto say = [&](const std::string& s) {
    if (!quiet) std::cout << s << std::flush;
  };

  std::filesystem::create_directories(out_dir);
  // The fit: catalogue garments modelled in T-pose (their own pose, not the body's), fitted onto
  // the mannequin posed by the skeleton: `vfit fit` itself.
  GarmentOptions go;
  go.pose = RestPose::TPOSE;
  go.type = GarmentType::TEE;
  go.size = "M";
  const Garment tee = make_garment(go);
  go.type = GarmentType::TROUSERS;
  go.size = "P2";
  const Garment trousers = make_garment(go);
  const auto tee_file = out_dir / "tee_M_tpose.obj", trousers_file = out_dir / "trousers_P2_tpose.obj";
  write_mesh(tee_file, tee.mesh);
  write_mesh(trousers_file, trousers.mesh);
  say("fitting " + tee_file.string() + " and " + trousers_file.string() +
      " onto the mannequin in the 'demo' pose (arms down, left knee bent):\n");
  std::vector<std::string> fit_tokens = {"--body",    "mannequin",
                                         "--pose",    "demo",
                                         "--garment", trousers_file.string(),
                                         "--garment", tee_file.string(),
                                         "--out",     (out_dir / "fit.glb").string(),
                                         "--report",  (out_dir / "fit_report.json").string(),
                                         "--render",  (out_dir / "fit_views.png").string()};
  if (quiet) fit_tokens.push_back("--quiet");
  Args fit_args(fit_tokens, "fit");
  if (const int rc = run_fit(fit_args); rc != 0) return rc;
  say("\n");

  // The same outfit in motion: a procedural walk cycle (one second at 30 fps) played on the
  // mannequin by `vfit animate` (the garments fitted at rest, skinned to its skeleton).
  const auto walk_file = out_dir / "walk_cycle.json";
  write_file_atomically(walk_file, pose_sequence_json(walk_cycle(RestPose::APOSE)));
  say("animating them through " + walk_file.string() + " (a walk cycle, 30 frames):\n");
  std::vector<std::string> animate_tokens = {"--garment",
                                             trousers_file.string(),
                                             "--garment",
                                             tee_file.string(),
                                             "--motion",
                                             walk_file.string(),
                                             "--no-simulation",
                                             "--out",
                                             (out_dir / "walk.glb").string(),
                                             "--render",
                                             (out_dir / "walk_frames.png").string(),
                                             "--report",
                                             (out_dir / "walk_report.json").string()};
  if (quiet) animate_tokens.push_back("--quiet");
  Args animate_args(animate_tokens, "animate");
  if (const int rc = run_animate(animate_args); rc != 0) return rc;
  say("\n");

  std::vector<Item> items;
  // The built-in mannequin (average adult, A-pose), the garments, and the same body posed by its
  // skeleton, placed 1 m to its left.
  const auto tb = std::chrono::steady_clock::now();
  MannequinOptions mo;
  const Body body = make_mannequin(mo);
  const double body_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tb).count();
  Body posed = pose_body(body, named_pose("demo", body.rest_pose));
  for (std::size_t v = 0; v < posed.mesh.vertex_count(); ++v)
    posed.mesh.positions[3 * v] += 1.0f;
  {
    const MeasuredBody m = measure_body(body.mesh, body.joints);
    say("mannequin: " + std::to_string(body.mesh.vertex_count()) + " vertices, built in " +
        std::to_string(int(body_ms)) + " ms; requested vs measured:\n");
    for (std::string_view n : BodyMeasurements::names()) {
      char line[128];
      std::snprintf(line, sizeof line, "  %-15s %7.4f m  %7.4f m\n", std::string(n).c_str(), mo.measurements[n],
                    m.values[n]);
      say(line);
    }
  }
  items.push_back({"mannequin", body.mesh, {}});
  items.push_back({"tee_M_tpose", tee.mesh, {}});
  items.push_back({"trousers_P2_tpose", trousers.mesh, {}});
  items.push_back({"mannequin_posed_demo", posed.mesh, {}});
  // Procedural test meshes: a sphere (closed), a sleeve-like tube (two openings), a cloth grid.
  items.push_back({"builtin_sphere", make_uv_sphere(96, 128, 0.11f), {}});
  items.push_back({"builtin_sleeve_tube", make_tube(60, 48, 0.06f, 0.55f), {}});
  items.push_back({"builtin_cloth_grid", make_grid(80, 80, 1.0f, 1.0f), {}});
  for (Item& it : items) {
    TopologyReport t = analyse_topology(it.mesh.triangle_view(), it.mesh.vertex_count());
    it.summary = {{"file", "(built-in) " + it.name}, {"vertices", it.mesh.vertex_count()},
                  {"faces", it.mesh.face_count()},   {"units", "m"},
                  {"components", t.components},      {"boundary_loops", t.boundary_loops},
                  {"watertight", t.watertight()},    {"manifold", t.manifold()}};
  }

  std::size_t corpus_files = 0;
  if (auto corpus = find_corpus(corpus_flag)) {
    const auto derived = *corpus / "makehuman" / "derived";
    std::vector<std::filesystem::path> files;
    std::error_code ec;
    if (std::filesystem::exists(derived / "hm08_body.obj", ec)) files.push_back(derived / "hm08_body.obj");
    if (std::filesystem::is_directory(derived / "parts_on_hm08", ec))
      for (const auto& e : std::filesystem::directory_iterator(derived / "parts_on_hm08"))
        if (e.path().extension() == ".obj") files.push_back(e.path());
    std::sort(files.begin() + (files.empty() ? 0 : 1), files.end());
    say("reading " + std::to_string(files.size()) + " corpus meshes from " + corpus->string() + "\n");
    for (const auto& f : files) {
      MeshSummary s = summarise_mesh(f, {}, std::nullopt);
      nlohmann::json summary = summary_json(s); // before the mesh moves out of `s`
      Item it{f.stem().string(), std::move(s.parsed.mesh), std::move(summary)};
      scale_positions(it.mesh.positions, metres_per_unit(s.units));
      items.push_back(std::move(it));
      ++corpus_files;
    }
  } else {
    say("corpus not found (looked at --corpus, $VFIT_CORPUS, ../shared/corpus): built-in meshes only\n");
  }

  char row[256];
  say("\nmesh                                      vertices    faces units comps loops watertight\n");
  for (const Item& it : items) {
    const auto& j = it.summary;
    std::snprintf(row, sizeof row, "%-40s %9zu %8zu %5s %5zu %5zu %s\n", it.name.c_str(),
                  j["vertices"].get<std::size_t>(), j["faces"].get<std::size_t>(),
                  j["units"].get<std::string>().c_str(), j["components"].get<std::size_t>(),
                  j["boundary_loops"].get<std::size_t>(), j["watertight"].get<bool>() ? "yes" : "no");
    say(row);
  }

  // Vertex normals of the largest mesh on every backend, against the serial reference.
  const Item* big = &items.front();
  for (const Item& it : items)
    if (it.mesh.vertex_count() > big->mesh.vertex_count()) big = &it;
  say("\nvertex normals of " + big->name + " (" + std::to_string(big->mesh.vertex_count()) + " vertices):\n");
  nlohmann::json normals_report = nlohmann::json::array();
  std::vector<float> reference;
  for (Backend b : {Backend::SERIAL, Backend::TBB, Backend::OPENCL}) {
    if (b == Backend::OPENCL && (!opencl_built() || list_opencl_devices().empty())) {
      say("  opencl   unavailable (" + std::string(opencl_built() ? "no device" : "not built") + ")\n");
      continue;
    }
    Engine engine({b, device, 0});
    std::vector<float> normals;
    engine.vertex_normals(big->mesh, normals); // warm-up: builds OpenCL programs
    const auto t0 = std::chrono::steady_clock::now();
    engine.vertex_normals(big->mesh, normals);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    if (b == Backend::SERIAL) reference = normals;
    const double dev = max_angle_degrees(reference, normals);
    std::snprintf(row, sizeof row, "  %-8s %8.3f ms   max deviation from serial %.2e deg   [%s]\n",
                  backend_name(b).c_str(), ms, dev, engine.description().c_str());
    say(row);
    normals_report.push_back(
        {{"backend", backend_name(b)}, {"device", engine.description()}, {"ms", ms}, {"max_deviation_deg", dev}});
  }

  std::vector<NamedMesh> named;
  for (const Item& it : items)
    if (it.name.rfind("builtin_", 0) != 0) named.push_back({it.name, &it.mesh});
  const auto glb = out_dir / "demo.glb";
  write_meshes_glb(glb, named);
  nlohmann::json report;
  report["meshes"] = nlohmann::json::array();
  for (const Item& it : items)
    report["meshes"].push_back(it.summary);
  report["vertex_normals"] = normals_report;
  const auto json_path = out_dir / "demo.json";
  write_file_atomically(json_path, report.dump(2) + "\n");
  say("\nwrote " + (out_dir / "fit.glb").string() + ", " + (out_dir / "fit_report.json").string() + ", " +
      (out_dir / "fit_views.png").string() + " (the fit), " + glb.string() + " (" + std::to_string(named.size()) +
      " meshes, metres) and " + json_path.string() + "\n");
  return 0;
}

} // namespace vfit::cli
