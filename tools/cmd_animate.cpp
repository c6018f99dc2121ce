// SPDX-License-Identifier: Apache-2.0
// `vfit animate`: fits garments onto a body at rest (the fit pipeline), reads a motion-capture
// clip, retargets it onto the body, and steps the dressed character frame by frame
// (engine/animate/dressed_character.h: the garments skinned to the body's skeleton, posed by
// LBS). Writes an animated .glb (body and garments sharing one skeleton, each with a material),
// one OBJ per frame, and a JSON report with per-frame timings and penetration. Everything is
// computed before anything is written, and every file is written atomically.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "body_args.h"
#include "commands.h"
#include "dressed_scene.h"
#include "vfit/engine/animate/dressed_character.h"
#include "vfit/engine/engine.h"
#include "vfit/engine/view/bitmap_font.h"
#include "vfit/engine/view/image.h"
#include "vfit/engine/view/render.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/gltf_format.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/motion/gltf_motion.h"
#include "vfit/geometry/motion/retarget.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// "A:B" (frames A to B of the motion, 0-based, both included; either side may be empty).
std::pair<std::size_t, std::size_t> parse_frames(const std::string& value, std::size_t count) {
  const std::size_t colon = value.find(':');
  if (colon == std::string::npos) throw Error("--frames", 0, "expected A:B, got '" + value + "'");
  const std::string a = value.substr(0, colon), b = value.substr(colon + 1);
  const std::size_t first = a.empty() ? 0 : std::size_t(Args::to_int("--frames", a, 0, 100000000));
  const std::size_t last = b.empty() ? count - 1 : std::size_t(Args::to_int("--frames", b, 0, 100000000));
  if (first > last || last >= count)
    throw Error("--frames", 0,
                "'" + value + "' is not a range within the motion's " + std::to_string(count) +
                    " frames (0:" + std::to_string(count - 1) + ")");
  return {first, last};
}

// The garments' edge strain: |l/L − 1| over every garment edge, L its length at rest (the
// fitted garment); mean and maximum, of `positions(g)` for each garment g.
struct Strain {
  double mean = 0, max = 0, stretch = 0; // stretch: the mean of max(0, l/L − 1)
};
template <class Positions> Strain edge_strain(const DressedCharacter& c, Positions positions) {
  Strain s;
  std::size_t edges = 0;
  for (std::size_t g = 0; g < c.garment_count(); ++g) {
    const Mesh& rest = c.garment_rest(g);
    const std::span<const float> x = positions(g);
    for (std::size_t f = 0; f < rest.face_count(); ++f)
      for (std::size_t k = 0; k < 3; ++k) {
        const auto a = std::size_t(rest.triangles[3 * f + k]), b = std::size_t(rest.triangles[3 * f + (k + 1) % 3]);
        if (a > b) continue; // each interior edge once (boundary edges of one orientation only)
        double l = 0, l0 = 0;
        for (std::size_t i = 0; i < 3; ++i) {
          l += (double(x[3 * a + i]) - x[3 * b + i]) * (double(x[3 * a + i]) - x[3 * b + i]);
          l0 += (double(rest.positions[3 * a + i]) - rest.positions[3 * b + i]) *
                (double(rest.positions[3 * a + i]) - rest.positions[3 * b + i]);
        }
        if (!(l0 > 0)) continue;
        const double e = std::fabs(std::sqrt(l / l0) - 1);
        s.stretch += std::max(0.0, std::sqrt(l / l0) - 1);
        s.mean += e;
        s.max = std::max(s.max, e);
        ++edges;
      }
  }
  if (edges) s.mean /= double(edges), s.stretch /= double(edges);
  return s;
}

// One mesh of the body and every garment, for the per-frame OBJ files.
Mesh frame_mesh(const DressedCharacter& c) {
  Mesh out;
  auto add = [&](std::span<const float> positions, const Mesh& topology) {
    const auto base = std::int32_t(out.positions.size() / 3);
    out.positions.insert(out.positions.end(), positions.begin(), positions.end());
    for (const std::int32_t v : topology.triangles)
      out.triangles.push_back(base + v);
  };
  add(c.body_positions(), c.body().mesh);
  for (std::size_t g = 0; g < c.garment_count(); ++g)
    add(c.garment_positions(g), c.garment_rest(g));
  return out;
}

} // namespace

int run_animate(Args& args) {
  const bool quiet = args.flag("quiet");
  const bool progress = !quiet && (args.flag("progress") || isatty(STDERR_FILENO) == 1);
  std::vector<std::string> sources = args.values("body");
  if (sources.empty()) sources.push_back("mannequin");
  if (sources.size() > 1) throw Error("--body", 0, "animates one body; give one --body");
  const BodyRequest body_flags = body_request_from_args(args, sources[0]);
  if (args.value("pose")) throw Error("--pose", 0, "the motion poses the body; drop --pose");
  const auto garment_files = args.values("garment");
  const auto motion_file = args.value("motion");
  const auto mapping_file = args.value("mapping");
  const auto out = args.value("out");
  const auto frames_dir = args.value("frames-dir");
  const auto report_file = args.value("report");
  const auto render_file = args.value("render");
  const auto render_every_value = args.value("render-every");
  const bool render_stages = args.flag("render-stages");
  const auto render_size_value = args.value("render-size");
  const int render_size = render_size_value ? Args::to_int("--render-size", *render_size_value, 64, 2048) : 256;
  const auto fps_value = args.value("fps");
  const auto physics_value = args.value("physics");
  const auto frames_value = args.value("frames");
  FitOptions options;
  options.simulate = !args.flag("no-simulation");
  args.positionals(0, 0);

  if (garment_files.empty()) throw Error("vfit animate", 0, "at least one --garment FILE is required");
  if (!motion_file) throw Error("vfit animate", 0, "--motion FILE.bvh is required");
  const std::string motion_ext = lower_extension(*motion_file);
  const bool gltf_motion = motion_ext == ".glb" || motion_ext == ".gltf";
  const bool bvh_motion = motion_ext == ".bvh" || gltf_motion;
  if (!bvh_motion && motion_ext != ".json")
    throw Error(*motion_file, 0, "--motion reads a .bvh clip, an animated .glb/.gltf or a pose-sequence .json");
  if (!bvh_motion && mapping_file) throw Error("--mapping", 0, "maps a clip's joint names; a pose sequence has ours");
  if (out && lower_extension(*out) != ".glb") throw Error(*out, 0, "--out writes an animated .glb");
  if (report_file && lower_extension(*report_file) != ".json")
    throw Error(*report_file, 0, "--report writes a .json file");
  if (render_file && lower_extension(*render_file) != ".png")
    throw Error(*render_file, 0, "--render writes a .png file");
  if (render_every_value && !render_file) throw Error("--render-every", 0, "needs --render FILE.png");
  if (render_stages && !render_file) throw Error("--render-stages", 0, "needs --render FILE.png");
  if (physics_value && *physics_value != "on" && *physics_value != "off")
    throw Error("--physics", 0, "expected on or off, got '" + *physics_value + "'");
  AnimationOptions animation;
  animation.physics = !physics_value || *physics_value == "on";
  animation.threads = thread_limit(); // --threads N (main()), 0: every core
  const double fps = fps_value ? double(Args::to_int("--fps", *fps_value, 1, 1000)) : 0.0;
  {
    std::vector<std::string> inputs = garment_files;
    inputs.insert(inputs.end(), {sources[0], *motion_file});
    if (mapping_file) inputs.push_back(*mapping_file);
    for (const auto& [file, option] : {std::pair{out, "--out"}, {report_file, "--report"}, {render_file, "--render"}})
      if (file) check_output_path(*file, option, inputs);
    if (frames_dir && std::filesystem::exists(*frames_dir) && !std::filesystem::is_directory(*frames_dir))
      throw Error(*frames_dir, 0, "--frames-dir names a file, not a folder");
  }

  // The motion first (fast, and the likeliest to be refused), then the garments, then the body.
  std::optional<BvhMotion> bvh;
  std::optional<PoseSequence> sequence;
  MotionMapping mapping;
  if (bvh_motion) {
    bvh = gltf_motion ? read_gltf_motion(*motion_file) : read_bvh(*motion_file);
    mapping = mapping_file ? load_motion_mapping(*mapping_file) : detect_motion_mapping(*bvh);
  } else {
    sequence = read_pose_sequence_json(*motion_file);
  }
  std::vector<FitGarmentInput> garments;
  for (const std::string& f : garment_files) {
    ParsedMesh parsed = read_mesh(f, ReadOptions{});
    if (!quiet)
      for (const auto& w : parsed.warnings)
        std::cerr << "vfit: warning: " << w << "\n";
    garments.push_back({f, std::move(parsed.mesh)});
  }
  const Engine engine({options.backend, "", animation.threads});
  BodySource source{body_flags, std::nullopt, ""};
  source.request.source = sources[0];
  auto t0 = Clock::now();
  const SourcedBody made = engine.make_body(source);
  const Body& body = made.body;
  const double body_ms = ms_since(t0);
  if (!quiet)
    for (const auto& w : made.loaded.warnings)
      std::cerr << "vfit: warning: " << w << "\n";

  // The garments are fitted onto the body at rest, where its skin weights are bound.
  t0 = Clock::now();
  const FitResult fitted = engine.fit(body, garments, options);
  const double fit_ms = ms_since(t0);
  if (!quiet)
    for (const GarmentFitReport& g : fitted.report.garments)
      for (const auto& w : g.warnings)
        std::cerr << "vfit: warning: " << g.name << ": " << w << "\n";
  if (progress) std::fprintf(stderr, "vfit: fitted %zu garments at rest in %.0f ms\n", garments.size(), fit_ms);

  t0 = Clock::now();
  RetargetedMotion motion;
  if (bvh) {
    motion = retarget_bvh(*bvh, body.joints, mapping);
  } else {
    motion.frames = sequence->frames;
    motion.fps = sequence->fps;
    motion.mapping = "poses";
  }
  if (fps > 0) {
    motion.frames = resample_poses(motion.frames, motion.fps, fps);
    motion.fps = fps;
  }
  const auto [first, last] = frames_value ? parse_frames(*frames_value, motion.frames.size())
                                          : std::pair<std::size_t, std::size_t>{0, motion.frames.size() - 1};
  const std::vector<Pose> frames(motion.frames.begin() + std::ptrdiff_t(first),
                                 motion.frames.begin() + std::ptrdiff_t(last) + 1);
  const double retarget_ms = ms_since(t0);

  // Inner garments first (the fit's dressing order), so each is layered over the ones under it.
  std::vector<FittedGarment> dressed = fitted.garments;
  {
    std::vector<std::size_t> order(dressed.size());
    for (std::size_t i = 0; i < order.size(); ++i)
      order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return fitted.report.garments[a].order < fitted.report.garments[b].order;
    });
    for (std::size_t i = 0; i < order.size(); ++i)
      dressed[i] = fitted.garments[order[i]];
  }
  t0 = Clock::now();
  DressedCharacter character(body, dressed, animation);
  const double setup_ms = ms_since(t0);
  nlohmann::ordered_json per_frame = nlohmann::ordered_json::array();
  std::vector<Mesh> frame_meshes;
  // --render: every Nth frame (default: at most 8 of them) as a tile of the contact sheet.
  const std::size_t every = render_every_value
                                ? std::size_t(Args::to_int("--render-every", *render_every_value, 1, 100000))
                                : std::max<std::size_t>(1, (frames.size() + 7) / 8);
  struct SheetFrame {
    std::size_t frame;
    std::vector<std::vector<Mesh>> stages; // (skinned, cloth,) final: body first, then the garments
  };
  std::vector<SheetFrame> sheet;
  // --out: each garment's frames beyond its skinning (physics, blend, clean-up), as morph targets.
  std::vector<MorphFrames> morphs(character.garment_count());
  FrameReport sum;
  double worst_depth = 0, worst_frame_ms = 0;
  std::size_t worst_inside = 0, worst_inside_1mm = 0, worst_crossing = 0, worst_layer = 0, restarts = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const FrameReport& s = character.step(frames[f], 1.0 / motion.fps);
    sum.add(s);
    worst_frame_ms = std::max(worst_frame_ms, s.total_ms);
    restarts += s.restarted ? 1 : 0;
    t0 = Clock::now();
    const FramePenetration p = character.measure();
    const double measure_ms = ms_since(t0);
    worst_depth = std::max(worst_depth, p.max_depth_mm);
    worst_inside = std::max(worst_inside, p.inside);
    worst_inside_1mm = std::max(worst_inside_1mm, p.inside_1mm);
    worst_crossing = std::max(worst_crossing, p.crossing_edges);
    worst_layer = std::max(worst_layer, p.layer_inside + p.layer_crossing_edges);
    if (report_file) { // the edge strain of the skinned, physical and final garments: for the report only
      const Strain strain_lbs = edge_strain(character, [&](std::size_t g) { return character.garment_skinned(g); });
      const Strain strain_physics =
          edge_strain(character, [&](std::size_t g) { return character.garment_physical(g); });
      const Strain strain_out = edge_strain(character, [&](std::size_t g) { return character.garment_positions(g); });
      per_frame.push_back(
          {{"frame", first + f},
           {"lbs_ms", s.lbs_ms},
           {"physics_ms", s.physics_ms},
           {"blend_ms", s.blend_ms},
           {"cleanup_ms", s.cleanup_ms},
           {"layering_ms", s.layering_ms},
           {"step_ms", s.total_ms},
           {"measure_ms", measure_ms},
           {"restarted", s.restarted},
           {"diverged", s.diverged},
           {"solver_iterations", s.solver_iterations},
           {"pushed_out_of_body", s.body_pushed},
           {"crossing_edges_moved", s.crossings_pushed},
           {"pushed_out_of_layers", s.layer_pushed},
           {"non_finite_replaced", s.non_finite},
           {"cleanup_left_inside_1mm", s.left_inside_1mm},
           {"cleanup_left_crossing", s.left_crossing},
           {"inside", p.inside},
           {"inside_1mm", p.inside_1mm},
           {"crossing_edges", p.crossing_edges},
           {"layer_inside", p.layer_inside},
           {"layer_crossing_edges", p.layer_crossing_edges},
           {"max_depth_mm", p.max_depth_mm},
           {"strain_lbs", {{"mean", strain_lbs.mean}, {"stretch", strain_lbs.stretch}, {"max", strain_lbs.max}}},
           {"strain_physics",
            {{"mean", strain_physics.mean}, {"stretch", strain_physics.stretch}, {"max", strain_physics.max}}},
           {"strain", {{"mean", strain_out.mean}, {"stretch", strain_out.stretch}, {"max", strain_out.max}}}});
    }
    if (frames_dir) frame_meshes.push_back(frame_mesh(character));
    if (out)
      for (std::size_t g = 0; g < character.garment_count(); ++g) {
        MorphFrames& m = morphs[g];
        const std::size_t values = 3 * character.garment_rest(g).vertex_count();
        m.offsets.resize(m.offsets.size() + values);
        character.bind_space_offsets(g, std::span<float>(m.offsets).last(values));
        ++m.count;
      }
    if (render_file && f % every == 0) {
      // The final frame, and with --render-stages the skinned garments and the cloth before it.
      auto tile = [&](auto positions) {
        std::vector<Mesh> meshes(1 + character.garment_count());
        meshes[0].triangles = body.mesh.triangles;
        meshes[0].positions.assign(character.body_positions().begin(), character.body_positions().end());
        for (std::size_t g = 0; g < character.garment_count(); ++g) {
          meshes[g + 1].triangles = character.garment_rest(g).triangles;
          const std::span<const float> x = positions(g);
          meshes[g + 1].positions.assign(x.begin(), x.end());
        }
        return meshes;
      };
      SheetFrame frame{first + f, {}};
      if (render_stages) {
        frame.stages.push_back(tile([&](std::size_t g) { return character.garment_skinned(g); }));
        frame.stages.push_back(tile([&](std::size_t g) { return character.garment_physical(g); }));
      }
      frame.stages.push_back(tile([&](std::size_t g) { return character.garment_positions(g); }));
      sheet.push_back(std::move(frame));
    }
    if (progress && (f % 30 == 0 || f + 1 == frames.size()))
      std::fprintf(stderr,
                   "vfit: frame %zu/%zu: %.1f ms (physics %.1f), %zu garment vertices more than 1 mm inside the "
                   "body, %zu edges through it\n",
                   f + 1, frames.size(), s.total_ms, s.physics_ms, p.inside_1mm, p.crossing_edges);
  }

  // The contact sheet: each tile a side view of one frame, labelled with its number; with
  // --render-stages each frame is a column of three tiles: skinned, cloth, final.
  std::optional<Image> contact_sheet;
  if (render_file) {
    const std::size_t stages = render_stages ? 3 : 1;
    const int columns = int(std::min<std::size_t>(sheet.size(), 8));
    const int rows = int((sheet.size() + std::size_t(columns) - 1) / std::size_t(columns) * stages);
    contact_sheet.emplace(columns * render_size, rows * render_size);
    RenderOptions ro;
    ro.size = render_size;
    ro.views = {RenderView::SIDE};
    const char* const names[3] = {"SKINNED", "CLOTH", "FINAL"};
    for (std::size_t k = 0; k < sheet.size(); ++k)
      for (std::size_t st = 0; st < stages; ++st) {
        std::vector<const Mesh*> meshes;
        for (const Mesh& m : sheet[k].stages[st])
          meshes.push_back(&m);
        const Rendering r = render_views(meshes, ro);
        const int x = int(k % std::size_t(columns)) * render_size;
        const int y = int((k / std::size_t(columns)) * stages + st) * render_size;
        contact_sheet->paste(r.views.front().image, x, y);
        std::string label = "FRAME " + std::to_string(sheet[k].frame);
        if (render_stages) label += std::string(" ") + names[st];
        draw_text(*contact_sheet, x + 6, y + 6, label, render_size >= 192 ? 2 : 1, Rgb8{40, 40, 40});
      }
  }

  // Outputs, once everything is computed.
  if (out) {
    std::vector<MeshSkin> skins(1 + character.garment_count(), body_skin(body));
    std::vector<NamedMesh> named = {{"body", &body.mesh, &skins[0], body_colour()}};
    for (std::size_t g = 0; g < character.garment_count(); ++g) {
      skins[g + 1].joints = character.garment_weights(g).joints;
      skins[g + 1].weights = character.garment_weights(g).weights;
      named.push_back({std::filesystem::path(character.garment_name(g)).stem().string(), &character.garment_rest(g),
                       &skins[g + 1], garment_colour(g), morphs[g].count > 0 ? &morphs[g] : nullptr});
    }
    const SkinAnimation clip =
        poses_to_skin_animation(body.joints, frames, motion.fps, std::filesystem::path(*motion_file).stem().string());
    write_file_atomically(*out, write_glb(named, &clip));
  }
  if (frames_dir) {
    std::filesystem::create_directories(*frames_dir);
    for (std::size_t f = 0; f < frame_meshes.size(); ++f) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%05zu.obj", first + f);
      write_mesh(std::filesystem::path(*frames_dir) / name, frame_meshes[f], "frame");
    }
  }
  if (contact_sheet) write_png(*render_file, *contact_sheet);
  if (report_file) {
    nlohmann::ordered_json r;
    r["motion"] = {{"file", *motion_file},
                   {"mapping", motion.mapping},
                   {"unit", bvh ? bvh->unit : std::string("m")},
                   {"up", up_axis_name(bvh ? bvh->up : UpAxis::POS_Y)},
                   {"source_fps", bvh ? bvh->fps() : sequence->fps},
                   {"fps", motion.fps},
                   {"frames", frames.size()},
                   {"first_frame", first},
                   {"leg_ratio", motion.leg_ratio}};
    nlohmann::ordered_json unmapped = nlohmann::ordered_json::array();
    for (const int j : motion.unmapped)
      unmapped.push_back(std::string(joint_name(j)));
    r["motion"]["unmapped_joints"] = std::move(unmapped);
    r["body"] = {{"source", sources[0]}, {"vertices", body.mesh.vertex_count()}};
    nlohmann::ordered_json gs = nlohmann::ordered_json::array();
    for (std::size_t g = 0; g < character.garment_count(); ++g) {
      const BlendWeights& b = character.garment_blend(g);
      nlohmann::ordered_json item = {{"name", character.garment_name(g)},
                                     {"type", garment_type_name(dressed[g].segmentation.type)},
                                     {"vertices", character.garment_rest(g).vertex_count()},
                                     {"layer", g},
                                     {"physical_weight", b.upper}};
      if (b.split)
        item["physical_weight_parts"] = {{"split_height_m", b.split_height},
                                         {"upper", b.upper},
                                         {"upper_vertices", b.upper_vertices},
                                         {"lower", b.lower},
                                         {"lower_vertices", b.lower_vertices}};
      gs.push_back(std::move(item));
    }
    r["garments"] = std::move(gs);
    r["method"] = animation.physics
                      ? "per frame: linear blend skinning of every layer; cloth physics against the moving body; "
                        "the blend of seed 001 eq. 8 with w_p from eq. 9; clean-up out of the body and layering "
                        "(eq. 7)"
                      : "per frame: linear blend skinning of every layer (eq. 8 with w_p = 0); clean-up out of the "
                        "body and layering (eq. 7)";
    const double n = frames.empty() ? 1.0 : double(frames.size());
    r["threads"] = animation.threads;
    r["timings_ms"] = {{"body", body_ms},
                       {"fit", fit_ms},
                       {"retarget", retarget_ms},
                       {"setup", setup_ms},
                       {"per_frame",
                        {{"lbs", sum.lbs_ms / n},
                         {"physics", sum.physics_ms / n},
                         {"blend", sum.blend_ms / n},
                         {"cleanup", sum.cleanup_ms / n},
                         {"layering", sum.layering_ms / n},
                         {"step", sum.total_ms / n},
                         {"worst_step", worst_frame_ms}}}};
    r["physics"] = {{"on", animation.physics},
                    {"restarts", restarts},
                    {"diverged", sum.diverged},
                    {"non_finite_replaced", sum.non_finite}};
    r["penetration"] = {{"worst_inside", worst_inside},
                        {"worst_inside_1mm", worst_inside_1mm},
                        {"worst_depth_mm", worst_depth},
                        {"worst_crossing_edges", worst_crossing},
                        {"worst_layer_offences", worst_layer}};
    r["frames"] = std::move(per_frame);
    write_file_atomically(*report_file, r.dump(2) + "\n");
  }
  if (!quiet) {
    const double n = frames.empty() ? 1.0 : double(frames.size());
    std::printf("animated %zu frames at %.0f fps (%s, mapping %s), physics %s: %.1f ms per frame (%.0f frames per "
                "second; LBS %.2f, physics %.1f, blend %.2f, clean-up %.1f, layering %.1f)\n",
                frames.size(), motion.fps, std::filesystem::path(*motion_file).filename().c_str(),
                motion.mapping.c_str(), animation.physics ? "on" : "off", sum.total_ms / n,
                sum.total_ms > 0 ? 1000.0 * n / sum.total_ms : 0.0, sum.lbs_ms / n, sum.physics_ms / n,
                sum.blend_ms / n, sum.cleanup_ms / n, sum.layering_ms / n);
    std::printf("after clean-up, worst frame: %zu garment vertices more than 1 mm inside the body (deepest %.1f mm), "
                "%zu edges through it, %zu layer offences\n",
                worst_inside_1mm, worst_depth, worst_crossing, worst_layer);
  }
  if (!quiet && (worst_inside_1mm > 0 || worst_crossing > 0 || worst_layer > 0))
    std::cerr << "vfit: warning: the per-frame clean-up left garments in the body or in each other on some frames "
                 "(see the report's frames)\n";
  if (!quiet && (sum.diverged > 0 || sum.non_finite > 0))
    std::cerr << "vfit: warning: the cloth diverged on " << sum.diverged << " garment-frames and " << sum.non_finite
              << " blended vertices were not finite; their skinned positions were used\n";
  return 0;
}

} // namespace vfit::cli
