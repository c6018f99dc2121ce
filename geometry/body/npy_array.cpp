// SPDX-License-Identifier: Apache-2.0
// The `.npy` format (NumPy's NEP 1): magic, version, a Python-literal header dict, raw data.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <optional>

#include "npz_reader.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr std::string_view NPY_MAGIC{"\x93NUMPY", 6};

/// What the header dict says.
struct NpyHeader {
  std::string descr;
  bool fortran_order = false;
  std::vector<std::size_t> shape;
};

/// Parser of the header's Python literal: {'descr': '<f8', 'fortran_order': False,
/// 'shape': (6890, 3), }. Structured dtypes (a list as descr) are refused by the caller.
class HeaderParser {
public:
  HeaderParser(std::string_view text, const std::string& where) : m_text(text), m_where(where) {}

  NpyHeader parse() {
    NpyHeader h;
    bool seen_descr = false, seen_order = false, seen_shape = false;
    expect('{');
    while (!accept('}')) {
      const std::string key = string_literal();
      expect(':');
      if (key == "descr") {
        skip_space();
        if (peek() == '[') fail("structured dtypes (record arrays) are not supported");
        h.descr = string_literal();
        seen_descr = true;
      } else if (key == "fortran_order") {
        h.fortran_order = boolean();
        seen_order = true;
      } else if (key == "shape") {
        h.shape = shape_tuple();
        seen_shape = true;
      } else {
        fail("unexpected key '" + key + "' in the .npy header");
      }
      if (!accept(',')) {
        expect('}');
        break;
      }
    }
    if (!seen_descr || !seen_order || !seen_shape) fail("the .npy header lacks 'descr', 'fortran_order' or 'shape'");
    return h;
  }

private:
  [[noreturn]] void fail(const std::string& what) const { throw Error(m_where + what); }
  void skip_space() {
    while (m_at < m_text.size() && std::isspace(static_cast<unsigned char>(m_text[m_at])))
      ++m_at;
  }
  char peek() const { return m_at < m_text.size() ? m_text[m_at] : '\0'; }
  bool accept(char c) {
    skip_space();
    if (peek() != c) return false;
    ++m_at;
    return true;
  }
  void expect(char c) {
    if (!accept(c))
      fail(std::string("malformed .npy header: expected '") + c + "' at character " + std::to_string(m_at + 1));
  }
  std::string string_literal() {
    skip_space();
    const char quote = peek();
    if (quote != '\'' && quote != '"')
      fail("malformed .npy header: expected a quoted string at character " + std::to_string(m_at + 1));
    const std::size_t end = m_text.find(quote, m_at + 1);
    if (end == std::string_view::npos) fail("malformed .npy header: unterminated string");
    std::string s(m_text.substr(m_at + 1, end - m_at - 1));
    m_at = end + 1;
    return s;
  }
  bool boolean() {
    skip_space();
    for (const auto& [word, value] :
         {std::pair{std::string_view("True"), true}, std::pair{std::string_view("False"), false}})
      if (m_text.substr(m_at, word.size()) == word) {
        m_at += word.size();
        return value;
      }
    fail("malformed .npy header: 'fortran_order' is not True or False");
  }
  std::vector<std::size_t> shape_tuple() {
    std::vector<std::size_t> shape;
    expect('(');
    while (!accept(')')) {
      skip_space();
      if (!std::isdigit(static_cast<unsigned char>(peek()))) fail("malformed .npy header: bad 'shape'");
      std::size_t n = 0;
      while (std::isdigit(static_cast<unsigned char>(peek()))) {
        const auto digit = static_cast<std::size_t>(m_text[m_at++] - '0');
        if (n > (SIZE_MAX - digit) / 10) fail("malformed .npy header: a dimension of 'shape' overflows");
        n = 10 * n + digit;
      }
      if (peek() == 'L') ++m_at; // Python 2 long literals
      shape.push_back(n);
      if (!accept(',')) {
        expect(')');
        break;
      }
    }
    return shape;
  }

  std::string_view m_text;
  std::string m_where;
  std::size_t m_at = 0;
};

template <typename T> void convert(const char* data, std::size_t count, bool swap, std::vector<double>& out) {
  out.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, data + i * sizeof(T), sizeof(T));
    if (swap) std::reverse(raw, raw + sizeof(T));
    T value;
    std::memcpy(&value, raw, sizeof(T));
    out[i] = static_cast<double>(value);
  }
}

/// Converts `count` elements of dtype (kind, size); false if the dtype is unsupported.
bool convert_values(char kind, std::size_t size, const char* data, std::size_t count, bool swap,
                    std::vector<double>& out) {
  switch (kind) {
  case 'f':
    if (size == 4) return convert<float>(data, count, swap, out), true;
    if (size == 8) return convert<double>(data, count, swap, out), true;
    return false;
  case 'i':
    if (size == 1) return convert<std::int8_t>(data, count, swap, out), true;
    if (size == 2) return convert<std::int16_t>(data, count, swap, out), true;
    if (size == 4) return convert<std::int32_t>(data, count, swap, out), true;
    if (size == 8) return convert<std::int64_t>(data, count, swap, out), true;
    return false;
  case 'u':
    if (size == 1) return convert<std::uint8_t>(data, count, swap, out), true;
    if (size == 2) return convert<std::uint16_t>(data, count, swap, out), true;
    if (size == 4) return convert<std::uint32_t>(data, count, swap, out), true;
    if (size == 8) return convert<std::uint64_t>(data, count, swap, out), true;
    return false;
  case 'b':
    if (size != 1) return false;
    out.resize(count);
    for (std::size_t i = 0; i < count; ++i)
      out[i] = data[i] != 0 ? 1.0 : 0.0;
    return true;
  default: return false;
  }
}

/// Reorders Fortran-order values (first index fastest) into C order (last index fastest).
std::vector<double> fortran_to_c_order(const std::vector<double>& f, const std::vector<std::size_t>& shape) {
  std::vector<double> c(f.size());
  if (f.empty()) return c;
  const std::size_t rank = shape.size();
  std::vector<std::size_t> c_stride(rank, 1), index(rank, 0);
  for (std::size_t k = rank - 1; k-- > 0;)
    c_stride[k] = c_stride[k + 1] * shape[k + 1];
  std::size_t c_at = 0;
  for (std::size_t f_at = 0; f_at < f.size(); ++f_at) {
    c[c_at] = f[f_at];
    // Advance the multi-index in Fortran order, keeping the C offset in step.
    for (std::size_t k = 0; k < rank; ++k) {
      c_at += c_stride[k];
      if (++index[k] < shape[k]) break;
      c_at -= shape[k] * c_stride[k];
      index[k] = 0;
    }
  }
  return c;
}

} // namespace

std::string NpyArray::shape_text() const {
  std::string s = "(";
  for (std::size_t k = 0; k < shape.size(); ++k)
    s += (k ? ", " : "") + std::to_string(shape[k]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

NpyArray parse_npy(std::string_view bytes, const std::string& source, const std::string& entry) {
  const std::string where = source + ": entry '" + entry + "': ";
  if (bytes.size() < 10 || bytes.substr(0, NPY_MAGIC.size()) != NPY_MAGIC)
    throw Error(where + "not a .npy array (bad magic)");
  const int major = static_cast<unsigned char>(bytes[6]);
  std::size_t header_size = 0, header_start = 0;
  if (major == 1) {
    header_size = static_cast<unsigned char>(bytes[8]) | static_cast<std::size_t>(static_cast<unsigned char>(bytes[9]))
                                                             << 8;
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) throw Error(where + "truncated .npy header");
    for (int i = 3; i >= 0; --i)
      header_size = (header_size << 8) | static_cast<unsigned char>(bytes[8 + i]);
    header_start = 12;
  } else {
    throw Error(where + ".npy format version " + std::to_string(major) + " is not supported");
  }
  if (header_size > bytes.size() - header_start) throw Error(where + "truncated .npy header");
  const NpyHeader header = HeaderParser(bytes.substr(header_start, header_size), where).parse();

  NpyArray array;
  array.shape = header.shape;
  array.dtype = header.descr;
  std::string_view descr = header.descr;
  char order = '=';
  if (!descr.empty() && std::string_view("<>|=").find(descr[0]) != std::string_view::npos) {
    order = descr[0];
    descr.remove_prefix(1);
  }
  std::string name = entry.ends_with(".npy") ? entry.substr(0, entry.size() - 4) : entry;
  if (descr == "O")
    throw Error(where + "array '" + name +
                "' is a pickled object array; re-save the model with numpy arrays (not chumpy/scipy objects)");
  const char kind = descr.empty() ? '?' : descr[0];
  std::size_t item_size = 0;
  for (std::size_t i = 1; i < descr.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(descr[i])) || item_size > 64) {
      item_size = 0;
      break;
    }
    item_size = 10 * item_size + static_cast<std::size_t>(descr[i] - '0');
  }

  const std::size_t available = bytes.size() - header_start - header_size;
  std::size_t count = 1;
  for (std::size_t n : array.shape) {
    if (n != 0 && count > SIZE_MAX / n) throw Error(where + "shape " + array.shape_text() + " is too large");
    count *= n;
  }
  if (item_size != 0 && count > available / item_size)
    throw Error(where + "truncated data (shape " + array.shape_text() + " needs " + std::to_string(count) + " × " +
                std::to_string(item_size) + " bytes, " + std::to_string(available) + " present)");
  const bool file_big_endian = order == '>' || (order == '=' && std::endian::native == std::endian::big);
  const bool swap = order != '|' && file_big_endian != (std::endian::native == std::endian::big);
  std::vector<double> values;
  if (item_size == 0 ||
      !convert_values(kind, item_size, bytes.data() + header_start + header_size, count, swap, values))
    throw Error(where + "array '" + name + "' has unsupported dtype '" + header.descr + "'");
  array.values =
      header.fortran_order && array.shape.size() > 1 ? fortran_to_c_order(values, array.shape) : std::move(values);
  return array;
}

} // namespace vfit
