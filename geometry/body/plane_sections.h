// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Sections of a mesh by a family of parallel planes p · d = level, for any unit direction d:
/// the loops where each plane cuts the mesh, with their area centroid, area, perimeter and
/// extents. Joint estimation (joint_estimation.h) slices bodies along Y for the legs, torso and
/// head and along each arm's direction for the arms (seed 001 §5).

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// One loop where a plane cuts a mesh. Open chains (the plane crossing a hole in the mesh) are
/// closed by a straight segment from their last point to their first.
struct PlaneSection {
  std::vector<Eigen::Vector3d> points;                ///< the loop's points in order (m)
  std::vector<Eigen::Vector2d> uv;                    ///< the same points in the plane's basis (u, v) (m)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(); ///< area centroid (vertex mean when degenerate)
  Eigen::Vector2d centroid_uv = Eigen::Vector2d::Zero();
  double area = 0;      ///< enclosed area (m², ≥ 0)
  double perimeter = 0; ///< length of the closed polyline (m)
  double diameter = 0;  ///< largest distance between two points (m; the hull's, approximately)
  bool closed = true;   ///< false when the plane crossed a mesh boundary (a hole)

  /// True when the point (in the plane's basis) lies inside the loop (even-odd rule).
  bool contains(const Eigen::Vector2d& q) const;
};

/// Precomputed slicing of one mesh along one direction: triangles are bucketed by their range
/// of p · d so that each plane visits only the triangles it can cut.
class PlaneSlicer {
public:
  /// `direction` need not be unit length (it is normalised); it must not be zero. The mesh is
  /// referenced, not copied: it must outlive the slicer.
  PlaneSlicer(const Mesh& mesh, const Eigen::Vector3d& direction);

  /// The loops of the plane p · d = `level` (m), with at least 3 points each; none outside
  /// [min_level(), max_level()]. Vertices exactly on the plane count as above it.
  std::vector<PlaneSection> sections(double level) const;

  /// The plane's in-plane basis: u, v with (u, v, d) right-handed. For d = +Y: u = +Z, v = +X.
  const Eigen::Vector3d& u() const { return m_u; }
  const Eigen::Vector3d& v() const { return m_v; }
  const Eigen::Vector3d& direction() const { return m_d; }
  /// The point of the plane at `level` with in-plane coordinates q.
  Eigen::Vector3d point(double level, const Eigen::Vector2d& q) const {
    return level * m_d + q.x() * m_u + q.y() * m_v;
  }
  /// In-plane coordinates of p.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const { return {p.dot(m_u), p.dot(m_v)}; }
  double min_level() const { return m_min; }
  double max_level() const { return m_max; }

private:
  const Mesh& m_mesh;
  Eigen::Vector3d m_d, m_u, m_v;
  std::vector<double> m_level;      ///< p · d per vertex
  std::vector<std::int32_t> m_weld; ///< per vertex, the first vertex at the same position
  double m_min = 0, m_max = 0, m_bucket = 1;
  std::vector<std::int32_t> m_bucket_start, m_bucket_faces; ///< CSR: faces overlapping each bucket
};

} // namespace vfit
