// SPDX-License-Identifier: Apache-2.0
#include "segment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "geodesic.h"
#include "segment_parts.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using namespace segment_detail;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point& t) {
  const auto now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - t).count();
  t = now;
  return ms;
}

[[noreturn]] void reject(const std::string& why) { throw Error("garment", 0, "cannot segment: " + why); }

constexpr double MIN_OPENING = 0.05;       // of the garment's extent: smaller openings are holes, pockets
constexpr double BOTTOM_REACH = 0.05;      // of the height: a leg's hem is at the garment's bottom
constexpr double SLEEVE_RADII = 0.5;       // without a branch, an opening this many radii from its armpit ends a sleeve
constexpr double HANGING = 0.1;            // ... and hangs this many radii below it
constexpr double DRESS_LENGTH = 2;         // armhole depths below the armholes: a dress
constexpr double SKIRT_DIAMETERS = 5;      // a skirt is at most this many waist diameters tall
constexpr double MIN_PERSISTENCE = 0.02;   // of the largest distance: shallower branches are noise
constexpr double MIN_BRANCH_SHARE = 0.005; // of the vertices
constexpr double LOOP_SHARE = 0.2;         // share of an opening's vertices that puts it in a branch
constexpr double LOOP_SHARED = 0.05;       // share held by other branches that makes it a hole instead

double loop_radius(const BoundaryLoop& l) { return l.perimeter / (2 * std::numbers::pi); }

// An opening around the vertical mid-line (collar, waistband, hem), not off to one side (cuffs, leg hems).
bool is_central(const GarmentFrame& fr, const BoundaryLoop& l) {
  return std::abs(l.centroid.x() - fr.mid_x) < 0.5 * loop_radius(l);
}

struct Openings {
  std::vector<int> main; // indices of the significant openings of the main component
};

Openings find_openings(const GarmentFrame& fr, GarmentSegmentation& out) {
  const SurfaceGraph& g = *fr.graph;
  Openings o;
  std::size_t small = 0;
  for (int i = 0; i < int(g.loops.size()); ++i) {
    if (!fr.main[g.loops[i].vertices.front()]) continue;
    if (g.loops[i].perimeter >= MIN_OPENING * fr.extent && g.loops[i].vertices.size() >= 3)
      o.main.push_back(i);
    else
      ++small;
  }
  if (small > 0)
    out.warnings.push_back(std::to_string(small) + " small opening(s) (under 5 % of the garment's size) ignored");
  return o;
}

// Turns merge events into limbs: branches holding an off-centre opening and no central one.
// Each opening goes to the branch holding most of its vertices, if that is a fair share (a
// short wide sleeve holds only the far side of its cuff above the armpit's level) and no other
// branch holds a noticeable part (an opening shared between branches is a hole in one surface,
// like a dress's armhole with its strap, not the end of a limb).
std::vector<Limb> find_limbs(const GarmentFrame& fr, const Openings& open, const std::vector<MergeEvent>& events) {
  const SurfaceGraph& g = *fr.graph;
  std::vector<Limb> limbs;
  for (const MergeEvent& e : events) {
    std::vector<int> lateral(e.branches.size(), -1);
    std::vector<char> central(e.branches.size(), 0);
    for (std::size_t k = 0; k < open.main.size(); ++k) {
      const int li = open.main[k];
      if (li == fr.source) continue;
      const BoundaryLoop& l = g.loops[li];
      std::size_t best = 0, others = 0;
      int holder = -1;
      for (std::size_t i = 0; i < e.branches.size(); ++i) {
        const std::size_t in = e.branches[i].tag_counts[k];
        others += std::min(in, best);
        if (in > best) {
          best = in;
          holder = int(i);
        }
      }
      const double n = double(l.vertices.size());
      if (holder < 0 || double(best) < LOOP_SHARE * n || double(others) > LOOP_SHARED * n) continue;
      if (is_central(fr, l))
        central[holder] = 1;
      else if (lateral[holder] < 0 || l.perimeter > g.loops[lateral[holder]].perimeter)
        lateral[holder] = li;
    }
    for (std::size_t i = 0; i < e.branches.size(); ++i) {
      if (lateral[i] < 0 || central[i]) continue;
      Limb limb;
      limb.loop = lateral[i];
      limb.side = g.loops[limb.loop].centroid.x() > fr.mid_x ? 1 : -1;
      limb.saddle = e.saddle;
      limb.saddle_value = e.value;
      limb.birth = e.branches[i].birth_vertex;
      // A sleeve merges into a torso that goes on (another branch, not itself a limb, at least
      // half its size); a leg merges only with its twin.
      for (std::size_t j = 0; j < e.branches.size(); ++j)
        if (j != i && (lateral[j] < 0 || central[j]) && 2 * e.branches[j].vertex_count >= e.branches[i].vertex_count)
          limb.joins_trunk = true;
      limb.reaches_bottom = g.loops[limb.loop].min_y <= fr.min_y + BOTTOM_REACH * (fr.max_y - fr.min_y);
      // A limb merging at several saddles (first into noise, then into the torso) is kept
      // at its last, lowest-valued one: there it is whole.
      auto same = std::find_if(limbs.begin(), limbs.end(), [&](const Limb& l) { return l.loop == limb.loop; });
      if (same == limbs.end())
        limbs.push_back(std::move(limb));
      else if (limb.saddle_value < same->saddle_value)
        *same = std::move(limb);
    }
  }
  for (Limb& l : limbs)
    l.vertices = superlevel_component(g, *fr.f, l.birth, l.saddle_value);
  return limbs;
}

// One limb per side: the one with the longest opening; reports what was dropped.
std::vector<Limb> pair_up(std::vector<Limb> limbs, const char* what, GarmentSegmentation& out) {
  std::vector<Limb> best;
  for (int side : {-1, 1}) {
    int pick = -1, count = 0;
    for (int i = 0; i < int(limbs.size()); ++i)
      if (limbs[i].side == side) {
        ++count;
        if (pick < 0 || limbs[i].vertices.size() > limbs[pick].vertices.size()) pick = i;
      }
    if (count > 1)
      out.warnings.push_back(std::to_string(count) + " " + what + " branches on one side; kept the largest");
    if (pick >= 0) best.push_back(std::move(limbs[pick]));
  }
  return best;
}

// Tops and tubes: sleeves, a sleeveless top or dress, or a skirt; fills type, labels and key
// points (the §4.2 refinement of sleeves happens here too).
void classify_top(const GarmentFrame& fr, const Openings& open, const std::vector<Limb>& limbs,
                  GarmentSegmentation& out) {
  const SurfaceGraph& g = *fr.graph;
  const BoundaryLoop& src = g.loops[fr.source];
  std::vector<int> lateral;
  int hem = -1;
  for (int li : open.main) {
    if (li == fr.source) continue;
    if (!is_central(fr, g.loops[li]))
      lateral.push_back(li);
    else if (hem < 0 || g.loops[li].centroid.y() < g.loops[hem].centroid.y())
      hem = li;
  }
  if (hem >= 0 && g.loops[hem].centroid.y() >= src.centroid.y()) hem = -1;
  // The garment's bottom: its hem, or (open at the front) its lowest band.
  std::vector<std::int32_t> bottom;
  if (hem >= 0)
    bottom = g.loops[hem].vertices;
  else
    for (std::size_t v = 0; v < g.vertex_count(); ++v)
      if (fr.main[v] && g.points[v].y() <= fr.min_y + BOTTOM_REACH * (fr.max_y - fr.min_y))
        bottom.push_back(std::int32_t(v));

  std::vector<Arm> arms = find_arms(fr, lateral, limbs, bottom), sleeves;
  for (Arm& a : arms) {
    // Without a Reeb branch, a sleeve shows as an opening hanging below its armpit, some way
    // off; an armhole has its armpit at its own lowest point.
    const BoundaryLoop& l = g.loops[a.loop];
    const double radius = l.perimeter / (2 * std::numbers::pi);
    if (a.branch || (a.length >= SLEEVE_RADII * radius && g.points[a.armpit].y() > l.min_y + HANGING * radius))
      sleeves.push_back(std::move(a));
  }
  if (!sleeves.empty()) {
    if (sleeves.size() == 1) out.warnings.push_back("only one sleeve found; the other side is all torso");
    for (const Limb& l : limbs)
      for (const Arm& a : sleeves)
        if (l.loop == a.loop && l.joins_trunk)
          for (std::int32_t v : l.vertices)
            out.coarse_parts[v] = a.side > 0 ? GarmentPart::LEFT_SLEEVE : GarmentPart::RIGHT_SLEEVE;
    refine_sleeves(fr, sleeves, out);
    return;
  }
  if (arms.size() == 2) {
    // Two armholes: a sleeveless top, or a dress when it reaches well below them.
    if (hem < 0) reject("two armholes but no hem");
    const double armhole_bottom = std::min(g.points[arms[0].armpit].y(), g.points[arms[1].armpit].y());
    const double depth = src.max_y - armhole_bottom, below = armhole_bottom - g.loops[hem].max_y;
    out.key_points.p1 = g.points[arms[0].armpit];
    out.key_points.p2 = g.points[arms[1].armpit];
    if (below > DRESS_LENGTH * depth) {
      out.type = GarmentType::DRESS;
      const double waist = narrowest_girth_height(fr, armhole_bottom, g.loops[hem].max_y);
      out.key_points.waist_height = waist;
      for (std::size_t v = 0; v < g.vertex_count(); ++v)
        if (fr.main[v] && g.points[v].y() < waist) out.vertex_parts[v] = GarmentPart::SKIRT;
      out.coarse_parts = out.vertex_parts;
    } else {
      out.type = GarmentType::TEE;
      out.warnings.push_back("sleeveless top: reported as a tee without sleeves (all torso)");
    }
    return;
  }
  // A lone tube: a skirt when upright and no taller than a few waist diameters.
  if (hem < 0 || !lateral.empty()) reject("openings that make neither a top, nor trousers, nor a skirt");
  const BoundaryLoop& h = g.loops[hem];
  const double height = src.centroid.y() - h.centroid.y(), diameter = src.perimeter / std::numbers::pi;
  if (std::abs(src.normal.y()) < 0.8 || std::abs(h.normal.y()) < 0.8 || height > SKIRT_DIAMETERS * diameter)
    reject("a lone tube that is not an upright skirt (level openings, at most 5 waist diameters tall)");
  out.type = GarmentType::SKIRT;
  std::fill(out.vertex_parts.begin(), out.vertex_parts.end(), GarmentPart::SKIRT);
  out.coarse_parts = out.vertex_parts;
}

} // namespace

GarmentSegmentation segment_garment(const Mesh& garment, const SegmentOptions& options) {
  GarmentSegmentation out;
  if (garment.vertex_count() == 0 || garment.face_count() == 0) reject("the mesh has no faces");
  auto t0 = Clock::now(), t = t0;

  const SurfaceGraph g = build_surface_graph(garment);
  const std::size_t nv = g.vertex_count();
  GarmentFrame fr;
  fr.graph = &g;
  fr.main.assign(nv, 0);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  std::size_t main_count = 0;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!g.points[v].allFinite()) reject("vertex " + std::to_string(v) + " has a non-finite position");
    if (g.component[v] != 0) continue;
    fr.main[v] = 1;
    ++main_count;
    lo = lo.cwiseMin(g.points[v]);
    hi = hi.cwiseMax(g.points[v]);
  }
  if (main_count < 10) reject("fewer than 10 connected vertices");
  if (!(g.mean_edge > 0) || !((hi - lo).maxCoeff() > 0)) reject("the mesh has no extent");
  fr.mid_x = 0.5 * (lo.x() + hi.x());
  fr.half_width = 0.5 * (hi.x() - lo.x());
  fr.min_y = lo.y();
  fr.max_y = hi.y();
  fr.extent = (hi - lo).maxCoeff();
  if (g.component_count > 1)
    out.warnings.push_back(std::to_string(g.component_count - 1) + " extra component(s) with " +
                           std::to_string(nv - main_count) + " vertices labelled as the main part; only the largest (" +
                           std::to_string(main_count) + " vertices) is segmented");
  const Openings open = find_openings(fr, out);
  if (open.main.empty()) reject("no openings: a closed surface is not a garment");
  if (open.main.size() == 1) reject("a single opening: a sheet or a band, not a garment with a body inside");
  for (int li : open.main)
    if (is_central(fr, g.loops[li]) && (fr.source < 0 || g.loops[li].max_y > g.loops[fr.source].max_y)) fr.source = li;
  if (fr.source < 0) reject("no opening around the vertical mid-line (is the garment upright, Y up?)");
  out.timings.graph_ms = ms_since(t);

  // §4.1: geodesic distance from the source opening's centre: each of its vertices starts at
  // its straight-line distance from the centre, as if the opening were spanned by a flat disc.
  const BoundaryLoop& src = g.loops[fr.source];
  out.key_points.source = src.centroid;
  std::vector<GeodesicSeed> seeds;
  for (std::int32_t v : src.vertices)
    seeds.push_back({v, (g.points[v] - src.centroid).norm()});
  out.geodesic = geodesic_distance(g, seeds);
  fr.f = &out.geodesic;
  double f_max = 0;
  for (double d : out.geodesic)
    if (std::isfinite(d)) f_max = std::max(f_max, d);
  out.timings.geodesic_ms = ms_since(t);

  const int levels =
      options.reeb_levels > 0 ? options.reeb_levels : std::clamp(int(std::lround(f_max / (3 * g.mean_edge))), 8, 64);
  out.reeb_graph = build_reeb_graph(g, out.geodesic, levels);
  std::vector<std::int32_t> opening_of(nv, -1);
  for (std::size_t k = 0; k < open.main.size(); ++k)
    for (std::int32_t v : g.loops[open.main[k]].vertices)
      opening_of[v] = std::int32_t(k);
  const auto events = merge_tree(g, out.geodesic, MIN_PERSISTENCE * f_max,
                                 std::max<std::size_t>(3, std::size_t(MIN_BRANCH_SHARE * double(main_count))),
                                 opening_of, int(open.main.size()));
  out.timings.reeb_ms = ms_since(t);

  const std::vector<Limb> limbs = find_limbs(fr, open, events);
  out.coarse_parts.assign(nv, GarmentPart::TORSO);
  out.vertex_parts.assign(nv, GarmentPart::TORSO);
  // Legs merge only with each other and end at the bottom of the garment. (The sleeves of an
  // open-front jacket merge with each other too, but its hem hangs lower than its cuffs.)
  std::vector<Limb> legs;
  for (const Limb& l : limbs)
    if (!l.joins_trunk && l.reaches_bottom) legs.push_back(l);
  legs = pair_up(std::move(legs), "leg", out);
  if (legs.size() == 1) reject("a single leg-like branch: neither trousers nor a top");
  if (legs.size() == 2) {
    for (const Limb& l : legs)
      for (std::int32_t v : l.vertices)
        out.coarse_parts[v] = l.side > 0 ? GarmentPart::LEFT_LEG : GarmentPart::RIGHT_LEG;
    out.timings.classify_ms = ms_since(t);
    refine_legs(fr, legs, options.leg_slope, out);
  } else {
    classify_top(fr, open, limbs, out);
    out.timings.classify_ms = ms_since(t);
  }
  out.timings.refine_ms = ms_since(t);
  out.timings.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return out;
}

UprightSegmentation segment_upright(const std::string& name, Mesh& mesh, std::optional<UpAxis> up,
                                    std::optional<Facing> facing, const SegmentOptions& options) {
  // A top's collar sits higher at the back than its neckline at the front: a top edge leaning
  // forward by this share of the depth means a top stored back to front (measured tops lean
  // back by 0.06-0.30; the margin is two thirds of the smallest).
  constexpr double FORWARD_LEAN = 0.04;
  std::vector<UpAxis> tries = {UpAxis::POS_Y, UpAxis::POS_Z};
  if (up)
    tries = {*up};
  else if (detect_up_axis(mesh.positions, mesh.triangles) == UpAxis::POS_Z)
    tries = {UpAxis::POS_Z, UpAxis::POS_Y};
  // The surface gives the up axis but not its sign (detect_up_axis()): a garment recognised
  // neither way is tried upside down along the axis tried first (trousers stored upside down
  // read as a top with two armholes and no hem).
  if (!up) tries.push_back(tries[0] == UpAxis::POS_Z ? UpAxis::NEG_Z : UpAxis::NEG_Y);
  const std::vector<float> as_given = mesh.positions;
  std::string first_error;
  for (UpAxis axis : tries) {
    mesh.positions = as_given;
    rotate_to_y_up(mesh.positions, axis);
    const std::vector<float> turned = mesh.positions;
    const GarmentTilt tilt = estimate_tilt(mesh);
    // Straightened first; as it stood when the straightened garment is not recognised.
    for (const bool straighten : {true, false}) {
      if (straighten && !tilt.changed()) continue;
      mesh.positions = turned;
      UprightSegmentation out;
      out.up = axis;
      if (straighten) {
        apply_tilt(mesh.positions, tilt);
        out.tilt = tilt;
      }
      if (facing) {
        out.facing = *facing;
      } else if (lateral_axis_is_z(mesh.positions, mesh.triangles)) {
        out.facing = top_edge_lean(mesh.positions, 0) <= 0 ? Facing::POS_X : Facing::NEG_X;
        out.front_known = false;
      }
      rotate_to_face_z(mesh.positions, out.facing);
      try {
        out.segmentation = segment_garment(mesh, options);
      } catch (const Error& e) {
        if (first_error.empty()) first_error = e.what();
        continue;
      }
      const bool sleeved =
          out.segmentation.type == GarmentType::TEE || out.segmentation.type == GarmentType::LONG_SLEEVE;
      if (!facing && sleeved) {
        const double lean = top_edge_lean(mesh.positions, 2);
        if (lean >= FORWARD_LEAN) {
          // Stored back to front: turned round, its sleeves swap sides.
          rotate_to_face_z(mesh.positions, Facing::NEG_Z);
          out.facing = compose_facing(out.facing, Facing::NEG_Z);
          out.segmentation = segment_garment(mesh, options);
        }
        if (std::abs(lean) >= FORWARD_LEAN) out.front_known = true;
      }
      return out;
    }
  }
  mesh.positions = as_given;
  throw Error(name, 0,
              "not a recognisable garment: " + first_error +
                  (tries.size() > 1 ? " (tried with " + up_axis_name(tries[0]) + ", " + up_axis_name(tries[1]) +
                                          " and " + up_axis_name(tries[2]) + " up)"
                                    : std::string()));
}

} // namespace vfit
