// SPDX-License-Identifier: Apache-2.0
#include "off_format.h"

#include "text_words.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <vector>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using text::is_space;
using text::Words;

/// A word from the file, made printable and short enough for a one-line message.
std::string quoted(std::string_view word) {
  std::string s = "'";
  for (char c : word.substr(0, 40))
    s += (c >= 0x20 && c < 0x7f) ? c : '?';
  return s + (word.size() > 40 ? "...'" : "'");
}

/// The file's lines with `#` comments removed and blank lines skipped, numbered from 1.
class Lines {
public:
  explicit Lines(std::string_view text) : m_text(text) {}
  bool next(Words& words) {
    while (m_pos < m_text.size()) {
      const std::size_t eol = m_text.find('\n', m_pos);
      std::string_view line = m_text.substr(m_pos, eol == std::string_view::npos ? eol : eol - m_pos);
      m_pos = eol == std::string_view::npos ? m_text.size() : eol + 1;
      ++m_line;
      if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
      std::string_view probe;
      if (Words(line).next(probe)) {
        words = Words(line);
        return true;
      }
    }
    return false;
  }
  std::int64_t line() const { return m_line; }
  std::size_t bytes_left() const { return m_text.size() - m_pos; }

private:
  std::string_view m_text;
  std::size_t m_pos = 0;
  std::int64_t m_line = 0;
};

bool parse_int(std::string_view word, std::int64_t& out) {
  const char* first = word.data() + (!word.empty() && word[0] == '+');
  const char* last = word.data() + word.size();
  const auto [p, ec] = std::from_chars(first, last, out);
  return ec == std::errc() && p == last && first != last;
}

/// from_chars<float> so the shortest representation a writer chose reads back bit-identical;
/// out-of-range text becomes ±inf (or underflows) so the caller can reject it by name.
bool parse_float(std::string_view word, float& out) {
  const char* first = word.data() + (!word.empty() && word[0] == '+');
  const char* last = word.data() + word.size();
  const auto [p, ec] = std::from_chars(first, last, out);
  if (p != last || first == last) return false;
  if (ec == std::errc::result_out_of_range) out = std::strtof(std::string(first, last).c_str(), nullptr);
  return ec == std::errc() || ec == std::errc::result_out_of_range;
}

/// Reads the body after the header: one vertex or face per line, messages naming the line.
class OffReader {
public:
  OffReader(Lines& lines, const std::string& path, ParsedMesh& out) : m_lines(lines), m_path(path), m_out(out) {}

  [[noreturn]] void fail(const std::string& what) const { throw Error(m_path, m_lines.line(), m_label + what); }

  std::int64_t count(Words& words, const char* what) {
    std::string_view w;
    if (!words.next(w)) throw Error(m_path, m_lines.line(), std::string("missing ") + what + " count");
    std::int64_t n = 0;
    if (!parse_int(w, n))
      throw Error(m_path, m_lines.line(), std::string(what) + " count " + quoted(w) + " is not an integer");
    if (n < 0) throw Error(m_path, m_lines.line(), std::string("negative ") + what + " count " + quoted(w));
    return n;
  }

  /// Moves to element i (0-based) of `declared`; messages then name it "<element> <i+1>".
  void next_line(Words& words, const char* element, const char* elements, std::int64_t i, std::int64_t declared) {
    if (!m_lines.next(words))
      throw Error(m_path, m_lines.line(),
                  "truncated: header declares " + std::to_string(declared) + " " + elements + ", data ends after " +
                      std::to_string(i));
    m_label = std::string(element) + " " + std::to_string(i + 1) + ": ";
  }

  float coordinate(Words& words, const char* what) {
    std::string_view w;
    if (!words.next(w)) fail(std::string("missing ") + what);
    float v = 0;
    if (!parse_float(w, v)) fail(quoted(w) + " is not a number");
    if (std::isnan(v)) fail(std::string(what) + " is NaN");
    if (std::isinf(v)) fail(std::string(what) + " is infinite");
    return v;
  }

  void vertices(std::int64_t nv, bool with_normals) {
    Mesh& m = m_out.mesh;
    // Every vertex line holds at least "0 0 0\n": a header count cannot reserve more than that.
    const auto hint = std::min<std::size_t>(static_cast<std::size_t>(nv), m_lines.bytes_left() / 6);
    m.positions.reserve(3 * hint);
    for (std::int64_t i = 0; i < nv; ++i) {
      Words words;
      next_line(words, "vertex", "vertices", i, nv);
      for (int c = 0; c < 3; ++c)
        m.positions.push_back(coordinate(words, "coordinate"));
      for (int c = 0; with_normals && c < 3; ++c)
        m.normals.push_back(coordinate(words, "normal"));
    }
    if (nv > std::numeric_limits<std::int32_t>::max()) throw Error(m_path, 0, "too many vertices for 32-bit indices");
  }

  void faces(std::int64_t nf, std::int64_t nv) {
    Mesh& m = m_out.mesh;
    const auto hint = std::min<std::size_t>(static_cast<std::size_t>(nf), m_lines.bytes_left() / 8);
    m.triangles.reserve(3 * hint);
    m_out.source.face_origin.reserve(hint);
    std::vector<std::int32_t> corners;
    for (std::int64_t i = 0; i < nf; ++i) {
      Words words;
      next_line(words, "face", "faces", i, nf);
      std::string_view w;
      words.next(w);
      std::int64_t n = 0;
      if (!parse_int(w, n)) fail("vertex count " + quoted(w) + " is not an integer");
      if (n < 3) fail("has " + std::to_string(n) + " vertices (a face needs at least 3)");
      corners.clear();
      // Reads index by index rather than reserving n: the count is not trusted.
      for (std::int64_t k = 0; k < n; ++k) {
        if (!words.next(w)) fail("has fewer indices than its count " + std::to_string(n));
        std::int64_t index = 0;
        if (!parse_int(w, index)) fail("vertex index " + quoted(w) + " is not an integer");
        if (index < 0) fail("negative vertex index " + std::to_string(index));
        if (index >= nv)
          fail("vertex index " + std::to_string(index) + " out of range (" + std::to_string(nv) + " vertices)");
        corners.push_back(static_cast<std::int32_t>(index));
      }
      // Anything after the indices is a colour, which vfit does not use.
      for (std::size_t k = 1; k + 1 < corners.size(); ++k) {
        m.triangles.insert(m.triangles.end(), {corners[0], corners[k], corners[k + 1]});
        m_out.source.face_origin.push_back(m_lines.line());
      }
    }
  }

private:
  Lines& m_lines;
  const std::string& m_path;
  ParsedMesh& m_out;
  std::string m_label;
};

/// Parses "[ST][C][N]OFF"; returns false for anything else. `normals` says whether vertex
/// lines carry nx ny nz after the position.
bool parse_keyword(std::string_view word, bool& normals) {
  if (word.size() < 3 || word.substr(word.size() - 3) != "OFF") return false;
  std::string_view prefix = word.substr(0, word.size() - 3);
  if (prefix.starts_with("ST")) prefix.remove_prefix(2);
  if (prefix.starts_with("C")) prefix.remove_prefix(1);
  normals = prefix.starts_with("N");
  if (normals) prefix.remove_prefix(1);
  return prefix.empty();
}

} // namespace

ParsedMesh read_off(std::string_view bytes, const std::string& path) {
  if (bytes.empty()) throw Error(path, 0, "empty file");
  if (bytes.starts_with("\xEF\xBB\xBF")) bytes.remove_prefix(3);
  ParsedMesh out;
  out.source.path = path;
  out.source.text = true;
  Lines lines(bytes);
  Words words;
  if (!lines.next(words)) throw Error(path, 0, "not an OFF file (no 'OFF' header, only blank lines or comments)");
  std::string_view keyword;
  words.next(keyword);
  bool normals = false;
  if (!parse_keyword(keyword, normals)) {
    if (keyword.find("OFF") != std::string_view::npos)
      throw Error(path, lines.line(), "unsupported OFF variant " + quoted(keyword) + " (only [ST][C][N]OFF)");
    throw Error(path, lines.line(), "not an OFF file (missing 'OFF' header, found " + quoted(keyword) + ")");
  }
  OffReader reader(lines, path, out);
  // Counts may follow the keyword on the same line ("OFF 8 12 0").
  std::string_view probe;
  if (!Words(words).next(probe)) {
    if (!lines.next(words)) throw Error(path, lines.line(), "missing vertex and face counts");
  } else if (probe == "BINARY") {
    throw Error(path, lines.line(), "binary OFF is not supported");
  }
  const std::int64_t nv = reader.count(words, "vertex");
  const std::int64_t nf = reader.count(words, "face");
  reader.vertices(nv, normals);
  reader.faces(nf, nv);
  Mesh& m = out.mesh;
  if (m.triangles.empty()) throw Error(path, 0, "no faces");
  if (normals) m.normal_triangles = m.triangles;
  if (lines.next(words))
    out.warnings.push_back(path + ":" + std::to_string(lines.line()) + ": data after the last face ignored");
  return out;
}

std::string write_off(const Mesh& mesh) {
  std::string out = "OFF\n" + std::to_string(mesh.vertex_count()) + " " + std::to_string(mesh.face_count()) + " 0\n";
  out.reserve(out.size() + mesh.positions.size() * 12 + mesh.triangles.size() * 8);
  char buf[32];
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    out.append(buf, std::to_chars(buf, buf + sizeof buf, mesh.positions[i]).ptr);
    out += i % 3 == 2 ? '\n' : ' ';
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    if (i % 3 == 0) out += "3 ";
    out.append(buf, std::to_chars(buf, buf + sizeof buf, mesh.triangles[i]).ptr);
    out += i % 3 == 2 ? '\n' : ' ';
  }
  return out;
}

} // namespace vfit
