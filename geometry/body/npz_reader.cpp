// SPDX-License-Identifier: Apache-2.0
#include "npz_reader.h"

#include <algorithm>
#include <climits>
#include <cstring>

#include <zlib.h>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr std::uint32_t LOCAL_HEADER_SIGNATURE = 0x04034b50;
constexpr std::uint32_t CENTRAL_HEADER_SIGNATURE = 0x02014b50;
constexpr std::uint32_t EOCD_SIGNATURE = 0x06054b50;
constexpr std::uint32_t ZIP64_EOCD_SIGNATURE = 0x06064b50;
constexpr std::uint32_t ZIP64_LOCATOR_SIGNATURE = 0x07064b50;
constexpr std::uint64_t EOCD_SIZE = 22;
constexpr std::uint64_t ZIP64_LOCATOR_SIZE = 20;
constexpr std::uint64_t ZIP64_EOCD_SIZE = 56;
constexpr std::uint64_t CENTRAL_HEADER_SIZE = 46;
constexpr std::uint64_t LOCAL_HEADER_SIZE = 30;
constexpr std::uint64_t MAX_COMMENT = 0xFFFF;
// Deflate cannot compress better than about 1032:1; a larger claimed size is a corrupt or
// hostile header, refused before allocating for it.
constexpr std::uint64_t MAX_DEFLATE_RATIO = 1032;

/// Bounds-checked little-endian reads over the archive; every access says what it reads so a
/// short file yields a message, never an out-of-bounds read.
class ByteView {
public:
  ByteView(std::string_view bytes, const std::string& source) : m_bytes(bytes), m_source(source) {}

  bool has(std::uint64_t offset, std::uint64_t count) const {
    return offset <= m_bytes.size() && count <= m_bytes.size() - offset;
  }
  void require(std::uint64_t offset, std::uint64_t count, const std::string& what) const {
    if (!has(offset, count)) throw Error(m_source, 0, what + " lies past the end of the file (truncated archive?)");
  }
  std::uint64_t read(std::uint64_t offset, int width) const {
    std::uint64_t v = 0;
    for (int i = width - 1; i >= 0; --i)
      v = (v << 8) | static_cast<unsigned char>(m_bytes[offset + i]);
    return v;
  }
  std::uint16_t u16(std::uint64_t offset) const { return static_cast<std::uint16_t>(read(offset, 2)); }
  std::uint32_t u32(std::uint64_t offset) const { return static_cast<std::uint32_t>(read(offset, 4)); }
  std::uint64_t u64(std::uint64_t offset) const { return read(offset, 8); }
  std::string_view slice(std::uint64_t offset, std::uint64_t count) const { return m_bytes.substr(offset, count); }
  std::uint64_t size() const { return m_bytes.size(); }

private:
  std::string_view m_bytes;
  const std::string& m_source;
};

/// Where the central directory is and how many entries it holds.
struct CentralDirectory {
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
  std::uint64_t entries = 0;
};

std::uint64_t find_eocd(const ByteView& bytes, const std::string& source) {
  if (bytes.size() >= 6 && bytes.slice(0, 6) == std::string_view("\x93NUMPY", 6))
    throw Error(source, 0, "is a single .npy array, not an .npz archive");
  if (bytes.size() >= EOCD_SIZE) {
    const std::uint64_t last = bytes.size() - EOCD_SIZE;
    const std::uint64_t first = last > MAX_COMMENT ? last - MAX_COMMENT : 0;
    for (std::uint64_t at = last + 1; at-- > first;)
      if (bytes.u32(at) == EOCD_SIGNATURE && at + EOCD_SIZE + bytes.u16(at + 20) <= bytes.size()) return at;
  }
  throw Error(source, 0, "not a zip archive, or a truncated one (no end-of-central-directory record)");
}

CentralDirectory read_central_directory_location(const ByteView& bytes, const std::string& source) {
  const std::uint64_t eocd = find_eocd(bytes, source);
  if (bytes.u16(eocd + 4) != 0 || bytes.u16(eocd + 6) != 0)
    throw Error(source, 0, "split (multi-disk) zip archives are not supported");
  CentralDirectory cd{bytes.u32(eocd + 16), bytes.u32(eocd + 12), bytes.u16(eocd + 10)};
  const bool has_locator =
      eocd >= ZIP64_LOCATOR_SIZE && bytes.u32(eocd - ZIP64_LOCATOR_SIZE) == ZIP64_LOCATOR_SIGNATURE;
  if (!has_locator) {
    if (cd.entries == 0xFFFF || cd.size == 0xFFFFFFFF || cd.offset == 0xFFFFFFFF)
      throw Error(source, 0, "ZIP64 archive without its ZIP64 end-of-central-directory locator");
    return cd;
  }
  const std::uint64_t record = bytes.u64(eocd - ZIP64_LOCATOR_SIZE + 8);
  bytes.require(record, ZIP64_EOCD_SIZE, "the ZIP64 end-of-central-directory record");
  if (bytes.u32(record) != ZIP64_EOCD_SIGNATURE)
    throw Error(source, 0, "bad ZIP64 end-of-central-directory record signature");
  if (bytes.u32(record + 16) != 0 || bytes.u32(record + 20) != 0)
    throw Error(source, 0, "split (multi-disk) zip archives are not supported");
  cd.entries = bytes.u64(record + 32);
  cd.size = bytes.u64(record + 40);
  cd.offset = bytes.u64(record + 48);
  return cd;
}

/// The ZIP64 extended-information extra field (id 1) holds, in this order, only the values
/// whose 32-bit fields are saturated.
void apply_zip64_extra(const ByteView& bytes, std::uint64_t extra, std::uint64_t extra_size, std::uint64_t& size,
                       std::uint64_t& compressed, std::uint64_t& local_offset, const std::string& where) {
  const std::uint64_t end = extra + extra_size;
  for (std::uint64_t at = extra; at + 4 <= end;) {
    const std::uint16_t id = bytes.u16(at);
    const std::uint64_t length = bytes.u16(at + 2);
    if (at + 4 + length > end) throw Error(where + "extra field runs past its header");
    if (id == 1) {
      std::uint64_t field = at + 4;
      for (std::uint64_t* value : {&size, &compressed, &local_offset}) {
        if (*value != 0xFFFFFFFF) continue;
        if (field + 8 > at + 4 + length) throw Error(where + "ZIP64 extra field is too short");
        *value = bytes.u64(field);
        field += 8;
      }
      return;
    }
    at += 4 + length;
  }
}

/// RAII owner of a zlib inflate stream.
class RawInflater {
public:
  explicit RawInflater(const std::string& where) {
    if (inflateInit2(&m_stream, -15) != Z_OK) throw Error(where + "cannot initialise zlib");
  }
  ~RawInflater() { inflateEnd(&m_stream); }
  RawInflater(const RawInflater&) = delete;
  RawInflater& operator=(const RawInflater&) = delete;
  z_stream& stream() { return m_stream; }

private:
  z_stream m_stream{};
};

std::string inflate_raw(std::string_view in, std::uint64_t size, const std::string& where) {
  std::string out(size, '\0');
  RawInflater inflater(where);
  z_stream& s = inflater.stream();
  std::uint64_t in_used = 0;
  std::uint64_t out_used = 0;
  // zlib counts in 32-bit uInt: feed both buffers in slices so archives over 4 GiB work.
  for (;;) {
    const auto in_chunk = static_cast<uInt>(std::min<std::uint64_t>(in.size() - in_used, UINT_MAX));
    const auto out_chunk = static_cast<uInt>(std::min<std::uint64_t>(size - out_used, UINT_MAX));
    s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data() + in_used));
    s.avail_in = in_chunk;
    s.next_out = reinterpret_cast<Bytef*>(out.data() + out_used);
    s.avail_out = out_chunk;
    const int status = inflate(&s, Z_NO_FLUSH);
    in_used += in_chunk - s.avail_in;
    out_used += out_chunk - s.avail_out;
    if (status == Z_STREAM_END) break;
    if (status == Z_OK && (in_chunk != s.avail_in || out_chunk != s.avail_out)) continue;
    if (status == Z_DATA_ERROR || status == Z_NEED_DICT)
      throw Error(where + "corrupt deflate data" + (s.msg ? std::string(" (") + s.msg + ")" : std::string()));
    if (out_used == size && in_used < in.size())
      throw Error(where + "inflates to more than the " + std::to_string(size) + " bytes its header states");
    throw Error(where + "truncated deflate data");
  }
  if (out_used != size)
    throw Error(where + "inflates to " + std::to_string(out_used) + " bytes, its header states " +
                std::to_string(size));
  return out;
}

} // namespace

NpzArchive NpzArchive::open(const std::filesystem::path& path) {
  return from_bytes(read_file_bytes(path), path.string());
}

NpzArchive NpzArchive::from_bytes(std::string bytes, std::string source) {
  NpzArchive archive;
  archive.m_bytes = std::move(bytes);
  archive.m_source = std::move(source);
  archive.index_entries();
  return archive;
}

void NpzArchive::index_entries() {
  const ByteView bytes(m_bytes, m_source);
  const CentralDirectory cd = read_central_directory_location(bytes, m_source);
  bytes.require(cd.offset, cd.size, "the central directory");
  const std::uint64_t cd_end = cd.offset + cd.size;
  // Each header takes at least 46 bytes: bound the count before reserving for it.
  if (cd.entries > cd.size / CENTRAL_HEADER_SIZE)
    throw Error(m_source, 0,
                "central directory claims " + std::to_string(cd.entries) + " entries in " + std::to_string(cd.size) +
                    " bytes");
  m_entries.reserve(cd.entries);
  std::uint64_t at = cd.offset;
  for (std::uint64_t i = 0; i < cd.entries; ++i) {
    const std::string header_name = "central directory entry " + std::to_string(i + 1);
    if (at + CENTRAL_HEADER_SIZE > cd_end || bytes.u32(at) != CENTRAL_HEADER_SIGNATURE)
      throw Error(m_source, 0, header_name + ": bad or truncated header");
    const std::uint16_t flags = bytes.u16(at + 8);
    Entry e;
    e.method = bytes.u16(at + 10);
    e.crc = bytes.u32(at + 16);
    e.compressed_size = bytes.u32(at + 20);
    e.size = bytes.u32(at + 24);
    const std::uint64_t name_size = bytes.u16(at + 28);
    const std::uint64_t extra_size = bytes.u16(at + 30);
    const std::uint64_t comment_size = bytes.u16(at + 32);
    std::uint64_t local = bytes.u32(at + 42);
    const std::uint64_t next = at + CENTRAL_HEADER_SIZE + name_size + extra_size + comment_size;
    if (next > cd_end) throw Error(m_source, 0, header_name + ": name or extra field runs past the central directory");
    e.file_name = std::string(bytes.slice(at + CENTRAL_HEADER_SIZE, name_size));
    const std::string where = m_source + ": entry '" + e.file_name + "': ";
    apply_zip64_extra(bytes, at + CENTRAL_HEADER_SIZE + name_size, extra_size, e.size, e.compressed_size, local, where);
    if (flags & 1u) throw Error(where + "encrypted entries are not supported");
    if (e.method != 0 && e.method != 8)
      throw Error(where + "compression method " + std::to_string(e.method) +
                  " is not supported (only stored and deflated)");
    if (e.method == 0 && e.size != e.compressed_size)
      throw Error(where + "stored entry whose sizes differ (" + std::to_string(e.compressed_size) + " vs " +
                  std::to_string(e.size) + ")");
    if (e.method == 8 && e.size / MAX_DEFLATE_RATIO > e.compressed_size + 1)
      throw Error(where + "claims an implausible uncompressed size of " + std::to_string(e.size) + " bytes");
    if (!bytes.has(local, LOCAL_HEADER_SIZE) || bytes.u32(local) != LOCAL_HEADER_SIGNATURE)
      throw Error(where + "bad or truncated local header");
    // The local header's own name and extra lengths decide where the data starts; its sizes
    // may be zero (data descriptor), so the central directory's are used.
    e.data_offset = local + LOCAL_HEADER_SIZE + bytes.u16(local + 26) + bytes.u16(local + 28);
    if (!bytes.has(e.data_offset, e.compressed_size)) throw Error(where + "truncated data");
    for (const Entry& other : m_entries)
      if (other.file_name == e.file_name) throw Error(where + "appears twice in the archive");
    m_entries.push_back(std::move(e));
    at = next;
  }
}

std::vector<std::string> NpzArchive::names() const {
  std::vector<std::string> out;
  for (const Entry& e : m_entries)
    if (e.file_name.size() > 4 && e.file_name.ends_with(".npy"))
      out.push_back(e.file_name.substr(0, e.file_name.size() - 4));
  return out;
}

const NpzArchive::Entry* NpzArchive::find(std::string_view name) const {
  const std::string file_name = std::string(name) + ".npy";
  for (const Entry& e : m_entries)
    if (e.file_name == file_name) return &e;
  return nullptr;
}

bool NpzArchive::contains(std::string_view name) const { return find(name) != nullptr; }

std::string NpzArchive::entry_bytes(const Entry& e) const {
  const std::string where = m_source + ": entry '" + e.file_name + "': ";
  const std::string_view packed = std::string_view(m_bytes).substr(e.data_offset, e.compressed_size);
  std::string data = e.method == 0 ? std::string(packed) : inflate_raw(packed, e.size, where);
  if (crc32_z(0L, reinterpret_cast<const Bytef*>(data.data()), data.size()) != e.crc)
    throw Error(where + "CRC-32 mismatch (corrupt data)");
  return data;
}

NpyArray NpzArchive::array(std::string_view name) const {
  const Entry* e = find(name);
  if (!e) throw Error(m_source, 0, "no array '" + std::string(name) + "'");
  return parse_npy(entry_bytes(*e), m_source, e->file_name);
}

std::map<std::string, NpyArray> read_npz(const std::filesystem::path& path) {
  const NpzArchive archive = NpzArchive::open(path);
  std::map<std::string, NpyArray> out;
  for (const std::string& name : archive.names())
    out.emplace(name, archive.array(name));
  return out;
}

} // namespace vfit
