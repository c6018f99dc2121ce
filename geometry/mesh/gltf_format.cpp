// Reading glTF 2.0 (.glb and .gltf); write_glb lives in gltf_writer.cpp.
#include "gltf_format.h"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <numeric>
#include <optional>
#include <unordered_map>

#include "kernels/error.h"

namespace vfit {
namespace {

using Json = nlohmann::json;

// GLB and accessor data are little-endian; we read them with memcpy.
static_assert(std::endian::native == std::endian::little, "glTF reading assumes a little-endian host");

constexpr std::uint32_t GLB_MAGIC = 0x46546C67;  // "glTF"
constexpr std::uint32_t CHUNK_JSON = 0x4E4F534A; // "JSON"
constexpr std::uint32_t CHUNK_BIN = 0x004E4942;  // "BIN\0"
constexpr int UNSIGNED_BYTE = 5121;
constexpr int UNSIGNED_SHORT = 5123;
constexpr int UNSIGNED_INT = 5125;
constexpr int FLOAT = 5126;
// An accessor without a bufferView is all zeros; a cap keeps a hostile count from allocating
// gigabytes out of a few bytes of JSON.
constexpr std::uint64_t MAX_ZERO_ACCESSOR_COUNT = std::uint64_t{1} << 24;

template <class T> T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

std::string hex(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", static_cast<unsigned>(v));
  return text;
}

// A string from the file, quoted and escaped so that a message stays on one line.
std::string quoted(const std::string& s) { return Json(s).dump(-1, ' ', false, Json::error_handler_t::replace); }

struct GlbChunks {
  std::string_view json;
  std::optional<std::string_view> bin;
};

GlbChunks split_glb(std::string_view bytes, const std::string& path) {
  if (bytes.size() < 4) throw Error(path, 0, "not a glTF file (" + std::to_string(bytes.size()) + " bytes)");
  if (load<std::uint32_t>(bytes.data()) != GLB_MAGIC)
    throw Error(path, 0, "not a glTF file (bad magic " + hex(load<std::uint32_t>(bytes.data())) + ")");
  if (bytes.size() < 12)
    throw Error(path, 0, "truncated: a .glb header needs 12 bytes, the file has " + std::to_string(bytes.size()));
  const auto version = load<std::uint32_t>(bytes.data() + 4);
  if (version != 2) throw Error(path, 0, "unsupported glTF version " + std::to_string(version));
  const auto length = load<std::uint32_t>(bytes.data() + 8);
  if (length != bytes.size())
    throw Error(path, 0,
                "header length field says " + std::to_string(length) + " bytes, the file has " +
                    std::to_string(bytes.size()));
  GlbChunks chunks;
  std::size_t at = 12;
  for (int index = 0; at < bytes.size(); ++index) {
    if (bytes.size() - at < 8)
      throw Error(path, 0, "truncated: chunk header at byte " + std::to_string(at) + " is cut off");
    const auto size = load<std::uint32_t>(bytes.data() + at);
    const auto type = load<std::uint32_t>(bytes.data() + at + 4);
    const std::string kind = type == CHUNK_JSON ? "JSON" : type == CHUNK_BIN ? "BIN" : hex(type);
    if (size > bytes.size() - at - 8)
      throw Error(path, 0,
                  "truncated: " + kind + " chunk at byte " + std::to_string(at) + " declares " + std::to_string(size) +
                      " bytes, " + std::to_string(bytes.size() - at - 8) + " remain");
    const std::string_view data = bytes.substr(at + 8, size);
    if (index == 0 && type != CHUNK_JSON) throw Error(path, 0, "first chunk is " + kind + ", not JSON");
    if (index == 0)
      chunks.json = data;
    else if (type == CHUNK_BIN && !chunks.bin)
      chunks.bin = data; // the spec says to skip unknown chunks
    at += 8 + std::size_t{size};
  }
  if (at == 12) throw Error(path, 0, "truncated: no JSON chunk");
  return chunks;
}

std::optional<std::string> decode_base64(std::string_view text) {
  while (!text.empty() && text.back() == '=')
    text.remove_suffix(1);
  if (text.size() % 4 == 1) return std::nullopt;
  std::string out;
  out.reserve(text.size() / 4 * 3 + 2);
  std::uint32_t bits = 0;
  int pending = 0;
  for (char c : text) {
    int v = -1;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+' || c == '-')
      v = 62; // '-' and '_': the URL-safe alphabet some exporters use
    else if (c == '/' || c == '_')
      v = 63;
    if (v < 0) return std::nullopt;
    bits = (bits << 6) | static_cast<std::uint32_t>(v);
    pending += 6;
    if (pending >= 8) {
      pending -= 8;
      out += static_cast<char>((bits >> pending) & 0xFF);
    }
  }
  return out;
}

// The key under which corners weld: the position's bits with -0.0 folded into 0.0.
using PositionKey = std::array<std::uint32_t, 3>;
struct KeyHash {
  template <std::size_t N> std::size_t operator()(const std::array<std::uint32_t, N>& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (std::uint32_t v : k)
      h = (h ^ v) * 1099511628211ull;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};
std::uint32_t weld_bits(float x) { return std::bit_cast<std::uint32_t>(x == 0.0f ? 0.0f : x); }

// Per-corner values (UVs: N = 2, normals: N = 3) → unique values and #F × 3 indices into them.
template <std::size_t N>
void dedupe_corners(const std::vector<float>& corners, std::vector<float>& values, std::vector<std::int32_t>& indices) {
  std::unordered_map<std::array<std::uint32_t, N>, std::int32_t, KeyHash> index_of;
  indices.resize(corners.size() / N);
  for (std::size_t c = 0; c < indices.size(); ++c) {
    std::array<std::uint32_t, N> key;
    for (std::size_t k = 0; k < N; ++k)
      key[k] = weld_bits(corners[N * c + k]);
    auto [it, inserted] = index_of.try_emplace(key, static_cast<std::int32_t>(values.size() / N));
    if (inserted) values.insert(values.end(), corners.begin() + N * c, corners.begin() + N * (c + 1));
    indices[c] = it->second;
  }
}

struct AccessorLayout {
  const char* data = nullptr; // nullptr: no bufferView, every element is zero
  std::uint64_t count = 0;
  std::uint64_t stride = 0;
  int components = 0;
  int component_type = 0;
  bool normalized = false;
};

// Reads one document; the state is the lazily loaded buffers and the mesh being assembled.
class GltfReader {
public:
  GltfReader(std::string_view bytes, const std::string& path) : m_path(path) {
    std::size_t first = 0;
    if (bytes.starts_with("\xEF\xBB\xBF")) first = 3; // a UTF-8 byte-order mark
    while (first < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[first])))
      ++first;
    if (bytes.empty()) throw Error(path, 0, "empty file, not a glTF file");
    if (first < bytes.size() && bytes[first] == '{') {
      parse_json(bytes.substr(first));
    } else {
      const GlbChunks chunks = split_glb(bytes, path);
      m_bin = chunks.bin;
      parse_json(chunks.json);
    }
  }

  ParsedMesh read() {
    check_required_extensions();
    std::vector<std::pair<std::size_t, Eigen::Matrix4d>> stack;
    const std::vector<std::size_t> roots = scene_roots();
    for (auto it = roots.rbegin(); it != roots.rend(); ++it)
      stack.emplace_back(*it, Eigen::Matrix4d::Identity());
    std::vector<char> visited(array_size("nodes"), 0);
    // An explicit stack: a hostile file can nest nodes deeper than the call stack allows.
    while (!stack.empty()) {
      auto [n, parent] = stack.back();
      stack.pop_back();
      const Json& node = element("nodes", n, "node");
      if (visited[n]) throw fail("node " + std::to_string(n) + " is reached twice (the hierarchy is not a tree)");
      visited[n] = 1;
      const Eigen::Matrix4d world = parent * local_transform(node, n);
      // glTF ignores a skinned mesh node's transform: its joints place it. Until skins are read,
      // the bind-pose positions as stored are the best pose we have.
      const bool skinned = node.contains("skin");
      if (node.contains("mesh"))
        add_mesh(index(node, "mesh", "node " + std::to_string(n)), skinned ? Eigen::Matrix4d::Identity() : world);
      if (const auto children = node.find("children"); children != node.end()) {
        if (!children->is_array()) throw fail("node " + std::to_string(n) + ": 'children' is not an array");
        for (auto it = children->rbegin(); it != children->rend(); ++it)
          stack.emplace_back(as_index(*it, "node " + std::to_string(n) + " child"), world);
      }
    }
    return finish();
  }

private:
  Error fail(const std::string& what) const { return Error(m_path, 0, what); }

  void parse_json(std::string_view text) {
    // Some writers pad the JSON chunk with NULs instead of spaces.
    while (!text.empty() && (text.back() == '\0' || std::isspace(static_cast<unsigned char>(text.back()))))
      text.remove_suffix(1);
    try {
      m_root = Json::parse(text.begin(), text.end());
    } catch (const Json::parse_error& e) {
      throw fail(std::string("invalid JSON: ") + e.what());
    }
    if (!m_root.is_object()) throw fail("invalid JSON: the top level is not an object");
  }

  std::size_t array_size(const char* name) const {
    const auto it = m_root.find(name);
    if (it == m_root.end()) return 0;
    if (!it->is_array()) throw fail(std::string("'") + name + "' is not an array");
    return it->size();
  }

  const Json& element(const char* array, std::size_t i, const std::string& what) const {
    if (i >= array_size(array))
      throw fail(what + " " + std::to_string(i) + " does not exist (" + std::to_string(array_size(array)) + " " +
                 array + ")");
    const Json& e = m_root[array][i];
    if (!e.is_object()) throw fail(what + " " + std::to_string(i) + " is not an object");
    return e;
  }

  std::uint64_t as_index(const Json& v, const std::string& owner) const {
    if (!v.is_number_unsigned()) throw fail(owner + ": expected a non-negative integer, got " + v.dump());
    return v.get<std::uint64_t>();
  }

  std::uint64_t index(const Json& obj, const char* key, const std::string& owner,
                      std::optional<std::uint64_t> fallback = std::nullopt) const {
    const auto it = obj.find(key);
    if (it != obj.end()) return as_index(*it, owner + " '" + key + "'");
    if (!fallback) throw fail(owner + ": missing '" + key + "'");
    return *fallback;
  }

  // `n` numbers under `key`, or nullopt when the key is absent.
  std::optional<std::vector<double>> numbers(const Json& obj, const char* key, std::size_t n,
                                             const std::string& owner) const {
    const auto it = obj.find(key);
    if (it == obj.end()) return std::nullopt;
    if (!it->is_array() || it->size() != n)
      throw fail(owner + ": '" + key + "' must be an array of " + std::to_string(n) + " numbers");
    std::vector<double> out;
    for (const Json& v : *it) {
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw fail(owner + ": '" + key + "' holds a non-number " + v.dump());
      out.push_back(v.get<double>());
    }
    return out;
  }

  void check_required_extensions() const {
    const auto it = m_root.find("extensionsRequired");
    if (it == m_root.end() || !it->is_array()) return;
    for (const Json& e : *it) {
      const std::string name = e.is_string() ? e.get<std::string>() : "";
      // Material and texture extensions don't change geometry; anything else (Draco, meshopt,
      // quantization, instancing) would be silently misread.
      if (!name.starts_with("KHR_materials_") && !name.starts_with("KHR_texture_") &&
          !name.starts_with("EXT_texture_") && name != "KHR_lights_punctual")
        throw fail("unsupported required extension " + quoted(name));
    }
  }

  std::string_view buffer(std::size_t b) {
    if (const auto it = m_buffers.find(b); it != m_buffers.end()) return it->second;
    const std::string owner = "buffer " + std::to_string(b);
    const Json& buf = element("buffers", b, "buffer");
    const std::uint64_t length = index(buf, "byteLength", owner);
    std::string_view data;
    const auto uri = buf.find("uri");
    if (uri == buf.end()) {
      if (!m_bin) throw fail(owner + " has no uri and the file has no BIN chunk");
      if (b != 0) throw fail(owner + " has no uri; only buffer 0 may refer to the BIN chunk");
      data = *m_bin;
    } else if (!uri->is_string()) {
      throw fail(owner + ": 'uri' is not a string");
    } else if (const std::string text = uri->get<std::string>(); text.starts_with("data:")) {
      const std::size_t comma = text.find(',');
      if (comma == std::string::npos || !std::string_view(text).substr(0, comma).ends_with(";base64"))
        throw fail(owner + ": only base64 data URIs are supported");
      auto decoded = decode_base64(std::string_view(text).substr(comma + 1));
      if (!decoded) throw fail(owner + ": invalid base64 in its data URI");
      data = m_owned.emplace_back(std::move(*decoded));
    } else {
      data = m_owned.emplace_back(read_external(text, owner));
    }
    if (data.size() < length)
      throw fail("truncated: " + owner + " holds " + std::to_string(data.size()) + " bytes, its byteLength is " +
                 std::to_string(length));
    return m_buffers[b] = data.substr(0, length);
  }

  std::string read_external(const std::string& uri, const std::string& owner) const {
    const std::filesystem::path relative(uri);
    if (uri.find(':') != std::string::npos || relative.is_absolute() || relative.has_root_path())
      throw fail(owner + ": uri " + quoted(uri) + " is not a relative file path");
    for (const auto& part : relative)
      if (part == "..") throw fail(owner + ": uri " + quoted(uri) + " leaves the folder of the .gltf");
    const std::filesystem::path file = std::filesystem::path(m_path).parent_path() / relative;
    std::ifstream in(file, std::ios::binary);
    std::error_code ec;
    if (!in || std::filesystem::is_directory(file, ec)) throw fail(owner + ": cannot read " + quoted(file.string()));
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

  AccessorLayout accessor(std::size_t a) {
    const std::string owner = "accessor " + std::to_string(a);
    const Json& acc = element("accessors", a, "accessor");
    if (acc.contains("sparse")) throw fail("unsupported sparse accessor " + std::to_string(a));
    AccessorLayout l;
    l.count = index(acc, "count", owner);
    l.component_type = static_cast<int>(index(acc, "componentType", owner));
    l.normalized = acc.value("normalized", false);
    const std::string type = acc.value("type", "");
    static const std::unordered_map<std::string, int> components{{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                                 {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
    if (const auto it = components.find(type); it != components.end())
      l.components = it->second;
    else
      throw fail(owner + ": unknown type " + quoted(type));
    const int size = l.component_type == FLOAT || l.component_type == UNSIGNED_INT    ? 4
                     : l.component_type == 5122 || l.component_type == UNSIGNED_SHORT ? 2
                     : l.component_type == 5120 || l.component_type == UNSIGNED_BYTE  ? 1
                                                                                      : 0;
    if (size == 0) throw fail(owner + ": unknown componentType " + std::to_string(l.component_type));
    const std::uint64_t element_size = std::uint64_t(size) * l.components;
    if (!acc.contains("bufferView")) {
      if (l.count > MAX_ZERO_ACCESSOR_COUNT) throw fail(owner + ": count " + std::to_string(l.count) + " too large");
      l.stride = element_size;
      return l;
    }
    const std::uint64_t v = index(acc, "bufferView", owner);
    const std::string view_owner = owner + ": bufferView " + std::to_string(v);
    const Json& view = element("bufferViews", v, owner + ": bufferView");
    const std::string_view data = buffer(index(view, "buffer", view_owner));
    const std::uint64_t view_offset = index(view, "byteOffset", view_owner, 0);
    const std::uint64_t view_length = index(view, "byteLength", view_owner);
    if (view_offset > data.size() || view_length > data.size() - view_offset)
      throw fail(view_owner + " lies past the end of its buffer (" + std::to_string(data.size()) + " bytes)");
    l.stride = index(view, "byteStride", view_owner, 0);
    if (l.stride == 0) l.stride = element_size;
    if (l.stride < element_size) throw fail(view_owner + ": byteStride is smaller than an element");
    const std::uint64_t offset = index(acc, "byteOffset", owner, 0);
    if (l.count > 0 && (offset > view_length || element_size > view_length - offset ||
                        (l.count - 1) > (view_length - offset - element_size) / l.stride))
      throw fail(owner + " reads past the end of bufferView " + std::to_string(v) + " (" + std::to_string(view_length) +
                 " bytes)");
    l.data = data.data() + view_offset + offset;
    return l;
  }

  // `components` floats per element; normalized unsigned bytes/shorts too where glTF allows them.
  std::vector<float> read_floats(std::size_t a, const char* semantic, int components, bool allow_normalized) {
    const AccessorLayout l = accessor(a);
    const bool quantized =
        allow_normalized && l.normalized && (l.component_type == UNSIGNED_BYTE || l.component_type == UNSIGNED_SHORT);
    if (l.components != components || (l.component_type != FLOAT && !quantized))
      throw fail("accessor " + std::to_string(a) + ": unsupported layout for " + semantic + " (componentType " +
                 std::to_string(l.component_type) + ", " + std::to_string(l.components) + " components)");
    std::vector<float> out(l.count * components, 0.0f);
    if (!l.data) return out;
    for (std::uint64_t e = 0; e < l.count; ++e) {
      const char* p = l.data + e * l.stride;
      for (int k = 0; k < components; ++k) {
        float& x = out[e * components + k];
        if (l.component_type == FLOAT)
          x = load<float>(p + 4 * k);
        else if (l.component_type == UNSIGNED_BYTE)
          x = static_cast<float>(load<std::uint8_t>(p + k)) / 255.0f;
        else
          x = static_cast<float>(load<std::uint16_t>(p + 2 * k)) / 65535.0f;
      }
    }
    return out;
  }

  std::vector<std::uint32_t> read_indices(std::size_t a) {
    const AccessorLayout l = accessor(a);
    if (l.components != 1 ||
        (l.component_type != UNSIGNED_BYTE && l.component_type != UNSIGNED_SHORT && l.component_type != UNSIGNED_INT))
      throw fail("accessor " + std::to_string(a) + ": indices must be unsigned byte, short or int scalars");
    std::vector<std::uint32_t> out(l.count, 0);
    if (!l.data) return out;
    for (std::uint64_t e = 0; e < l.count; ++e) {
      const char* p = l.data + e * l.stride;
      out[e] = l.component_type == UNSIGNED_BYTE    ? load<std::uint8_t>(p)
               : l.component_type == UNSIGNED_SHORT ? load<std::uint16_t>(p)
                                                    : load<std::uint32_t>(p);
    }
    return out;
  }

  std::vector<std::size_t> scene_roots() const {
    std::optional<std::uint64_t> scene;
    if (m_root.contains("scene"))
      scene = index(m_root, "scene", "'scene'");
    else if (array_size("scenes") > 0)
      scene = 0;
    std::vector<std::size_t> roots;
    if (scene) {
      const Json& s = element("scenes", *scene, "scene");
      if (const auto nodes = s.find("nodes"); nodes != s.end() && nodes->is_array())
        for (const Json& n : *nodes)
          roots.push_back(as_index(n, "scene " + std::to_string(*scene) + " node"));
      return roots;
    }
    // No scene at all: every node that is nobody's child is a root.
    std::vector<char> is_child(array_size("nodes"), 0);
    for (std::size_t n = 0; n < is_child.size(); ++n) {
      const Json& node = element("nodes", n, "node");
      if (const auto c = node.find("children"); c != node.end() && c->is_array())
        for (const Json& child : *c)
          if (child.is_number_unsigned() && child.get<std::uint64_t>() < is_child.size())
            is_child[child.get<std::uint64_t>()] = 1;
    }
    for (std::size_t n = 0; n < is_child.size(); ++n)
      if (!is_child[n]) roots.push_back(n);
    return roots;
  }

  Eigen::Matrix4d local_transform(const Json& node, std::size_t n) const {
    const std::string owner = "node " + std::to_string(n);
    if (const auto m = numbers(node, "matrix", 16, owner)) return Eigen::Map<const Eigen::Matrix4d>(m->data());
    const auto t = numbers(node, "translation", 3, owner).value_or(std::vector<double>{0, 0, 0});
    const auto r = numbers(node, "rotation", 4, owner).value_or(std::vector<double>{0, 0, 0, 1});
    const auto s = numbers(node, "scale", 3, owner).value_or(std::vector<double>{1, 1, 1});
    Eigen::Quaterniond q(r[3], r[0], r[1], r[2]); // glTF stores x, y, z, w
    if (q.norm() > 0.0)
      q.normalize();
    else
      q = Eigen::Quaterniond::Identity();
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = q.toRotationMatrix() * Eigen::Vector3d(s[0], s[1], s[2]).asDiagonal();
    m.topRightCorner<3, 1>() = Eigen::Vector3d(t[0], t[1], t[2]);
    return m;
  }

  void add_mesh(std::size_t m, const Eigen::Matrix4d& world);
  void add_primitive(std::size_t m, std::size_t p, const Json& primitive, const Eigen::Matrix4d& world,
                     std::int32_t label);
  ParsedMesh finish();

  std::string m_path;
  Json m_root;
  std::optional<std::string_view> m_bin;
  std::deque<std::string> m_owned; // decoded and external buffers; a deque keeps views valid
  std::unordered_map<std::size_t, std::string_view> m_buffers;

  ParsedMesh m_out;
  std::unordered_map<PositionKey, std::int32_t, KeyHash> m_vertex_of;
  std::vector<std::int32_t> m_label_of_mesh;
  std::vector<float> m_corner_uvs;     // 2 per corner; (0, 0) where the primitive has none
  std::vector<float> m_corner_normals; // 3 per corner; filled in finish() where missing
  std::vector<char> m_corner_has_normal;
  bool m_any_uvs = false;
  bool m_any_normals = false;
};

void GltfReader::add_mesh(std::size_t m, const Eigen::Matrix4d& world) {
  const Json& mesh = element("meshes", m, "mesh");
  const auto primitives = mesh.find("primitives");
  if (primitives == mesh.end() || !primitives->is_array())
    throw fail("mesh " + std::to_string(m) + " has no 'primitives' array");
  // One label per glTF mesh, shared by every node that instances it.
  if (m_label_of_mesh.empty()) m_label_of_mesh.assign(array_size("meshes"), -1);
  std::vector<std::string>& names = m_out.mesh.label_names;
  if (m_label_of_mesh[m] < 0) {
    m_label_of_mesh[m] = static_cast<std::int32_t>(names.size());
    const auto name = mesh.find("name");
    const bool named = name != mesh.end() && name->is_string() && !name->get<std::string>().empty();
    names.push_back(named ? name->get<std::string>() : "mesh" + std::to_string(m));
  }
  for (std::size_t p = 0; p < primitives->size(); ++p) {
    if (!(*primitives)[p].is_object())
      throw fail("primitive " + std::to_string(p) + " of mesh " + std::to_string(m) + " is not an object");
    add_primitive(m, p, (*primitives)[p], world, m_label_of_mesh[m]);
  }
}

void GltfReader::add_primitive(std::size_t m, std::size_t p, const Json& primitive, const Eigen::Matrix4d& world,
                               std::int32_t label) {
  const std::string owner = "primitive " + std::to_string(p) + " of mesh " + std::to_string(m);
  const std::uint64_t mode = index(primitive, "mode", owner, 4);
  if (mode <= 3) {
    m_out.warnings.push_back(owner + ": " + (mode == 0 ? "points" : "lines") + " skipped");
    return;
  }
  if (mode > 6) throw fail(owner + ": unknown mode " + std::to_string(mode));
  const auto attributes = primitive.find("attributes");
  if (attributes == primitive.end() || !attributes->is_object() || !attributes->contains("POSITION"))
    throw fail(owner + " has no POSITION attribute");
  const std::uint64_t position_accessor = index(*attributes, "POSITION", owner);
  const std::vector<float> local = read_floats(position_accessor, "POSITION", 3, false);
  const std::size_t n = local.size() / 3;
  for (std::size_t i = 0; i < local.size(); ++i)
    if (!std::isfinite(local[i]))
      throw fail("accessor " + std::to_string(position_accessor) + ": POSITION element " + std::to_string(i / 3) +
                 " is not finite");
  auto read_attribute = [&](const char* semantic, int components, bool allow_normalized) {
    if (!attributes->contains(semantic)) return std::vector<float>{};
    const std::uint64_t a = index(*attributes, semantic, owner);
    std::vector<float> values = read_floats(a, semantic, components, allow_normalized);
    if (values.size() != n * components)
      throw fail("accessor " + std::to_string(a) + ": " + semantic + " count differs from POSITION's (" +
                 std::to_string(n) + ")");
    return values;
  };
  const std::vector<float> normals = read_attribute("NORMAL", 3, false);
  const std::vector<float> uvs = read_attribute("TEXCOORD_0", 2, true);

  std::vector<std::uint32_t> indices(n);
  if (primitive.contains("indices"))
    indices = read_indices(index(primitive, "indices", owner));
  else
    std::iota(indices.begin(), indices.end(), 0u);
  for (std::uint32_t i : indices)
    if (i >= n)
      throw fail(owner + ": index " + std::to_string(i) + " out of range (" + std::to_string(n) + " vertices)");
  if (mode == 4 && indices.size() % 3 != 0)
    throw fail(owner + ": " + std::to_string(indices.size()) + " indices is not a multiple of 3");
  std::vector<std::uint32_t> corners = mode == 4 ? indices : std::vector<std::uint32_t>{};
  for (std::size_t i = 0; mode != 4 && i + 2 < indices.size(); ++i) {
    // Strip and fan orders from the glTF spec (3.7.2.1), both keeping the first triangle's winding.
    const std::array<std::uint32_t, 3> t = mode == 5
                                               ? std::array{indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]}
                                               : std::array{indices[i + 1], indices[i + 2], indices[0]};
    // Strips are stitched with repeated indices; those zero-area joins are not faces.
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
    corners.insert(corners.end(), t.begin(), t.end());
  }
  if (m_out.mesh.triangles.size() + corners.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw fail(owner + ": too many faces");

  const Eigen::Matrix3d linear = world.topLeftCorner<3, 3>();
  const Eigen::Vector3d offset = world.topRightCorner<3, 1>();
  const double det = linear.determinant();
  // A mirroring transform turns counter-clockwise triangles clockwise (glTF spec 3.7.4).
  if (det < 0)
    for (std::size_t c = 0; c < corners.size(); c += 3)
      std::swap(corners[c + 1], corners[c + 2]);
  // Normals transform by the inverse transpose, which is the cofactor matrix over det; the
  // cofactor form (sign-corrected) also survives a singular, zero-scale transform.
  Eigen::Matrix3d cofactor;
  cofactor.col(0) = linear.col(1).cross(linear.col(2));
  cofactor.col(1) = linear.col(2).cross(linear.col(0));
  cofactor.col(2) = linear.col(0).cross(linear.col(1));
  if (det < 0) cofactor = -cofactor;

  // Weld in accessor order (not first-use order) so a file that lists each vertex once keeps
  // its vertex order; vertices no triangle uses are dropped.
  std::vector<char> used(n, 0);
  for (std::uint32_t c : corners)
    used[c] = 1;
  std::vector<std::int32_t> welded(n, -1);
  std::vector<float>& positions = m_out.mesh.positions;
  for (std::size_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    const Eigen::Vector3d q = linear * Eigen::Vector3d(local[3 * i], local[3 * i + 1], local[3 * i + 2]) + offset;
    const std::array<float, 3> x{static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
      throw fail(owner + ": vertex " + std::to_string(i) + " is not finite after its node transform");
    const PositionKey key{weld_bits(x[0]), weld_bits(x[1]), weld_bits(x[2])};
    const auto [it, inserted] = m_vertex_of.try_emplace(key, static_cast<std::int32_t>(positions.size() / 3));
    if (inserted) positions.insert(positions.end(), x.begin(), x.end());
    welded[i] = it->second;
  }

  m_any_uvs = m_any_uvs || !uvs.empty();
  m_any_normals = m_any_normals || !normals.empty();
  for (std::uint32_t c : corners) {
    m_out.mesh.triangles.push_back(welded[c]);
    // glTF puts the UV origin at the image's top-left, vfit (like OBJ) at its bottom-left.
    m_corner_uvs.push_back(uvs.empty() ? 0.0f : uvs[2 * c]);
    m_corner_uvs.push_back(uvs.empty() ? 0.0f : 1.0f - uvs[2 * c + 1]);
    Eigen::Vector3d nrm = Eigen::Vector3d::Zero();
    if (!normals.empty()) nrm = cofactor * Eigen::Vector3d(normals[3 * c], normals[3 * c + 1], normals[3 * c + 2]);
    if (nrm.norm() > 0.0) nrm.normalize();
    for (int k = 0; k < 3; ++k)
      m_corner_normals.push_back(static_cast<float>(nrm[k]));
    m_corner_has_normal.push_back(!normals.empty());
  }
  m_out.mesh.face_labels.insert(m_out.mesh.face_labels.end(), corners.size() / 3, label);
}

ParsedMesh GltfReader::finish() {
  Mesh& mesh = m_out.mesh;
  if (mesh.triangles.empty()) throw fail("no faces (no triangle primitives in the default scene)");
  if (m_any_uvs) dedupe_corners<2>(m_corner_uvs, mesh.uvs, mesh.uv_triangles);
  if (m_any_normals) {
    // Corners of primitives without normals get their face's geometric normal.
    for (std::size_t c = 0; c < m_corner_has_normal.size(); ++c) {
      if (m_corner_has_normal[c]) continue;
      const std::size_t f = c / 3;
      auto corner = [&](int k) {
        const std::size_t v = static_cast<std::size_t>(mesh.triangles[3 * f + k]);
        return Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
      };
      Eigen::Vector3d nrm = (corner(1) - corner(0)).cross(corner(2) - corner(0));
      if (nrm.norm() > 0.0) nrm.normalize();
      for (int k = 0; k < 3; ++k)
        m_corner_normals[3 * c + k] = static_cast<float>(nrm[k]);
    }
    dedupe_corners<3>(m_corner_normals, mesh.normals, mesh.normal_triangles);
  }
  m_out.source.path = m_path;
  m_out.source.text = false;
  m_out.source.face_origin.resize(mesh.face_count());
  std::iota(m_out.source.face_origin.begin(), m_out.source.face_origin.end(), std::int64_t{1});
  return std::move(m_out);
}

} // namespace

ParsedMesh read_gltf(std::string_view bytes, const std::string& path) {
  try {
    GltfReader reader(bytes, path);
    return reader.read();
  } catch (const Json::exception& e) {
    // Our accessors check types; this catches whatever a malformed document slips past them.
    throw Error(path, 0, std::string("invalid glTF: ") + e.what());
  }
}

} // namespace vfit
