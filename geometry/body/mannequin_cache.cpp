// SPDX-License-Identifier: Apache-2.0
#include "mannequin_cache.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/version.h"

namespace vfit {
namespace {

constexpr std::string_view MAGIC = "vfit mannequin cache 1\n";

std::string key_of(const MannequinOptions& o) {
  std::ostringstream k;
  k.precision(17);
  k << "vfit " << version() << " " << git_commit() << " " << build_flavour() << "\n";
  const BodyMeasurements& m = o.measurements;
  for (const std::string_view name : BodyMeasurements::names())
    k << name << "=" << m[name] << " ";
  k << "pose=" << static_cast<int>(o.pose) << " vertices=" << o.target_vertices << "\n";
  return k.str();
}

std::uint64_t fnv1a(std::string_view s) {
  std::uint64_t h = 1469598103934665603ull;
  for (const char c : s) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

template <class T> void put(std::string& out, const std::vector<T>& v) {
  const std::uint64_t n = v.size();
  out.append(reinterpret_cast<const char*>(&n), sizeof n);
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

// Reads a vector written by put(); false when the bytes run out or the count is absurd.
template <class T> bool get(std::string_view& in, std::vector<T>& v) {
  std::uint64_t n = 0;
  if (in.size() < sizeof n) return false;
  std::memcpy(&n, in.data(), sizeof n);
  in.remove_prefix(sizeof n);
  if (n > in.size() / sizeof(T)) return false;
  v.resize(n);
  std::memcpy(v.data(), in.data(), n * sizeof(T));
  in.remove_prefix(n * sizeof(T));
  return true;
}

std::string encode(const std::string& key, const Body& b) {
  std::string out(MAGIC);
  put(out, std::vector<char>(key.begin(), key.end()));
  put(out, b.mesh.positions);
  put(out, b.mesh.triangles);
  put(out, std::vector<double>(b.joints.data(), b.joints.data() + b.joints.size()));
  put(out, b.weights.joints);
  put(out, b.weights.weights);
  return out;
}

std::optional<Body> decode(const std::string& key, std::string_view in, const MannequinOptions& o) {
  if (!in.starts_with(MAGIC)) return std::nullopt;
  in.remove_prefix(MAGIC.size());
  std::vector<char> stored_key;
  std::vector<double> joints;
  Body b;
  if (!get(in, stored_key) || std::string_view(stored_key.data(), stored_key.size()) != key) return std::nullopt;
  if (!get(in, b.mesh.positions) || !get(in, b.mesh.triangles) || !get(in, joints) || !get(in, b.weights.joints) ||
      !get(in, b.weights.weights) || !in.empty())
    return std::nullopt;
  const std::size_t nv = b.mesh.positions.size() / 3;
  if (nv != o.target_vertices || b.mesh.positions.size() % 3 != 0 || b.mesh.triangles.size() % 3 != 0 ||
      joints.size() != std::size_t(b.joints.size()) || b.weights.joints.size() != 4 * nv ||
      b.weights.weights.size() != 4 * nv)
    return std::nullopt;
  for (const std::int32_t t : b.mesh.triangles)
    if (t < 0 || std::size_t(t) >= nv) return std::nullopt;
  for (const std::int32_t j : b.weights.joints)
    if (j < 0 || j >= JOINT_COUNT) return std::nullopt;
  std::memcpy(b.joints.data(), joints.data(), joints.size() * sizeof(double));
  b.rest_pose = o.pose;
  b.source = "mannequin";
  return b;
}

} // namespace

std::optional<std::filesystem::path> mannequin_cache_dir() {
  const std::string_view commit = git_commit();
  if (commit == "unknown" || commit.ends_with("-dirty")) return std::nullopt;
  if (const char* dir = std::getenv("VFIT_CACHE_DIR")) {
    if (std::string_view(dir) == "off" || !*dir) return std::nullopt;
    return std::filesystem::path(dir);
  }
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::filesystem::path(xdg) / "vfit";
  if (const char* home = std::getenv("HOME"); home && *home) return std::filesystem::path(home) / ".cache" / "vfit";
  return std::nullopt;
}

Body cached_mannequin(const MannequinOptions& options) {
  const std::optional<std::filesystem::path> dir = mannequin_cache_dir();
  if (!dir) return make_mannequin(options);
  const std::string key = key_of(options);
  char name[40];
  std::snprintf(name, sizeof name, "mannequin-%016llx.bin", static_cast<unsigned long long>(fnv1a(key)));
  const std::filesystem::path file = *dir / name;
  {
    std::ifstream in(file, std::ios::binary);
    if (in) {
      const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (std::optional<Body> hit = decode(key, bytes, options)) return std::move(*hit);
    }
  }
  Body body = make_mannequin(options);
  try {
    std::filesystem::create_directories(*dir);
    write_file_atomically(file, encode(key, body));
  } catch (const std::exception&) {
    // A cache that cannot be written costs the next run the build again, nothing else.
  }
  return body;
}

} // namespace vfit
