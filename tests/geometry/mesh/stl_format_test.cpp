// SPDX-License-Identifier: Apache-2.0
// STL reader and writer: binary round trips with welding, ASCII grammar tolerance, binary
// detection, and malformed files that must fail naming the file and the problem.

#include "vfit/geometry/mesh/stl_format.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "test_support.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

::testing::AssertionResult fails_with(const std::string& bytes, const std::vector<std::string>& parts) {
  try {
    read_stl(bytes, "bad.stl");
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

std::array<float, 3> corner(const Mesh& m, std::size_t f, int c) {
  const auto v = static_cast<std::size_t>(m.triangles[3 * f + c]);
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}

std::vector<std::array<float, 3>> sorted_positions(const Mesh& m) {
  std::vector<std::array<float, 3>> out;
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    out.push_back({m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]});
  std::sort(out.begin(), out.end());
  return out;
}

float float_at(const std::string& bytes, std::size_t offset) {
  float v;
  std::memcpy(&v, bytes.data() + offset, 4); // the test host is little-endian, like STL
  return v;
}

TEST(StlFormat, BinaryRoundTripWeldsTheOctahedronBack) {
  const Mesh in = test::octahedron();
  const std::string bytes = write_stl(in);
  ASSERT_EQ(bytes.size(), 84u + 50u * 8u);
  EXPECT_EQ(bytes.substr(0, 15), "vfit binary STL");
  const ParsedMesh out = read_stl(bytes, "rt.stl");
  EXPECT_EQ(out.mesh.vertex_count(), 6u) << "corners with identical positions must weld";
  ASSERT_EQ(out.mesh.face_count(), 8u);
  EXPECT_EQ(sorted_positions(out.mesh), sorted_positions(in));
  for (std::size_t f = 0; f < 8; ++f)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(corner(out.mesh, f, c), corner(in, f, c)) << "face " << f << " corner " << c;
  // Welding recovers topology: every vertex is shared by 4 faces, as in the input.
  std::vector<int> valence(6, 0);
  for (std::int32_t v : out.mesh.triangles)
    ++valence[static_cast<std::size_t>(v)];
  EXPECT_EQ(valence, std::vector<int>(6, 4));
  EXPECT_FALSE(out.source.text);
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
}

TEST(StlFormat, WriterStoresUnitFacetNormalsAndZeroForDegenerate) {
  Mesh m = test::octahedron();
  m.triangles.insert(m.triangles.end(), {0, 0, 1}); // degenerate: two equal corners
  const std::string bytes = write_stl(m);
  const float s = 1.0f / std::sqrt(3.0f);
  // Face 0 is (+x, +y, +z): outward normal (1, 1, 1)/√3, to float rounding.
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(float_at(bytes, 84 + 4 * k), s, 1e-6f);
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(float_at(bytes, 84 + 50 * 8 + 4 * k), 0.0f);
}

TEST(StlFormat, BinaryWhoseHeaderStartsWithSolidIsStillBinary) {
  std::string bytes = write_stl(test::octahedron());
  const std::string fake = "solid pretending to be ascii";
  std::memcpy(bytes.data(), fake.data(), fake.size());
  const ParsedMesh out = read_stl(bytes, "s.stl");
  EXPECT_FALSE(out.source.text);
  EXPECT_EQ(out.mesh.face_count(), 8u);
}

TEST(StlFormat, AsciiWithMultipleSolidsWhitespaceAndCaseVariants) {
  const std::string text =
      "  solid first part\n"
      "facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 1 1 0\n endloop\nendfacet\n"
      "endsolid first part\r\n"
      "SOLID second\r\n"
      "  FACET NORMAL 0 0 1\r\n\tOUTER   LOOP\r\n VERTEX 0 0 0 VERTEX 1 1 0\r\n  vertex +0 1 0\r\n"
      "  ENDLOOP\r\n ENDFACET\r\n"
      "ENDSOLID second\r\n";
  const ParsedMesh out = read_stl(text, "a.stl");
  EXPECT_EQ(out.mesh.vertex_count(), 4u);
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
  EXPECT_TRUE(out.source.text);
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{2, 11}));
  EXPECT_TRUE(out.warnings.empty());
}

// A UTF-8 byte-order mark before "solid": before, read as a truncated binary STL.
TEST(StlFormat, AsciiAfterAUtf8ByteOrderMark) {
  std::string text = "\xEF\xBB\xBFsolid s\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n"
                     "  vertex 0 1 0\n endloop\nendfacet\nendsolid s\n";
  text += std::string(100, ' '); // past the 84 bytes of a binary header, as a real file is
  const ParsedMesh out = read_stl(text, "a.stl");
  EXPECT_TRUE(out.source.text);
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2}));
}

TEST(StlFormat, WeldsNegativeZeroWithZeroAndTriangulatesPolygonLoops) {
  const std::string text =
      "solid q\nfacet normal 0 0 1\nouter loop\nvertex -0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 -0.0\n"
      "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex -1 0 0\nendloop\n"
      "endfacet\n"; // no endsolid: accepted with a warning
  const ParsedMesh out = read_stl(text, "q.stl");
  EXPECT_EQ(out.mesh.vertex_count(), 5u);
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{2, 2, 10}));
  ASSERT_EQ(out.warnings.size(), 1u);
  EXPECT_NE(out.warnings[0].find("endsolid"), std::string::npos);
}

struct BadCase {
  const char* name;
  std::string bytes;
  std::vector<std::string> parts;
};

std::string with_float(std::string bytes, std::size_t offset, float v) {
  std::memcpy(bytes.data() + offset, &v, 4);
  return bytes;
}

std::string binary_octahedron() { return write_stl(test::octahedron()); }

std::string solid_headed_truncated() {
  std::string bytes = binary_octahedron();
  std::memcpy(bytes.data(), "solid x", 7);
  return bytes.substr(0, bytes.size() - 20);
}

const std::string FACET_HEAD = "solid t\nfacet normal 0 0 1\nouter loop\n";

class StlFormatBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(StlFormatBadInput, ThrowsNamingTheFileAndTheProblem) {
  EXPECT_THROW(read_stl(GetParam().bytes, "bad.stl"), Error);
  std::vector<std::string> parts = GetParam().parts;
  parts.insert(parts.begin(), "bad.stl");
  EXPECT_TRUE(fails_with(GetParam().bytes, parts));
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, StlFormatBadInput,
    ::testing::Values(
        BadCase{"empty", "", {"bad.stl: empty file"}},
        BadCase{"short_garbage", "hello, world", {"bad.stl:1: not an STL file"}},
        BadCase{"long_garbage", std::string(200, 'x'), {"bad.stl: ", "not an STL file"}},
        BadCase{"trailing_bytes", binary_octahedron() + "xx", {"not an STL file", "sizes do not match", "486"}},
        BadCase{"truncated_binary",
                binary_octahedron().substr(0, 84 + 50 * 5 + 7),
                {"bad.stl: truncated binary STL", "header declares 8 facets (484 bytes), file has 341 bytes"}},
        BadCase{"truncated_binary_solid_header", solid_headed_truncated(), {"truncated binary STL"}},
        BadCase{"absurd_facet_count",
                with_float(binary_octahedron(), 80, std::bit_cast<float>(0xFFFFFFFFu)),
                {"truncated binary STL", "4294967295 facets"}},
        BadCase{"binary_nan",
                with_float(binary_octahedron(), 84 + 50 + 12 + 4, std::numeric_limits<float>::quiet_NaN()),
                {"bad.stl: facet 2: vertex coordinate is NaN"}},
        BadCase{"binary_inf",
                with_float(binary_octahedron(), 84 + 12, std::numeric_limits<float>::infinity()),
                {"facet 1: vertex coordinate is infinite"}},
        BadCase{"binary_no_facets", std::string(80, ' ') + std::string(4, '\0'), {"bad.stl: no faces"}},
        BadCase{"ascii_no_facets", "solid empty\nendsolid empty\n", {"bad.stl: no faces"}},
        BadCase{"ascii_truncated", FACET_HEAD + "vertex 0 0 0\nvertex 1 0", {"bad.stl:5: truncated"}},
        BadCase{"ascii_nan", FACET_HEAD + "vertex 0 0 0\nvertex nan 0 0\n", {"bad.stl:5: vertex coordinate is NaN"}},
        BadCase{"ascii_inf", FACET_HEAD + "vertex 0 0 0\nvertex 1 0 1e39\n", {":5:", "infinite"}},
        BadCase{"ascii_non_numeric", FACET_HEAD + "vertex 0 zero 0\n", {"bad.stl:4: 'zero' is not a number"}},
        BadCase{
            "ascii_bad_keyword", "solid t\nfacet normal 0 0 1\nouter lop\n", {":3:", "expected 'loop', found 'lop'"}},
        BadCase{"ascii_two_vertex_loop",
                FACET_HEAD + "vertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n",
                {":6:", "2 vertices"}},
        BadCase{"ascii_trailing_garbage",
                FACET_HEAD + "vertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\ngarbage\n",
                {":10:", "expected 'solid', found 'garbage'"}}),
    [](const auto& test_case) { return std::string(test_case.param.name); });

} // namespace
} // namespace vfit
