// SPDX-License-Identifier: Apache-2.0
#include "stl_format.h"

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <vector>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr std::size_t HEADER_BYTES = 84; // 80-byte header + uint32 facet count
constexpr std::size_t FACET_BYTES = 50;  // normal, 3 corners (12 floats) + uint16 attribute

std::uint32_t load_u32_le(const char* p) {
  std::uint32_t u;
  std::memcpy(&u, p, 4);
  if constexpr (std::endian::native == std::endian::big) u = __builtin_bswap32(u);
  return u;
}

void append_u32_le(std::string& out, std::uint32_t u) {
  if constexpr (std::endian::native == std::endian::big) u = __builtin_bswap32(u);
  char buf[4];
  std::memcpy(buf, &u, 4);
  out.append(buf, 4);
}

/// A corner position as its float bit patterns, with -0.0 folded onto 0.0 so that the two
/// zeros (which compare equal) weld.
struct PositionKey {
  std::array<std::uint32_t, 3> bits;
  bool operator==(const PositionKey&) const = default;
};

struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const {
    std::uint64_t h = k.bits[0];
    h = (h ^ (std::uint64_t{k.bits[1]} << 32)) * 0x9E3779B97F4A7C15ull;
    h = (h ^ k.bits[2] ^ (h >> 29)) * 0xBF58476D1CE4E5B9ull;
    return static_cast<std::size_t>(h ^ (h >> 32));
  }
};

/// Turns STL's unshared corners into an indexed mesh: one vertex per distinct position.
class Welder {
public:
  Welder(Mesh& mesh, std::size_t corner_hint) : m_mesh(mesh) {
    m_index.reserve(corner_hint / 4); // closed meshes have about 6 corners per vertex
    m_mesh.positions.reserve(3 * (corner_hint / 4));
    m_mesh.triangles.reserve(corner_hint);
  }
  std::int32_t vertex(const std::array<float, 3>& p) {
    PositionKey key;
    for (int c = 0; c < 3; ++c)
      key.bits[c] = std::bit_cast<std::uint32_t>(p[c] == 0.0f ? 0.0f : p[c]);
    const auto next = static_cast<std::int32_t>(m_index.size());
    const auto [it, inserted] = m_index.try_emplace(key, next);
    if (inserted) m_mesh.positions.insert(m_mesh.positions.end(), p.begin(), p.end());
    return it->second;
  }

private:
  Mesh& m_mesh;
  std::unordered_map<PositionKey, std::int32_t, PositionKeyHash> m_index;
};

const char* non_finite(float v) { return std::isnan(v) ? "NaN" : std::isinf(v) ? "infinite" : nullptr; }

ParsedMesh read_binary(std::string_view bytes, const std::string& path) {
  ParsedMesh out;
  out.source.path = path;
  out.source.text = false;
  const std::size_t n = (bytes.size() - HEADER_BYTES) / FACET_BYTES;
  if (n == 0) throw Error(path, 0, "no faces");
  if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) / 3)
    throw Error(path, 0, "too many facets for 32-bit indices");
  Welder welder(out.mesh, 3 * n);
  out.source.face_origin.reserve(n);
  for (std::size_t f = 0; f < n; ++f) {
    const char* facet = bytes.data() + HEADER_BYTES + FACET_BYTES * f;
    for (int c = 0; c < 3; ++c) {
      std::array<float, 3> p;
      for (int k = 0; k < 3; ++k) {
        p[k] = std::bit_cast<float>(load_u32_le(facet + 12 + 12 * c + 4 * k));
        if (const char* bad = non_finite(p[k]))
          throw Error(path, 0, "facet " + std::to_string(f + 1) + ": vertex coordinate is " + bad);
      }
      out.mesh.triangles.push_back(welder.vertex(p));
    }
    out.source.face_origin.push_back(static_cast<std::int64_t>(f) + 1);
  }
  return out;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

/// Whitespace-separated tokens of the whole text, with the line each one is on.
class Tokens {
public:
  explicit Tokens(std::string_view text) : m_text(text) {}
  bool next(std::string_view& token) {
    while (m_pos < m_text.size() && is_space(m_text[m_pos]))
      m_line += m_text[m_pos++] == '\n';
    const std::size_t start = m_pos;
    while (m_pos < m_text.size() && !is_space(m_text[m_pos]))
      ++m_pos;
    token = m_text.substr(start, m_pos - start);
    return !token.empty();
  }
  /// Drops the rest of the current line (a solid's name).
  void skip_line() {
    const std::size_t eol = m_text.find('\n', m_pos);
    m_pos = eol == std::string_view::npos ? m_text.size() : eol;
  }
  std::int64_t line() const { return m_line; }

private:
  std::string_view m_text;
  std::size_t m_pos = 0;
  std::int64_t m_line = 1;
};

bool keyword_is(std::string_view token, std::string_view keyword) {
  if (token.size() != keyword.size()) return false;
  for (std::size_t i = 0; i < token.size(); ++i)
    if ((token[i] | 0x20) != keyword[i]) return false; // keywords are lower-case letters
  return true;
}

/// A word from the file, made printable and short enough for a one-line message.
std::string quoted(std::string_view word) {
  std::string s = "'";
  for (char c : word.substr(0, 40))
    s += (c >= 0x20 && c < 0x7f) ? c : '?';
  return s + (word.size() > 40 ? "...'" : "'");
}

/// The ASCII grammar, one method per production; errors name the line of the offending token.
class AsciiParser {
public:
  AsciiParser(std::string_view text, const std::string& path, ParsedMesh& out)
      : m_tokens(text), m_path(path), m_out(out), m_welder(out.mesh, text.size() / 40) {}

  void solids() {
    std::string_view t;
    while (m_tokens.next(t)) {
      if (!keyword_is(t, "solid")) fail("expected 'solid', found " + quoted(t));
      m_tokens.skip_line();
      if (!facets()) {
        m_out.warnings.push_back(m_path + ": missing 'endsolid' at the end of the file");
        return;
      }
      m_tokens.skip_line();
    }
  }

private:
  [[noreturn]] void fail(const std::string& what) const { throw Error(m_path, m_tokens.line(), what); }

  std::string_view token(const char* what) {
    std::string_view t;
    if (!m_tokens.next(t)) fail(std::string("truncated: file ends where ") + what + " was expected");
    return t;
  }
  void expect(const char* keyword) {
    const std::string_view t = token(keyword);
    if (!keyword_is(t, keyword)) fail(std::string("expected '") + keyword + "', found " + quoted(t));
  }
  float number(const char* what) {
    const std::string_view t = token("a number");
    const char* first = t.data() + (t[0] == '+');
    const char* last = t.data() + t.size();
    float v = 0;
    const auto [p, ec] = std::from_chars(first, last, v);
    if (p != last || first == last || (ec != std::errc() && ec != std::errc::result_out_of_range))
      fail(quoted(t) + " is not a number");
    if (ec == std::errc::result_out_of_range) v = std::strtof(std::string(first, last).c_str(), nullptr);
    if (const char* bad = non_finite(v)) fail(std::string(what) + " is " + bad);
    return v;
  }

  /// Reads facets up to 'endsolid' (true) or the end of the text (false).
  bool facets() {
    std::string_view t;
    while (m_tokens.next(t)) {
      if (keyword_is(t, "endsolid")) return true;
      if (!keyword_is(t, "facet")) fail("expected 'facet' or 'endsolid', found " + quoted(t));
      facet();
    }
    return false;
  }

  void facet() {
    const std::int64_t line = m_tokens.line();
    expect("normal");
    for (int k = 0; k < 3; ++k)
      number("facet normal component"); // recomputed downstream
    expect("outer");
    expect("loop");
    m_corners.clear();
    for (std::string_view t = token("'vertex'"); !keyword_is(t, "endloop"); t = token("'endloop'")) {
      if (!keyword_is(t, "vertex")) fail("expected 'vertex' or 'endloop', found " + quoted(t));
      std::array<float, 3> p;
      for (float& c : p)
        c = number("vertex coordinate");
      m_corners.push_back(m_welder.vertex(p));
    }
    if (m_corners.size() < 3) fail("facet has " + std::to_string(m_corners.size()) + " vertices (at least 3 needed)");
    expect("endfacet");
    Mesh& m = m_out.mesh;
    for (std::size_t k = 1; k + 1 < m_corners.size(); ++k) {
      m.triangles.insert(m.triangles.end(), {m_corners[0], m_corners[k], m_corners[k + 1]});
      m_out.source.face_origin.push_back(line);
    }
  }

  Tokens m_tokens;
  const std::string& m_path;
  ParsedMesh& m_out;
  Welder m_welder;
  std::vector<std::int32_t> m_corners;
};

bool starts_with_solid(std::string_view bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && is_space(bytes[i]))
    ++i;
  return keyword_is(bytes.substr(i, 5), "solid");
}

/// A NUL or control byte early on: a binary file whose header happens to start with "solid".
bool looks_binary(std::string_view bytes) {
  for (char c : bytes.substr(0, 512))
    if (static_cast<unsigned char>(c) < 0x20 && !is_space(c)) return true;
  return false;
}

} // namespace

ParsedMesh read_stl(std::string_view bytes, const std::string& path) {
  if (bytes.empty()) throw Error(path, 0, "empty file");
  const std::uint64_t declared = bytes.size() >= HEADER_BYTES ? load_u32_le(bytes.data() + 80) : 0;
  const std::uint64_t binary_size = HEADER_BYTES + FACET_BYTES * declared;
  if (bytes.size() >= HEADER_BYTES && binary_size == bytes.size()) return read_binary(bytes, path);
  // Not binary by its size: a UTF-8 byte-order mark before an ASCII file's "solid" is skipped.
  const std::string_view text = bytes.starts_with("\xEF\xBB\xBF") ? bytes.substr(3) : bytes;
  const bool solid = starts_with_solid(text);
  if (bytes.size() >= HEADER_BYTES && (!solid || looks_binary(text))) {
    // Without "solid" (or with binary bytes after it) only binary remains, and its size is wrong.
    const std::string sizes = "header declares " + std::to_string(declared) + " facets (" +
                              std::to_string(binary_size) + " bytes), file has " + std::to_string(bytes.size()) +
                              " bytes";
    if (binary_size > bytes.size()) throw Error(path, 0, "truncated binary STL (or not an STL file): " + sizes);
    throw Error(path, 0, "not an STL file: not ASCII, and as binary the sizes do not match: " + sizes);
  }
  if (!solid) throw Error(path, 1, "not an STL file (no 'solid' keyword and too short for binary)");
  ParsedMesh out;
  out.source.path = path;
  out.source.text = true;
  AsciiParser(text, path, out).solids();
  if (out.mesh.triangles.empty()) throw Error(path, 0, "no faces");
  return out;
}

std::string write_stl(const Mesh& mesh) {
  const std::size_t n = mesh.face_count();
  if (n > std::numeric_limits<std::uint32_t>::max()) throw Error("mesh", 0, "too many faces for binary STL");
  std::string out(80, '\0');
  const std::string_view title = "vfit binary STL";
  std::memcpy(out.data(), title.data(), title.size());
  append_u32_le(out, static_cast<std::uint32_t>(n));
  out.reserve(HEADER_BYTES + FACET_BYTES * n);
  for (std::size_t f = 0; f < n; ++f) {
    std::array<std::array<float, 3>, 3> p;
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k)
        p[c][k] = mesh.positions[3 * static_cast<std::size_t>(mesh.triangles[3 * f + c]) + k];
    const float e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const float e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    float normal[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const float length = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    // A degenerate facet gets the zero normal, which STL readers take as "compute it yourself".
    for (float& c : normal)
      c = length > 0 && std::isfinite(length) ? c / length : 0.0f;
    for (float c : normal)
      append_u32_le(out, std::bit_cast<std::uint32_t>(c));
    for (const auto& corner : p)
      for (float c : corner)
        append_u32_le(out, std::bit_cast<std::uint32_t>(c));
    out.append(2, '\0');
  }
  return out;
}

} // namespace vfit
