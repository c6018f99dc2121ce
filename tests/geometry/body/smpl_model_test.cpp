// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/body/smpl_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "npz_test_writer.h"
#include "smpl_test_model.h"
#include "test_support.h"
#include "vfit/geometry/body/npz_reader.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using test::NpyData;
using test::NpyList;
using test::ZipMode;

/// Writes `bytes` to `dir/name` and returns the path.
std::filesystem::path write_to(const test::TempDir& dir, const std::string& name, const std::string& bytes) {
  const auto path = dir / name;
  test::write_file(path, bytes);
  return path;
}

/// Runs `body`, expecting a vfit::Error whose message starts with `path` and contains `parts`.
void expect_error(const std::function<void()>& body, const std::filesystem::path& path,
                  const std::vector<std::string>& parts) {
  try {
    body();
    ADD_FAILURE() << "no vfit::Error thrown";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path.string() + ": ", 0), 0u) << what;
    for (const std::string& part : parts)
      EXPECT_NE(what.find(part), std::string::npos) << "'" << part << "' not in: " << what;
  }
}

// ---------------------------------------------------------------------------------------------
// Npz: the archive and array reader.

struct DtypeCase {
  std::string descr;
  std::vector<double> values; // 2 × 3, C order
  friend std::ostream& operator<<(std::ostream& os, const DtypeCase& c) { return os << c.descr; }
};

class NpzDtype : public testing::TestWithParam<DtypeCase> {};

TEST_P(NpzDtype, RoundTripsValuesAndShape) {
  const test::TempDir dir;
  const NpyData a{GetParam().descr, {2, 3}, GetParam().values};
  const auto path = write_to(dir, "a.npz", test::npz_bytes({{"a", a}}, ZipMode::STORED));
  const auto arrays = read_npz(path);
  ASSERT_EQ(arrays.size(), 1u);
  const NpyArray& got = arrays.at("a");
  EXPECT_EQ(got.shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(got.dtype, GetParam().descr);
  EXPECT_EQ(got.values, GetParam().values);
}

INSTANTIATE_TEST_SUITE_P(
    Npz, NpzDtype,
    testing::Values(DtypeCase{"<f4", {0.5, -1.25, 3, 1e-3f, 7, -8}}, DtypeCase{"<f8", {0.1, -1e300, 3, 1e-300, 7, -8}},
                    DtypeCase{">f8", {0.1, -2.5, 3, 4, 5, 6}}, DtypeCase{">f4", {0.5, -2.5, 3, 4, 5, 6}},
                    DtypeCase{"<i4", {-2147483648.0, -1, 0, 1, 2, 2147483647.0}},
                    DtypeCase{">i4", {-7, -1, 0, 1, 2, 300}}, DtypeCase{"<i8", {-1, 4294967295.0, 0, 1e15, 2, 3}},
                    DtypeCase{"<i2", {-32768, -1, 0, 1, 2, 32767}}, DtypeCase{"<u4", {4294967295.0, 0, 1, 2, 3, 65536}},
                    DtypeCase{">u2", {65535, 0, 1, 2, 3, 256}}, DtypeCase{"<u8", {0, 1, 2, 1e15, 4, 5}},
                    DtypeCase{"|u1", {0, 1, 2, 128, 254, 255}}, DtypeCase{"|b1", {0, 1, 1, 0, 0, 1}}),
    [](const auto& p) {
      std::string n = p.param.descr;
      std::replace(n.begin(), n.end(), '<', 'L');
      std::replace(n.begin(), n.end(), '>', 'B');
      std::replace(n.begin(), n.end(), '|', 'N');
      return n;
    });

TEST(Npz, FortranOrderArraysAreReadInCOrder) {
  const test::TempDir dir;
  std::vector<double> c(24), f(24);
  for (std::size_t i = 0; i < 24; ++i)
    c[i] = static_cast<double>(i) + 0.5;
  // c[(i·3 + j)·4 + k] sits at f[i + 2j + 6k] in Fortran order.
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < 3; ++j)
      for (std::size_t k = 0; k < 4; ++k)
        f[i + 2 * j + 6 * k] = c[(i * 3 + j) * 4 + k];
  const std::vector<double> f2 = {1, 4, 2, 5, 3, 6}; // [[1, 2, 3], [4, 5, 6]] in Fortran order
  const auto path = write_to(
      dir, "f.npz",
      test::npz_bytes({{"cube", NpyData{"<f8", {2, 3, 4}, f, true}}, {"matrix", NpyData{">i8", {2, 3}, f2, true}}},
                      ZipMode::DEFLATED));
  const auto arrays = read_npz(path);
  EXPECT_EQ(arrays.at("cube").values, c);
  EXPECT_EQ(arrays.at("matrix").values, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(arrays.at("matrix").shape, (std::vector<std::size_t>{2, 3}));
}

TEST(Npz, HeaderVersionsScalarsAndEmptyArrays) {
  const test::TempDir dir;
  const auto path = write_to(dir, "v.npz",
                             test::npz_bytes({{"v2", NpyData{"<f8", {4}, {1, 2, 3, 4}, false, 2}},
                                              {"v3", NpyData{"<i4", {2, 1}, {5, 6}, false, 3}},
                                              {"scalar", NpyData{"<f8", {}, {42}}},
                                              {"empty", NpyData{"<f4", {0, 3}, {}}}},
                                             ZipMode::STORED));
  const NpzArchive archive = NpzArchive::open(path);
  EXPECT_EQ(archive.names(), (std::vector<std::string>{"v2", "v3", "scalar", "empty"}));
  EXPECT_EQ(archive.array("v2").values, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(archive.array("v2").shape_text(), "(4,)");
  EXPECT_EQ(archive.array("v3").values, (std::vector<double>{5, 6}));
  EXPECT_EQ(archive.array("scalar").values, (std::vector<double>{42}));
  EXPECT_TRUE(archive.array("scalar").shape.empty());
  EXPECT_EQ(archive.array("empty").size(), 0u);
  EXPECT_EQ(archive.array("empty").shape_text(), "(0, 3)");
}

class NpzArchiveMode : public testing::TestWithParam<ZipMode> {};

TEST_P(NpzArchiveMode, LargeArraysRoundTripAndMissingNamesAreErrors) {
  const test::TempDir dir;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  NpyData big{"<f8", {1000, 3, 7}, {}};
  for (int i = 0; i < 21000; ++i)
    big.values.push_back(i % 5 == 0 ? 0.0 : u(rng));
  const auto path =
      write_to(dir, "m.npz", test::npz_bytes({{"big", big}, {"small", NpyData{"<i4", {3}, {1, 2, 3}}}}, GetParam()));
  const NpzArchive archive = NpzArchive::open(path);
  EXPECT_TRUE(archive.contains("big"));
  EXPECT_FALSE(archive.contains("bigger"));
  EXPECT_EQ(archive.array("big").values, big.values);
  EXPECT_EQ(archive.array("small").values, (std::vector<double>{1, 2, 3}));
  expect_error([&] { archive.array("weights"); }, path, {"no array 'weights'"});
}

INSTANTIATE_TEST_SUITE_P(Npz, NpzArchiveMode,
                         testing::Values(ZipMode::STORED, ZipMode::DEFLATED, ZipMode::STORED_ZIP64));

TEST(Npz, CorruptedArchivesThrowOnlyVfitErrors) {
  // Byte flips and truncations anywhere in stored, deflated and ZIP64 archives: each read either
  // succeeds or throws vfit::Error; the sanitizer build checks that nothing reads out of bounds.
  const test::TempDir dir;
  std::mt19937 rng(17);
  const NpyList arrays = {{"a", NpyData{"<f8", {4, 3}, std::vector<double>(12, 0.25)}},
                          {"b", NpyData{">i4", {5}, {1, 2, 3, 4, 5}, true, 2}}};
  int errors = 0;
  for (const ZipMode mode : {ZipMode::STORED, ZipMode::DEFLATED, ZipMode::STORED_ZIP64}) {
    const std::string good = test::npz_bytes(arrays, mode);
    for (int trial = 0; trial < 300; ++trial) {
      std::string bytes = good;
      if (trial % 3 == 0)
        bytes.resize(rng() % bytes.size());
      else
        for (int k = 0; k < 1 + trial % 4; ++k)
          bytes[rng() % bytes.size()] = static_cast<char>(rng());
      const auto path = write_to(dir, "c.npz", bytes);
      try {
        read_npz(path);
      } catch (const Error&) {
        ++errors;
      } catch (const std::exception& e) {
        ADD_FAILURE() << "not a vfit::Error: " << e.what();
      }
    }
  }
  EXPECT_GT(errors, 300); // most corruptions are caught (CRC, structure); some hit unused bytes
}

struct BadNpzCase {
  std::string name;
  std::function<std::string()> bytes;
  std::vector<std::string> message_parts;
  friend std::ostream& operator<<(std::ostream& os, const BadNpzCase& c) { return os << c.name; }
};

std::string one_array_zip(const NpyData& a, ZipMode mode) { return test::npz_bytes({{"a", a}}, mode); }

/// Replaces the bytes of the first occurrence of `from` in `s` by `to` (same length).
std::string patched(std::string s, const std::string& from, const std::string& to) {
  const std::size_t at = s.find(from);
  if (at == std::string::npos) throw std::runtime_error("patch target not found");
  return s.replace(at, from.size(), to);
}

std::string double_bytes(double x) {
  std::string out(sizeof x, '\0');
  std::memcpy(out.data(), &x, sizeof x);
  return out;
}

class NpzBadInput : public testing::TestWithParam<BadNpzCase> {};

TEST_P(NpzBadInput, ThrowsNamingTheFileAndEntry) {
  const test::TempDir dir;
  const auto path = write_to(dir, "bad.npz", GetParam().bytes());
  expect_error([&] { read_npz(path); }, path, GetParam().message_parts);
}

const NpyData SMALL{"<f8", {2, 3}, {1, 2, 3, 4, 5, 6}};

INSTANTIATE_TEST_SUITE_P(
    Npz, NpzBadInput,
    testing::Values(
        BadNpzCase{"NotAZip", [] { return std::string("v_template = [[0, 0, 0]]\n"); }, {"not a zip archive"}},
        BadNpzCase{"Empty", [] { return std::string(); }, {"not a zip archive"}},
        BadNpzCase{"TruncatedZip",
                   [] {
                     const std::string z = one_array_zip(SMALL, ZipMode::DEFLATED);
                     return z.substr(0, z.size() - 10);
                   },
                   {"truncated"}},
        BadNpzCase{"SingleNpy", [] { return test::npy_bytes(SMALL); }, {"single .npy array"}},
        BadNpzCase{"TruncatedArrayData",
                   [] {
                     return one_array_zip(NpyData{"<f8", {10, 3}, {1, 2, 3, 4, 5}}, ZipMode::STORED);
                   },
                   {"entry 'a.npy': truncated data"}},
        BadNpzCase{"CorruptDeflate",
                   [] {
                     std::string z = one_array_zip(SMALL, ZipMode::DEFLATED);
                     // The first data byte: BFINAL = 1 and the invalid block type 3.
                     const std::size_t data = 30 + std::string("a.npy").size();
                     z[data] = static_cast<char>(0xFF);
                     return z;
                   },
                   {"entry 'a.npy': corrupt deflate data"}},
        BadNpzCase{"CrcMismatch",
                   [] {
                     // The last value, 6.0, becomes 7.0 after the CRC was computed.
                     const std::string z = one_array_zip(SMALL, ZipMode::STORED);
                     return patched(z, double_bytes(6.0), double_bytes(7.0));
                   },
                   {"entry 'a.npy': CRC-32 mismatch"}},
        BadNpzCase{"UnsupportedMethod",
                   [] {
                     std::string z = one_array_zip(SMALL, ZipMode::STORED);
                     const std::size_t central = z.find(std::string("PK\x01\x02", 4));
                     z[central + 10] = 12; // bzip2
                     return z;
                   },
                   {"entry 'a.npy': compression method 12"}},
        BadNpzCase{"PickledObjectArray",
                   [] {
                     return one_array_zip(NpyData{"|O", {2}, {0, 0}}, ZipMode::DEFLATED);
                   },
                   {"entry 'a.npy'", "array 'a' is a pickled object array", "re-save"}},
        BadNpzCase{"UnicodeDtype",
                   [] {
                     return one_array_zip(NpyData{"<U3", {1}, {0}}, ZipMode::STORED);
                   },
                   {"array 'a' has unsupported dtype '<U3'"}},
        BadNpzCase{"BadMagic",
                   [] {
                     return test::zip_bytes({{"a.npy", "NUMPY but not really an array"}}, ZipMode::STORED);
                   },
                   {"entry 'a.npy': not a .npy array"}},
        BadNpzCase{"MalformedHeader",
                   [] {
                     return test::zip_bytes({{"a.npy", patched(test::npy_bytes(SMALL), "'shape': (2", "'shape': [2")}},
                                            ZipMode::STORED);
                   },
                   {"entry 'a.npy': malformed .npy header"}},
        BadNpzCase{
            "HeaderPastEnd",
            [] {
              return test::zip_bytes({{"a.npy", std::string("\x93NUMPY\x01\x00\xff\x00{'de", 14)}}, ZipMode::STORED);
            },
            {"entry 'a.npy': truncated .npy header"}}),
    [](const auto& p) { return p.param.name; });

// ---------------------------------------------------------------------------------------------
// SmplModel

using test::NB;
using test::NP;
using test::reference_smpl;
using test::SyntheticSmpl;

NpyData& array_named(NpyList& arrays, const std::string& name) {
  for (auto& [n, a] : arrays)
    if (n == name) return a;
  throw std::runtime_error("no test array " + name);
}

/// One synthetic model on disk, written once for the suite, plus a copy without pose blend shapes.
class SmplModelTest : public testing::Test {
protected:
  static void SetUpTestSuite() {
    s_dir = std::make_unique<test::TempDir>();
    s_model = std::make_unique<SyntheticSmpl>(7);
    s_path = write_to(*s_dir, "model.npz", test::npz_bytes(s_model->arrays(), ZipMode::DEFLATED));
    s_flat = std::make_unique<SyntheticSmpl>(*s_model);
    std::fill(s_flat->posedirs.begin(), s_flat->posedirs.end(), 0.0);
    s_flat_path = write_to(*s_dir, "flat.npz", test::npz_bytes(s_flat->arrays(), ZipMode::STORED));
  }
  static void TearDownTestSuite() { s_dir.reset(); }

  static inline std::unique_ptr<test::TempDir> s_dir;
  static inline std::unique_ptr<SyntheticSmpl> s_model, s_flat;
  static inline std::filesystem::path s_path, s_flat_path;
};

TEST_F(SmplModelTest, ZeroBetasAndZeroPoseGiveTheTemplateExactly) {
  const SmplModel model = SmplModel::load(s_path);
  const std::vector<double> zeros(NB, 0.0);
  for (const auto& betas : {std::vector<double>{}, zeros}) {
    const VertexPositions v = model.posed_vertices(betas, Pose{});
    const Mesh mesh = model.posed_mesh(betas, Pose{});
    for (std::size_t i = 0; i < 3 * s_model->nv; ++i) {
      ASSERT_EQ(v(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)), s_model->v_template[i]) << i;
      ASSERT_EQ(mesh.positions[i], static_cast<float>(s_model->v_template[i])) << i;
    }
    ASSERT_EQ(mesh.triangles.size(), s_model->faces.size());
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
      EXPECT_EQ(mesh.triangles[i], s_model->faces[i]);
  }
}

TEST_F(SmplModelTest, ShapedMeshIsTheTemplatePlusShapeBlendShapes) {
  const SmplModel model = SmplModel::load(s_path);
  EXPECT_EQ(model.shape_count(), static_cast<int>(NB));
  EXPECT_EQ(model.vertex_count(), s_model->nv);
  const std::vector<double> betas = {0.3, -0.7};
  const VertexPositions v = model.shaped_vertices(betas);
  for (std::size_t i = 0; i < 3 * s_model->nv; ++i) {
    const double expected =
        s_model->v_template[i] + 0.3 * s_model->shapedirs[i * NB] - 0.7 * s_model->shapedirs[i * NB + 1];
    EXPECT_NEAR(v(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)), expected,
                1e-14); // a few roundings of O(1) values
  }
  // Shorter betas are zero-padded.
  EXPECT_EQ(v, model.shaped_vertices(std::vector<double>{0.3, -0.7, 0.0, 0.0}));
  const Mesh mesh = model.shaped_mesh(betas);
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    EXPECT_EQ(mesh.positions[i],
              static_cast<float>(v(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3))));
}

TEST_F(SmplModelTest, RestJointsAreRegressedFromTheShapedVertices) {
  const SmplModel model = SmplModel::load(s_path);
  const std::vector<double> betas = {1.0, 0.5, -0.25, 2.0};
  const VertexPositions v = model.shaped_vertices(betas);
  const JointPositions joints = model.rest_joints(betas);
  for (int j = 0; j < JOINT_COUNT; ++j)
    for (int k = 0; k < 3; ++k) {
      double expected = 0;
      for (std::size_t i = 0; i < s_model->nv; ++i)
        expected += s_model->j_regressor[j * s_model->nv + i] * v(static_cast<Eigen::Index>(i), k);
      EXPECT_NEAR(joints(j, k), expected, 1e-12) << "joint " << j;
    }
}

TEST_F(SmplModelTest, PosedVerticesAndJointsMatchTheReference) {
  const SmplModel model = SmplModel::load(s_path);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Pose pose = test::random_pose(seed);
    const std::vector<double> betas = {0.1 * seed, -0.5, 1.5, -1.0 / seed};
    std::vector<double> joints;
    const auto expected = reference_smpl(*s_model, betas, pose, &joints);
    const VertexPositions v = model.posed_vertices(betas, pose);
    // Double precision throughout, O(1) values, a few hundred operations: 1e-9 is ample.
    EXPECT_LT(test::max_difference(v, expected), 1e-9) << "seed " << seed;
    const JointPositions posed = model.posed_joints(betas, pose);
    for (int j = 0; j < JOINT_COUNT; ++j)
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(posed(j, k), joints[3 * j + k], 1e-9) << "joint " << j;
    const Mesh mesh = model.posed_mesh(betas, pose);
    for (std::size_t i = 0; i < mesh.positions.size(); ++i)
      ASSERT_EQ(mesh.positions[i],
                static_cast<float>(v(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3))));
  }
}

TEST_F(SmplModelTest, RootRotationRotatesEveryVertexRigidlyAboutTheRootJoint) {
  const SmplModel model = SmplModel::load(s_path);
  const std::vector<double> betas = {0.4, 0.0, -0.3, 0.2};
  Pose pose;
  pose.axis_angle(0, 1) = std::numbers::pi / 2;
  const VertexPositions rest = model.shaped_vertices(betas);
  const Eigen::RowVector3d root = model.rest_joints(betas).row(0);
  const VertexPositions v = model.posed_vertices(betas, pose);
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    const Eigen::RowVector3d d = rest.row(i) - root;
    const Eigen::RowVector3d expected = root + Eigen::RowVector3d(d.z(), d.y(), -d.x()); // +90° about Y: x → −z
    EXPECT_LT((v.row(i) - expected).norm(), 1e-12) << "vertex " << i;
  }
}

TEST_F(SmplModelTest, PoseBlendShapesActOnlyWhenJointsBelowTheRootRotate) {
  const SmplModel model = SmplModel::load(s_path);
  const SmplModel flat = SmplModel::load(s_flat_path);
  const std::vector<double> betas = {0.5, 0.5, 0.5, 0.5};
  Pose pose;
  pose.translation << 0.1, -0.2, 0.3;
  EXPECT_EQ(model.posed_vertices(betas, pose), flat.posed_vertices(betas, pose));
  pose.axis_angle.row(0) << 0.3, -1.0, 0.2;
  EXPECT_EQ(model.posed_vertices(betas, pose), flat.posed_vertices(betas, pose));
  pose.axis_angle.row(idx(Joint::LEFT_ELBOW)) << 0.0, 0.0, 0.8;
  const VertexPositions with = model.posed_vertices(betas, pose);
  const VertexPositions without = flat.posed_vertices(betas, pose);
  EXPECT_GT((with - without).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(test::max_difference(without, reference_smpl(*s_flat, betas, pose)), 1e-9);
}

TEST_F(SmplModelTest, SkinsWithTheDenseWeightsNotTheTopFour) {
  const SmplModel flat = SmplModel::load(s_flat_path);
  const Pose pose = test::random_pose(21, 0.8);
  const VertexPositions dense = flat.posed_vertices({}, pose);
  const Body top4 = pose_body(flat.rest_body(), pose);
  double pelvis_box = 0, other_boxes = 0; // the pelvis box's vertices have 6 influences, the others 4
  for (Eigen::Index i = 0; i < dense.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      const double d = std::abs(dense(i, k) - top4.mesh.positions[static_cast<std::size_t>(3 * i + k)]);
      (i < 8 ? pelvis_box : other_boxes) = std::max(i < 8 ? pelvis_box : other_boxes, d);
    }
  EXPECT_GT(pelvis_box, 1e-3);
  EXPECT_LT(other_boxes, 1e-5); // float positions and weights in pose_body
}

TEST_F(SmplModelTest, RestBodyIsTheShapedTposeWithTopFourWeights) {
  const SmplModel model = SmplModel::load(s_path);
  const std::vector<double> betas = {-1.0, 0.5};
  const Body body = model.rest_body(betas);
  EXPECT_EQ(body.source, s_path.string());
  EXPECT_EQ(body.rest_pose, RestPose::TPOSE);
  EXPECT_EQ(body.joints, model.rest_joints(betas));
  EXPECT_EQ(body.mesh.positions, model.shaped_mesh(betas).positions);
  EXPECT_EQ(body.mesh.triangles.size(), 3 * model.face_count());
  EXPECT_NO_THROW(validate_skin_weights(body.weights, model.vertex_count(), body.source));
  const std::size_t v = 12; // a 4-influence vertex: its weights are kept as they are
  for (int k = 0; k < 4; ++k)
    EXPECT_FLOAT_EQ(body.weights.weights[4 * v + k],
                    static_cast<float>(s_model->weights[v * 24 + body.weights.joints[4 * v + k]]));
}

TEST_F(SmplModelTest, MembersItDoesNotUseAreIgnored) {
  NpyList arrays = s_model->arrays();
  arrays.emplace_back("bs_style", NpyData{"<U3", {}, {0}});
  arrays.emplace_back("vert_sym_idxs", NpyData{"|O", {1}, {0}});
  arrays.emplace_back("J", NpyData{"<f8", {24, 3}, std::vector<double>(72, 0.5)});
  const auto path = write_to(*s_dir, "extra.npz", test::npz_bytes(arrays, ZipMode::DEFLATED));
  EXPECT_EQ(SmplModel::load(path).vertex_count(), s_model->nv);
}

TEST_F(SmplModelTest, BetasLongerThanTheModelAreAnError) {
  const SmplModel model = SmplModel::load(s_path);
  const std::vector<double> betas(NB + 1, 0.1);
  expect_error([&] { model.shaped_mesh(betas); }, s_path, {"5 shape coefficients", "'shapedirs'"});
  expect_error([&] { model.posed_mesh(betas, Pose{}); }, s_path, {"5 shape coefficients"});
}

struct FormatCase {
  std::string name;
  ZipMode mode;
  std::string template_descr, kintree_descr;
  double root_parent;
  bool flat_posedirs;
  friend std::ostream& operator<<(std::ostream& os, const FormatCase& c) { return os << c.name; }
};

class SmplModelFormat : public testing::TestWithParam<FormatCase> {};

TEST_P(SmplModelFormat, LoadsAndMatchesTheReference) {
  const FormatCase& c = GetParam();
  const SyntheticSmpl m(3);
  NpyList arrays = m.arrays();
  array_named(arrays, "v_template").descr = c.template_descr;
  array_named(arrays, "kintree_table").descr = c.kintree_descr;
  array_named(arrays, "kintree_table").values[0] = c.root_parent;
  if (c.flat_posedirs) array_named(arrays, "posedirs").shape = {3 * m.nv, NP};
  const test::TempDir dir;
  const SmplModel model = SmplModel::load(write_to(dir, "m.npz", test::npz_bytes(arrays, c.mode)));
  EXPECT_EQ(model.vertex_count(), m.nv);
  EXPECT_EQ(model.face_count(), m.faces.size() / 3);
  const std::vector<double> betas = {0.5, -1.0, 2.0, 0.25};
  const Pose pose = test::random_pose(5);
  EXPECT_LT(test::max_difference(model.posed_vertices(betas, pose), reference_smpl(m, betas, pose)), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(
    SmplModel, SmplModelFormat,
    testing::Values(FormatCase{"DeflatedF4", ZipMode::DEFLATED, "<f4", "<i8", -1, false},
                    FormatCase{"StoredBigEndianU4Root", ZipMode::STORED, ">f8", "<u4", 4294967295.0, true},
                    FormatCase{"Zip64", ZipMode::STORED_ZIP64, "<f8", ">i4", -1, false},
                    FormatCase{"U8Root", ZipMode::DEFLATED, "<f4", "<u8", 18446744073709551615.0, true}),
    [](const auto& p) { return p.param.name; });

struct BadModelCase {
  std::string name;
  std::function<void(NpyList&, std::size_t nv)> mutate;
  std::vector<std::string> message_parts;
  bool truncate_file = false;
  friend std::ostream& operator<<(std::ostream& os, const BadModelCase& c) { return os << c.name; }
};

class SmplModelBadInput : public testing::TestWithParam<BadModelCase> {};

TEST_P(SmplModelBadInput, ThrowsNamingTheFileAndTheArray) {
  const SyntheticSmpl m(9);
  NpyList arrays = m.arrays();
  GetParam().mutate(arrays, m.nv);
  std::string bytes = test::npz_bytes(arrays, ZipMode::DEFLATED);
  if (GetParam().truncate_file) bytes.resize(bytes.size() / 2);
  const test::TempDir dir;
  const auto path = write_to(dir, "model.npz", bytes);
  expect_error([&] { SmplModel::load(path); }, path, GetParam().message_parts);
}

using Arrays = NpyList&;
INSTANTIATE_TEST_SUITE_P(
    SmplModel, SmplModelBadInput,
    testing::Values(BadModelCase{"MissingArray",
                                 [](Arrays a, std::size_t) {
                                   std::erase_if(a, [](const auto& e) { return e.first == "J_regressor"; });
                                 },
                                 {"no array 'J_regressor'"}},
                    BadModelCase{"TemplateWrongShape",
                                 [](Arrays a, std::size_t nv) {
                                   array_named(a, "v_template").shape = {3 * nv / 4, 4};
                                 },
                                 {"array 'v_template' has shape (36, 4)"}},
                    BadModelCase{"NanInTemplate",
                                 [](Arrays a, std::size_t) { array_named(a, "v_template").values[5] = std::nan(""); },
                                 {"array 'v_template' holds NaN"}},
                    BadModelCase{"InfInPosedirs",
                                 [](Arrays a, std::size_t) { array_named(a, "posedirs").values[77] = HUGE_VAL; },
                                 {"array 'posedirs' holds an infinite value"}},
                    BadModelCase{"FaceIndexOutOfRange",
                                 [](Arrays a, std::size_t nv) { array_named(a, "f").values[7] = double(nv); },
                                 {"array 'f'", "out of range"}},
                    BadModelCase{"NegativeFaceIndex",
                                 [](Arrays a, std::size_t) {
                                   array_named(a, "f").descr = "<i4";
                                   array_named(a, "f").values[0] = -1;
                                 },
                                 {"array 'f'", "vertex index -1"}},
                    BadModelCase{"FractionalFaceIndex",
                                 [](Arrays a, std::size_t) {
                                   array_named(a, "f").descr = "<f8";
                                   array_named(a, "f").values[2] = 1.5;
                                 },
                                 {"array 'f'", "is not an integer"}},
                    BadModelCase{"PickledRegressor",
                                 [](Arrays a, std::size_t) { array_named(a, "J_regressor").descr = "|O"; },
                                 {"array 'J_regressor' is a pickled object array"}},
                    BadModelCase{"WrongParents",
                                 [](Arrays a, std::size_t) { array_named(a, "kintree_table").values[18] = 13; },
                                 {"array 'kintree_table'", "left_elbow"}},
                    BadModelCase{"WrongJointIds",
                                 [](Arrays a, std::size_t) { array_named(a, "kintree_table").values[24 + 3] = 4; },
                                 {"array 'kintree_table'"}},
                    BadModelCase{"KintreeTransposed",
                                 [](Arrays a, std::size_t) {
                                   array_named(a, "kintree_table").shape = {24, 2};
                                 },
                                 {"array 'kintree_table' has shape (24, 2)"}},
                    BadModelCase{"WeightsNotSummingToOne",
                                 [](Arrays a, std::size_t) { array_named(a, "weights").values[24 * 3 + 5] += 0.1; },
                                 {"array 'weights' row 3"}},
                    BadModelCase{"NegativeWeight",
                                 [](Arrays a, std::size_t) {
                                   auto& w = array_named(a, "weights").values;
                                   const auto zero = std::find(w.begin(), w.begin() + 24, 0.0);
                                   *zero = -0.05;
                                   *std::max_element(w.begin(), w.begin() + 24) += 0.05;
                                 },
                                 {"array 'weights' has a negative weight"}},
                    BadModelCase{"PosedirsWrongShape",
                                 [](Arrays a, std::size_t nv) {
                                   auto& p = array_named(a, "posedirs");
                                   p.shape = {nv, 3, 200};
                                   p.values.resize(nv * 3 * 200);
                                 },
                                 {"array 'posedirs' has shape"}},
                    BadModelCase{"ShapedirsWrongVertexCount",
                                 [](Arrays a, std::size_t nv) {
                                   array_named(a, "shapedirs").shape = {nv / 2, 3, 2 * NB};
                                 },
                                 {"array 'shapedirs' has shape"}},
                    BadModelCase{"RegressorTransposed",
                                 [](Arrays a, std::size_t nv) {
                                   array_named(a, "J_regressor").shape = {nv, 24};
                                 },
                                 {"array 'J_regressor'", "expected (24, 48)"}},
                    BadModelCase{"TruncatedShapedirs",
                                 [](Arrays a, std::size_t) { array_named(a, "shapedirs").values.resize(100); },
                                 {"entry 'shapedirs.npy': truncated data"}},
                    BadModelCase{"TruncatedArchive", [](Arrays, std::size_t) {}, {"truncated"}, true}),
    [](const auto& p) { return p.param.name; });

} // namespace
} // namespace vfit
