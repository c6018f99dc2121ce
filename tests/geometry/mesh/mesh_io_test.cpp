// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/mesh_io.h"

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/validate.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

std::string read_error(const std::filesystem::path& p, ReadOptions o = {}) {
  try {
    read_mesh(p, o);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

class MeshIoRoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(MeshIoRoundTrip, WriteThenReadKeepsGeometryAndUvs) {
  test::TempDir tmp;
  const Mesh m = make_uv_sphere(6, 10, 0.5f);
  const auto path = tmp / (std::string("sphere") + GetParam());
  write_mesh(path, m);
  const ParsedMesh back = read_mesh(path);
  EXPECT_EQ(back.mesh.vertex_count(), m.vertex_count());
  EXPECT_EQ(back.mesh.face_count(), m.face_count());
  const std::string ext = GetParam();
  if (ext != ".stl") { // STL re-welds vertices in its own order
    EXPECT_EQ(back.mesh.positions, m.positions);
    EXPECT_EQ(back.mesh.triangles, m.triangles);
  }
  if (ext == ".obj" || ext == ".ply" || ext == ".glb") {
    ASSERT_TRUE(back.mesh.has_uvs());
    for (std::size_t c = 0; c < m.uv_triangles.size(); ++c)
      for (int k = 0; k < 2; ++k)
        ASSERT_EQ(back.mesh.uvs[2 * back.mesh.uv_triangles[c] + k], m.uvs[2 * m.uv_triangles[c] + k]) << "corner " << c;
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, MeshIoRoundTrip, ::testing::Values(".obj", ".ply", ".off", ".stl", ".glb"),
                         [](const auto& param) { return std::string(param.param + 1); });

TEST(MeshIo, DetectsFormatFromExtensionCaseInsensitively) {
  EXPECT_EQ(mesh_format_from_path("a/B.OBJ"), MeshFormat::OBJ);
  EXPECT_EQ(mesh_format_from_path("x.Glb"), MeshFormat::GLB);
  EXPECT_THROW(mesh_format_from_path("x.fbx"), Error);
  EXPECT_THROW(mesh_format_from_path("noext"), Error);
}

TEST(MeshIo, MissingFileAndFolderAreNamed) {
  test::TempDir tmp;
  EXPECT_NE(read_error(tmp / "nope.obj").find("nope.obj: cannot open"), std::string::npos);
  std::filesystem::create_directory(tmp / "dir.obj");
  EXPECT_NE(read_error(tmp / "dir.obj").find("not a regular file"), std::string::npos);
}

TEST(MeshIo, DegenerateAndDuplicateFacesNameTheirLineOrAreRepaired) {
  test::TempDir tmp;
  const auto deg = tmp / "deg.obj";
  test::write_file(deg, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\n");
  EXPECT_NE(read_error(deg).find("deg.obj:5: degenerate face"), std::string::npos) << read_error(deg);
  const auto dup = tmp / "dup.obj";
  test::write_file(dup, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3 1\n");
  EXPECT_NE(read_error(dup).find("dup.obj:5: duplicate face: same vertices as face 1 (line 4)"), std::string::npos)
      << read_error(dup);
  ReadOptions repair;
  repair.repair = true;
  const ParsedMesh fixed = read_mesh(dup, repair);
  EXPECT_EQ(fixed.mesh.face_count(), 1u);
  ASSERT_EQ(fixed.warnings.size(), 1u);
  EXPECT_NE(fixed.warnings[0].find("dropped 0 degenerate faces and 1 duplicate face"), std::string::npos);
}

TEST(MeshIo, ValidationRejectsProgrammaticBadMeshes) {
  Mesh m = test::unit_square();
  MeshSource src{"mem", false, {}};
  std::vector<std::string> warnings;
  m.positions[4] = std::numeric_limits<float>::quiet_NaN();
  try {
    validate_mesh(m, src, {}, warnings);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mem: vertex 2: coordinate is NaN"), std::string::npos) << e.what();
  }
  m = test::unit_square();
  m.triangles[5] = -1;
  try {
    validate_mesh(m, src, {}, warnings);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mem: face 2: vertex index 0 out of range"), std::string::npos) << e.what();
  }
  Mesh empty;
  EXPECT_THROW(validate_mesh(empty, src, {}, warnings), Error);
}

TEST(MeshIo, WritesAtomicallyAndLeavesNoTemporaryFiles) {
  test::TempDir tmp;
  const auto out = tmp / "out.obj";
  test::write_file(out, "old contents");
  write_mesh(out, test::unit_square());
  EXPECT_EQ(read_mesh(out).mesh.face_count(), 2u);
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(tmp.path())) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 1u);
  // A folder that does not exist: an error naming the output, and nothing written.
  EXPECT_THROW(write_file_atomically(tmp / "missing" / "x.obj", "x"), Error);
  EXPECT_FALSE(std::filesystem::exists(tmp / "missing"));
}

} // namespace
} // namespace vfit
