// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Reading NumPy `.npz` archives: a zip file (entries stored or deflated, ZIP64 included) whose
/// entries are `.npy` arrays (format versions 1–3). Used to load SMPL-format body models
/// (seed 000 §3) without Python. Every malformed input throws vfit::Error naming the file and
/// the entry; nothing is ever read out of bounds.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace vfit {

/// One `.npy` array converted to double and laid out in C order (last index fastest), whatever
/// the file's byte order and `fortran_order`.
struct NpyArray {
  std::vector<std::size_t> shape; ///< dimensions; empty for a 0-d scalar (then 1 value)
  std::vector<double> values;     ///< Π shape numbers in C order; booleans are 0 / 1
  std::string dtype;              ///< the file's descr, e.g. "<f8", ">i4", "|b1"

  /// Number of values, Π shape.
  std::size_t size() const { return values.size(); }
  /// "(6890, 3)": the shape as NumPy prints it, for messages.
  std::string shape_text() const;
};

/// Parses the bytes of one `.npy` file. Supported dtypes: f4 f8, i1 i2 i4 i8, u1 u2 u4 u8, b1, in
/// either byte order. `source` (a file path) and `entry` (the member's name, "x.npy") name the
/// array in errors: "<source>: entry 'x.npy': truncated data". Object arrays ('|O', pickled) are
/// rejected with a message telling the user to re-save the model with plain numpy arrays.
NpyArray parse_npy(std::string_view bytes, const std::string& source, const std::string& entry);

/// An opened `.npz` archive: its central directory is read and checked on open (bounds,
/// compression method, encryption, duplicates); an array is decompressed, CRC-checked and
/// parsed only when asked for, so unsupported members a caller never reads do no harm.
class NpzArchive {
public:
  /// Reads and indexes the archive at `path`. Throws vfit::Error naming `path` when it can't be
  /// read or is not a well-formed zip archive.
  static NpzArchive open(const std::filesystem::path& path);
  /// The same, over bytes already in memory; `source` names them in errors.
  static NpzArchive from_bytes(std::string bytes, std::string source);

  /// The file path (or name) given on open.
  const std::string& source() const { return m_source; }
  /// Names of the `.npy` members without the ".npy" suffix, in archive order. Other members are
  /// ignored, as numpy.load's `files` does.
  std::vector<std::string> names() const;
  /// Whether a member `<name>.npy` exists.
  bool contains(std::string_view name) const;
  /// The array `<name>.npy`, decompressed and parsed. Throws vfit::Error
  /// "<source>: no array '<name>'" when absent, or naming the entry when it is malformed.
  NpyArray array(std::string_view name) const;

private:
  struct Entry {
    std::string file_name;         ///< the member's name in the archive, "x.npy"
    std::uint64_t data_offset = 0; ///< first byte of the (compressed) data
    std::uint64_t compressed_size = 0;
    std::uint64_t size = 0;   ///< uncompressed size
    std::uint16_t method = 0; ///< 0 stored, 8 deflated
    std::uint32_t crc = 0;
  };

  void index_entries();
  const Entry* find(std::string_view name) const;
  std::string entry_bytes(const Entry& entry) const;

  std::string m_bytes;
  std::string m_source;
  std::vector<Entry> m_entries;
};

/// Reads every `.npy` member of the archive at `path`, keyed by name without ".npy".
/// Throws vfit::Error naming the file and the entry at the first malformed or unsupported one.
std::map<std::string, NpyArray> read_npz(const std::filesystem::path& path);

} // namespace vfit
