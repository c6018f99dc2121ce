// SPDX-License-Identifier: Apache-2.0
#include "straighten.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "surface_graph.h"
#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {
namespace {

constexpr double MIN_OPENING = 0.05;     // of the extent, as segment.cpp: smaller openings are pockets
constexpr double SYMMETRY_MARGIN = 0.02; // mirror asymmetry: left-right below the others by this (up_axis.h)
constexpr double MIN_SEPARATION = 0.1;   // of the total spread: a principal axis this distinct is stable
constexpr double SIDE_DEAD_BAND = 4;     // degrees (upright garments: 0.0-3.5)
constexpr double LEVEL_CONE = 40;        // degrees: openings this close to level ring the body
constexpr double FLATNESS = 0.12;        // rms distance from the plane, of the opening's radius
constexpr double BOTTOM_BAND = 0.1;      // of the height: openings this close to the lowest end the garment
constexpr double LEAN_DEAD_BAND = 9;     // degrees (upright garments: never both cues past it)
constexpr double MOST = 45;              // degrees: larger turns are the axis-aligned cases' to handle

double to_degrees(double radians) { return radians * 180 / std::numbers::pi; }

// The signed angle about unit `axis` from `v`'s projection on the plane normal to `axis` to +Y's.
double lean_about(const Eigen::Vector3d& axis, const Eigen::Vector3d& v) {
  const Eigen::Vector3d up = (Eigen::Vector3d::UnitY() - axis.dot(Eigen::Vector3d::UnitY()) * axis).normalized();
  const Eigen::Vector3d p = v - axis.dot(v) * axis;
  return std::atan2(axis.dot(up.cross(p)), up.dot(p));
}

} // namespace

GarmentTilt estimate_tilt(const Mesh& mesh) {
  GarmentTilt out;
  const std::size_t nv = mesh.vertex_count();
  if (nv == 0 || mesh.face_count() == 0) return out;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  std::vector<Eigen::Vector3d> points(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    points[v] = Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
    if (!points[v].allFinite()) return out; // the segmentation names the vertex
    lo = lo.cwiseMin(points[v]);
    hi = hi.cwiseMax(points[v]);
  }
  const double extent = (hi - lo).maxCoeff();
  if (!(extent > 0)) return out;
  out.centre = 0.5 * (lo + hi);
  for (std::int32_t v : mesh.triangles)
    if (v < 0 || std::size_t(v) >= nv) return out; // ... and the bad index

  // 1. The left-right axis: a principal axis of the surface, the mirror plane of a symmetric garment.
  double area = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    const Eigen::Vector3d &a = points[std::size_t(mesh.triangles[3 * f])],
                          &b = points[std::size_t(mesh.triangles[3 * f + 1])],
                          &c = points[std::size_t(mesh.triangles[3 * f + 2])];
    const double w = 0.5 * (b - a).cross(c - a).norm();
    const Eigen::Vector3d m = (a + b + c) / 3 - out.centre;
    area += w;
    mean += w * m;
    second += w * m * m.transpose();
  }
  if (!(area > 0)) return out;
  mean /= area;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(second / area - mean * mean.transpose());
  const Eigen::Matrix3d axes = pca.eigenvectors(); // columns, ascending spread
  // Mirror asymmetry across each axis of the orthonormal frame `frame` (columns).
  std::vector<float> in_frame(mesh.positions.size());
  const auto asymmetry = [&](const Eigen::Matrix3d& frame) {
    for (std::size_t v = 0; v < nv; ++v) {
      const Eigen::Vector3d q = frame.transpose() * (points[v] - out.centre);
      for (int k = 0; k < 3; ++k)
        in_frame[3 * v + std::size_t(k)] = float(q[k]);
    }
    return mirror_asymmetry(in_frame, mesh.triangles);
  };
  const Eigen::Vector3d spread = pca.eigenvalues();
  const auto apart = [&](int i, int j) { return std::abs(spread[i] - spread[j]) >= MIN_SEPARATION * spread.sum(); };
  std::optional<Eigen::Vector3d> side_axis;
  const std::array<double, 3> asym = asymmetry(axes);
  int side = 0;
  for (int k = 1; k < 3; ++k)
    if (asym[std::size_t(k)] < asym[std::size_t(side)]) side = k;
  const int other[2] = {(side + 1) % 3, (side + 2) % 3};
  if (apart(side, other[0]) && apart(side, other[1])) {
    if (asym[std::size_t(side)] + SYMMETRY_MARGIN <= std::min(asym[std::size_t(other[0])], asym[std::size_t(other[1])]))
      side_axis = axes.col(side);
  }
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d lateral = Eigen::Vector3d::UnitX();
  if (side_axis) {
    const Eigen::Vector3d e = *side_axis;
    lateral = std::abs(e.x()) >= std::abs(e.z()) ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d from = e.dot(lateral) >= 0 ? e : Eigen::Vector3d(-e);
    const double angle = to_degrees(std::acos(std::clamp(from.dot(lateral), -1.0, 1.0)));
    if (angle >= SIDE_DEAD_BAND && angle < MOST) {
      rotation = Eigen::Quaterniond::FromTwoVectors(from, lateral).toRotationMatrix();
      out.side_degrees = angle;
    }
  } else if (lateral_axis_is_z(mesh.positions, mesh.triangles)) {
    lateral = Eigen::Vector3d::UnitZ();
  }

  // 2. The lean about the left-right axis, from the openings (rotated as the garment is).
  SurfaceGraph g;
  try {
    g = build_surface_graph(mesh);
  } catch (...) {
    return out;
  }
  struct Opening {
    Eigen::Vector3d centroid, normal;
    double perimeter, flatness;
  };
  std::vector<Opening> openings;
  for (const BoundaryLoop& l : g.loops) {
    if (l.vertices.size() < 3 || l.perimeter < MIN_OPENING * extent || g.component[l.vertices.front()] != 0) continue;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::int32_t v : l.vertices)
      c += points[std::size_t(v)];
    c /= double(l.vertices.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (std::int32_t v : l.vertices)
      cov += (points[std::size_t(v)] - c) * (points[std::size_t(v)] - c).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> plane(cov / double(l.vertices.size()));
    Eigen::Vector3d n = rotation * plane.eigenvectors().col(0);
    if (n.y() < 0) n = -n;
    openings.push_back({out.centre + rotation * (l.centroid - out.centre), n, l.perimeter,
                        std::sqrt(std::max(0.0, plane.eigenvalues()[0])) / (l.perimeter / (2 * std::numbers::pi))});
  }
  double lean = 0;
  if (openings.size() >= 2) {
    double top = -INFINITY, low = INFINITY;
    const Opening* highest = nullptr;
    const Opening* level = nullptr;
    for (const Opening& o : openings) {
      if (o.centroid.y() > top) top = o.centroid.y(), highest = &o;
      low = std::min(low, o.centroid.y());
      const double off = to_degrees(std::acos(std::clamp(o.normal.y(), -1.0, 1.0)));
      if (off <= LEVEL_CONE && o.flatness <= FLATNESS && (!level || o.perimeter > level->perimeter)) level = &o;
    }
    Eigen::Vector3d bottom = Eigen::Vector3d::Zero();
    double weight = 0;
    const double band = BOTTOM_BAND * (hi - lo).maxCoeff();
    for (const Opening& o : openings)
      if (&o != highest && o.centroid.y() <= low + band) bottom += o.perimeter * o.centroid, weight += o.perimeter;
    if (level && weight > 0 && top > low + band) {
      const double by_line = lean_about(lateral, highest->centroid - bottom / weight);
      const double by_level = lean_about(lateral, level->normal);
      const double smaller = std::abs(by_line) <= std::abs(by_level) ? by_line : by_level;
      if (by_line * by_level > 0 && std::abs(smaller) >= LEAN_DEAD_BAND * std::numbers::pi / 180 &&
          std::abs(to_degrees(by_line)) < MOST && std::abs(to_degrees(by_level)) < MOST)
        lean = smaller;
    }
  }
  if (lean != 0) {
    rotation = Eigen::AngleAxisd(-lean, lateral).toRotationMatrix() * rotation; // leaning by `lean`: back
    out.pitch_degrees = to_degrees(std::abs(lean));
  }
  out.rotation = rotation;
  out.degrees = to_degrees(Eigen::AngleAxisd(rotation).angle());
  return out;
}

void apply_tilt(std::span<float> positions, const GarmentTilt& tilt) {
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
    const Eigen::Vector3d p(positions[i], positions[i + 1], positions[i + 2]);
    const Eigen::Vector3d q = tilt.centre + tilt.rotation * (p - tilt.centre);
    positions[i] = float(q.x());
    positions[i + 1] = float(q.y());
    positions[i + 2] = float(q.z());
  }
}

} // namespace vfit
