// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// An SMPL-format parametric body model read from a NumPy `.npz` file (seed 000 §3: the SMPL body
/// model M(θ, β) of Loper et al. 2015). Shape blend shapes, joint regression, pose-corrective
/// blend shapes and linear blend skinning, evaluated exactly as SMPL defines them.
/// Conventions: metres, the model's own axes (SMPL: Y up, facing +Z), the canonical 24 joints.

#include <filesystem>
#include <span>
#include <string>

#include <Eigen/Core>

#include "body.h"
#include "skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Vertex positions in double precision, #V × 3 (m).
using VertexPositions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Number of pose-corrective features: 23 non-root joints × 9 entries of (R_j − I).
inline constexpr int SMPL_POSE_FEATURE_COUNT = 9 * (JOINT_COUNT - 1);

/// An SMPL-format model. `betas` arguments are shape coefficients β (dimensionless); a span
/// shorter than shape_count() is zero-padded (empty = the mean shape), a longer one is an error.
class SmplModel {
public:
  /// Loads the `.npz` at `path`. Required arrays (any supported numeric dtype):
  /// v_template #V × 3 (m); shapedirs #V × 3 × #B; posedirs #V × 3 × 207 or 3#V × 207;
  /// J_regressor 24 × #V (dense); weights #V × 24 (rows sum to 1); kintree_table 2 × 24 whose
  /// first row holds SMPL's parents (root −1 or 4294967295) and second row 0..23; f #F × 3
  /// vertex indices. Other members are ignored. Throws vfit::Error naming the file and the
  /// array for a missing array, a wrong shape, NaN/∞, an index out of range, non-SMPL parents,
  /// or weight rows not summing to 1 (±1e-3).
  static SmplModel load(const std::filesystem::path& path);

  /// The file the model was loaded from.
  const std::string& source() const { return m_source; }
  /// #B, the number of shape coefficients the model has.
  int shape_count() const { return static_cast<int>(m_shapedirs.cols()); }
  /// #V.
  std::size_t vertex_count() const { return static_cast<std::size_t>(m_template.size() / 3); }
  /// #F.
  std::size_t face_count() const { return m_triangles.size() / 3; }

  /// v_shaped = v_template + shapedirs · β, the template plus shape blend shapes (#V × 3, m;
  /// Loper et al. 2015 eqs. 6 and 8 with B_P = 0).
  VertexPositions shaped_vertices(std::span<const double> betas = {}) const;
  /// shaped_vertices() as a mesh with the model's triangles (float positions).
  Mesh shaped_mesh(std::span<const double> betas = {}) const;
  /// Rest joints J(β) = J_regressor · v_shaped (24 × 3, m; Loper et al. 2015 eq. 10).
  JointPositions rest_joints(std::span<const double> betas = {}) const;
  /// The shaped body in the model's rest T-pose: shaped mesh, rest joints, the 4 largest skin
  /// weights per vertex renormalised (SkinWeights::from_dense), RestPose::TPOSE, source = file.
  Body rest_body(std::span<const double> betas = {}) const;

  /// M(β, θ) + translation (#V × 3, m; seed 000 §3, Loper et al. 2015 eqs. 2–10): v_shaped,
  /// J = J_regressor · v_shaped, pose feature (R_j − I) row-major for joints 1..23, v_posed = v_shaped + posedirs ·
  /// feature, then LBS with the full dense weights and skinning_transforms(J, θ), plus pose.translation. At the rest
  /// pose (all rotations zero) the skinning is the identity and is skipped, so the result is exactly v_shaped +
  /// translation.
  VertexPositions posed_vertices(std::span<const double> betas, const Pose& pose) const;
  /// posed_vertices() as a mesh with the model's triangles (float positions).
  Mesh posed_mesh(std::span<const double> betas, const Pose& pose) const;
  /// The posed joints (24 × 3, m): forward kinematics of `pose` on rest_joints(betas),
  /// translation included.
  JointPositions posed_joints(std::span<const double> betas, const Pose& pose) const;

private:
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  Eigen::VectorXd shaped_flat(std::span<const double> betas) const;
  JointPositions regress_joints(const Eigen::VectorXd& shaped) const;
  Mesh to_mesh(const VertexPositions& vertices) const;

  std::string m_source;
  Eigen::VectorXd m_template;                                                    ///< 3#V: x y z per vertex
  RowMatrix m_shapedirs;                                                         ///< 3#V × #B
  RowMatrix m_posedirs;                                                          ///< 3#V × 207
  RowMatrix m_joint_regressor;                                                   ///< 24 × #V
  Eigen::Matrix<double, Eigen::Dynamic, JOINT_COUNT, Eigen::RowMajor> m_weights; ///< #V × 24
  std::vector<std::int32_t> m_triangles;                                         ///< #F × 3
};

} // namespace vfit
