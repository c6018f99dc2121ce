// SPDX-License-Identifier: Apache-2.0
#include "ply_format.h"

#include "text_words.h"

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using text::is_space;
using text::Words;

enum class Scalar : std::uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

/// PLY's type names (the original and the sized spelling) and their sizes in bytes.
struct ScalarName {
  std::string_view name, sized_name;
  Scalar type;
  std::size_t bytes;
};
constexpr ScalarName SCALARS[] = {{"char", "int8", Scalar::I8, 1},      {"uchar", "uint8", Scalar::U8, 1},
                                  {"short", "int16", Scalar::I16, 2},   {"ushort", "uint16", Scalar::U16, 2},
                                  {"int", "int32", Scalar::I32, 4},     {"uint", "uint32", Scalar::U32, 4},
                                  {"float", "float32", Scalar::F32, 4}, {"double", "float64", Scalar::F64, 8}};

constexpr std::size_t size_of(Scalar s) { return SCALARS[static_cast<int>(s)].bytes; }

std::optional<Scalar> scalar_named(std::string_view n) {
  for (const ScalarName& s : SCALARS)
    if (n == s.name || n == s.sized_name) return s.type;
  return std::nullopt;
}

/// The mesh attribute a property feeds; NONE properties are read past.
enum class Role : std::uint8_t { NONE, X, Y, Z, NX, NY, NZ, U, V, INDICES, TEXCOORD, COUNT };

struct Property {
  std::string name;
  Scalar type = Scalar::F32;      // the value type, or a list's item type
  Scalar count_type = Scalar::U8; // lists only
  bool is_list = false;
  Role role = Role::NONE;
  std::int64_t line = 0;
};

struct Element {
  std::string name;
  std::int64_t count = 0;
  std::int64_t line = 0;
  std::vector<Property> properties;
};

enum class Encoding { ASCII, LITTLE, BIG };

struct Header {
  Encoding encoding = Encoding::ASCII;
  std::vector<Element> elements;
  std::size_t body_offset = 0;
  std::int64_t header_lines = 0;
};

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  Words words(line);
  for (std::string_view w; words.next(w);)
    out.push_back(w);
  return out;
}

/// A word from the file, made printable and short enough for a one-line message.
std::string quoted(std::string_view word) {
  std::string s = "'";
  for (char c : word.substr(0, 40))
    s += (c >= 0x20 && c < 0x7f) ? c : '?';
  return s + (word.size() > 40 ? "...'" : "'");
}

std::string format_number(double v) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

/// One ASCII value. Float properties go through from_chars<float> so that the shortest
/// representation a writer chose reads back bit-identical. Out-of-range text becomes ±inf
/// or an underflowed value (strtod's answer) so the caller can name it as infinite.
bool parse_value(std::string_view word, Scalar type, double& out) {
  const char* first = word.data();
  const char* last = first + word.size();
  if (first != last && *first == '+') ++first;
  std::from_chars_result r{};
  if (type == Scalar::F32) {
    float f = 0;
    r = std::from_chars(first, last, f);
    out = f;
  } else {
    r = std::from_chars(first, last, out);
  }
  if (r.ptr != last || first == last) return false;
  if (r.ec == std::errc::result_out_of_range) {
    const std::string copy(first, last);
    out = type == Scalar::F32 ? std::strtof(copy.c_str(), nullptr) : std::strtod(copy.c_str(), nullptr);
    return true;
  }
  return r.ec == std::errc();
}

std::string plural(const std::string& element) {
  if (element == "vertex") return "vertices";
  if (element == "face") return "faces";
  return "'" + element + "' elements";
}

Header parse_header(std::string_view bytes, const std::string& path, std::vector<std::string>& warnings) {
  if (bytes.empty()) throw Error(path, 0, "empty file");
  Header h;
  std::size_t pos = 0;
  std::int64_t line = 0;
  bool have_format = false;
  for (;;) {
    if (pos >= bytes.size()) throw Error(path, line, "header has no 'end_header' line");
    const std::size_t eol = bytes.find('\n', pos);
    const std::string_view text = bytes.substr(pos, eol == std::string_view::npos ? eol : eol - pos);
    pos = eol == std::string_view::npos ? bytes.size() : eol + 1;
    const auto words = split(text);
    if (++line == 1) {
      if (words.size() != 1 || words[0] != "ply") throw Error(path, 1, "not a PLY file (missing 'ply' magic)");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "end_header") break;
    if (words[0] == "format") {
      if (have_format) throw Error(path, line, "second 'format' line");
      if (words.size() != 3) throw Error(path, line, "bad format line (expected 'format <encoding> 1.0')");
      if (words[1] == "ascii")
        h.encoding = Encoding::ASCII;
      else if (words[1] == "binary_little_endian")
        h.encoding = Encoding::LITTLE;
      else if (words[1] == "binary_big_endian")
        h.encoding = Encoding::BIG;
      else
        throw Error(path, line, "unsupported format " + quoted(words[1]));
      if (words[2] != "1.0")
        warnings.push_back(path + ":" + std::to_string(line) + ": PLY version " + quoted(words[2]) + " read as 1.0");
      have_format = true;
    } else if (words[0] == "element") {
      if (words.size() != 3) throw Error(path, line, "bad element line (expected 'element <name> <count>')");
      Element e{std::string(words[1]), 0, line, {}};
      const auto [p, ec] = std::from_chars(words[2].data(), words[2].data() + words[2].size(), e.count);
      if (ec == std::errc::result_out_of_range)
        throw Error(path, line, "element count " + quoted(words[2]) + " is absurdly large");
      if (ec != std::errc() || p != words[2].data() + words[2].size())
        throw Error(path, line, "element count " + quoted(words[2]) + " is not an integer");
      if (e.count < 0) throw Error(path, line, "negative element count " + quoted(words[2]));
      for (const Element& other : h.elements)
        if (other.name == e.name) throw Error(path, line, "second element named " + quoted(e.name));
      h.elements.push_back(std::move(e));
    } else if (words[0] == "property") {
      if (h.elements.empty()) throw Error(path, line, "property before any element");
      Property prop;
      prop.line = line;
      const bool list = words.size() == 5 && words[1] == "list";
      if (!list && words.size() != 3) throw Error(path, line, "bad property line");
      const auto type = scalar_named(words[list ? 3 : 1]);
      if (!type) throw Error(path, line, "unsupported property type " + quoted(words[list ? 3 : 1]));
      prop.type = *type;
      if (list) {
        const auto count_type = scalar_named(words[2]);
        if (!count_type || *count_type == Scalar::F32 || *count_type == Scalar::F64)
          throw Error(path, line, "unsupported list count type " + quoted(words[2]));
        prop.count_type = *count_type;
      }
      prop.is_list = list;
      prop.name = std::string(words.back());
      h.elements.back().properties.push_back(std::move(prop));
    } else {
      throw Error(path, line, "bad header line: unknown keyword " + quoted(words[0]));
    }
  }
  if (!have_format) throw Error(path, line, "header has no 'format' line");
  h.body_offset = pos;
  h.header_lines = line;
  return h;
}

constexpr std::pair<std::string_view, Role> VERTEX_ROLES[] = {
    {"x", Role::X},         {"y", Role::Y},         {"z", Role::Z},         {"nx", Role::NX},      {"ny", Role::NY},
    {"nz", Role::NZ},       {"u", Role::U},         {"v", Role::V},         {"s", Role::U},        {"t", Role::V},
    {"texture_u", Role::U}, {"texture_v", Role::V}, {"texture_s", Role::U}, {"texture_t", Role::V}};

/// Tags the properties read into the mesh and checks the ones it cannot do without.
void assign_roles(Header& h, const std::string& path) {
  bool have_vertex = false;
  for (Element& e : h.elements) {
    if (e.name == "vertex") {
      have_vertex = true;
      bool seen[static_cast<int>(Role::COUNT)] = {};
      for (Property& p : e.properties) {
        if (p.is_list) continue;
        for (const auto& [name, role] : VERTEX_ROLES)
          if (p.name == name) p.role = role;
        seen[static_cast<int>(p.role)] = true;
      }
      for (Role r : {Role::X, Role::Y, Role::Z})
        if (!seen[static_cast<int>(r)])
          throw Error(path, e.line,
                      std::string("element 'vertex' has no property '") + "xyz"[static_cast<int>(r) - 1] + "'");
    } else if (e.name == "face") {
      bool have_indices = false;
      for (Property& p : e.properties) {
        if ((p.name == "vertex_indices" || p.name == "vertex_index") && !have_indices) {
          if (!p.is_list) throw Error(path, p.line, "face property " + quoted(p.name) + " must be a list");
          p.role = Role::INDICES;
          have_indices = true;
        } else if (p.name == "texcoord" && p.is_list) {
          p.role = Role::TEXCOORD;
        }
      }
      if (!have_indices) throw Error(path, e.line, "element 'face' has no 'vertex_indices' list");
    }
  }
  if (!have_vertex) throw Error(path, 0, "header has no 'vertex' element");
}

template <class U> U byte_swapped(U u) {
  if constexpr (sizeof(U) == 2)
    return static_cast<U>(__builtin_bswap16(u));
  else if constexpr (sizeof(U) == 4)
    return __builtin_bswap32(u);
  else
    return __builtin_bswap64(u);
}

template <class T, class U> T load(const char* p, bool swap) {
  U u;
  std::memcpy(&u, p, sizeof u);
  return std::bit_cast<T>(swap ? byte_swapped(u) : u);
}

double load_scalar(const char* p, Scalar t, bool swap) {
  switch (t) {
  case Scalar::I8: return static_cast<std::int8_t>(*p);
  case Scalar::U8: return static_cast<std::uint8_t>(*p);
  case Scalar::I16: return load<std::int16_t, std::uint16_t>(p, swap);
  case Scalar::U16: return load<std::uint16_t, std::uint16_t>(p, swap);
  case Scalar::I32: return load<std::int32_t, std::uint32_t>(p, swap);
  case Scalar::U32: return load<std::uint32_t, std::uint32_t>(p, swap);
  case Scalar::F32: return load<float, std::uint32_t>(p, swap);
  case Scalar::F64: return load<double, std::uint64_t>(p, swap);
  }
  return 0;
}

/// What a body reader (ASCII or binary) shares: the element being read, for messages.
class SourceBase {
public:
  explicit SourceBase(const std::string& path) : m_path(path) {}
  const std::string& path() const { return m_path; }
  [[noreturn]] void fail(std::int64_t line, const std::string& what) const {
    throw Error(m_path, line, m_element->name + " " + std::to_string(m_index + 1) + ": " + what);
  }
  [[noreturn]] void truncated(std::int64_t line) const {
    throw Error(m_path, line,
                "truncated: header declares " + std::to_string(m_element->count) + " " + plural(m_element->name) +
                    ", data ends after " + std::to_string(m_index));
  }

protected:
  const std::string& m_path;
  const Element* m_element = nullptr;
  std::int64_t m_index = 0;
};

class BinarySource : public SourceBase {
public:
  BinarySource(std::string_view body, bool swap, const std::string& path)
      : SourceBase(path), m_p(body.data()), m_end(body.data() + body.size()), m_swap(swap) {}
  void begin(const Element& e, std::int64_t i) { m_element = &e, m_index = i; }
  void end() {}
  std::int64_t origin() const { return m_index + 1; }
  [[noreturn]] void fail(const std::string& what) const { SourceBase::fail(0, what); }
  std::size_t bytes_left() const { return static_cast<std::size_t>(m_end - m_p); }

  /// Checks that n values of type t remain before reading any, so absurd list counts stop here.
  void expect(Scalar t, std::uint64_t n) {
    if (n > bytes_left() / size_of(t)) truncated(0);
  }
  double value(Scalar t) {
    expect(t, 1);
    const double v = load_scalar(m_p, t, m_swap);
    m_p += size_of(t);
    return v;
  }
  std::uint64_t count(Scalar t) {
    const double n = value(t);
    if (n < 0) fail("negative list count " + format_number(n));
    return static_cast<std::uint64_t>(n);
  }
  void skip(Scalar t, std::uint64_t n) {
    expect(t, n);
    m_p += size_of(t) * n;
  }

private:
  const char* m_p;
  const char* m_end;
  bool m_swap;
};

/// Reads one element per line, as every ASCII PLY writer lays them out; blank lines are skipped.
class AsciiSource : public SourceBase {
public:
  AsciiSource(std::string_view body, std::int64_t header_lines, const std::string& path)
      : SourceBase(path), m_body(body), m_line(header_lines) {}
  void begin(const Element& e, std::int64_t i) {
    m_element = &e, m_index = i;
    if (!next_line()) truncated(m_line);
  }
  void end() {
    std::string_view w;
    if (m_words.next(w)) ++m_extra_lines;
  }
  std::int64_t origin() const { return m_line; }
  [[noreturn]] void fail(const std::string& what) const { SourceBase::fail(m_line, what); }
  std::size_t bytes_left() const { return m_body.size() - m_pos; }

  void expect(Scalar, std::uint64_t) {}
  double value(Scalar t) {
    std::string_view w;
    if (!m_words.next(w)) fail("too few values on the line");
    double v = 0;
    if (!parse_value(w, t, v)) fail(quoted(w) + " is not a number");
    return v;
  }
  std::uint64_t count(Scalar t) {
    const double n = value(t);
    if (n < 0 || n != std::floor(n)) fail("list count " + format_number(n) + " is not a non-negative integer");
    return n > 1e18 ? std::uint64_t{1} << 60 : static_cast<std::uint64_t>(n);
  }
  void skip(Scalar, std::uint64_t n) {
    std::string_view w;
    for (std::uint64_t k = 0; k < n; ++k)
      if (!m_words.next(w)) fail("too few values on the line");
  }
  void finish(std::vector<std::string>& warnings) {
    if (m_extra_lines > 0)
      warnings.push_back(m_path + ": " + std::to_string(m_extra_lines) + " element lines had extra values (ignored)");
    const std::int64_t last = m_line;
    if (next_line())
      warnings.push_back(m_path + ":" + std::to_string(m_line) + ": data after the last element ignored");
    m_line = last;
  }

private:
  bool next_line() {
    while (m_pos < m_body.size()) {
      const std::size_t eol = m_body.find('\n', m_pos);
      const std::string_view text = m_body.substr(m_pos, eol == std::string_view::npos ? eol : eol - m_pos);
      m_pos = eol == std::string_view::npos ? m_body.size() : eol + 1;
      ++m_line;
      m_words = Words(text);
      std::string_view probe;
      if (Words(text).next(probe)) return true;
    }
    return false;
  }

  std::string_view m_body;
  std::size_t m_pos = 0;
  std::int64_t m_line;
  Words m_words;
  std::int64_t m_extra_lines = 0;
};

/// Bytes (ASCII: characters) an element needs at least, so a header count can size a
/// reservation without trusting it beyond what the file could hold.
std::size_t min_bytes(const Element& e, bool ascii) {
  std::size_t n = 0;
  for (const Property& p : e.properties)
    n += ascii ? 2 : size_of(p.is_list ? p.count_type : p.type);
  return std::max<std::size_t>(n, 1);
}

struct Builder {
  ParsedMesh& out;
  std::int64_t vertex_count = 0;
  bool vertex_normals = false;
  bool vertex_uvs = false;
  bool face_texcoords = false;
  bool bad_normals = false;
};

template <class Source> float checked_float(Source& src, double v, const char* what) {
  if (std::isnan(v)) src.fail(std::string(what) + " is NaN");
  if (std::isinf(v)) src.fail(std::string(what) + " is infinite");
  if (std::fabs(v) > std::numeric_limits<float>::max()) src.fail(std::string(what) + " is too large for a float");
  return static_cast<float>(v);
}

template <class Source> void read_vertices(const Element& e, Source& src, Builder& b, bool ascii) {
  Mesh& m = b.out.mesh;
  const auto hint = std::min<std::size_t>(static_cast<std::size_t>(e.count), src.bytes_left() / min_bytes(e, ascii));
  m.positions.reserve(3 * hint);
  if (b.vertex_normals) m.normals.reserve(3 * hint);
  if (b.vertex_uvs) m.uvs.reserve(2 * hint);
  std::array<double, static_cast<int>(Role::COUNT)> v{};
  for (std::int64_t i = 0; i < e.count; ++i) {
    src.begin(e, i);
    for (const Property& p : e.properties) {
      if (p.is_list)
        src.skip(p.type, src.count(p.count_type));
      else
        v[static_cast<int>(p.role)] = src.value(p.type);
    }
    src.end();
    for (Role r : {Role::X, Role::Y, Role::Z})
      m.positions.push_back(checked_float(src, v[static_cast<int>(r)], "coordinate"));
    if (b.vertex_normals) {
      for (Role r : {Role::NX, Role::NY, Role::NZ}) {
        const double n = v[static_cast<int>(r)];
        // A bad normal is not worth rejecting the mesh for: normals are recomputed anyway.
        const bool ok = std::isfinite(n) && std::fabs(n) <= std::numeric_limits<float>::max();
        b.bad_normals |= !ok;
        m.normals.push_back(ok ? static_cast<float>(n) : 0.0f);
      }
    }
    if (b.vertex_uvs) {
      m.uvs.push_back(checked_float(src, v[static_cast<int>(Role::U)], "texture coordinate"));
      m.uvs.push_back(checked_float(src, v[static_cast<int>(Role::V)], "texture coordinate"));
    }
  }
  // Only reachable with a multi-gigabyte file: smaller ones hit "truncated" above.
  if (e.count > std::numeric_limits<std::int32_t>::max())
    throw Error(src.path(), 0, "too many vertices for 32-bit indices");
}

template <class Source> std::int32_t checked_index(Source& src, double d, std::int64_t vertex_count) {
  if (d != std::floor(d)) src.fail("vertex index " + format_number(d) + " is not an integer");
  if (d < 0) src.fail("negative vertex index " + format_number(d));
  if (d >= static_cast<double>(vertex_count) || d > std::numeric_limits<std::int32_t>::max())
    src.fail("vertex index " + format_number(d) + " out of range (" + std::to_string(vertex_count) + " vertices)");
  return static_cast<std::int32_t>(d);
}

template <class Source> void read_faces(const Element& e, Source& src, Builder& b, bool ascii) {
  Mesh& m = b.out.mesh;
  const auto hint = std::min<std::size_t>(static_cast<std::size_t>(e.count), src.bytes_left() / min_bytes(e, ascii));
  m.triangles.reserve(3 * hint);
  b.out.source.face_origin.reserve(hint);
  std::vector<std::int32_t> corners;
  std::vector<float> tex;
  for (std::int64_t i = 0; i < e.count; ++i) {
    src.begin(e, i);
    corners.clear();
    tex.clear();
    for (const Property& p : e.properties) {
      if (!p.is_list) {
        src.value(p.type);
        continue;
      }
      const std::uint64_t n = src.count(p.count_type);
      src.expect(p.type, n);
      if (p.role == Role::INDICES) {
        for (std::uint64_t k = 0; k < n; ++k)
          corners.push_back(checked_index(src, src.value(p.type), b.vertex_count));
      } else if (p.role == Role::TEXCOORD) {
        for (std::uint64_t k = 0; k < n; ++k)
          tex.push_back(checked_float(src, src.value(p.type), "texture coordinate"));
      } else {
        src.skip(p.type, n);
      }
    }
    src.end();
    const std::size_t n = corners.size();
    if (n < 3) src.fail("has " + std::to_string(n) + " vertices (a face needs at least 3)");
    if (b.face_texcoords && tex.size() != 2 * n)
      src.fail("texcoord list has " + std::to_string(tex.size()) + " values for " + std::to_string(n) +
               " corners (expected " + std::to_string(2 * n) + ")");
    const std::size_t uv_base = m.uvs.size() / 2;
    if (b.face_texcoords) {
      if (uv_base + n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        src.fail("too many texture coordinates");
      m.uvs.insert(m.uvs.end(), tex.begin(), tex.end());
    }
    // Fan triangulation (0, k, k+1): exact for the convex polygons PLY writers emit.
    for (std::size_t k = 1; k + 1 < n; ++k) {
      m.triangles.insert(m.triangles.end(), {corners[0], corners[k], corners[k + 1]});
      b.out.source.face_origin.push_back(src.origin());
      if (b.face_texcoords) {
        const auto base = static_cast<std::int32_t>(uv_base);
        m.uv_triangles.insert(m.uv_triangles.end(),
                              {base, base + static_cast<std::int32_t>(k), base + static_cast<std::int32_t>(k + 1)});
      }
    }
  }
}

template <class Source> void skip_element(const Element& e, Source& src) {
  if (e.properties.empty()) return;
  for (std::int64_t i = 0; i < e.count; ++i) {
    src.begin(e, i);
    for (const Property& p : e.properties)
      src.skip(p.type, p.is_list ? src.count(p.count_type) : 1);
    src.end();
  }
}

template <class Source> void read_body(const Header& h, Source& src, Builder& b) {
  const bool ascii = h.encoding == Encoding::ASCII;
  for (const Element& e : h.elements) {
    if (e.name == "vertex")
      read_vertices(e, src, b, ascii);
    else if (e.name == "face")
      read_faces(e, src, b, ascii);
    else
      skip_element(e, src);
  }
}

/// Which optional attributes the header offers; per-corner texcoords win over per-vertex UVs
/// because they keep seams.
void plan_attributes(const Header& h, Builder& b) {
  bool has[static_cast<int>(Role::COUNT)] = {};
  for (const Element& e : h.elements) {
    if (e.name != "vertex" && e.name != "face") continue;
    if (e.name == "vertex") b.vertex_count = e.count;
    for (const Property& p : e.properties)
      has[static_cast<int>(p.role)] = true;
  }
  const auto on = [&](Role r) { return has[static_cast<int>(r)]; };
  b.vertex_normals = on(Role::NX) && on(Role::NY) && on(Role::NZ);
  b.face_texcoords = on(Role::TEXCOORD);
  b.vertex_uvs = on(Role::U) && on(Role::V) && !b.face_texcoords;
}

template <class T> void append_binary(std::string& out, T v) {
  using U = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint8_t>;
  auto u = std::bit_cast<U>(v);
  if constexpr (std::endian::native == std::endian::big && sizeof(U) > 1) u = byte_swapped(u);
  char buf[sizeof u];
  std::memcpy(buf, &u, sizeof u);
  out.append(buf, sizeof u);
}

template <class T> void append_text(std::string& out, T v, char separator) {
  char buf[32];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
  out += separator;
}

} // namespace

ParsedMesh read_ply(std::string_view bytes, const std::string& path, bool allow_point_cloud) {
  // A UTF-8 byte-order mark before the 'ply' magic (a header saved by a text editor).
  if (bytes.starts_with("\xEF\xBB\xBF")) bytes.remove_prefix(3);
  ParsedMesh out;
  Header h = parse_header(bytes, path, out.warnings);
  assign_roles(h, path);
  out.source.path = path;
  out.source.text = h.encoding == Encoding::ASCII;
  Builder b{out};
  plan_attributes(h, b);
  const std::string_view body = bytes.substr(h.body_offset);
  if (h.encoding == Encoding::ASCII) {
    AsciiSource src(body, h.header_lines, path);
    read_body(h, src, b);
    src.finish(out.warnings);
  } else {
    const bool big = h.encoding == Encoding::BIG;
    BinarySource src(body, big != (std::endian::native == std::endian::big), path);
    read_body(h, src, b);
    if (src.bytes_left() > 0)
      out.warnings.push_back(path + ": " + std::to_string(src.bytes_left()) + " bytes after the last element ignored");
  }
  Mesh& m = out.mesh;
  if (m.triangles.empty() && !(allow_point_cloud && m.vertex_count() > 0))
    throw Error(path, 0, allow_point_cloud ? "no vertices" : "no faces");
  if (b.bad_normals) {
    out.warnings.push_back(path + ": vertex normals contain NaN or infinite values; normals ignored");
    m.normals.clear();
  }
  if (!m.normals.empty()) m.normal_triangles = m.triangles;
  if (b.vertex_uvs) m.uv_triangles = m.triangles;
  return out;
}

std::string write_ply(const Mesh& mesh, bool binary) {
  const bool normals =
      mesh.has_normals() && mesh.normal_triangles == mesh.triangles && mesh.normals.size() == mesh.positions.size();
  const bool uvs = mesh.has_uvs();
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::string out = "ply\nformat ";
  out += binary ? "binary_little_endian 1.0\n" : "ascii 1.0\n";
  out += "comment written by vfit\nelement vertex " + std::to_string(nv) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  out += "element face " + std::to_string(nf) + "\nproperty list uchar int vertex_indices\n";
  if (uvs) out += "property list uchar float texcoord\n";
  out += "end_header\n";
  out.reserve(out.size() + nv * (normals ? 24 : 12) + nf * (uvs ? 38 : 13));
  for (std::size_t v = 0; v < nv; ++v) {
    for (int c = 0; c < 3; ++c) {
      const float x = mesh.positions[3 * v + c];
      binary ? append_binary(out, x) : append_text(out, x, normals || c < 2 ? ' ' : '\n');
    }
    for (int c = 0; normals && c < 3; ++c) {
      const float n = mesh.normals[3 * v + c];
      binary ? append_binary(out, n) : append_text(out, n, c < 2 ? ' ' : '\n');
    }
  }
  for (std::size_t f = 0; f < nf; ++f) {
    if (binary)
      append_binary(out, std::uint8_t{3});
    else
      out += "3 ";
    for (int c = 0; c < 3; ++c) {
      const std::int32_t i = mesh.triangles[3 * f + c];
      binary ? append_binary(out, i) : append_text(out, i, uvs || c < 2 ? ' ' : '\n');
    }
    if (!uvs) continue;
    if (binary)
      append_binary(out, std::uint8_t{6});
    else
      out += "6 ";
    for (int c = 0; c < 6; ++c) {
      const float t = mesh.uvs[2 * static_cast<std::size_t>(mesh.uv_triangles[3 * f + c / 2]) + c % 2];
      binary ? append_binary(out, t) : append_text(out, t, c < 5 ? ' ' : '\n');
    }
  }
  return out;
}

} // namespace vfit
