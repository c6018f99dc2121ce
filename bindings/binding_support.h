// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// What the C API and the Python module share: meshes and poses from a caller's arrays, checked
/// with messages in the caller's terms (0-based indices, as the arrays are), rest-pose names,
/// and the rule for animating a fit. Internal to bindings/ (not installed).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

#include "vfit/geometry/body/body.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/error.h"

namespace vfit::bindings {

/// A mesh from positions (vertex_count × 3) and triangles (triangle_count × 3), copied. Throws
/// std::invalid_argument for no vertices or triangles, vfit::Error ("mesh: …") for a coordinate
/// that is not finite or a triangle naming a vertex out of range, 0-based. O(V + T).
inline Mesh mesh_from_arrays(const float* positions, std::size_t vertex_count, const std::int32_t* triangles,
                             std::size_t triangle_count) {
  if (vertex_count == 0 || triangle_count == 0) throw std::invalid_argument("a mesh needs vertices and triangles");
  if (!positions || !triangles) throw std::invalid_argument("positions or triangles is NULL");
  Mesh mesh;
  mesh.positions.assign(positions, positions + 3 * vertex_count);
  mesh.triangles.assign(triangles, triangles + 3 * triangle_count);
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!std::isfinite(mesh.positions[i])) throw Error("mesh", 0, "vertex " + std::to_string(i / 3) + " is not finite");
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (mesh.triangles[i] < 0 || static_cast<std::size_t>(mesh.triangles[i]) >= vertex_count)
      throw Error("mesh", 0,
                  "triangle " + std::to_string(i / 3) + " names vertex " + std::to_string(mesh.triangles[i]) + " of " +
                      std::to_string(vertex_count));
  return mesh;
}

/// "tpose" or "apose"; throws std::invalid_argument naming the value otherwise.
inline RestPose rest_pose_named(std::string_view name) {
  if (name == "tpose") return RestPose::TPOSE;
  if (name == "apose") return RestPose::APOSE;
  throw std::invalid_argument("rest pose \"" + std::string(name) + "\": expected \"tpose\" or \"apose\"");
}

/// A pose from 75 numbers: 24 joints' axis-angle rotations (radians, SMPL's joint order), then
/// the root translation (m). Throws std::invalid_argument for a value that is not finite.
inline Pose pose_from_values(const double* values) {
  if (!values) throw std::invalid_argument("the pose is NULL");
  Pose pose =
      Pose::from_smpl_vector(std::span<const double>(values, 72), Eigen::Vector3d(values[72], values[73], values[74]));
  if (!pose.axis_angle.allFinite() || !pose.translation.allFinite())
    throw std::invalid_argument("the pose holds a value that is not finite");
  return pose;
}

/// A dressed character binds the body at rest: its garments must have been fitted onto that
/// body, unposed. Throws std::invalid_argument saying which rule a fit breaks.
inline void require_fit_at_rest(const Body& fitted_onto, bool fitted_at_rest, const Body& rest) {
  if (!fitted_at_rest)
    throw std::invalid_argument("the garments were fitted onto a posed body; fit them onto the body at rest");
  if (fitted_onto.mesh.positions != rest.mesh.positions)
    throw std::invalid_argument("the garments were fitted onto another body");
}

} // namespace vfit::bindings
