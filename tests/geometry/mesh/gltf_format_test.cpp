// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/gltf_format.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>

#include "support/test_support.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {
namespace {

using Json = nlohmann::json;

// ---- building inputs by hand, independently of the writer under test ----

std::string base64(const std::string& bytes) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t v = static_cast<std::uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<std::uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<std::uint8_t>(bytes[i + 2]);
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? alphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? alphabet[v & 63] : '=';
  }
  return out;
}

template <class T> void append(std::string& bin, const std::vector<T>& values) {
  bin.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

std::string data_uri(const std::string& bin) { return "data:application/octet-stream;base64," + base64(bin); }

// One triangle: 3 float positions (bytes 0–35), then 3 uint16 indices (36–41).
std::string triangle_bin(std::vector<float> positions = {0, 0, 0, 1, 0, 0, 0, 1, 0},
                         std::vector<std::uint16_t> indices = {0, 1, 2}) {
  std::string bin;
  append(bin, positions);
  append(bin, indices);
  return bin;
}

Json triangle_document(const std::string& bin) {
  Json doc = Json::parse(R"({
    "asset": {"version": "2.0"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                  {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]
  })");
  doc["buffers"] = Json::array({{{"byteLength", bin.size()}, {"uri", data_uri(bin)}}});
  return doc;
}

std::uint32_t u32_at(const std::string& bytes, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, bytes.data() + at, 4);
  return v;
}
void set_u32(std::string& bytes, std::size_t at, std::uint32_t v) { std::memcpy(bytes.data() + at, &v, 4); }

Json json_chunk(const std::string& glb) { return Json::parse(test::glb_json_text(glb)); }

std::array<float, 2> uv_of(const Mesh& m, std::size_t corner) {
  const auto t = static_cast<std::size_t>(m.uv_triangles[corner]);
  return {m.uvs[2 * t], m.uvs[2 * t + 1]};
}
std::array<float, 3> normal_of(const Mesh& m, std::size_t corner) {
  const auto t = static_cast<std::size_t>(m.normal_triangles[corner]);
  return {m.normals[3 * t], m.normals[3 * t + 1], m.normals[3 * t + 2]};
}
// (b − a) × (c − a) of face f.
std::array<double, 3> face_normal(const Mesh& m, std::size_t f) {
  auto p = [&](int k, int axis) { return double(m.positions[3 * std::size_t(m.triangles[3 * f + k]) + axis]); };
  const double u[3] = {p(1, 0) - p(0, 0), p(1, 1) - p(0, 1), p(1, 2) - p(0, 2)};
  const double v[3] = {p(2, 0) - p(0, 0), p(2, 1) - p(0, 1), p(2, 2) - p(0, 2)};
  return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
}

std::string write_one(const std::string& name, const Mesh& mesh) {
  const NamedMesh named{name, &mesh};
  return write_glb(std::span<const NamedMesh>(&named, 1));
}

// ---- round trips ----

TEST(GltfFormatRoundTrip, UnitSquareKeepsPositionsTrianglesAndUvs) {
  const Mesh square = test::unit_square();
  const ParsedMesh p = read_gltf(write_one("square", square), "square.glb");
  EXPECT_EQ(p.mesh.positions, square.positions);
  EXPECT_EQ(p.mesh.triangles, square.triangles);
  ASSERT_TRUE(p.mesh.has_uvs());
  for (std::size_t c = 0; c < 6; ++c)
    EXPECT_EQ(uv_of(p.mesh, c), uv_of(square, c)) << "corner " << c;
  ASSERT_TRUE(p.mesh.has_normals()); // computed by the writer: the square faces +Z
  for (std::size_t c = 0; c < 6; ++c)
    EXPECT_EQ(normal_of(p.mesh, c), (std::array<float, 3>{0, 0, 1}));
  EXPECT_EQ(p.mesh.label_names, std::vector<std::string>{"square"});
  EXPECT_EQ(p.mesh.face_labels, (std::vector<std::int32_t>{0, 0}));
  EXPECT_EQ(p.source.path, "square.glb");
  EXPECT_FALSE(p.source.text);
  EXPECT_EQ(p.source.face_origin, (std::vector<std::int64_t>{1, 2}));
  EXPECT_TRUE(p.warnings.empty());
}

TEST(GltfFormatRoundTrip, OctahedronWithoutUvsKeepsVerticesAndNormals) {
  const Mesh octahedron = test::octahedron();
  const std::string glb = write_one("octahedron", octahedron);
  const ParsedMesh p = read_gltf(glb, "octahedron.glb");
  EXPECT_EQ(p.mesh.vertex_count(), 6u);
  EXPECT_EQ(p.mesh.face_count(), 8u);
  EXPECT_EQ(p.mesh.positions, octahedron.positions);
  EXPECT_EQ(p.mesh.triangles, octahedron.triangles);
  EXPECT_FALSE(p.mesh.has_uvs());
  EXPECT_FALSE(json_chunk(glb)["meshes"][0]["primitives"][0]["attributes"].contains("TEXCOORD_0"));
  // Oracle: the area-weighted vertex normals; the reader renormalises in double, hence 1e-6.
  std::vector<float> oracle;
  vertex_normals_serial(octahedron.positions, octahedron.triangles, oracle);
  ASSERT_TRUE(p.mesh.has_normals());
  for (std::size_t c = 0; c < 24; ++c)
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(normal_of(p.mesh, c)[k], oracle[3 * std::size_t(octahedron.triangles[c]) + k], 1e-6);
}

TEST(GltfFormatRoundTrip, UvSeamIsSplitOnWriteAndWeldedOnRead) {
  Mesh seam = test::unit_square();
  // Corners 0 and 2 of the second triangle get UVs of their own: vertices 0 and 2 carry two each.
  seam.uvs = {0, 0, 0.5f, 0, 0.5f, 0.5f, 0.75f, 0, 1, 0.5f, 0.75f, 0.5f};
  seam.uv_triangles = {0, 1, 2, 3, 4, 5};
  const std::string glb = write_one("seam", seam);
  const Json doc = json_chunk(glb);
  const std::size_t position = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
  EXPECT_EQ(doc["accessors"][position]["count"], 6); // 4 vertices + 2 split at the seam

  const ParsedMesh p = read_gltf(glb, "seam.glb");
  EXPECT_EQ(p.mesh.positions, seam.positions);
  EXPECT_EQ(p.mesh.triangles, seam.triangles);
  ASSERT_TRUE(p.mesh.has_uvs());
  EXPECT_EQ(p.mesh.uvs.size(), 12u);
  for (std::size_t c = 0; c < 6; ++c)
    EXPECT_EQ(uv_of(p.mesh, c), uv_of(seam, c)) << "corner " << c;
}

TEST(GltfFormatRoundTrip, TwoMeshesKeepTheirNamesAsLabels) {
  const Mesh body = test::unit_square();
  Mesh shirt = test::octahedron();
  for (std::size_t i = 2; i < shirt.positions.size(); i += 3)
    shirt.positions[i] += 5.0f; // apart from body
  const std::vector<NamedMesh> meshes{{"body", &body}, {"shirt", &shirt}};
  const std::string glb = write_glb(meshes);
  const Json doc = json_chunk(glb);
  EXPECT_EQ(doc["nodes"][1]["name"], "shirt");

  const ParsedMesh p = read_gltf(glb, "pair.glb");
  EXPECT_EQ(p.mesh.vertex_count(), 10u);
  ASSERT_EQ(p.mesh.face_count(), 10u);
  EXPECT_EQ(p.mesh.label_names, (std::vector<std::string>{"body", "shirt"}));
  for (std::size_t f = 0; f < 10; ++f)
    EXPECT_EQ(p.mesh.face_labels[f], f < 2 ? 0 : 1) << "face " << f;
  for (std::size_t c = 0; c < 24; ++c)
    EXPECT_EQ(p.mesh.triangles[6 + c], shirt.triangles[c] + 4);
  // The shirt has no UVs, so its corners read back as (0, 0) beside the body's UVs.
  ASSERT_TRUE(p.mesh.has_uvs());
  EXPECT_EQ(uv_of(p.mesh, 6), (std::array<float, 2>{0, 0}));
}

// ---- the writer ----

TEST(GltfFormatWrite, GlbLayoutFollowsTheSpec) {
  Mesh octahedron = test::octahedron();
  const std::string glb = write_one("o", octahedron);
  ASSERT_GE(glb.size(), 28u);
  EXPECT_EQ(u32_at(glb, 0), 0x46546C67u);
  EXPECT_EQ(u32_at(glb, 4), 2u);
  EXPECT_EQ(u32_at(glb, 8), glb.size());
  const std::uint32_t json_length = u32_at(glb, 12);
  EXPECT_EQ(json_length % 4, 0u);
  EXPECT_EQ(u32_at(glb, 16), 0x4E4F534Au);
  const std::size_t bin_at = 20 + json_length;
  ASSERT_LE(bin_at + 8, glb.size());
  EXPECT_EQ(u32_at(glb, bin_at) % 4, 0u);
  EXPECT_EQ(u32_at(glb, bin_at + 4), 0x004E4942u);
  EXPECT_EQ(bin_at + 8 + u32_at(glb, bin_at), glb.size());

  const Json doc = json_chunk(glb);
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  EXPECT_EQ(doc["asset"]["generator"], "vfit");
  EXPECT_EQ(doc["buffers"][0]["byteLength"], u32_at(glb, bin_at));
  for (const Json& view : doc["bufferViews"]) {
    EXPECT_EQ(view["byteOffset"].get<std::size_t>() % 4, 0u);
    EXPECT_TRUE(view["target"] == 34962 || view["target"] == 34963);
  }
  const Json& primitive = doc["meshes"][0]["primitives"][0];
  const Json& indices = doc["accessors"][primitive["indices"].get<std::size_t>()];
  EXPECT_EQ(indices["componentType"], 5125);
  EXPECT_EQ(doc["bufferViews"][indices["bufferView"].get<std::size_t>()]["target"], 34963);
  const Json& position = doc["accessors"][primitive["attributes"]["POSITION"].get<std::size_t>()];
  EXPECT_EQ(position["min"], Json::array({-1.0, -1.0, -1.0}));
  EXPECT_EQ(position["max"], Json::array({1.0, 1.0, 1.0}));
}

TEST(GltfFormatWrite, RejectsMissingMeshesAndBadIndices) {
  const std::vector<NamedMesh> missing{{"ghost", nullptr}};
  EXPECT_THROW(write_glb(missing), Error);
  Mesh broken = test::unit_square();
  broken.triangles[4] = 9;
  try {
    write_one("broken", broken);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("broken"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
  }
}

// ---- reading hand-built files ----

TEST(GltfFormatRead, ComposesNodeTransformsAndTransformsNormals) {
  std::string bin = triangle_bin();
  const float n = 1.0f / std::sqrt(2.0f);
  append(bin, std::vector<float>{n, n, 0, n, n, 0, n, n, 0});
  Json doc = triangle_document(bin);
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 44}, {"byteLength", 36}});
  doc["accessors"].push_back({{"bufferView", 2}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"}});
  doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2;
  // Buffer view 2 starts at 44: the indices end at 42, so pad the buffer as a writer would.
  bin.insert(42, 2, '\0');
  doc["buffers"][0] = {{"byteLength", bin.size()}, {"uri", data_uri(bin)}};
  // Parent: a matrix translating by (10, 0, 0); child: scale (2, 1, 1), 90° about Z, then (1, 2, 3).
  doc["nodes"] = Json::parse(R"([
    {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1], "children": [1]},
    {"mesh": 0, "translation": [1, 2, 3], "rotation": [0, 0, 0.70710678118654752, 0.70710678118654752],
     "scale": [2, 1, 1]}])");
  const ParsedMesh p = read_gltf(doc.dump(), "nodes.gltf");
  const std::vector<float> want = {11, 2, 3, 11, 4, 3, 10, 2, 3};
  ASSERT_EQ(p.mesh.positions.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i)
    EXPECT_NEAR(p.mesh.positions[i], want[i], 1e-5) << i;
  // Inverse transpose of the scale maps (1, 1, 0) to (0.5, 1, 0), which the rotation turns into
  // (−1, 0.5, 0); transforming by the matrix itself would give (−1, 2, 0) instead.
  ASSERT_TRUE(p.mesh.has_normals());
  const double len = std::sqrt(1.25);
  const std::array<float, 3> got = normal_of(p.mesh, 0);
  EXPECT_NEAR(got[0], -1.0 / len, 1e-6);
  EXPECT_NEAR(got[1], 0.5 / len, 1e-6);
  EXPECT_NEAR(got[2], 0.0, 1e-6);
  EXPECT_EQ(p.mesh.label_names, std::vector<std::string>{"mesh0"});
}

TEST(GltfFormatRead, MirroringTransformKeepsTrianglesCounterClockwise) {
  Json doc = triangle_document(triangle_bin());
  doc["nodes"][0]["scale"] = {-1, 1, 1};
  const ParsedMesh p = read_gltf(doc.dump(), "mirror.gltf");
  EXPECT_GT(face_normal(p.mesh, 0)[2], 0.0); // +Z before mirroring, so +Z after
}

TEST(GltfFormatRead, DropsVerticesNoTriangleUses) {
  const std::string bin = triangle_bin({0, 0, 0, 9, 9, 9, 1, 0, 0, 0, 1, 0}, {0, 2, 3});
  Json doc = triangle_document(bin);
  doc["bufferViews"][0]["byteLength"] = 48;
  doc["bufferViews"][1]["byteOffset"] = 48;
  doc["accessors"][0]["count"] = 4;
  const ParsedMesh p = read_gltf(doc.dump(), "unused.gltf");
  EXPECT_EQ(p.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  EXPECT_EQ(p.mesh.triangles, (std::vector<std::int32_t>{0, 1, 2}));
}

TEST(GltfFormatRead, SkinnedMeshIgnoresItsNodeTransform) {
  Json doc = triangle_document(triangle_bin());
  doc["nodes"][0]["translation"] = {5, 0, 0};
  const std::vector<float> moved = read_gltf(doc.dump(), "moved.gltf").mesh.positions;
  EXPECT_EQ(moved[0], 5.0f);
  doc["nodes"][0]["skin"] = 0; // the spec: joints place a skinned mesh, not its node
  EXPECT_EQ(read_gltf(doc.dump(), "skinned.gltf").mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
}

TEST(GltfFormatRead, ReadsExternalBinBesideTheGltf) {
  test::TempDir dir;
  const std::string bin = triangle_bin({0, 0, 0, 2, 0, 0, 0, 3, 0});
  test::write_file(dir / "tri.bin", bin);
  Json doc = triangle_document(bin);
  doc["buffers"][0]["uri"] = "tri.bin";
  test::write_file(dir / "tri.gltf", doc.dump(2));
  const ParsedMesh p = read_gltf(test::read_file(dir / "tri.gltf"), (dir / "tri.gltf").string());
  EXPECT_EQ(p.mesh.positions, (std::vector<float>{0, 0, 0, 2, 0, 0, 0, 3, 0}));
}

TEST(GltfFormatRead, StripsAndFansBecomeTrianglesAndPointsAreSkipped) {
  std::string bin;
  append(bin, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});           // strip, bytes 0–47
  append(bin, std::vector<float>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0}); // fan, 48–107
  append(bin, std::vector<std::uint8_t>{0, 1, 2, 3, 3, 0, 0, 0});                // strip indices, a degenerate join
  Json doc = triangle_document(bin);
  doc["bufferViews"] = Json::parse(R"([{"buffer": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48,
    "byteLength": 60}, {"buffer": 0, "byteOffset": 108, "byteLength": 5}])");
  doc["accessors"] = Json::parse(R"([{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
    {"bufferView": 1, "componentType": 5126, "count": 5, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5121, "count": 5, "type": "SCALAR"}])");
  doc["meshes"][0]["primitives"] = Json::parse(R"([{"attributes": {"POSITION": 0}, "indices": 2, "mode": 5},
    {"attributes": {"POSITION": 1}, "mode": 6}, {"attributes": {"POSITION": 1}, "mode": 0}])");
  const ParsedMesh p = read_gltf(doc.dump(), "strips.gltf");
  EXPECT_EQ(p.mesh.face_count(), 2u + 3u);
  EXPECT_EQ(p.mesh.vertex_count(), 5u); // the fan shares four positions with the strip
  EXPECT_EQ(std::vector<std::int32_t>(p.mesh.triangles.begin(), p.mesh.triangles.begin() + 6),
            (std::vector<std::int32_t>{0, 1, 2, 1, 3, 2}));
  for (std::size_t f = 0; f < p.mesh.face_count(); ++f)
    EXPECT_GT(face_normal(p.mesh, f)[2], 0.0) << f;
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_NE(p.warnings[0].find("points"), std::string::npos) << p.warnings[0];
}

TEST(GltfFormatRead, HonoursStridesOffsetsAndNormalizedByteUvs) {
  std::string bin(4, 'x');                                                // skipped by the view's byteOffset
  append(bin, std::vector<float>{0, 0, 0, -7, 1, 0, 0, -7, 0, 1, 0, -7}); // stride 16, junk in the 4th
  append(bin, std::vector<std::uint8_t>{0, 0, 255, 0, 0, 255});
  Json doc = triangle_document(bin);
  doc["bufferViews"] = Json::parse(R"([{"buffer": 0, "byteOffset": 4, "byteLength": 48, "byteStride": 16},
    {"buffer": 0, "byteOffset": 52, "byteLength": 6}])");
  doc["accessors"] = Json::parse(R"([{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
    {"bufferView": 1, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC2"}])");
  doc["meshes"][0]["primitives"] = Json::parse(R"([{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}}])");
  const ParsedMesh p = read_gltf(doc.dump(), "stride.gltf");
  EXPECT_EQ(p.mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  ASSERT_TRUE(p.mesh.has_uvs());
  // 255 → 1; v flips to vfit's bottom-left origin.
  EXPECT_EQ(uv_of(p.mesh, 0), (std::array<float, 2>{0, 1}));
  EXPECT_EQ(uv_of(p.mesh, 1), (std::array<float, 2>{1, 1}));
  EXPECT_EQ(uv_of(p.mesh, 2), (std::array<float, 2>{0, 0}));
}

// ---- bad input: every case names the file and the problem ----

struct BadInput {
  std::string name;
  std::function<std::string()> bytes;
  std::string word; ///< must appear in the message
};

std::string square_glb() { return write_one("square", test::unit_square()); }
std::string mutated(const std::function<void(Json&)>& edit) {
  Json doc = triangle_document(triangle_bin());
  edit(doc);
  return doc.dump();
}

const std::vector<BadInput> BAD_INPUTS = {
    {"empty_file", [] { return std::string(); }, "empty"},
    {"not_gltf", [] { return std::string("solid cube\nendsolid cube\n"); }, "not a glTF"},
    {"bad_magic",
     [] {
       std::string g = square_glb();
       g[0] = 'x';
       return g;
     },
     "magic"},
    {"wrong_version",
     [] {
       std::string g = square_glb();
       set_u32(g, 4, 1);
       return g;
     },
     "version"},
    {"wrong_length",
     [] {
       std::string g = square_glb();
       set_u32(g, 8, u32_at(g, 8) + 4);
       return g;
     },
     "length"},
    {"truncated_json_chunk",
     [] {
       std::string g = square_glb().substr(0, 40);
       set_u32(g, 8, 40);
       return g;
     },
     "truncated"},
    {"invalid_json", [] { return std::string("{\"asset\": {\"version\": "); }, "invalid JSON"},
    {"accessor_past_buffer", [] { return mutated([](Json& d) { d["accessors"][0]["count"] = 4; }); },
     "accessor 0 reads past"},
    {"view_past_buffer", [] { return mutated([](Json& d) { d["bufferViews"][1]["byteLength"] = 60; }); },
     "bufferView 1 lies past"},
    {"index_out_of_range",
     [] {
       return mutated([](Json& d) {
         d["buffers"][0]["uri"] = data_uri(triangle_bin({0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 7}));
       });
     },
     "primitive 0 of mesh 0: index 7 out of range"},
    {"nan_position",
     [] {
       const float nan = std::numeric_limits<float>::quiet_NaN();
       return mutated([&](Json& d) { d["buffers"][0]["uri"] = data_uri(triangle_bin({0, 0, 0, nan, 0, 0, 0, 1, 0})); });
     },
     "accessor 0: POSITION element 1 is not finite"},
    {"missing_buffer_file", [] { return mutated([](Json& d) { d["buffers"][0]["uri"] = "missing.bin"; }); },
     "missing.bin"},
    {"uri_leaves_folder", [] { return mutated([](Json& d) { d["buffers"][0]["uri"] = "../secret.bin"; }); }, "leaves"},
    {"bad_base64", [] { return mutated([](Json& d) { d["buffers"][0]["uri"] = "data:;base64,@@@@"; }); }, "base64"},
    {"sparse_accessor", [] { return mutated([](Json& d) {
                               d["accessors"][0]["sparse"] = {{"count", 1}};
                             }); },
     "unsupported sparse accessor 0"},
    {"no_faces", [] { return mutated([](Json& d) { d["meshes"][0]["primitives"][0]["mode"] = 1; }); }, "no faces"},
    {"node_cycle", [] { return mutated([](Json& d) { d["nodes"][0]["children"] = {0}; }); }, "node 0"},
    {"wrong_position_type", [] { return mutated([](Json& d) { d["accessors"][0]["componentType"] = 5123; }); },
     "POSITION"},
    {"draco_required",
     [] { return mutated([](Json& d) { d["extensionsRequired"] = {"KHR_draco_mesh_compression"}; }); },
     "KHR_draco_mesh_compression"},
    {"huge_zero_accessor",
     [] {
       return mutated([](Json& d) {
         d["accessors"][0] = {{"componentType", 5126}, {"count", 1ull << 40}, {"type", "VEC3"}};
       });
     },
     "too large"},
    {"string_for_index", [] { return mutated([](Json& d) { d["nodes"][0]["mesh"] = "0"; }); }, "node 0"},
};

void PrintTo(const BadInput& input, std::ostream* out) { *out << input.name; }

class GltfFormatBadInput : public testing::TestWithParam<BadInput> {};

TEST_P(GltfFormatBadInput, ThrowsNamingTheFileAndTheProblem) {
  const std::string path = "bad/" + GetParam().name + ".gltf";
  try {
    read_gltf(GetParam().bytes(), path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(GetParam().word), std::string::npos) << message;
  }
}

INSTANTIATE_TEST_SUITE_P(GltfFiles, GltfFormatBadInput, testing::ValuesIn(BAD_INPUTS),
                         [](const testing::TestParamInfo<BadInput>& param) { return param.param.name; });

// Every prefix and every single-byte corruption of a valid file must throw vfit::Error or read
// cleanly: never crash, over-read (ASan) or leak another exception type.
TEST(GltfFormatBadInputSweep, TruncationsAndCorruptionsOnlyThrowVfitErrors) {
  const std::string good = square_glb();
  std::size_t errors = 0;
  auto attempt = [&](const std::string& bytes) {
    try {
      read_gltf(bytes, "sweep.glb");
    } catch (const Error&) {
      ++errors;
    }
  };
  for (std::size_t size = 0; size < good.size(); ++size) {
    std::string cut = good.substr(0, size);
    if (size >= 12) set_u32(cut, 8, static_cast<std::uint32_t>(size)); // get past the length check
    attempt(cut);
  }
  EXPECT_EQ(errors, good.size()) << "every truncated file is an error";
  for (std::size_t at = 0; at < good.size(); ++at) {
    for (char value : {'\0', '\xFF', '9', '"', '}'}) {
      std::string bad = good;
      bad[at] = value;
      attempt(bad);
    }
  }
}

// ---- the shared corpus ----

TEST(GltfFormatCorpus, ReadsTheRiggedMakeHumanBody) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "corpus folder absent";
  const auto file = *corpus / "makehuman" / "derived" / "hm08_body_rigged.glb";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << file << " absent";
  const ParsedMesh p = read_gltf(test::read_file(file), file.string());
  EXPECT_GT(p.mesh.vertex_count(), 10000u);
  EXPECT_GT(p.mesh.face_count(), 10000u);
  for (std::int32_t v : p.mesh.triangles)
    ASSERT_LT(static_cast<std::size_t>(v), p.mesh.vertex_count());
  std::cout << "hm08_body_rigged.glb: " << p.mesh.vertex_count() << " vertices, " << p.mesh.face_count() << " faces, "
            << p.mesh.uvs.size() / 2 << " uvs, " << p.mesh.normals.size() / 3 << " normals, "
            << p.mesh.label_names.size() << " labels, " << p.warnings.size() << " warnings\n";
}

} // namespace
} // namespace vfit
