// SPDX-License-Identifier: Apache-2.0
// The glTF document shared by read_gltf() and read_gltf_body(): GLB chunks, JSON, buffers
// (BIN chunk, base64 data URIs, files beside a .gltf), accessors and node transforms.
#include "gltf_document.h"

#include <Eigen/Geometry>

#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace vfit::gltf {
namespace {

// GLB and accessor data are little-endian; we read them with memcpy.
static_assert(std::endian::native == std::endian::little, "glTF reading assumes a little-endian host");

constexpr std::uint32_t GLB_MAGIC = 0x46546C67;  // "glTF"
constexpr std::uint32_t CHUNK_JSON = 0x4E4F534A; // "JSON"
constexpr std::uint32_t CHUNK_BIN = 0x004E4942;  // "BIN\0"
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

} // namespace

GltfDocument::GltfDocument(std::string_view bytes, const std::string& path) : m_path(path) {
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

void GltfDocument::parse_json(std::string_view text) {
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

std::size_t GltfDocument::array_size(const char* name) const {
  const auto it = m_root.find(name);
  if (it == m_root.end()) return 0;
  if (!it->is_array()) throw fail(std::string("'") + name + "' is not an array");
  return it->size();
}

const Json& GltfDocument::element(const char* array, std::size_t i, const std::string& what) const {
  if (i >= array_size(array))
    throw fail(what + " " + std::to_string(i) + " does not exist (" + std::to_string(array_size(array)) + " " + array +
               ")");
  const Json& e = m_root[array][i];
  if (!e.is_object()) throw fail(what + " " + std::to_string(i) + " is not an object");
  return e;
}

std::uint64_t GltfDocument::as_index(const Json& v, const std::string& owner) const {
  if (!v.is_number_unsigned()) throw fail(owner + ": expected a non-negative integer, got " + v.dump());
  return v.get<std::uint64_t>();
}

std::uint64_t GltfDocument::index(const Json& obj, const char* key, const std::string& owner,
                                  std::optional<std::uint64_t> fallback) const {
  const auto it = obj.find(key);
  if (it != obj.end()) return as_index(*it, owner + " '" + key + "'");
  if (!fallback) throw fail(owner + ": missing '" + key + "'");
  return *fallback;
}

std::optional<std::vector<double>> GltfDocument::numbers(const Json& obj, const char* key, std::size_t n,
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

void GltfDocument::check_required_extensions() const {
  const auto it = m_root.find("extensionsRequired");
  if (it == m_root.end() || !it->is_array()) return;
  for (const Json& e : *it) {
    const std::string name = e.is_string() ? e.get<std::string>() : "";
    // Material and texture extensions don't change geometry; anything else (Draco, meshopt,
    // quantization, instancing) would be silently misread.
    if (!name.starts_with("KHR_materials_") && !name.starts_with("KHR_texture_") && !name.starts_with("EXT_texture_") &&
        name != "KHR_lights_punctual")
      throw fail("unsupported required extension " + quoted(name));
  }
}

std::string_view GltfDocument::buffer(std::size_t b) {
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

std::string GltfDocument::read_external(const std::string& uri, const std::string& owner) const {
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

AccessorLayout GltfDocument::accessor(std::size_t a) {
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

std::vector<float> GltfDocument::read_floats(std::size_t a, const char* semantic, int components,
                                             bool allow_normalized) {
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

std::vector<std::uint32_t> GltfDocument::read_unsigned(std::size_t a, const char* semantic, int components) {
  const AccessorLayout l = accessor(a);
  if (l.components != components ||
      (l.component_type != UNSIGNED_BYTE && l.component_type != UNSIGNED_SHORT && l.component_type != UNSIGNED_INT))
    throw fail("accessor " + std::to_string(a) + ": unsupported layout for " + semantic + " (componentType " +
               std::to_string(l.component_type) + ", " + std::to_string(l.components) + " components)");
  std::vector<std::uint32_t> out(l.count * components, 0);
  if (!l.data) return out;
  for (std::uint64_t e = 0; e < l.count; ++e) {
    const char* p = l.data + e * l.stride;
    for (int k = 0; k < components; ++k)
      out[e * components + k] = l.component_type == UNSIGNED_BYTE    ? load<std::uint8_t>(p + k)
                                : l.component_type == UNSIGNED_SHORT ? load<std::uint16_t>(p + 2 * k)
                                                                     : load<std::uint32_t>(p + 4 * k);
  }
  return out;
}

std::vector<std::uint32_t> GltfDocument::read_indices(std::size_t a) {
  const AccessorLayout l = accessor(a);
  if (l.components != 1 ||
      (l.component_type != UNSIGNED_BYTE && l.component_type != UNSIGNED_SHORT && l.component_type != UNSIGNED_INT))
    throw fail("accessor " + std::to_string(a) + ": indices must be unsigned byte, short or int scalars");
  return read_unsigned(a, "indices", 1);
}

std::vector<std::size_t> GltfDocument::scene_roots() const {
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

Eigen::Matrix4d GltfDocument::local_transform(const Json& node, std::size_t n) const {
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

std::string GltfDocument::node_name(std::size_t n) const {
  const Json& node = element("nodes", n, "node");
  const auto name = node.find("name");
  if (name != node.end() && name->is_string() && !name->get<std::string>().empty()) return name->get<std::string>();
  return "node" + std::to_string(n);
}

} // namespace vfit::gltf
