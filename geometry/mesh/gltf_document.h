// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Private to geometry/ (not installed, not for engine/ or tools/): a parsed glTF 2.0 document
/// with checked access to its JSON, buffers, accessors and node transforms, and the mesh
/// assembler (welding, UV/normal seams, labels) that read_gltf() and read_gltf_body() share.
/// Every method throws vfit::Error "<path>: <what>" naming the element at fault.

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "mesh.h"
#include "vfit/kernels/error.h"

namespace vfit::gltf {

using Json = nlohmann::json;

inline constexpr int UNSIGNED_BYTE = 5121;
inline constexpr int UNSIGNED_SHORT = 5123;
inline constexpr int UNSIGNED_INT = 5125;
inline constexpr int FLOAT = 5126;

/// Where an accessor's elements lie: `count` elements of `components` components of
/// `component_type`, `stride` bytes apart from `data` (nullptr: no bufferView, all zeros).
struct AccessorLayout {
  const char* data = nullptr;
  std::uint64_t count = 0;
  std::uint64_t stride = 0;
  int components = 0;
  int component_type = 0;
  bool normalized = false;
};

/// A `.glb` (magic "glTF") or `.gltf` (JSON, recognised by its leading `{`) document. `path`
/// names it in messages and resolves a `.gltf`'s relative buffer URIs. Buffers are decoded on
/// first use and kept; views into them stay valid while the document lives.
class GltfDocument {
public:
  GltfDocument(std::string_view bytes, const std::string& path);

  const Json& root() const { return m_root; }
  const std::string& path() const { return m_path; }
  /// The error to throw: "<path>: <what>".
  Error fail(const std::string& what) const { return Error(m_path, 0, what); }

  /// Size of the top-level array `name` (0 when absent).
  std::size_t array_size(const char* name) const;
  /// Element `i` of the top-level array `array`, which must be an object; `what` names it.
  const Json& element(const char* array, std::size_t i, const std::string& what) const;
  /// `v` as a non-negative integer; `owner` names it in the message.
  std::uint64_t as_index(const Json& v, const std::string& owner) const;
  /// `obj[key]` as a non-negative integer, `fallback` when absent (an error without one).
  std::uint64_t index(const Json& obj, const char* key, const std::string& owner,
                      std::optional<std::uint64_t> fallback = std::nullopt) const;
  /// `n` finite numbers under `key`, or nullopt when the key is absent.
  std::optional<std::vector<double>> numbers(const Json& obj, const char* key, std::size_t n,
                                             const std::string& owner) const;
  /// Throws for required extensions that change geometry (Draco, meshopt, quantization, ...).
  void check_required_extensions() const;

  /// Layout of accessor `a`, bounds-checked against its bufferView and buffer.
  AccessorLayout accessor(std::size_t a);
  /// `components` floats per element; normalized unsigned bytes/shorts too when
  /// `allow_normalized` (mapped to [0, 1]). `semantic` names the data in messages.
  std::vector<float> read_floats(std::size_t a, const char* semantic, int components, bool allow_normalized);
  /// `components` unsigned integers (byte, short or int) per element.
  std::vector<std::uint32_t> read_unsigned(std::size_t a, const char* semantic, int components);
  /// Triangle indices: unsigned byte, short or int scalars.
  std::vector<std::uint32_t> read_indices(std::size_t a);

  /// Root nodes of `scene`, else of scene 0, else every node that is nobody's child.
  std::vector<std::size_t> scene_roots() const;
  /// A node's local transform from `matrix` or from TRS (quaternion normalised).
  Eigen::Matrix4d local_transform(const Json& node, std::size_t n) const;
  /// Node `n`'s name, or "node<n>" when it has none.
  std::string node_name(std::size_t n) const;

private:
  void parse_json(std::string_view text);
  std::string_view buffer(std::size_t b);
  std::string read_external(const std::string& uri, const std::string& owner) const;

  std::string m_path;
  Json m_root;
  std::optional<std::string_view> m_bin;
  std::deque<std::string> m_owned; // decoded and external buffers; a deque keeps views valid
  std::unordered_map<std::size_t, std::string_view> m_buffers;
};

/// The key under which corners weld: a position's bits with −0.0 folded into 0.0.
using PositionKey = std::array<std::uint32_t, 3>;
/// FNV-1a over the words of a weld key (positions: N = 3, UVs: N = 2).
struct KeyHash {
  template <std::size_t N> std::size_t operator()(const std::array<std::uint32_t, N>& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (std::uint32_t v : k)
      h = (h ^ v) * 1099511628211ull;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

/// The welded vertex of each POSITION element of one triangle primitive (−1: no triangle uses it).
struct PrimitiveVertices {
  std::size_t mesh = 0;
  std::size_t primitive = 0;
  std::vector<std::int32_t> welded;
};

/// Assembles one vfit::Mesh from glTF meshes, as read_gltf() documents: positions transformed
/// by the node's world matrix, corners with bit-identical positions welded across primitives,
/// per-corner UVs (v flipped) and normals, one face label per glTF mesh.
class GltfMeshBuilder {
public:
  explicit GltfMeshBuilder(GltfDocument& document) : m_doc(document) {}

  /// Adds every triangle primitive of mesh `m` with `world` applied (points and lines are
  /// skipped with a warning).
  void add_mesh(std::size_t m, const Eigen::Matrix4d& world);
  /// One entry per primitive added so far, in order.
  const std::vector<PrimitiveVertices>& primitive_vertices() const { return m_primitives; }
  /// The mesh; throws "no faces" when nothing was a triangle. Call once.
  ParsedMesh finish();

private:
  void add_primitive(std::size_t m, std::size_t p, const Json& primitive, const Eigen::Matrix4d& world,
                     std::int32_t label);

  GltfDocument& m_doc;
  ParsedMesh m_out;
  std::unordered_map<PositionKey, std::int32_t, KeyHash> m_vertex_of;
  std::vector<std::int32_t> m_label_of_mesh;
  std::vector<PrimitiveVertices> m_primitives;
  std::vector<float> m_corner_uvs;     // 2 per corner; (0, 0) where the primitive has none
  std::vector<float> m_corner_normals; // 3 per corner; filled in finish() where missing
  std::vector<char> m_corner_has_normal;
  bool m_any_uvs = false;
  bool m_any_normals = false;
};

} // namespace vfit::gltf
