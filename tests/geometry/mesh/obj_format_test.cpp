// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/obj_format.h"

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

std::string error_of(const std::string& text) {
  try {
    read_obj(text, "t.obj");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ObjFormat, ReadsTrianglesQuadsAndPolygonsWithFans) {
  const std::string text = "# comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\n"
                           "f 1 2 3\nf 1 2 3 4\nf 1 2 3 5 4\n";
  ParsedMesh p = read_obj(text, "t.obj");
  EXPECT_EQ(p.mesh.vertex_count(), 5u);
  EXPECT_EQ(p.mesh.face_count(), 1u + 2u + 3u);
  const std::vector<std::int32_t> want = {0, 1, 2, 0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 4, 0, 4, 3};
  EXPECT_EQ(p.mesh.triangles, want);
  EXPECT_EQ(p.source.face_origin, (std::vector<std::int64_t>{7, 8, 8, 9, 9, 9}));
}

TEST(ObjFormat, KeepsUvsNormalsAndGroupsPerCorner) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nvn 0 0 1\n"
                           "g front\nf 1/1/1 2/2/1 3/3/1\ng back\nf 1/4/1 3/3/1 2/2/1\n";
  ParsedMesh p = read_obj(text, "t.obj");
  ASSERT_TRUE(p.mesh.has_uvs());
  ASSERT_TRUE(p.mesh.has_normals());
  EXPECT_EQ(p.mesh.uv_triangles, (std::vector<std::int32_t>{0, 1, 2, 3, 2, 1}));
  EXPECT_EQ(p.mesh.normal_triangles, (std::vector<std::int32_t>{0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(p.mesh.label_names, (std::vector<std::string>{"front", "back"}));
  EXPECT_EQ(p.mesh.face_labels, (std::vector<std::int32_t>{0, 1}));
}

TEST(ObjFormat, ResolvesNegativeRelativeIndices) {
  ParsedMesh p = read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -1 -2\n", "t.obj");
  EXPECT_EQ(p.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 3, 2}));
}

TEST(ObjFormat, AcceptsCrLfTabsPlusSignsAndExtraVertexColours) {
  ParsedMesh p = read_obj("v\t+0 0 0 1 0 0\r\nv 1e0 0 0\r\nv 0 1 0\r\nf 1// 2 3\r\n", "t.obj");
  EXPECT_EQ(p.mesh.vertex_count(), 3u);
  EXPECT_EQ(p.mesh.positions[3], 1.0f);
}

// A UTF-8 byte-order mark (Notepad, some exporters): before, it hid the first vertex, and the
// face then named vertex 3 of 2.
TEST(ObjFormat, SkipsAUtf8ByteOrderMark) {
  ParsedMesh p = read_obj("\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj");
  EXPECT_EQ(p.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  EXPECT_EQ(p.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2}));
  EXPECT_EQ(p.source.face_origin, (std::vector<std::int64_t>{4}));
  EXPECT_TRUE(p.warnings.empty());
}

TEST(ObjFormat, RoundTripIsExact) {
  Mesh m = make_uv_sphere(7, 9, 0.123456789f);
  m.face_labels.assign(m.face_count(), 0);
  for (std::size_t f = m.face_count() / 2; f < m.face_count(); ++f)
    m.face_labels[f] = 1;
  m.label_names = {"upper", "lower"};
  ParsedMesh back = read_obj(write_obj(m), "t.obj");
  EXPECT_EQ(back.mesh.positions, m.positions);
  EXPECT_EQ(back.mesh.triangles, m.triangles);
  EXPECT_EQ(back.mesh.uvs, m.uvs);
  EXPECT_EQ(back.mesh.uv_triangles, m.uv_triangles);
  EXPECT_EQ(back.mesh.face_labels, m.face_labels);
  EXPECT_EQ(back.mesh.label_names, m.label_names);
}

TEST(ObjFormat, ParallelChunksGiveTheSameMeshAsOneChunk) {
  // Large enough for several 1 MiB chunks, with relative indices crossing chunk borders.
  std::string text;
  const int n = 60000;
  for (int i = 0; i < n; ++i)
    text += "v " + std::to_string(i) + " " + std::to_string(i % 7) + " 0.25\n";
  for (int i = 0; i + 2 < n; ++i)
    text += "f " + std::to_string(i + 1) + " " + std::to_string(i + 2) + " -" + std::to_string(n - i - 2) + "\n";
  ASSERT_GT(text.size(), 2u << 20);
  ParsedMesh p = read_obj(text, "big.obj");
  ASSERT_EQ(p.mesh.vertex_count(), std::size_t(n));
  ASSERT_EQ(p.mesh.face_count(), std::size_t(n - 2));
  for (int i = 0; i + 2 < n; ++i) {
    ASSERT_EQ(p.mesh.triangles[3 * i], i);
    ASSERT_EQ(p.mesh.triangles[3 * i + 2], i + 2) << "face " << i;
    ASSERT_EQ(p.source.face_origin[i], n + i + 1);
  }
}

struct BadObj {
  const char* name;
  const char* text;
  const char* expect; // substring of the message
};

void PrintTo(const BadObj& b, std::ostream* os) { *os << b.name; }

class ObjFormatBadInput : public ::testing::TestWithParam<BadObj> {};

TEST_P(ObjFormatBadInput, NamesFileLineAndProblem) {
  const std::string msg = error_of(GetParam().text);
  EXPECT_NE(msg.find("t.obj"), std::string::npos) << msg;
  EXPECT_NE(msg.find(GetParam().expect), std::string::npos) << msg;
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, ObjFormatBadInput,
    ::testing::Values(
        BadObj{"nan", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj:2: x coordinate is NaN"},
        BadObj{"inf", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", "t.obj:3: y coordinate is infinite"},
        BadObj{"overflow", "v 0 0 0\nv 1 0 1e999\nv 0 1 0\nf 1 2 3\n", "t.obj:2: z coordinate is infinite"},
        BadObj{"garbage_number", "v 0 0 0\nv 1 abc 0\nv 0 1 0\nf 1 2 3\n", "t.obj:2: bad number 'abc'"},
        BadObj{"missing_coordinate", "v 0 0\n", "t.obj:1: missing z coordinate"},
        BadObj{"huge_index", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999\n",
               "t.obj:4: vertex index 99999999 out of range"},
        BadObj{"index_zero", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "t.obj:4: face index 0"},
        BadObj{"relative_before_start", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "t.obj:4: vertex index (relative)"},
        BadObj{"two_vertex_face", "v 0 0 0\nv 1 0 0\nf 1 2\n", "t.obj:3: face with 2 vertices"},
        BadObj{"bad_uv_index", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
               "t.obj:5: texture index 2 out of range"},
        BadObj{"no_faces", "v 0 0 0\nv 1 0 0\n", "no faces"},
        BadObj{"garbage", "\x01\x02\x03 hello\x7f\nzzz\n", "not an OBJ mesh"}, BadObj{"empty", "", "not an OBJ mesh"},
        BadObj{"bad_face_token", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x3\n", "t.obj:4: bad face index"},
        BadObj{"huge_integer", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n",
               "t.obj:4: bad face index"}),
    [](const ::testing::TestParamInfo<BadObj>& param) { return std::string(param.param.name); });

} // namespace
} // namespace vfit
