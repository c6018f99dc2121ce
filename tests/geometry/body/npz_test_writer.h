// SPDX-License-Identifier: Apache-2.0
#pragma once
// Test-only writers of `.npy` arrays and `.npz` (zip) archives: stored or deflated entries, and
// optionally the ZIP64 records NumPy writes for large arrays. Independent of the reader under test.

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <zlib.h>

namespace vfit::test {

/// One array to write: values are given in the file's order (Fortran order when fortran_order).
struct NpyData {
  std::string descr = "<f8";
  std::vector<std::size_t> shape;
  std::vector<double> values;
  bool fortran_order = false;
  int version = 1;
};

/// Named arrays, in archive order.
using NpyList = std::vector<std::pair<std::string, NpyData>>;

enum class ZipMode { STORED, DEFLATED, STORED_ZIP64 };

/// Appends the low `width` (≤ 8) bytes of `value`, little-endian.
inline void put_le(std::string& out, std::uint64_t value, int width) {
  for (int i = 0; i < width; ++i)
    out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

template <typename T> void put_value(std::string& out, T v, bool big_endian) {
  char raw[sizeof(T)];
  std::memcpy(raw, &v, sizeof(T));
  if (big_endian) std::reverse(raw, raw + sizeof(T)); // the test host is little-endian
  out.append(raw, sizeof(T));
}

inline std::string npy_bytes(const NpyData& a) {
  std::string dict =
      "{'descr': '" + a.descr + "', 'fortran_order': " + (a.fortran_order ? "True" : "False") + ", 'shape': (";
  for (std::size_t k = 0; k < a.shape.size(); ++k)
    dict += (k ? ", " : "") + std::to_string(a.shape[k]);
  dict += std::string(a.shape.size() == 1 ? ",), }" : "), }");
  const std::size_t prefix = a.version == 1 ? 10 : 12;
  while ((prefix + dict.size() + 1) % 64 != 0)
    dict += ' ';
  dict += '\n';
  std::string out("\x93NUMPY", 6);
  out.push_back(static_cast<char>(a.version));
  out.push_back(0);
  put_le(out, dict.size(), a.version == 1 ? 2 : 4);
  out += dict;
  const bool big = a.descr[0] == '>';
  const std::string type = a.descr.substr(1);
  for (double v : a.values) {
    if (type == "f4")
      put_value(out, static_cast<float>(v), big);
    else if (type == "f8")
      put_value(out, v, big);
    else if (type == "i2")
      put_value(out, static_cast<std::int16_t>(v), big);
    else if (type == "i4")
      put_value(out, static_cast<std::int32_t>(v), big);
    else if (type == "i8")
      put_value(out, static_cast<std::int64_t>(v), big);
    else if (type == "u1" || type == "b1")
      put_value(out, static_cast<std::uint8_t>(v), big);
    else if (type == "u2")
      put_value(out, static_cast<std::uint16_t>(v), big);
    else if (type == "u4")
      put_value(out, static_cast<std::uint32_t>(v), big);
    // 2^64 − 1 rounds to 2^64 as a double, which does not convert back.
    else if (type == "u8")
      put_value(out, v >= 18446744073709551615.0 ? UINT64_MAX : static_cast<std::uint64_t>(v), big);
    else
      out += "\x80\x02cnumpy\n"; // '|O', '<U3', ...: some bytes, never parsed as numbers
  }
  return out;
}

inline std::string deflate_raw(const std::string& data) {
  z_stream s{};
  if (deflateInit2(&s, Z_BEST_COMPRESSION, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("deflateInit2 failed");
  std::string out(deflateBound(&s, static_cast<uLong>(data.size())), '\0');
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  s.avail_in = static_cast<uInt>(data.size());
  s.next_out = reinterpret_cast<Bytef*>(out.data());
  s.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&s, Z_FINISH);
  out.resize(s.total_out);
  deflateEnd(&s);
  if (status != Z_STREAM_END) throw std::runtime_error("deflate failed");
  return out;
}

/// A zip archive of (name, bytes) members.
inline std::string zip_bytes(const std::vector<std::pair<std::string, std::string>>& members, ZipMode mode) {
  const bool zip64 = mode == ZipMode::STORED_ZIP64;
  const std::uint16_t method = mode == ZipMode::DEFLATED ? 8 : 0;
  const std::uint64_t saturated = 0xFFFFFFFF;
  std::string out, central;
  for (const auto& [name, data] : members) {
    const std::string payload = method == 8 ? deflate_raw(data) : data;
    const std::uint32_t crc = crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size()));
    const std::uint64_t local = out.size();
    put_le(out, 0x04034b50, 4);
    put_le(out, zip64 ? 45 : 20, 2);
    put_le(out, 0, 2);
    put_le(out, method, 2);
    put_le(out, 0, 2);
    put_le(out, 0x21, 2);
    put_le(out, crc, 4);
    put_le(out, zip64 ? saturated : payload.size(), 4);
    put_le(out, zip64 ? saturated : data.size(), 4);
    put_le(out, name.size(), 2);
    put_le(out, zip64 ? 20 : 0, 2);
    out += name;
    if (zip64) {
      put_le(out, 1, 2);
      put_le(out, 16, 2);
      put_le(out, data.size(), 8);
      put_le(out, payload.size(), 8);
    }
    out += payload;

    put_le(central, 0x02014b50, 4);
    put_le(central, zip64 ? 45 : 20, 2);
    put_le(central, zip64 ? 45 : 20, 2);
    put_le(central, 0, 2);
    put_le(central, method, 2);
    put_le(central, 0, 2);
    put_le(central, 0x21, 2);
    put_le(central, crc, 4);
    put_le(central, zip64 ? saturated : payload.size(), 4);
    put_le(central, zip64 ? saturated : data.size(), 4);
    put_le(central, name.size(), 2);
    put_le(central, zip64 ? 28 : 0, 2);
    put_le(central, 0, 2); // comment length
    put_le(central, 0, 2); // disk number
    put_le(central, 0, 2); // internal attributes
    put_le(central, 0, 4); // external attributes
    put_le(central, zip64 ? saturated : local, 4);
    central += name;
    if (zip64) {
      put_le(central, 1, 2);
      put_le(central, 24, 2);
      put_le(central, data.size(), 8);
      put_le(central, payload.size(), 8);
      put_le(central, local, 8);
    }
  }
  const std::uint64_t cd_offset = out.size();
  out += central;
  if (zip64) {
    const std::uint64_t record = out.size();
    put_le(out, 0x06064b50, 4);
    put_le(out, 44, 8);
    put_le(out, 45, 2);
    put_le(out, 45, 2);
    put_le(out, 0, 8); // this disk, central directory disk
    put_le(out, members.size(), 8);
    put_le(out, members.size(), 8);
    put_le(out, central.size(), 8);
    put_le(out, cd_offset, 8);
    put_le(out, 0x07064b50, 4);
    put_le(out, 0, 4);
    put_le(out, record, 8);
    put_le(out, 1, 4);
  }
  put_le(out, 0x06054b50, 4);
  put_le(out, 0, 4);
  put_le(out, zip64 ? 0xFFFF : members.size(), 2);
  put_le(out, zip64 ? 0xFFFF : members.size(), 2);
  put_le(out, zip64 ? saturated : central.size(), 4);
  put_le(out, zip64 ? saturated : cd_offset, 4);
  put_le(out, 0, 2);
  return out;
}

/// An `.npz` archive of the arrays (members named "<name>.npy").
inline std::string npz_bytes(const NpyList& arrays, ZipMode mode) {
  std::vector<std::pair<std::string, std::string>> members;
  for (const auto& [name, a] : arrays)
    members.emplace_back(name + ".npy", npy_bytes(a));
  return zip_bytes(members, mode);
}

} // namespace vfit::test
