// SPDX-License-Identifier: Apache-2.0
// PLY reader and writer: exact round trips, every encoding and scalar type, skipping what vfit
// does not read, and a catalogue of malformed files that must fail with a useful message.

#include "vfit/geometry/mesh/ply_format.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>

#include "test_support.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

/// Binary PLY bodies built value by value in either byte order.
class Bytes {
public:
  explicit Bytes(std::string header, bool big_endian = false) : m_bytes(std::move(header)), m_big(big_endian) {}
  template <class T> Bytes& put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (m_big == (std::endian::native == std::endian::little)) std::reverse(raw, raw + sizeof(T));
    m_bytes.append(raw, sizeof(T));
    return *this;
  }
  template <class T> Bytes& put(std::initializer_list<T> values) {
    for (T v : values)
      put(v);
    return *this;
  }
  const std::string& str() const { return m_bytes; }

private:
  std::string m_bytes;
  bool m_big;
};

std::string binary_header(const std::string& elements, const char* encoding = "binary_little_endian") {
  return std::string("ply\nformat ") + encoding + " 1.0\n" + elements + "end_header\n";
}

/// The message of the vfit::Error that reading `bytes` throws, or a failure saying what happened.
::testing::AssertionResult fails_with(const std::string& bytes, const std::vector<std::string>& parts) {
  try {
    read_ply(bytes, "bad.ply");
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

/// UV of corner c of triangle f, resolved through uv_triangles.
std::pair<float, float> corner_uv(const Mesh& m, std::size_t f, int c) {
  const auto t = static_cast<std::size_t>(m.uv_triangles[3 * f + c]);
  return {m.uvs[2 * t], m.uvs[2 * t + 1]};
}

/// A mesh whose coordinates are random finite float bit patterns (denormals and extremes
/// included), so a text round trip is exact only if writing and parsing are.
Mesh awkward_floats() {
  Mesh m;
  std::mt19937 rng(7);
  while (m.positions.size() < 3 * 300) {
    const float v = std::bit_cast<float>(static_cast<std::uint32_t>(rng()));
    if (std::isfinite(v)) m.positions.push_back(v);
  }
  for (std::int32_t i = 0; i + 2 < 300; ++i)
    m.triangles.insert(m.triangles.end(), {i, i + 1, i + 2});
  return m;
}

Mesh octahedron_with_normals() {
  Mesh m = test::octahedron();
  m.normals = m.positions; // unit vectors already
  m.normal_triangles = m.triangles;
  return m;
}

struct RoundTripCase {
  const char* name;
  std::function<Mesh()> make;
  bool binary;
};

class PlyFormatRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(PlyFormatRoundTrip, ReadsBackWhatItWrote) {
  const Mesh in = GetParam().make();
  const std::string bytes = write_ply(in, GetParam().binary);
  const ParsedMesh out = read_ply(bytes, "rt.ply");
  ASSERT_EQ(out.mesh.positions.size(), in.positions.size());
  EXPECT_EQ(std::memcmp(out.mesh.positions.data(), in.positions.data(), in.positions.size() * sizeof(float)), 0)
      << "positions are not bit-identical";
  EXPECT_EQ(out.mesh.triangles, in.triangles);
  EXPECT_EQ(out.mesh.normals, in.normals);
  EXPECT_EQ(out.mesh.has_normals(), in.has_normals());
  ASSERT_EQ(out.mesh.has_uvs(), in.has_uvs());
  for (std::size_t f = 0; in.has_uvs() && f < in.face_count(); ++f)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(corner_uv(out.mesh, f, c), corner_uv(in, f, c)) << "face " << f;
  EXPECT_EQ(out.source.path, "rt.ply");
  EXPECT_EQ(out.source.text, !GetParam().binary);
  ASSERT_EQ(out.source.face_origin.size(), in.face_count());
  // Binary: 1-based face indices; ASCII: the face's line, after the header and vertex lines.
  const auto header_lines = std::count(bytes.begin(), bytes.begin() + bytes.find("end_header") + 11, '\n');
  for (std::size_t f = 0; f < in.face_count(); ++f) {
    const auto first = GetParam().binary ? 1 : header_lines + static_cast<std::int64_t>(in.vertex_count()) + 1;
    EXPECT_EQ(out.source.face_origin[f], first + static_cast<std::int64_t>(f));
  }
  EXPECT_TRUE(out.warnings.empty());
}

INSTANTIATE_TEST_SUITE_P(Meshes, PlyFormatRoundTrip,
                         ::testing::Values(RoundTripCase{"square_uvs_binary", test::unit_square, true},
                                           RoundTripCase{"square_uvs_ascii", test::unit_square, false},
                                           RoundTripCase{"octahedron_binary", test::octahedron, true},
                                           RoundTripCase{"octahedron_ascii", test::octahedron, false},
                                           RoundTripCase{"normals_binary", octahedron_with_normals, true},
                                           RoundTripCase{"normals_ascii", octahedron_with_normals, false},
                                           RoundTripCase{"awkward_floats_binary", awkward_floats, true},
                                           RoundTripCase{"awkward_floats_ascii", awkward_floats, false}),
                         [](const auto& test_case) { return std::string(test_case.param.name); });

TEST(PlyFormat, WriterSkipsNormalsThatAreNotPerVertex) {
  Mesh m = test::octahedron();
  m.normals = {0, 0, 1};
  m.normal_triangles.assign(m.triangles.size(), 0);
  const std::string bytes = write_ply(m, false);
  EXPECT_EQ(bytes.find("property float nx"), std::string::npos);
  EXPECT_FALSE(read_ply(bytes, "n.ply").mesh.has_normals());
}

TEST(PlyFormat, ReadsBigEndianWithMixedScalarTypes) {
  const std::string header = binary_header("element vertex 4\nproperty double x\nproperty float32 y\nproperty int16 z\n"
                                           "element face 1\nproperty list ushort uint vertex_indices\n",
                                           "binary_big_endian");
  Bytes b(header, true);
  b.put(0.5).put(1.25f).put(std::int16_t{-3});
  b.put(2.0).put(0.0f).put(std::int16_t{300});
  b.put(-1.0).put(-8.5f).put(std::int16_t{0});
  b.put(1e10).put(3.0f).put(std::int16_t{7});
  b.put(std::uint16_t{4}).put<std::uint32_t>({3, 2, 1, 0});
  const ParsedMesh out = read_ply(b.str(), "be.ply");
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{0.5f, 1.25f, -3, 2, 0, 300, -1, -8.5f, 0, 1e10f, 3, 7}));
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{3, 2, 1, 3, 1, 0}));
  EXPECT_FALSE(out.source.text);
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{1, 1}));
}

TEST(PlyFormat, SkipsUnknownElementsAndPropertiesInBinary) {
  const std::string header =
      binary_header("element material 2\nproperty uchar red\nproperty list int float weights\n"
                    "element vertex 3\nproperty uchar flag\nproperty float x\nproperty float y\nproperty float z\n"
                    "property list uchar int8 junk\nproperty double confidence\n"
                    "element face 2\nproperty int flags\nproperty list uchar int vertex_indices\n"
                    "property list uint short extra\n"
                    "element edge 1\nproperty int a\nproperty int b\n");
  Bytes b(header);
  b.put(std::uint8_t{1}).put(std::int32_t{2}).put({0.5f, 0.25f});
  b.put(std::uint8_t{2}).put(std::int32_t{0});
  b.put(std::uint8_t{9}).put({1.0f, 2.0f, 3.0f}).put(std::uint8_t{2}).put<std::int8_t>({-1, -2}).put(0.5);
  b.put(std::uint8_t{9}).put({4.0f, 5.0f, 6.0f}).put(std::uint8_t{0}).put(0.5);
  b.put(std::uint8_t{9}).put({7.0f, 8.0f, 9.0f}).put(std::uint8_t{1}).put<std::int8_t>({5}).put(0.5);
  b.put(std::int32_t{-1}).put(std::uint8_t{3}).put<std::int32_t>({0, 1, 2}).put(std::uint32_t{1}).put(std::int16_t{4});
  b.put(std::int32_t{-1}).put(std::uint8_t{3}).put<std::int32_t>({2, 1, 0}).put(std::uint32_t{0});
  b.put<std::int32_t>({0, 1});
  const ParsedMesh out = read_ply(b.str(), "skip.ply");
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 2, 1, 0}));
  EXPECT_TRUE(out.warnings.empty()) << out.warnings.front();
}

TEST(PlyFormat, TriangulatesPolygonsAndRecordsTheirLines) {
  const std::string text = "ply\nformat ascii 1.0\ncomment a quad and a pentagon\nobj_info made by hand\n"
                           "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 2\nproperty list uchar int vertex_index\nend_header\n"
                           "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 1.5 0\n"
                           "4 0 1 2 3\n\n5   0 1 2 4 3\r\n";
  const ParsedMesh out = read_ply(text, "poly.ply");
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 4, 0, 4, 3}));
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{17, 17, 19, 19, 19}));
  EXPECT_TRUE(out.source.text);
}

// A UTF-8 byte-order mark before the 'ply' magic: before, "not a PLY file".
TEST(PlyFormat, SkipsAUtf8ByteOrderMark) {
  const std::string text = "\xEF\xBB\xBFply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                           "property float y\nproperty float z\nelement face 1\n"
                           "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const ParsedMesh out = read_ply(text, "bom.ply");
  EXPECT_EQ(out.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  EXPECT_EQ(out.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2}));
  EXPECT_EQ(out.source.face_origin, (std::vector<std::int64_t>{13}));
}

TEST(PlyFormat, ReadsPerCornerTexcoordsAndPerVertexUvs) {
  const std::string corners =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "property float s\nproperty float t\n"
      "element face 1\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0 9 9\n1 0 0 9 9\n1 1 0 9 9\n0 1 0 9 9\n4 0 1 2 3 8 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8\n";
  const Mesh m = read_ply(corners, "tc.ply").mesh;
  // Per-corner texcoords keep seams, so they win over the per-vertex s/t.
  EXPECT_EQ(m.uvs, (std::vector<float>{0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f}));
  EXPECT_EQ(m.uv_triangles, (std::vector<std::int32_t>{0, 1, 2, 0, 2, 3}));

  const std::string per_vertex =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property float texture_u\nproperty float texture_v\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 +1\n3 0 1 2\n";
  const Mesh v = read_ply(per_vertex, "uv.ply").mesh;
  EXPECT_EQ(v.uvs, (std::vector<float>{0, 0, 1, 0, 1, 1}));
  EXPECT_EQ(v.uv_triangles, v.triangles);
}

TEST(PlyFormat, IgnoresNaNNormalsWithAWarning) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 0 0 1\n1 0 0 nan 0 1\n1 1 0 0 0 1\n3 0 1 2\n";
  const ParsedMesh out = read_ply(text, "n.ply");
  EXPECT_FALSE(out.mesh.has_normals());
  ASSERT_EQ(out.warnings.size(), 1u);
  EXPECT_NE(out.warnings[0].find("normals"), std::string::npos);
}

struct BadCase {
  const char* name;
  std::string bytes;
  std::vector<std::string> parts;
};

const std::string VERTEX3 = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const std::string FACES = "property list uchar int vertex_indices\n";

std::string ascii(const std::string& body, int faces = 1) {
  return "ply\nformat ascii 1.0\n" + VERTEX3 + "element face " + std::to_string(faces) + "\n" + FACES + "end_header\n" +
         body;
}

std::string binary_faces(int declared, int written, std::int32_t index = 2) {
  Bytes b(binary_header(VERTEX3 + "element face " + std::to_string(declared) + "\n" + FACES));
  b.put({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f});
  for (int f = 0; f < written; ++f)
    b.put(std::uint8_t{3}).put<std::int32_t>({0, 1, index});
  return b.str();
}

std::string binary_nan_vertex() {
  Bytes b(binary_header(VERTEX3 + "element face 1\n" + FACES));
  b.put({0.0f, 0.0f, 0.0f, 1.0f, std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f, 1.0f, 0.0f});
  return b.put(std::uint8_t{3}).put<std::int32_t>({0, 1, 2}).str();
}

std::string binary_huge_list() {
  Bytes b(binary_header(VERTEX3 + "element face 1\nproperty list uint int vertex_indices\n"));
  b.put({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f});
  return b.put(std::uint32_t{0xFFFFFFFFu}).put<std::int32_t>({0, 1, 2}).str();
}

class PlyFormatBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(PlyFormatBadInput, ThrowsNamingTheFileAndTheProblem) {
  EXPECT_THROW(read_ply(GetParam().bytes, "bad.ply"), Error);
  std::vector<std::string> parts = GetParam().parts;
  parts.insert(parts.begin(), "bad.ply");
  EXPECT_TRUE(fails_with(GetParam().bytes, parts));
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, PlyFormatBadInput,
    ::testing::Values(
        BadCase{"empty", "", {"bad.ply: empty file"}},
        BadCase{"garbage", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16), {"bad.ply:1: not a PLY file"}},
        BadCase{"bad_magic", "plx\nformat ascii 1.0\nend_header\n", {"missing 'ply' magic"}},
        BadCase{"no_end_header", "ply\nformat ascii 1.0\n" + VERTEX3, {":6:", "no 'end_header'"}},
        BadCase{"no_format", "ply\n" + VERTEX3 + "end_header\n", {"no 'format' line"}},
        BadCase{"bad_encoding", "ply\nformat binary_middle_endian 1.0\nend_header\n", {":2:", "unsupported format"}},
        BadCase{"unknown_keyword", "ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n", {":3:", "unknown keyword"}},
        BadCase{"unsupported_type",
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty int64 x\nend_header\n",
                {":4:", "unsupported property type 'int64'"}},
        BadCase{"float_list_count",
                "ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\n",
                {":4:", "unsupported list count type"}},
        BadCase{
            "property_first", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", {"property before any element"}},
        BadCase{"negative_count",
                "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n",
                {":3:", "negative element count"}},
        BadCase{"count_not_integer", "ply\nformat ascii 1.0\nelement vertex 3.5\nend_header\n", {"not an integer"}},
        BadCase{"count_overflows",
                "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n",
                {"absurdly large"}},
        BadCase{"absurd_vertex_count",
                binary_header("element vertex 4000000000000\nproperty float x\nproperty float y\nproperty float z\n"
                              "element face 1\n" +
                              FACES) +
                    std::string(24, '\0'),
                {"bad.ply: truncated: header declares 4000000000000 vertices, data ends after 2"}},
        BadCase{"truncated_binary_faces",
                binary_faces(12, 7),
                {"bad.ply: truncated: header declares 12 faces, data ends after 7"}},
        BadCase{"truncated_binary_mid_face",
                binary_faces(2, 2).substr(0, binary_faces(2, 2).size() - 3),
                {"truncated", "data ends after 1"}},
        BadCase{"truncated_ascii",
                ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 3),
                {"bad.ply:13: truncated: header declares 3 faces, data ends after 1"}},
        BadCase{"truncated_ascii_vertices", ascii("0 0 0\n1 0 0\n"), {"declares 3 vertices, data ends after 2"}},
        BadCase{"ascii_nan", ascii("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"), {"bad.ply:11: vertex 2: coordinate is NaN"}},
        BadCase{"ascii_inf", ascii("0 0 0\n1 0 -inf\n0 1 0\n3 0 1 2\n"), {":11:", "infinite"}},
        BadCase{"ascii_overflow", ascii("0 0 0\n1 0 1e39\n0 1 0\n3 0 1 2\n"), {":11:", "infinite"}},
        BadCase{"binary_nan", binary_nan_vertex(), {"bad.ply: vertex 2: coordinate is NaN"}},
        BadCase{"huge_index",
                ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 99\n"),
                {"bad.ply:13: face 1: vertex index 99 out of range (3 vertices)"}},
        BadCase{"binary_huge_index",
                binary_faces(1, 1, 2147483647),
                {"bad.ply: face 1: vertex index 2147483647 out of range"}},
        BadCase{"negative_index", ascii("0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"), {":13:", "negative vertex index -1"}},
        BadCase{"binary_negative_index", binary_faces(1, 1, -5), {"face 1: negative vertex index -5"}},
        BadCase{"fractional_index", ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n"), {"not an integer"}},
        BadCase{"two_vertex_face", ascii("0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), {":13:", "at least 3"}},
        BadCase{"binary_huge_list", binary_huge_list(), {"truncated", "faces"}},
        BadCase{"ascii_huge_list", ascii("0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n"), {":13:", "too few values"}},
        BadCase{"short_vertex_line", ascii("0 0 0\n1 0\n0 1 0\n3 0 1 2\n"), {":11:", "vertex 2: too few values"}},
        BadCase{"non_numeric", ascii("0 0 0\n1 abc 0\n0 1 0\n3 0 1 2\n"), {":11:", "'abc' is not a number"}},
        BadCase{"no_faces", ascii("0 0 0\n1 0 0\n0 1 0\n", 0), {"bad.ply: no faces"}},
        BadCase{
            "no_face_element", "ply\nformat ascii 1.0\n" + VERTEX3 + "end_header\n0 0 0\n1 0 0\n0 1 0\n", {"no faces"}},
        BadCase{"no_vertex_element",
                "ply\nformat ascii 1.0\nelement face 0\n" + FACES + "end_header\n",
                {"no 'vertex' element"}},
        BadCase{"missing_y",
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n",
                {":3:", "no property 'y'"}},
        BadCase{"no_index_list",
                "ply\nformat ascii 1.0\n" + VERTEX3 + "element face 1\nproperty int foo\nend_header\n",
                {"no 'vertex_indices' list"}},
        BadCase{"scalar_indices",
                "ply\nformat ascii 1.0\n" + VERTEX3 + "element face 1\nproperty int vertex_indices\nend_header\n",
                {":8:", "must be a list"}},
        BadCase{"texcoord_count",
                "ply\nformat ascii 1.0\n" + VERTEX3 + "element face 1\n" + FACES +
                    "property list uchar float texcoord\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 4 0 0 1 1\n",
                {":14:", "texcoord list has 4 values"}}),
    [](const auto& test_case) { return std::string(test_case.param.name); });

} // namespace
} // namespace vfit
