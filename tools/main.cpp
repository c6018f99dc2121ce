// SPDX-License-Identifier: Apache-2.0
// vfit: automatic 3D garment fitting and cloth simulation — the command-line tool.
// Exit codes: 0 success, 2 bad input or usage (vfit::Error), 1 internal failure.
#include <cstring>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "args.h"
#include "commands.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/version.h"

namespace {

constexpr const char* MAIN_HELP = R"(vfit — fits 3D garments onto 3D bodies and simulates the cloth

usage: vfit <command> [options]    (vfit <command> --help for details)

commands:
  info FILE       counts, bounding box, units, components, boundary loops, manifoldness,
                  watertightness and Euler characteristic of a mesh file
  convert IN OUT  converts between OBJ, PLY, OFF, STL (read) and OBJ, PLY, OFF, STL, GLB (write)
  devices         the compute backends: TBB threads and OpenCL platforms/devices
  body            builds the parametric mannequin (measurements, preset, pose, rigged glTF)
  garment TYPE    generates a catalogue garment (tee, long-sleeve, trousers, shorts, dress, skirt)
  measure BODY    the 11 body measurements of any body, rigged or bare
  render MESH...  PNG pictures (front, side, back) of a body and its garments
  fit             fits garments onto a body: timed stages, fitted meshes, JSON report, PNG
  animate         dresses a body and plays a motion-capture clip (BVH) on it: animated .glb
  bench STUDY     timing studies: table1 (seed 000 Table 1's nine pairs), sweep (10^3-10^6)
  demo            the built-in demonstration (README's main job)

every command takes --threads N: at most N worker threads (default: every core)
mesh formats read: .obj .ply .off .stl .glb .gltf
exit codes: 0 ok, 2 bad input (the message names the file and the element), 1 internal failure
)";

constexpr const char* INFO_HELP = R"(usage: vfit info FILE [--json] [--units m|dm|cm|mm|in] [--repair]

Reads and validates FILE, then prints its vertex/face/edge counts, attributes (UVs, normals,
labels), bounding box and extent, units (detected from the extent and position unless --units states them),
surface area, connected components, boundary loops, manifoldness, orientation, watertightness
and Euler characteristic.
  --json      machine-readable output (keys include vertices, faces, units, components,
              boundary_loops, manifold, watertight, euler_characteristic)
  --units U   the file's length unit; skips detection
  --repair    drop degenerate and duplicate faces (with a warning) instead of failing
)";

constexpr const char* CONVERT_HELP = R"(usage: vfit convert IN OUT [--to-metres] [--units U] [--repair] [--quiet]

Reads and validates IN and writes OUT in the format of its extension (.obj with UVs, .ply binary,
.off, .stl binary, .glb). OUT is written to a temporary file and renamed; IN is never
overwritten (OUT == IN is refused).
  --to-metres  scale coordinates to metres (units detected from the extent, or --units)
  --units U    IN's unit: m, dm, cm, mm or in (inches are never detected)
  --repair     drop degenerate and duplicate faces instead of failing
)";

constexpr const char* DEVICES_HELP = R"(usage: vfit devices [--json]

Lists the compute backends: TBB's thread count and every OpenCL platform and device, with the
one selected by default. Select a device for the OpenCL backend with --device (N, P:D, gpu,
cpu, or a substring of its name) or the environment variable VFIT_OPENCL_DEVICE.
)";

constexpr const char* DEMO_HELP = R"(usage: vfit demo [--out DIR] [--corpus DIR] [--device SEL] [--quiet]

The built-in demonstration: a catalogue tee (M) and trousers (P2), modelled in T-pose and
written to DIR as OBJ, are fitted by `vfit fit` onto the mannequin posed by its skeleton (arms
down, left knee bent): DIR/fit.glb (body and garments), DIR/fit_report.json (stage times,
penetration before/after, verdict) and DIR/fit_views.png (front, side, back). Then it measures
the mannequin back against its request; when the shared corpus is present (--corpus,
$VFIT_CORPUS, or ../shared/corpus) it reads and validates its MakeHuman body and garments
(detecting their units); prints a summary table, computes vertex normals on the serial, TBB and
OpenCL backends and compares them, and writes DIR/demo.glb (all meshes in metres, one named
mesh each) and DIR/demo.json. DIR defaults to ./vfit_demo.
)";

constexpr const char* BODY_HELP =
    R"(usage: vfit body [--preset NAME] [--height M] [--chest M] ... [--pose-rest apose|tpose]
                 [--from FILE [--betas B1,B2,...] [--joints-in FILE.json] [--units U] [--up A]
                 [--facing F] [--repair]]
                 [--pose NAME|FILE.json] [--vertices N] [--out FILE] [--joints FILE.json]
                 [--rigged FILE.glb] [--quiet]
       vfit body --scan FILE [--units U] [--up A] [--facing F] [--out FILE] [--joints FILE.json] [--rigged FILE.glb]
                 [--pose NAME|FILE.json] [--pose-out FILE.json] [--quiet]

Builds a body and writes it, posed. --from takes a body you bring instead of the mannequin: an
SMPL-format model (.npz: v_template, shapedirs, posedirs, J_regressor, weights, kintree_table,
f) with shape --betas; a rigged glTF (.glb/.gltf; SMPL, Mixamo or MakeHuman bone names, or
--rig-mapping FILE.json); or a plain mesh (a scan) whose joints come from --joints-in or are
estimated from its geometry. A plain mesh (and --scan) may be stored Y up facing +Z or Z up
facing -Y (Blender, scanners): the up axis is read from the surface and the body turned
upright, with a warning; --up +y|+z|-z|-y|+x|-x forces the file's up axis (outputs are Y up).
A plain mesh whose joints are estimated and whose feet do not point to +Z is tried turned to
face +Z from -z, +x and -x, with a warning; --facing +z|-z|+x|-x states where it faces. Meshes
wound inconsistently or inside out are re-wound, and holes are capped for joint estimation and
for --scan's fit (the rigged scan keeps its own surface), each with a warning.

Without --from, builds the built-in parametric mannequin from the 11 measurements of seed 004 (metres):
--height, --crotch-height, --knee-height, --arm-length, --forearm-length, --shoulder-width,
--chest, --waist, --hip, --thigh, --calf (girths). --preset starts from a body type:
average (default), banana, pear, apple, hourglass, tall, petite. The mesh has --vertices
vertices (default 7000), is watertight, and reproduces the requested girths; the table printed
compares requested and measured values.
  --pose P        pose the body (linear blend skinning): a pose JSON file mapping canonical
                  joint names to axis-angle vectors in radians (plus optional global_orient
                  and translation), or a built-in pose: arms_down, arms_raised, elbows_bent,
                  walking, knee_bent, legs_apart, demo, contrapposto, tpose, apose
  --out FILE      the body mesh (.obj, .ply, .glb, ...)
  --joints FILE   the 24 canonical joints (posed) as {"joints": {"pelvis": [x, y, z], ...}}
  --keypoints F   fit the mannequin's pose and shape to a photo's 2D keypoints (OpenPose BODY_25
                  or COCO-18 JSON, LSP {"layout": "lsp", "keypoints": [...]}, or {"joints":
                  {name: [x, y, c]}}); prints the fit's stages, iterations, ms and reprojection error
  --image-size W H  the photo's size in px (OpenPose files carry none); --focal F in px
                  (default 1.2 x the longer side); --keypoint-layout auto|body25|coco18|lsp|named
  --pose-out FILE the pose written (pose JSON), e.g. for `vfit fit --body B.glb --pose FILE`
  --rigged FILE   the rigged rest-pose body as glTF binary (.glb): 24 joint nodes with SMPL
                  names, a skin with inverse bind matrices, JOINTS_0/WEIGHTS_0
  --scan FILE     fit the mannequin's pose and shape to a body scan (mesh or point cloud, any
                  units detected or --units, Y or Z up as above; seed 001 eq. 3-4) and rig the scan
                  with weights interpolated from the fitted body; prints stages, iterations, ms
                  and the scan-to-body distance. --rigged writes the rigged scan in its own pose,
                  --joints the fitted joints, --pose-out the fitted pose (relative to the T-pose),
                  --out the scan, or with --pose P the rigged scan driven to P (T-pose-relative)
)";

constexpr const char* GARMENT_HELP =
    R"(usage: vfit garment TYPE --out FILE [--size S] [--vertices N] [--pose tpose|apose]
                    [--preset NAME] [--height M] [--chest M] ... [--quiet]

Generates a catalogue garment around the built-in mannequin: TYPE is tee, long-sleeve,
trousers, shorts, dress or skirt; S is XS, S, M (default), L, XL, XXL, or P1 (tight), P2
(good), P3 (loose), P4 (too large to stay up) for trousers; N vertices exactly (default 5000);
the garment's own pose (default tpose), independent of any body. The body it is sized for takes
the same measurement flags as `vfit body`. Writes the mesh (with UVs, parts as groups) and
FILE's stem + .labels.json: {"part_names": [...], "vertex_parts": [one per vertex]}.
)";

constexpr const char* MEASURE_HELP =
    R"(usage: vfit measure BODY [--json] [--units U] [--joints-in FILE.json] [--betas B1,B2,...]
                    [--rig-mapping FILE.json]

Measures any body in its rest pose (upright, arms away from the torso): the 11 measurements of
seed 004 (height, crotch height, knee height, arm and forearm length, shoulder width; chest,
waist, hip, thigh and calf girths as convex-hull perimeters of horizontal sections). BODY is
"mannequin" (with the `vfit body` flags), an SMPL-format model (.npz, with --betas), a rigged
glTF (.glb/.gltf; bones mapped to the canonical joints by name, or by --rig-mapping), or a plain
mesh (a scan) whose joints come from --joints-in or are estimated from its geometry. Units are
detected (m, dm, cm, mm) unless --units states them.
)";

constexpr const char* RENDER_HELP = R"(usage: vfit render MESH... --out FILE.png [--size N] [--views front,side,back]
                   [--scalar FILE.json] [--separate] [--perspective] [--supersampling N]
                   [--no-outlines] [--quiet]

Ray-casts pictures of meshes on vfit's Embree BVH (no GPU or display needed) so that a person
can judge a fit at a glance. The first MESH is the body (skin-grey), the rest are garments
(blue, orange, green, purple, yellow), all in the same units; a single .glb/.gltf holding
several meshes (such as `vfit demo`'s demo.glb) is split into them, the first being the
body. Each view is N × N pixels (default 512), framed on the bounding box of all meshes at one
common scale, with smooth shading, outlines at silhouettes and hems, and the inside of open
garments darker. Views are composited side by side with their names into FILE.png.
  --views LIST      which views, in order (default front,side,back): front looks from +Z
                    (the body faces +Z), side from +X (the body's left), back from -Z
  --scalar FILE     false colour by a per-vertex value, with a legend (min, middle, max):
                    {"values": [one number per vertex, or null], "mesh": 1, "name": "strain",
                    "min": ..., "max": ...}; "mesh" is an index into the MESH list (default:
                    the first garment, or the body when alone); min/max default to the
                    values' range; a range across 0 uses a blue-grey-red map
  --separate        one file per view instead: FILE's stem + _front.png, _side.png, _back.png
  --perspective     a 30-degree pinhole camera instead of the orthographic default
  --supersampling N N x N rays per pixel for anti-aliasing, 1-4 (default 2)
  --no-outlines     no dark lines at silhouettes and where one mesh meets another
Files are written atomically (a temporary file renamed); nothing is written on error.
)";

constexpr const char* ANIMATE_HELP =
    R"(usage: vfit animate --garment FILE [--garment FILE ...] --motion FILE.bvh|.glb|.json
                    [--body mannequin|FILE] [body flags] [--mapping FILE.json] [--fps N]
                    [--frames A:B] [--physics on|off] [--threads N] [--out FILE.glb]
                    [--frames-dir DIR] [--report FILE.json]
                    [--render FILE.png [--render-every N] [--render-size N] [--render-stages]]
                    [--no-simulation] [--quiet] [--progress]

Dresses a body and plays a motion-capture clip on it (seed 001 §7). The garments are fitted onto
the body at rest (its rest pose, where its skin weights are bound; the fit of `vfit fit`, with the
cloth simulated unless --no-simulation), skinned to the body's skeleton (the body's weights at
each garment vertex's closest point, a skirt's or dress's hem split between both hips, diffused
over the garment), then played frame by frame, inner garment first: linear blend skinning (LBS);
each garment's cloth carried by the skinning and stepped against the posed body (two implicit
steps per 30 fps frame, leashed to the skinned garment); the blend of eq. 8 with w_p from eq. 9
(skirts and dresses in an upper and a lower part); and a clean-up: vertices out of the body,
edges through it cleared, each garment outside the ones under it (eq. 7).
The clip (BVH: any channel order, its unit and up axis read from its skeleton) is retargeted onto
the body: its joint names are matched to a built-in convention (SMPL, Mixamo, CMU, MotionBuilder,
DAZ/cgspeed, MakeHuman) or to --mapping's JSON ({"pelvis": "Hips", "left_hip": "LeftUpLeg",
...}); its rest pose (T or A) is aligned bone by bone; its root motion is scaled by the legs'
length ratio. A .glb or .gltf motion is the first animation of a rigged glTF (its first skin's
joints, sampled at its keyframes' rate), retargeted the same way. A .json motion is our own
poses, {"fps": N, "frames": [pose, ...]}, each pose as --pose FILE.json reads it (SMPL joint
names, axis-angle radians, a translation in m).
  --fps N          resample the clip to N frames per second (slerp); default: the clip's own
  --frames A:B     only frames A to B of the (resampled) clip, 0-based, both included
  --physics off    LBS and the clean-up only (eq. 8 with w_p = 0); default on
  --threads N      threads per frame (default: every core)
  --out FILE.glb   the body and garments skinned to one skeleton, each with a material, the clip
                   as a glTF animation, and each garment's frames beyond its skinning as morph
                   targets, one per frame (plays in any glTF viewer)
  --frames-dir DIR one OBJ per frame (frame_00000.obj, ...), the body and garments as one mesh
  --render FILE.png  a contact sheet: every Nth frame (--render-every, default: 8 frames in all)
                   seen from the side, --render-size pixels square each (default 256), in rows of 8;
                   --render-stages: each frame as a column of three, skinned, cloth and final
  --report FILE    JSON: the clip (mapping, unit, up axis, rates, leg ratio, unmapped joints),
                   the garments' w_p, the timings per stage, and per frame the stage times, what
                   the clean-up moved, the garments' edge strain (skinned, cloth, final) and where
                   they stand as the fit measures them: vertices inside the body (count, count
                   over 1 mm, deepest mm), edges through it and layer offences
)";

constexpr const char* FIT_HELP =
    R"(usage: vfit fit --garment FILE [--garment FILE ...] [--body mannequin|FILE ...] [body flags]
                [--pose NAME|FILE.json] [--out FILE.obj|.ply|.glb] [--report FILE.json]
                [--render FILE.png] [--render-size N] [--no-simulation] [--backend serial|tbb] [--threads N]
                [--fabric NAME] [--clearance M] [--max-sim-seconds S] [--garment-units U] [--garment-scale S]
                [--garment-up auto|+y|+z|-z|-y|+x|-x] [--garment-facing auto|+z|-z|+x|-x] [--repair]
                [--layer-order auto|type|given] [--cloth-proxy auto|on|off] [--proxy-vertices N]
                [--quiet] [--debug DIR] [--progress] [--keypoints FILE.json [--image-size W H] [--focal F]]

Fits garments onto a body (seed 000 §4-6): per garment, units -> segmentation and type
detection -> part skeletons -> skeleton driving onto the posed body's bones (eq. 5-15, with
the placement of eq. 16-17; garments it cannot drive, e.g. skirts, get the coarse move alone)
-> penetration removal against the body and the garments under it, edges crossing the body
included -> cloth simulation to rest (stops at --max-sim-seconds of simulated time, default 3;
a diverged simulation is discarded and reported) -> fit feedback (strain, ease, size verdict).
Several garments are dressed inner to outer: as they lie in their files where they overlap in
one frame (an outfit file, or files exported together: a tee under overalls' bib, a shirt
tucked in), bottoms before tops otherwise (see --layer-order).
--body takes the same sources and flags as `vfit body --from` (default: the mannequin; use
--pose-rest apose|tpose and the measurement flags); --pose poses it. Several --body options fit
the same garments onto each body (the flags and --pose apply to all): the garments are read,
segmented and rigged once, and each body's outputs get its name before their extension
(--out fit.glb -> fit.walking.glb, fit.mannequin.glb; numbered when two names repeat). Garments may be in any
length unit (detected, or --garment-units; --garment-scale for an exporter's odd scale) and stored Y up facing +Z (OBJ, glTF) or Z up facing
-Y (Blender, scanners): the up axis is read from the surface (its left-right mirror symmetry
and its normals) and a Z-up garment is turned upright, with a warning in the report. Upright,
a garment whose left-right axis is Z (it faces +X or -X) is turned to face +Z, and a top with
sleeves stored back to front (its collar's back lower than its neckline) is turned round; for
bottoms turned a quarter, front and back are not told apart (see the report's warning).
  --garment-scale S metres per unit of the garment files (e.g. 0.0127), for a scale that is no
                    length unit; a garment whose size fits the body in no unit is refused
  --garment-up A    the garments' up axis in their files, when auto (the default) misreads it
  --garment-facing F  where the garments' fronts face once upright, when auto misreads it
  --layer-order R   auto (default): read from the garments' geometry as given where they
                    overlap in one frame, bottoms before tops elsewhere; type: bottoms before
                    tops; given: the --garment order (and an outfit file's order), innermost first
  --cloth-proxy M   auto (default): garments of more than 25,000 vertices are simulated on a
                    coarse proxy of --proxy-vertices (seed 004: the fine garment is rebuilt
                    from the simulated proxy, then its penetration removed); on: every garment;
                    off: every garment at its own resolution
  --proxy-vertices N  the proxy's vertex count (default 15000)
  --repair          drop degenerate and duplicate faces of the garments and of a body mesh
                    file (with a warning each) instead of failing on them
  --keypoints F     the body from a photo: the mannequin's measurements and pose fitted to the
                    photo's 2D keypoints (as `vfit body --keypoints`; instead of --pose)
  --out FILE        .glb: the body and each garment as named meshes, each skinned to the body's
                    skeleton (bound where the body stands) with a material of its own colour,
                    ready to pose in Blender or a game engine; .obj/.ply: the garments, one
                    group per garment
  --threads N       worker threads (default: every core)
  --report FILE     JSON: vfit version and commit, timings_ms per stage, penetration before/after (inside_count,
                    max_depth_mm, crossing_edges), verdict (falls off, tight, loose, good),
                    machine, and per garment the stages, regions (strain, ease) and reason
  --render FILE     front, side and back views of body and garments (N x N px each, default 512)
  --fabric NAME     cotton_jersey (default), denim, silk, wool
  --clearance M     gap left between garment and body in metres (default 0.003)
  --debug DIR       write each garment after each stage into DIR (created when absent):
                    <garment>_NN_<stage>.ply with segmentation labels as vertex colours,
                    part skeletons as OBJ polylines, the posed body, legend.txt; written as
                    the stages finish, once every garment has been recognised
  --progress        one line per stage per garment on stderr (the default when stderr is a
                    terminal; --quiet turns it off)
A table of stage times goes to stdout (not with --quiet). Nothing is written on error.
)";

constexpr const char* BENCH_HELP =
    R"(usage: vfit bench table1 [--runs N] [--rows N] [--garment NAME] [--json FILE] [--no-simulation] [--min-speedup X] [--quiet]
       vfit bench sweep [--garment TYPE] [--max-vertices N] [--runs N] [--json FILE] [--quiet]

table1: the nine garment/body pairs of seed 000 Table 1, rebuilt from the catalogue with the
paper's vertex counts on the mannequin in each row's pose, fitted N times (default 5) without
simulation (the table has none). Prints per pair the paper's milliseconds, ours (median and
minimum) and the speed-up for segmentation, deformation (part skeletons, driving and the coarse
move), penetration removal and their total; then, in its own column, the cloth simulation to
rest from one more fit with it on (not part of the total; --no-simulation skips it). --json
writes one row per pair with garment, vertices, faces and per stage paper_ms, median_ms,
min_ms and speedup, the simulation's ms, outcome and steps, plus the machine.
--rows N runs only the first N pairs, --garment NAME only the pairs of that garment ("Shorts 1").
--min-speedup X exits with status 1, naming the pairs, when a pair's total is under X times the
paper's (the regression check of `ctest -L bench`).
sweep: one garment (default tee) at 1,000 to --max-vertices (default 100,000; up to 10^6)
vertices in steps of sqrt(10), the same stages, and each stage's growth exponent k (time ∝ V^k).
Garment generation is not timed.
)";

bool wants_help(const std::vector<std::string>& args) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") return true;
  return false;
}

int dispatch(const std::string& command, std::vector<std::string> rest) {
  using namespace vfit::cli;
  struct Command {
    const char* name;
    const char* help;
    int (*run)(Args&);
  };
  static const Command commands[] = {{"info", INFO_HELP, run_info},          {"convert", CONVERT_HELP, run_convert},
                                     {"devices", DEVICES_HELP, run_devices}, {"demo", DEMO_HELP, run_demo},
                                     {"body", BODY_HELP, run_body},          {"garment", GARMENT_HELP, run_garment},
                                     {"render", RENDER_HELP, run_render},    {"fit", FIT_HELP, run_fit},
                                     {"bench", BENCH_HELP, run_bench},       {"measure", MEASURE_HELP, run_measure},
                                     {"animate", ANIMATE_HELP, run_animate}};
  for (const auto& c : commands) {
    if (command != c.name) continue;
    if (wants_help(rest)) {
      std::cout << c.help;
      return 0;
    }
    Args args(std::move(rest), command);
    // --threads N, for every command: the process's TBB parallelism capped at N (the engine's
    // arenas included), and the commands that create an Engine give it N.
    std::optional<tbb::global_control> limit;
    if (const auto threads = args.value("threads")) {
      set_thread_limit(Args::to_int("--threads", *threads, 1, 1024));
      limit.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(thread_limit()));
    }
    return c.run(args);
  }
  throw vfit::Error("vfit", 0, "unknown command '" + command + "' (see vfit --help)");
}

// Keeps freed memory in the process instead of returning it to the system after every fit:
// glibc trims the heap's top and unmaps large blocks as they are freed, so the next fit (a
// bench's next run, the next garment or body) touches fresh pages again. Measured with `vfit
// bench table1 --runs 9`, quiet: Shorts 1's penetration removal 11.5 -> 9.2 ms, all nine rows
// 181 -> 176-178 ms (the same removal run repeatedly in one warm heap, vfit_penetration_bench,
// takes 9.3 ms either way). Apps that link the engine and fit many garments can do the same.
void keep_freed_memory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 64 << 20);  // blocks below 64 MB come from the heap
  mallopt(M_TRIM_THRESHOLD, 256 << 20); // the heap keeps up to 256 MB free at its top
#endif
}

} // namespace

int main(int argc, char** argv) {
  keep_freed_memory();
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    std::cout << MAIN_HELP;
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "vfit " << vfit::version() << " (" << vfit::git_commit() << ")\n";
    return 0;
  }
  try {
    const std::string command = args[0];
    return dispatch(command, std::vector<std::string>(args.begin() + 1, args.end()));
  } catch (const vfit::Error& e) {
    std::cerr << "vfit: error: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    std::cerr << "vfit: internal error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "vfit: internal error: " << e.what() << "\n";
    return 1;
  }
}
