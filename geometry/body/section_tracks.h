// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A body's horizontal sections stacked by height, and body parts (torso, legs) followed
/// through them level by level: the vertical half of joint estimation (joint_estimation.h;
/// seed 001 §5).

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "plane_sections.h"

namespace vfit {

/// Horizontal sections of a mesh at evenly spaced heights. Level i lies at
/// y = floor + (i + ½)·step; its loops' in-plane coordinates are (z, x) (PlaneSlicer along +Y).
struct BodySlices {
  double floor = 0, top = 0, height = 0, step = 0; ///< m
  std::vector<std::vector<PlaneSection>> levels;

  /// Cuts `mesh` at `count` ≥ 1 levels between its lowest and highest points.
  BodySlices(const Mesh& mesh, int count);
  double y(int level) const { return floor + (level + 0.5) * step; }
  /// The level nearest height y (clamped to the slices).
  int index(double y) const;
};

/// A body part's loop index at each level, −1 where the part is absent.
using SectionTrack = std::vector<int>;

/// Follows a body part from loop `first` of level `start` in direction `dir` (+1 up, −1 down).
/// At each level the part's loop is the largest one containing the previous centroid, or
/// failing that (a notch such as an open mouth) the loop whose centroid lies closest within
/// `nearest` (m); loops under 0.3× the previous area (specks from folded or noisy triangles)
/// are taken only when nothing larger qualifies. Stops where no loop qualifies, or before a
/// level where `stop(level)` holds.
SectionTrack follow_part(const BodySlices& slices, int start, int first, int dir, double nearest,
                         const std::function<bool(int)>& stop = {});

/// The part's loop at `level`, or nullptr.
const PlaneSection* loop_at(const BodySlices& slices, const SectionTrack& track, int level);

/// The part's centroid at height y (m), interpolated between the two nearest levels. Throws
/// vfit::Error when the part has no loop at either.
Eigen::Vector3d centroid_at(const BodySlices& slices, const SectionTrack& track, double y);

/// Least-squares lines x(y), z(y) through the part's centroids at heights [lo, hi], evaluated
/// at height y: extrapolates a limb's axis past where its sections stop being round. With
/// fewer than two centroids, centroid_at(y).
Eigen::Vector3d axis_at(const BodySlices& slices, const SectionTrack& track, double lo, double hi, double y);

/// How far the loop reaches from the plane x = mid_x towards `side` (+1: +X, −1: −X), in m.
double reach(const PlaneSection& loop, double mid_x, int side);

} // namespace vfit
