// SPDX-License-Identifier: Apache-2.0
#include "section_tracks.h"

#include <algorithm>
#include <cmath>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// A part's area changes far less than this from one level to the next (3 mm apart).
constexpr double TRACK_AREA_RATIO = 0.3;

// The largest loop of at least `min_area` (m²) containing q (in-plane coordinates), or −1.
int largest_containing(const std::vector<PlaneSection>& loops, const Eigen::Vector2d& q, double min_area) {
  int best = -1;
  for (std::size_t j = 0; j < loops.size(); ++j)
    if (loops[j].area >= min_area && loops[j].contains(q) &&
        (best < 0 || loops[j].area > loops[std::size_t(best)].area))
      best = int(j);
  return best;
}

} // namespace

BodySlices::BodySlices(const Mesh& mesh, int count) {
  const PlaneSlicer slicer(mesh, Eigen::Vector3d::UnitY());
  floor = slicer.min_level();
  top = slicer.max_level();
  height = top - floor;
  step = height / std::max(count, 1);
  levels.resize(std::size_t(std::max(count, 1)));
  for (std::size_t i = 0; i < levels.size(); ++i)
    levels[i] = slicer.sections(y(int(i)));
}

int BodySlices::index(double at) const {
  return std::clamp(int(std::lround((at - floor) / step - 0.5)), 0, int(levels.size()) - 1);
}

SectionTrack follow_part(const BodySlices& s, int start, int first, int dir, double nearest,
                         const std::function<bool(int)>& stop) {
  SectionTrack track(s.levels.size(), -1);
  track[std::size_t(start)] = first;
  const PlaneSection* prev = &s.levels[std::size_t(start)][std::size_t(first)];
  for (int i = start + dir; i >= 0 && i < int(s.levels.size()) && !(stop && stop(i)); i += dir) {
    const auto& loops = s.levels[std::size_t(i)];
    const Eigen::Vector2d q = prev->centroid_uv;
    const double min_area = TRACK_AREA_RATIO * prev->area;
    int j = largest_containing(loops, q, min_area);
    for (std::size_t k = 0; j < 0 && k < loops.size(); ++k)
      if (loops[k].area >= min_area && (loops[k].centroid_uv - q).norm() < nearest &&
          (j < 0 || (loops[k].centroid_uv - q).norm() < (loops[std::size_t(j)].centroid_uv - q).norm()))
        j = int(k);
    if (j < 0) j = largest_containing(loops, q, 0); // the part really narrows (the neck above the shoulders)
    if (j < 0) break;
    track[std::size_t(i)] = j;
    prev = &loops[std::size_t(j)];
  }
  return track;
}

const PlaneSection* loop_at(const BodySlices& s, const SectionTrack& track, int level) {
  const int j = track[std::size_t(level)];
  return j < 0 ? nullptr : &s.levels[std::size_t(level)][std::size_t(j)];
}

Eigen::Vector3d centroid_at(const BodySlices& s, const SectionTrack& track, double y) {
  const double f = std::clamp((y - s.floor) / s.step - 0.5, 0.0, double(s.levels.size() - 1));
  const int i0 = int(std::floor(f)), i1 = std::min(i0 + 1, int(s.levels.size()) - 1);
  const PlaneSection *a = loop_at(s, track, i0), *b = loop_at(s, track, i1);
  if (a && b) return a->centroid + (f - i0) * (b->centroid - a->centroid);
  if (!a && !b) throw Error("joint estimation", 0, "no section of the body part at height " + std::to_string(y) + " m");
  return a ? a->centroid : b->centroid;
}

Eigen::Vector3d axis_at(const BodySlices& s, const SectionTrack& track, double lo, double hi, double y) {
  Eigen::Matrix2d ata = Eigen::Matrix2d::Zero(), atb = Eigen::Matrix2d::Zero(); // atb's columns: x, z
  for (int i = s.index(lo); i <= s.index(hi); ++i)
    if (const PlaneSection* l = loop_at(s, track, i)) {
      const Eigen::Vector2d a(1, l->centroid.y());
      ata += a * a.transpose();
      atb.col(0) += a * l->centroid.x();
      atb.col(1) += a * l->centroid.z();
    }
  if (ata(0, 0) < 2) return centroid_at(s, track, y);
  const Eigen::Matrix2d c = ata.ldlt().solve(atb);
  return {c(0, 0) + c(1, 0) * y, y, c(0, 1) + c(1, 1) * y};
}

double reach(const PlaneSection& loop, double mid_x, int side) {
  double w = 0;
  for (const auto& p : loop.points)
    w = std::max(w, side * (p.x() - mid_x));
  return w;
}

} // namespace vfit
