// SPDX-License-Identifier: Apache-2.0
#include "obj_format.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <optional>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

// Chunks of about this many bytes are parsed independently (in parallel), then stitched.
constexpr std::size_t OBJ_CHUNK_BYTES = std::size_t{1} << 20;

constexpr std::uint8_t REL_V = 1, REL_VT = 2, REL_VN = 4;
// A corner with no texture or normal index (a resolved relative index can be any negative value).
constexpr std::int64_t ABSENT = INT64_MIN;

// What one chunk of lines produced. Indices are stored as parsed: absolute (0-based) or, for
// negative OBJ indices, relative to the chunk's own element count (flag bits in `relative`),
// so chunks need no knowledge of what came before them.
struct ObjChunk {
  std::vector<float> v, vt, vn;
  std::vector<std::int64_t> cv, cvt, cvn;                  // per corner; ABSENT in cvt/cvn: no index
  std::vector<std::uint8_t> relative;                      // per corner
  std::vector<std::int32_t> poly_size;                     // corners per polygon
  std::vector<std::int64_t> poly_line;                     // 0-based line within the chunk
  std::vector<std::pair<std::size_t, std::string>> groups; // (polygon index, name)
  std::int64_t lines = 0;
  std::int64_t error_line = -1; // first error, 0-based line within the chunk
  std::string error;
  std::int64_t unknown_count = 0;
  std::int64_t unknown_line = -1;
  std::string unknown_word;
};

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

const char* skip_spaces(const char* p, const char* e) {
  while (p < e && is_space(*p))
    ++p;
  return p;
}

const char* token_end(const char* p, const char* e) {
  while (p < e && !is_space(*p))
    ++p;
  return p;
}

std::string quoted(const char* b, const char* e) {
  std::string s(b, std::min<std::size_t>(static_cast<std::size_t>(e - b), 24));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) c = '?';
  return "'" + s + "'";
}

// Parses one float token; returns an error text or empty.
std::string parse_float(const char*& p, const char* e, float& out, const char* what) {
  p = skip_spaces(p, e);
  if (p == e) return std::string("missing ") + what;
  const char* b = p;
  if (*p == '+') ++p; // from_chars rejects a leading '+', OBJ writers emit it
  auto r = std::from_chars(p, e, out);
  if (r.ec == std::errc::result_out_of_range) {
    out = INFINITY;
  } else if (r.ec != std::errc() || (r.ptr < e && !is_space(*r.ptr))) {
    return std::string("bad number ") + quoted(b, token_end(b, e)) + " for " + what;
  }
  p = r.ec == std::errc::result_out_of_range ? token_end(p, e) : r.ptr;
  if (!std::isfinite(out)) return std::string(what) + " is " + (std::isnan(out) ? "NaN" : "infinite");
  return {};
}

// Parses "a", "a/b", "a//c" or "a/b/c". Returns an error text or empty.
std::string parse_corner(const char* b, const char* e, ObjChunk& c) {
  std::int64_t idx[3] = {0, 0, 0};
  bool present[3] = {false, false, false};
  const char* p = b;
  for (int k = 0; k < 3 && p <= e; ++k) {
    const char* q = p;
    while (q < e && *q != '/')
      ++q;
    if (q > p) {
      auto r = std::from_chars(p, q, idx[k]);
      if (r.ec != std::errc() || r.ptr != q) return "bad face index " + quoted(b, e);
      if (idx[k] == 0) return "face index 0 in " + quoted(b, e) + " (OBJ indices start at 1)";
      present[k] = true;
    } else if (k == 0) {
      return "bad face index " + quoted(b, e);
    }
    if (q == e) break;
    p = q + 1;
    if (k == 2) return "bad face index " + quoted(b, e);
  }
  const std::int64_t counts[3] = {static_cast<std::int64_t>(c.v.size() / 3), static_cast<std::int64_t>(c.vt.size() / 2),
                                  static_cast<std::int64_t>(c.vn.size() / 3)};
  std::uint8_t rel = 0;
  std::int64_t out[3] = {ABSENT, ABSENT, ABSENT};
  for (int k = 0; k < 3; ++k) {
    if (!present[k]) continue;
    if (idx[k] > 0) {
      out[k] = idx[k] - 1;
    } else {
      out[k] = counts[k] + idx[k]; // may be negative: resolved against earlier chunks later
      rel |= static_cast<std::uint8_t>(1u << k);
    }
  }
  c.cv.push_back(out[0]);
  c.cvt.push_back(out[1]);
  c.cvn.push_back(out[2]);
  c.relative.push_back(rel);
  return {};
}

void parse_chunk(const char* begin, const char* end, ObjChunk& c) {
  const char* p = begin;
  while (p < end) {
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    if (!eol) eol = end;
    const char* s = skip_spaces(p, eol);
    const char* hash = static_cast<const char*>(std::memchr(s, '#', static_cast<std::size_t>(eol - s)));
    const char* le = hash ? hash : eol;
    std::string err;
    if (s < le) {
      const char* ke = token_end(s, le);
      const std::size_t klen = static_cast<std::size_t>(ke - s);
      const char* a = ke;
      if (klen == 1 && s[0] == 'v') {
        float x, y, z;
        if ((err = parse_float(a, le, x, "x coordinate")).empty() &&
            (err = parse_float(a, le, y, "y coordinate")).empty() &&
            (err = parse_float(a, le, z, "z coordinate")).empty()) {
          c.v.insert(c.v.end(), {x, y, z}); // extra tokens (w, colours) are ignored
        }
      } else if (klen == 2 && s[0] == 'v' && s[1] == 't') {
        float u, v = 0.0f;
        if ((err = parse_float(a, le, u, "u coordinate")).empty()) {
          if (skip_spaces(a, le) < le) err = parse_float(a, le, v, "v coordinate");
          if (err.empty()) c.vt.insert(c.vt.end(), {u, v});
        }
      } else if (klen == 2 && s[0] == 'v' && s[1] == 'n') {
        float x, y, z;
        if ((err = parse_float(a, le, x, "normal x")).empty() && (err = parse_float(a, le, y, "normal y")).empty() &&
            (err = parse_float(a, le, z, "normal z")).empty()) {
          c.vn.insert(c.vn.end(), {x, y, z});
        }
      } else if (klen == 1 && s[0] == 'f') {
        std::int32_t n = 0;
        for (a = skip_spaces(a, le); a < le && err.empty(); a = skip_spaces(a, le)) {
          const char* te = token_end(a, le);
          err = parse_corner(a, te, c);
          ++n;
          a = te;
        }
        if (err.empty() && n < 3) err = "face with " + std::to_string(n) + " vertices (needs at least 3)";
        if (err.empty()) { // on an error the chunk stops, so stray corners are never read
          c.poly_size.push_back(n);
          c.poly_line.push_back(c.lines);
        }
      } else if ((klen == 1 && (s[0] == 'g' || s[0] == 'o'))) {
        const char* nb = skip_spaces(a, le);
        const char* ne = le;
        while (ne > nb && is_space(ne[-1]))
          --ne;
        c.groups.emplace_back(c.poly_size.size(), nb < ne ? std::string(nb, ne) : std::string("default"));
      } else if (!(klen == 1 && (s[0] == 's' || s[0] == 'l' || s[0] == 'p')) &&
                 !(klen == 6 && (std::memcmp(s, "usemtl", 6) == 0 || std::memcmp(s, "mtllib", 6) == 0)) &&
                 !(klen == 2 && s[0] == 'v' && s[1] == 'p')) {
        if (c.unknown_count++ == 0) {
          c.unknown_line = c.lines;
          c.unknown_word = quoted(s, ke);
        }
      }
    }
    if (!err.empty()) {
      c.error_line = c.lines;
      c.error = std::move(err);
      return;
    }
    ++c.lines;
    p = eol + 1;
  }
}

std::vector<const char*> chunk_starts(std::string_view bytes) {
  std::vector<const char*> starts{bytes.data()};
  const char* end = bytes.data() + bytes.size();
  for (std::size_t at = OBJ_CHUNK_BYTES; at < bytes.size(); at += OBJ_CHUNK_BYTES) {
    const char* p = bytes.data() + at;
    if (p <= starts.back()) continue;
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    if (!nl || nl + 1 >= end) break;
    starts.push_back(nl + 1);
  }
  starts.push_back(end);
  return starts;
}

} // namespace

ParsedMesh read_obj(std::string_view bytes, const std::string& path) {
  // A UTF-8 byte-order mark (Windows editors, some exporters) would hide the first statement.
  if (bytes.starts_with("\xEF\xBB\xBF")) bytes.remove_prefix(3);
  const auto starts = chunk_starts(bytes);
  const std::size_t nchunks = starts.size() - 1;
  std::vector<ObjChunk> chunks(nchunks);
  parallel_for_range(nchunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      parse_chunk(starts[i], starts[i + 1], chunks[i]);
  });

  // Prefix sums over chunks: first line, vertices, uvs, normals, corners, polygons, triangles.
  struct Offsets {
    std::int64_t line = 0, v = 0, vt = 0, vn = 0, tri = 0;
  };
  std::vector<Offsets> off(nchunks + 1);
  for (std::size_t i = 0; i < nchunks; ++i) {
    const ObjChunk& c = chunks[i];
    if (c.error_line >= 0) throw Error(path, off[i].line + c.error_line + 1, c.error);
    std::int64_t tris = 0;
    for (std::int32_t n : c.poly_size)
      tris += n - 2;
    off[i + 1] = {off[i].line + c.lines, off[i].v + static_cast<std::int64_t>(c.v.size() / 3),
                  off[i].vt + static_cast<std::int64_t>(c.vt.size() / 2),
                  off[i].vn + static_cast<std::int64_t>(c.vn.size() / 3), off[i].tri + tris};
  }
  const Offsets total = off[nchunks];
  if (total.v == 0 && total.tri == 0) {
    std::string why = "not an OBJ mesh: no vertices and no faces";
    for (const ObjChunk& c : chunks)
      if (c.unknown_count > 0) {
        why += " (first unrecognised statement " + c.unknown_word + ")";
        break;
      }
    throw Error(path, 0, why);
  }
  if (total.tri == 0) throw Error(path, 0, "no faces (" + std::to_string(total.v) + " vertices, 0 faces)");
  if (total.v > INT32_MAX || total.tri > INT32_MAX / 3 || total.vt > INT32_MAX || total.vn > INT32_MAX)
    throw Error(path, 0, "too many elements for 32-bit indices");

  bool any_vt = false, all_vt = true, any_vn = false, all_vn = true, any_group = false;
  for (const ObjChunk& c : chunks) {
    for (std::int64_t t : c.cvt) {
      any_vt = any_vt || t != ABSENT;
      all_vt = all_vt && t != ABSENT;
    }
    for (std::int64_t n : c.cvn) {
      any_vn = any_vn || n != ABSENT;
      all_vn = all_vn && n != ABSENT;
    }
    any_group = any_group || !c.groups.empty();
  }

  ParsedMesh out;
  Mesh& m = out.mesh;
  out.source.path = path;
  out.source.text = true;
  m.positions.resize(static_cast<std::size_t>(3 * total.v));
  m.uvs.resize(static_cast<std::size_t>(2 * total.vt));
  m.normals.resize(static_cast<std::size_t>(3 * total.vn));
  m.triangles.resize(static_cast<std::size_t>(3 * total.tri));
  out.source.face_origin.resize(static_cast<std::size_t>(total.tri));
  if (any_vt) m.uv_triangles.resize(m.triangles.size());
  if (any_vn) m.normal_triangles.resize(m.triangles.size());
  // Corners without a UV or normal in a mesh that has them elsewhere point at one extra entry.
  const std::int32_t missing_vt = static_cast<std::int32_t>(total.vt);
  const std::int32_t missing_vn = static_cast<std::int32_t>(total.vn);
  if (any_vt && !all_vt) {
    m.uvs.insert(m.uvs.end(), {0.0f, 0.0f});
    out.warnings.push_back(path + ": some faces have no texture coordinates; they get (0, 0)");
  }
  if (any_vn && !all_vn) {
    m.normals.insert(m.normals.end(), {0.0f, 0.0f, 0.0f});
    out.warnings.push_back(path + ": some faces have no normals; they get a zero normal");
  }

  // Labels: one per distinct group name, in order of first appearance.
  std::vector<std::int32_t> poly_label;
  if (any_group) {
    m.face_labels.resize(static_cast<std::size_t>(total.tri));
    std::int32_t current = -1;
    for (const ObjChunk& c : chunks) {
      std::size_t gi = 0;
      for (std::size_t poly = 0; poly <= c.poly_size.size(); ++poly) {
        while (gi < c.groups.size() && c.groups[gi].first == poly) {
          const std::string& name = c.groups[gi++].second;
          auto it = std::find(m.label_names.begin(), m.label_names.end(), name);
          current = static_cast<std::int32_t>(it - m.label_names.begin());
          if (it == m.label_names.end()) m.label_names.push_back(name);
        }
        if (poly == c.poly_size.size()) break;
        if (current < 0) {
          m.label_names.push_back("default");
          current = static_cast<std::int32_t>(m.label_names.size() - 1);
        }
        poly_label.push_back(current);
      }
    }
  }

  // Stitch chunks in parallel: copy element arrays, resolve indices, fan-triangulate.
  std::vector<std::size_t> poly_offset(nchunks + 1, 0);
  for (std::size_t i = 0; i < nchunks; ++i)
    poly_offset[i + 1] = poly_offset[i] + chunks[i].poly_size.size();
  std::vector<std::string> errors(nchunks);
  std::vector<std::int64_t> error_lines(nchunks, 0);
  parallel_for_range(nchunks, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const ObjChunk& c = chunks[i];
      const Offsets& o = off[i];
      std::copy(c.v.begin(), c.v.end(), m.positions.begin() + 3 * o.v);
      std::copy(c.vt.begin(), c.vt.end(), m.uvs.begin() + 2 * o.vt);
      std::copy(c.vn.begin(), c.vn.end(), m.normals.begin() + 3 * o.vn);
      std::size_t corner = 0;
      std::int64_t tri = o.tri;
      for (std::size_t poly = 0; poly < c.poly_size.size(); ++poly) {
        const std::int32_t n = c.poly_size[poly];
        const std::int64_t line = o.line + c.poly_line[poly] + 1;
        std::int32_t iv[3], it[3], in[3];
        auto fail = [&](std::string what) {
          errors[i] = std::move(what);
          error_lines[i] = line;
          return false;
        };
        // Resolves one optional attribute index (texture or normal) of corner k.
        auto attribute = [&](std::int64_t raw, bool rel, std::int64_t offset, std::int64_t count, std::int32_t missing,
                             const char* what, std::int32_t& dst) {
          if (raw == ABSENT) {
            dst = missing;
            return true;
          }
          const std::int64_t t = raw + (rel ? offset : 0);
          if (t < 0 || t >= count)
            return fail(std::string(what) + " index " + (rel ? "(relative) " : "") + std::to_string(t + 1) +
                        " out of range (" + std::to_string(count) + " " + what + " coordinates)");
          dst = static_cast<std::int32_t>(t);
          return true;
        };
        auto resolve = [&](std::size_t k, int slot) -> bool {
          const bool rel = c.relative[k] & REL_V;
          const std::int64_t v = c.cv[k] + (rel ? o.v : 0);
          if (v < 0 || v >= total.v)
            return fail(std::string("vertex index ") + (rel ? "(relative) " : "") + std::to_string(v + 1) +
                        " out of range (" + std::to_string(total.v) + " vertices)");
          iv[slot] = static_cast<std::int32_t>(v);
          if (any_vt && !attribute(c.cvt[k], c.relative[k] & REL_VT, o.vt, total.vt, missing_vt, "texture", it[slot]))
            return false;
          if (any_vn && !attribute(c.cvn[k], c.relative[k] & REL_VN, o.vn, total.vn, missing_vn, "normal", in[slot]))
            return false;
          return true;
        };
        if (!resolve(corner, 0)) return;
        for (std::int32_t j = 1; j + 1 < n; ++j) {
          if (!resolve(corner + j, 1) || !resolve(corner + j + 1, 2)) return;
          const std::size_t t3 = static_cast<std::size_t>(3 * tri);
          std::copy(iv, iv + 3, m.triangles.begin() + t3);
          if (any_vt) std::copy(it, it + 3, m.uv_triangles.begin() + t3);
          if (any_vn) std::copy(in, in + 3, m.normal_triangles.begin() + t3);
          out.source.face_origin[tri] = line;
          if (any_group) m.face_labels[tri] = poly_label[poly_offset[i] + poly];
          ++tri;
        }
        corner += static_cast<std::size_t>(n);
      }
    }
  });
  for (std::size_t i = 0; i < nchunks; ++i)
    if (!errors[i].empty()) throw Error(path, error_lines[i], errors[i]);

  std::int64_t unknown = 0;
  for (const ObjChunk& c : chunks)
    unknown += c.unknown_count;
  if (unknown > 0) {
    for (std::size_t i = 0; i < nchunks; ++i)
      if (chunks[i].unknown_count > 0) {
        out.warnings.push_back(path + ":" + std::to_string(off[i].line + chunks[i].unknown_line + 1) + ": ignored " +
                               std::to_string(unknown) + " unrecognised statement(s), first " + chunks[i].unknown_word);
        break;
      }
  }
  if (!any_vt) m.uvs.clear();
  if (!any_vn) m.normals.clear();
  return out;
}

} // namespace vfit

namespace vfit {
namespace {

// Appends numbers to a string through a small stack buffer; to_chars gives the shortest text
// that reads back to the same float, so OBJ round trips are exact.
class TextWriter {
public:
  explicit TextWriter(std::size_t reserve) { m_out.reserve(reserve); }
  void put(std::string_view s) { m_out.append(s); }
  void put(float x) {
    char buf[32];
    auto r = std::to_chars(buf, buf + sizeof buf, x);
    m_out.append(buf, r.ptr);
  }
  void put(std::int64_t x) {
    char buf[24];
    auto r = std::to_chars(buf, buf + sizeof buf, x);
    m_out.append(buf, r.ptr);
  }
  std::string take() { return std::move(m_out); }

private:
  std::string m_out;
};

} // namespace

std::string write_obj(const Mesh& mesh) {
  TextWriter w(mesh.positions.size() * 12 + mesh.triangles.size() * 12 + 64);
  w.put("# written by vfit\n");
  auto vectors = [&](std::string_view tag, const std::vector<float>& xs, std::size_t dim) {
    for (std::size_t i = 0; i + dim <= xs.size(); i += dim) {
      w.put(tag);
      for (std::size_t k = 0; k < dim; ++k) {
        w.put(" ");
        w.put(xs[i + k]);
      }
      w.put("\n");
    }
  };
  vectors("v", mesh.positions, 3);
  if (mesh.has_uvs()) vectors("vt", mesh.uvs, 2);
  if (mesh.has_normals()) vectors("vn", mesh.normals, 3);
  std::int32_t label = -1;
  for (std::size_t f = 0; f < mesh.face_count(); ++f) {
    if (mesh.has_labels() && mesh.face_labels[f] != label) {
      label = mesh.face_labels[f];
      w.put("g ");
      w.put(static_cast<std::size_t>(label) < mesh.label_names.size() ? mesh.label_names[label] : "default");
      w.put("\n");
    }
    w.put("f");
    for (std::size_t k = 0; k < 3; ++k) {
      w.put(" ");
      w.put(static_cast<std::int64_t>(mesh.triangles[3 * f + k]) + 1);
      if (mesh.has_uvs() || mesh.has_normals()) {
        w.put("/");
        if (mesh.has_uvs()) w.put(static_cast<std::int64_t>(mesh.uv_triangles[3 * f + k]) + 1);
        if (mesh.has_normals()) {
          w.put("/");
          w.put(static_cast<std::int64_t>(mesh.normal_triangles[3 * f + k]) + 1);
        }
      }
    }
    w.put("\n");
  }
  return w.take();
}

} // namespace vfit
