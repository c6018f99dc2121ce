// SPDX-License-Identifier: Apache-2.0
#include "smpl_model.h"

#include <cmath>
#include <vector>

#include "npz_reader.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr double WEIGHT_SUM_TOLERANCE = 1e-3; // as validate_skin_weights: SMPL stores float32 weights
constexpr double UINT32_MAX_AS_DOUBLE = 4294967295.0;
constexpr double UINT64_MAX_AS_DOUBLE = 18446744073709551615.0;

/// Fetches the model's arrays and checks them, naming the file and the array in every error.
class ArrayChecker {
public:
  explicit ArrayChecker(const NpzArchive& archive) : m_archive(archive) {}

  NpyArray require(const std::string& name) const {
    if (!m_archive.contains(name))
      throw Error(
          m_archive.source(), 0,
          "no array '" + name +
              "' (an SMPL model needs v_template, shapedirs, posedirs, J_regressor, weights, kintree_table, f)");
    NpyArray a = m_archive.array(name);
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!std::isfinite(a.values[i]))
        throw Error(m_archive.source(), 0,
                    "array '" + name + "' holds " + (std::isnan(a.values[i]) ? "NaN" : "an infinite value") +
                        " at flat index " + std::to_string(i));
    return a;
  }

  [[noreturn]] void fail(const std::string& name, const std::string& what) const {
    throw Error(m_archive.source(), 0, "array '" + name + "' " + what);
  }

  void expect_shape(const NpyArray& a, const std::string& name, const std::vector<std::size_t>& shape,
                    const std::string& meaning) const {
    if (a.shape != shape) {
      NpyArray expected;
      expected.shape = shape;
      fail(name, "has shape " + a.shape_text() + ", expected " + expected.shape_text() + " (" + meaning + ")");
    }
  }

private:
  const NpzArchive& m_archive;
};

/// An array value for a message: integers without decimals.
std::string number_text(double x) {
  if (x == std::floor(x) && std::abs(x) < 1e15) return std::to_string(static_cast<long long>(x));
  return std::to_string(x);
}

bool is_root_marker(double parent) {
  return parent == -1.0 || parent == UINT32_MAX_AS_DOUBLE || parent == UINT64_MAX_AS_DOUBLE;
}

} // namespace

SmplModel SmplModel::load(const std::filesystem::path& path) {
  const NpzArchive archive = NpzArchive::open(path);
  const ArrayChecker check(archive);
  SmplModel m;
  m.m_source = archive.source();

  const NpyArray v_template = check.require("v_template");
  if (v_template.shape.size() != 2 || v_template.shape[1] != 3 || v_template.shape[0] == 0)
    check.fail("v_template", "has shape " + v_template.shape_text() + ", expected (#V, 3) with #V > 0");
  const std::size_t nv = v_template.shape[0];
  m.m_template = Eigen::Map<const Eigen::VectorXd>(v_template.values.data(), static_cast<Eigen::Index>(3 * nv));

  const NpyArray shapedirs = check.require("shapedirs");
  if (shapedirs.shape.size() != 3 || shapedirs.shape[0] != nv || shapedirs.shape[1] != 3)
    check.fail("shapedirs", "has shape " + shapedirs.shape_text() + ", expected (" + std::to_string(nv) + ", 3, #B)");
  m.m_shapedirs = Eigen::Map<const RowMatrix>(shapedirs.values.data(), static_cast<Eigen::Index>(3 * nv),
                                              static_cast<Eigen::Index>(shapedirs.shape[2]));

  // SMPL ships posedirs as (#V, 3, 207); some converters flatten it to (3#V, 207). Both have the
  // same C-order layout.
  const NpyArray posedirs = check.require("posedirs");
  const std::size_t pf = SMPL_POSE_FEATURE_COUNT;
  if (posedirs.shape != std::vector<std::size_t>{nv, 3, pf} && posedirs.shape != std::vector<std::size_t>{3 * nv, pf})
    check.fail("posedirs", "has shape " + posedirs.shape_text() + ", expected (" + std::to_string(nv) +
                               ", 3, 207) or (" + std::to_string(3 * nv) + ", 207)");
  m.m_posedirs =
      Eigen::Map<const RowMatrix>(posedirs.values.data(), static_cast<Eigen::Index>(3 * nv), SMPL_POSE_FEATURE_COUNT);

  const NpyArray regressor = check.require("J_regressor");
  check.expect_shape(regressor, "J_regressor", {JOINT_COUNT, nv}, "24 joints × #V, dense");
  m.m_joint_regressor =
      Eigen::Map<const RowMatrix>(regressor.values.data(), JOINT_COUNT, static_cast<Eigen::Index>(nv));

  const NpyArray weights = check.require("weights");
  check.expect_shape(weights, "weights", {nv, JOINT_COUNT}, "#V × 24 skin weights");
  m.m_weights = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, JOINT_COUNT, Eigen::RowMajor>>(
      weights.values.data(), static_cast<Eigen::Index>(nv), JOINT_COUNT);
  for (Eigen::Index v = 0; v < m.m_weights.rows(); ++v) {
    if ((m.m_weights.row(v).array() < 0.0).any())
      check.fail("weights", "has a negative weight at vertex " + std::to_string(v));
    const double sum = m.m_weights.row(v).sum();
    if (std::abs(sum - 1.0) > WEIGHT_SUM_TOLERANCE)
      check.fail("weights", "row " + std::to_string(v) + " sums to " + std::to_string(sum) + ", not 1");
  }

  const NpyArray kintree = check.require("kintree_table");
  check.expect_shape(kintree, "kintree_table", {2, JOINT_COUNT}, "parents and joint ids");
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const double parent = kintree.values[j];
    const bool ok = joint_parent(j) < 0 ? is_root_marker(parent) : parent == joint_parent(j);
    if (!ok)
      check.fail("kintree_table", "gives joint " + std::to_string(j) + " (" + std::string(joint_name(j)) + ") parent " +
                                      number_text(parent) + "; SMPL's is " + std::to_string(joint_parent(j)) +
                                      " (not an SMPL skeleton)");
    if (kintree.values[JOINT_COUNT + j] != j)
      check.fail("kintree_table", "row 2 column " + std::to_string(j) + " is not the joint id " + std::to_string(j));
  }

  const NpyArray faces = check.require("f");
  if (faces.shape.size() != 2 || faces.shape[1] != 3 || faces.shape[0] == 0)
    check.fail("f", "has shape " + faces.shape_text() + ", expected (#F, 3) with #F > 0");
  m.m_triangles.resize(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const double index = faces.values[i];
    if (index != std::floor(index))
      check.fail("f",
                 "face " + std::to_string(i / 3) + ": vertex index " + std::to_string(index) + " is not an integer");
    if (index < 0 || index >= static_cast<double>(nv))
      check.fail("f", "face " + std::to_string(i / 3) + ": vertex index " + number_text(index) + " out of range [0, " +
                          std::to_string(nv) + ")");
    m.m_triangles[i] = static_cast<std::int32_t>(index);
  }
  return m;
}

Eigen::VectorXd SmplModel::shaped_flat(std::span<const double> betas) const {
  if (betas.size() > static_cast<std::size_t>(shape_count()))
    throw Error(m_source, 0,
                "got " + std::to_string(betas.size()) + " shape coefficients (betas); array 'shapedirs' holds " +
                    std::to_string(shape_count()));
  Eigen::VectorXd v = m_template;
  if (!betas.empty()) {
    const auto n = static_cast<Eigen::Index>(betas.size());
    v.noalias() += m_shapedirs.leftCols(n) * Eigen::Map<const Eigen::VectorXd>(betas.data(), n);
  }
  return v;
}

JointPositions SmplModel::regress_joints(const Eigen::VectorXd& shaped) const {
  const Eigen::Map<const VertexPositions> v(shaped.data(), static_cast<Eigen::Index>(vertex_count()), 3);
  return m_joint_regressor * v;
}

Mesh SmplModel::to_mesh(const VertexPositions& vertices) const {
  Mesh mesh;
  mesh.positions.resize(static_cast<std::size_t>(vertices.size()));
  Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(mesh.positions.data(), vertices.rows(), 3) =
      vertices.cast<float>();
  mesh.triangles = m_triangles;
  return mesh;
}

VertexPositions SmplModel::shaped_vertices(std::span<const double> betas) const {
  const Eigen::VectorXd v = shaped_flat(betas);
  return Eigen::Map<const VertexPositions>(v.data(), static_cast<Eigen::Index>(vertex_count()), 3);
}

Mesh SmplModel::shaped_mesh(std::span<const double> betas) const { return to_mesh(shaped_vertices(betas)); }

JointPositions SmplModel::rest_joints(std::span<const double> betas) const {
  return regress_joints(shaped_flat(betas));
}

Body SmplModel::rest_body(std::span<const double> betas) const {
  const Eigen::VectorXd v = shaped_flat(betas);
  Body body;
  body.mesh = to_mesh(Eigen::Map<const VertexPositions>(v.data(), static_cast<Eigen::Index>(vertex_count()), 3));
  body.joints = regress_joints(v);
  body.weights = SkinWeights::from_dense(
      std::span<const double>(m_weights.data(), static_cast<std::size_t>(m_weights.size())), JOINT_COUNT);
  body.rest_pose = RestPose::TPOSE;
  body.source = m_source;
  return body;
}

VertexPositions SmplModel::posed_vertices(std::span<const double> betas, const Pose& pose) const {
  Eigen::VectorXd v = shaped_flat(betas);
  const auto nv = static_cast<Eigen::Index>(vertex_count());
  VertexPositions out(nv, 3);
  if (pose.axis_angle.isZero(0.0)) {
    out = Eigen::Map<const VertexPositions>(v.data(), nv, 3);
    out.rowwise() += pose.translation.transpose();
    return out;
  }
  const JointPositions joints = regress_joints(v);

  // Pose-corrective blend shapes (SMPL eq. 9): features (R_j − I), row-major, joints 1..23.
  Eigen::Matrix<double, SMPL_POSE_FEATURE_COUNT, 1> feature;
  for (int j = 1; j < JOINT_COUNT; ++j) {
    const Eigen::Matrix3d r = axis_angle_to_matrix(pose.axis_angle.row(j).transpose()) - Eigen::Matrix3d::Identity();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        feature(9 * (j - 1) + 3 * a + b) = r(a, b);
  }
  v.noalias() += m_posedirs * feature;

  // SMPL adds the translation after skinning, so the transforms are built without it.
  Pose rotation_only = pose;
  rotation_only.translation.setZero();
  const auto transforms = skinning_transforms(joints, rotation_only);
  Eigen::Matrix<double, JOINT_COUNT, 12, Eigen::RowMajor> stacked;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const Eigen::Matrix<double, 3, 4, Eigen::RowMajor> a = transforms[j].matrix().topRows<3>();
    stacked.row(j) = Eigen::Map<const Eigen::Matrix<double, 1, 12>>(a.data());
  }
  // Blended transforms, one 3 × 4 row-major matrix per vertex: #V × 24 dense weights times 24 × 12.
  const Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor> blended = m_weights * stacked;
  for (Eigen::Index i = 0; i < nv; ++i) {
    const Eigen::Map<const Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> t(blended.row(i).data());
    const Eigen::Vector3d p(v(3 * i), v(3 * i + 1), v(3 * i + 2));
    out.row(i) = (t.leftCols<3>() * p + t.col(3) + pose.translation).transpose();
  }
  return out;
}

Mesh SmplModel::posed_mesh(std::span<const double> betas, const Pose& pose) const {
  return to_mesh(posed_vertices(betas, pose));
}

JointPositions SmplModel::posed_joints(std::span<const double> betas, const Pose& pose) const {
  return ::vfit::posed_joints(rest_joints(betas), pose);
}

} // namespace vfit
