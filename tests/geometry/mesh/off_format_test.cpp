// SPDX-License-Identifier: Apache-2.0
// OFF reader and writer: exact round trips, header variants, polygons, and malformed files
// that must fail naming the file, the line and the problem.

#include "vfit/geometry/mesh/off_format.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>

#include "test_support.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

::testing::AssertionResult fails_with(const std::string& bytes, const std::vector<std::string>& parts) {
  try {
    read_off(bytes, "bad.off");
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const std::string& part : parts)
      if (what.find(part) == std::string::npos)
        return ::testing::AssertionFailure() << "message \"" << what << "\" lacks \"" << part << "\"";
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw a non-vfit exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "did not throw";
}

/// Random finite float bit patterns (denormals and extremes included): a text round trip of
/// these is exact only if both the writer and the parser are.
Mesh awkward_floats() {
  Mesh m;
  std::mt19937 rng(11);
  while (m.positions.size() < 3 * 200) {
    const float v = std::bit_cast<float>(static_cast<std::uint32_t>(rng()));
    if (std::isfinite(v)) m.positions.push_back(v);
  }
  for (std::int32_t i = 0; i + 2 < 200; ++i)
    m.triangles.insert(m.triangles.end(), {i, i + 2, i + 1});
  return m;
}

struct RoundTripCase {
  const char* name;
  std::function<Mesh()> make;
};

class OffFormatRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(OffFormatRoundTrip, ReadsBackWhatItWrote) {
  const Mesh in = GetParam().make();
  const ParsedMesh out = read_off(write_off(in), "rt.off");
  ASSERT_EQ(out.mesh.positions.size(), in.positions.size());
  EXPECT_EQ(std::memcmp(out.mesh.positions.data(), in.positions.data(), in.positions.size() * sizeof(float)), 0)
      << "positions are not bit-identical";
  EXPECT_EQ(out.mesh.triangles, in.triangles);
  EXPECT_FALSE(out.mesh.has_uvs());
  EXPECT_TRUE(out.source.text);
  EXPECT_EQ(out.source.path, "rt.off");
  // "OFF", the counts, one line per vertex, then one line per face.
  ASSERT_EQ(out.source.face_origin.size(), in.face_count());
  for (std::size_t f = 0; f < in.face_count(); ++f)
    EXPECT_EQ(out.source.face_origin[f], static_cast<std::int64_t>(3 + in.vertex_count() + f));
  EXPECT_TRUE(out.warnings.empty());
}

INSTANTIATE_TEST_SUITE_P(Meshes, OffFormatRoundTrip,
                         ::testing::Values(RoundTripCase{"square", test::unit_square},
                                           RoundTripCase{"octahedron", test::octahedron},
                                           RoundTripCase{"awkward_floats", awkward_floats}),
                         [](const auto& test_case) { return std::string(test_case.param.name); });

TEST(OffFormat, CountsOnTheHeaderLineAndComments) {
  const std::string text = "# made by hand\nOFF 4 1 0 # counts here\n\n# vertices\n0 0 0\n1 0 0\n1 1 0 # c\n0 1 0\n"
                           "4 0 1 2 3\n";
  const ParsedMesh out = read_off(text, "c.off");
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{9, 9}));
}

TEST(OffFormat, TriangulatesPolygonsAndIgnoresColours) {
  const std::string text = "COFF\r\n5 2 0\r\n0 0 0 255 0 0 255\r\n1 0 0 255 0 0 255\r\n1 1 0 1 1 1 1\r\n"
                           "0 1 0 0 0 0 0\r\n0.5 1.5 0 0 0 0 0\r\n5 0 1 2 4 3 1.0 0.0 0.0\r\n3 0 1 2\r\n";
  const ParsedMesh out = read_off(text, "p.off");
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 4, 0, 4, 3, 0, 1, 2}));
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{8, 8, 8, 9}));
  EXPECT_FALSE(out.mesh.has_normals());
}

TEST(OffFormat, ReadsNoffNormals) {
  const std::string text = "NOFF\n3 1 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 -1\n3 0 1 2\n";
  const Mesh m = read_off(text, "n.off").mesh;
  EXPECT_EQ(m.normals, (std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, -1}));
  EXPECT_EQ(m.normal_triangles, m.triangles);
}

struct BadCase {
  const char* name;
  std::string bytes;
  std::vector<std::string> parts;
};

class OffFormatBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(OffFormatBadInput, ThrowsNamingTheFileAndTheProblem) {
  EXPECT_THROW(read_off(GetParam().bytes, "bad.off"), Error);
  std::vector<std::string> parts = GetParam().parts;
  parts.insert(parts.begin(), "bad.off");
  EXPECT_TRUE(fails_with(GetParam().bytes, parts));
}

const std::string TRIANGLE_VERTICES = "0 0 0\n1 0 0\n0 1 0\n";

INSTANTIATE_TEST_SUITE_P(
    Catalogue, OffFormatBadInput,
    ::testing::Values(
        BadCase{"empty", "", {"bad.off: empty file"}}, BadCase{"only_comments", "# nothing\n\n", {"not an OFF file"}},
        BadCase{"garbage",
                std::string("\x7f"
                            "ELF\x02\x01\x01\0\0\0",
                            10),
                {"bad.off:1: not an OFF file"}},
        BadCase{"bad_magic", "OBJ\n3 1 0\n", {":1:", "missing 'OFF' header"}},
        BadCase{"four_d", "4OFF\n3 1 0\n", {":1:", "unsupported OFF variant"}},
        BadCase{"binary", "OFF BINARY\n", {":1:", "binary OFF"}},
        BadCase{"missing_counts", "OFF\n", {"missing vertex and face counts"}},
        BadCase{"missing_face_count", "OFF\n3\n", {":2:", "missing face count"}},
        BadCase{"negative_count", "OFF\n-3 1 0\n", {":2:", "negative vertex count"}},
        BadCase{"count_not_integer", "OFF\nthree 1 0\n", {":2:", "'three' is not an integer"}},
        BadCase{"absurd_count",
                "OFF\n1000000000000000 1 0\n" + TRIANGLE_VERTICES,
                {"bad.off:5: truncated: header declares 1000000000000000 vertices, data ends after 3"}},
        BadCase{"truncated_vertices", "OFF\n3 1 0\n0 0 0\n1 0 0\n", {":4: truncated", "3 vertices, data ends after 2"}},
        BadCase{"truncated_faces",
                "OFF\n3 2 0\n" + TRIANGLE_VERTICES + "3 0 1 2\n",
                {":6: truncated", "2 faces, data ends after 1"}},
        BadCase{"nan", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n", {"bad.off:5: vertex 3: coordinate is NaN"}},
        BadCase{"inf", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", {":4:", "infinite"}},
        BadCase{"overflow", "OFF\n3 1 0\n0 0 0\n1 -1e39 0\n0 1 0\n3 0 1 2\n", {":4:", "infinite"}},
        BadCase{"short_vertex", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", {":4:", "vertex 2: missing coordinate"}},
        BadCase{"non_numeric", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n", {":4:", "'x' is not a number"}},
        BadCase{"huge_index",
                "OFF\n3 1 0\n" + TRIANGLE_VERTICES + "3 0 1 99999999999\n",
                {"bad.off:6: face 1: vertex index 99999999999 out of range (3 vertices)"}},
        BadCase{
            "negative_index", "OFF\n3 1 0\n" + TRIANGLE_VERTICES + "3 0 -1 2\n", {":6:", "negative vertex index -1"}},
        BadCase{"two_vertex_face", "OFF\n3 1 0\n" + TRIANGLE_VERTICES + "2 0 1\n", {":6:", "at least 3"}},
        BadCase{"huge_face_count", "OFF\n3 1 0\n" + TRIANGLE_VERTICES + "4000000000 0 1 2\n", {":6:", "fewer indices"}},
        BadCase{"fractional_index", "OFF\n3 1 0\n" + TRIANGLE_VERTICES + "3 0 1 1.5\n", {":6:", "not an integer"}},
        BadCase{"no_faces", "OFF\n3 0 0\n" + TRIANGLE_VERTICES, {"bad.off: no faces"}}),
    [](const auto& test_case) { return std::string(test_case.param.name); });

} // namespace
} // namespace vfit
