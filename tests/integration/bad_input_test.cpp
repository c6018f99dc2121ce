// SPDX-License-Identifier: Apache-2.0
// The bad-input catalogue: every malformed file makes `vfit info` (and `vfit convert`) exit
// with code 2 and one line `vfit: error: <file>...: <what>` naming the problem, and writes
// nothing.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "test_support.h"

namespace vfit {
namespace {

std::string le32(std::uint32_t x) { return std::string(reinterpret_cast<const char*>(&x), 4); }
std::string lef(float x) { return std::string(reinterpret_cast<const char*>(&x), 4); }

std::string ply_header(const char* format, int nv, int nf) {
  return std::string("ply\nformat ") + format + " 1.0\nelement vertex " + std::to_string(nv) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(nf) +
         "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string binary_ply(int declared_faces, float first_x, int last_index) {
  std::string s = ply_header("binary_little_endian", 3, declared_faces);
  s += lef(first_x) + lef(0) + lef(0) + lef(1) + lef(0) + lef(0) + lef(0) + lef(1) + lef(0);
  s += std::string(1, '\3') + le32(0) + le32(1) + le32(static_cast<std::uint32_t>(last_index));
  return s;
}

std::string binary_stl(std::uint32_t declared, std::uint32_t written, float x) {
  std::string s(80, ' ');
  s += le32(declared);
  for (std::uint32_t i = 0; i < written; ++i) {
    s += lef(0) + lef(0) + lef(1);
    s += lef(x) + lef(0) + lef(0) + lef(1) + lef(0) + lef(0) + lef(0) + lef(1) + lef(0);
    s += std::string(2, '\0');
  }
  return s;
}

std::string glb(std::uint32_t magic, std::uint32_t declared_length, const std::string& json) {
  std::string padded = json;
  while (padded.size() % 4)
    padded += ' ';
  std::string s = le32(magic) + le32(2) + le32(declared_length) + le32(static_cast<std::uint32_t>(padded.size())) +
                  le32(0x4E4F534A) + padded;
  return s;
}

struct BadFile {
  const char* name; // the file name (its extension picks the reader)
  std::string contents;
  const char* expect; // a substring of the error line that names the problem
};

std::vector<BadFile> catalogue() {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  const std::string gltf_ok_start = R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":8}],)";
  return {
      {"nan.obj", tri + "v nan 0 0\nf 1 2 3\n", "nan.obj:4: x coordinate is NaN"},
      {"inf.obj", "v 0 0 0\nv 1 0 -inf\nv 0 1 0\nf 1 2 3\n", ":2: z coordinate is infinite"},
      {"huge_index.obj", tri + "f 1 2 4000000000\n", ":4: vertex index 4000000000 out of range"},
      {"zero_index.obj", tri + "f 0 1 2\n", ":4: face index 0"},
      {"two_corners.obj", tri + "f 1 2\n", ":4: face with 2 vertices"},
      {"bad_number.obj", "v 0 0 0\nv 1 O 0\nv 0 1 0\nf 1 2 3\n", ":2: bad number"},
      {"truncated.obj", tri + "f 1 2", ":4: face with 2 vertices"},
      {"degenerate.obj", tri + "f 1 2 2\n", ":4: degenerate face"},
      {"duplicate.obj", tri + "f 1 2 3\nf 3 1 2\n", ":5: duplicate face"},
      {"no_faces.obj", tri, "no faces"},
      {"garbage.obj", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16), "not an OBJ mesh"},
      {"empty.obj", "", "empty file"},
      {"bad_magic.ply", "plx\nformat ascii 1.0\nend_header\n", "bad_magic.ply"},
      {"truncated_binary.ply", binary_ply(5, 0.0f, 2), "truncated"},
      {"nan_binary.ply", binary_ply(1, std::nanf(""), 2), "NaN"},
      {"index_binary.ply", binary_ply(1, 0.0f, 77), "out of range"},
      {"truncated_ascii.ply", ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n", "bad_truncated_ascii.ply"},
      {"absurd_count.ply", ply_header("binary_little_endian", 2000000000, 1), "bad_absurd_count.ply"},
      {"bad_format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "bad_bad_format.ply"},
      {"no_header_end.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "bad_no_header_end.ply"},
      {"bad_header.off", "NOTOFF\n3 1 0\n", "bad_bad_header.off"},
      {"truncated.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "bad_truncated.off"},
      {"nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "NaN"},
      {"index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n", "out of range"},
      {"truncated_binary.stl", binary_stl(10, 3, 1.0f), "bad_truncated_binary.stl"},
      {"nan_binary.stl", binary_stl(1, 1, std::nanf("")), "NaN"},
      {"garbage.stl", "this is not an stl file at all", "bad_garbage.stl"},
      {"bad_magic.glb", glb(0x12345678, 40, "{}"), "bad_bad_magic.glb"},
      {"wrong_length.glb", glb(0x46546C67, 9999, "{}"), "bad_wrong_length.glb"},
      {"invalid_json.gltf", "{\"asset\": {\"version\": \"2.0\"", "invalid JSON"},
      {"accessor_past_end.gltf",
       gltf_ok_start +
           R"("bufferViews":[{"buffer":0,"byteLength":8}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})",
       "accessor"},
      {"unknown.fbx", "whatever", "unknown mesh format"},
  };
}

void PrintTo(const BadFile& b, std::ostream* os) { *os << b.name; }

class BadInputCatalogue : public ::testing::TestWithParam<BadFile> {};

TEST_P(BadInputCatalogue, InfoExitsTwoWithOneLineNamingTheProblem) {
  test::TempDir tmp;
  const auto path = tmp / (std::string("bad_") + GetParam().name);
  test::write_file(path, GetParam().contents);
  const auto r = test::run_cli({"info", path.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.err.rfind("vfit: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(path.filename().string()), std::string::npos) << "message does not name the file: " << r.err;
  EXPECT_NE(r.err.find(GetParam().expect), std::string::npos) << "expected '" << GetParam().expect << "' in: " << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST_P(BadInputCatalogue, ConvertWritesNothingAndLeavesTheInputAlone) {
  test::TempDir tmp;
  const auto path = tmp / (std::string("bad_") + GetParam().name);
  test::write_file(path, GetParam().contents);
  const auto out = tmp / "out.obj";
  const auto r = test::run_cli({"convert", path.string(), out.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_EQ(test::read_file(path), GetParam().contents);
  std::size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(tmp.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 1u) << "a temporary or partial file was left behind";
}

INSTANTIATE_TEST_SUITE_P(Files, BadInputCatalogue, ::testing::ValuesIn(catalogue()), [](const auto& param) {
  std::string n = param.param.name;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
});

TEST(BadInput, CatalogueHasAtLeastTwentyFiveCases) { EXPECT_GE(catalogue().size(), 25u); }

} // namespace
} // namespace vfit
