#include "weld.h"

#include <array>
#include <bit>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace vfit {

namespace {

struct KeyHash {
  std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
    std::uint64_t h = 1469598103934665603ull; // FNV-1a over the three words
    for (std::uint32_t w : k) {
      h ^= w;
      h *= 1099511628211ull;
    }
    return std::size_t(h);
  }
};

std::uint32_t key_bits(float x) { return std::bit_cast<std::uint32_t>(x == 0.0f ? 0.0f : x); }

} // namespace

WeldReport weld_coincident_vertices(Mesh& mesh) {
  WeldReport report;
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<char> used(nv, 0);
  for (std::int32_t v : mesh.triangles)
    if (v >= 0 && std::size_t(v) < nv) used[std::size_t(v)] = 1;
  // Each used vertex → the first used vertex at its position.
  std::vector<std::int32_t> first(nv, -1);
  std::unordered_map<std::array<std::uint32_t, 3>, std::int32_t, KeyHash> at;
  at.reserve(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) {
      ++report.unreferenced;
      continue;
    }
    const std::array<std::uint32_t, 3> key = {key_bits(mesh.positions[3 * v]), key_bits(mesh.positions[3 * v + 1]),
                                              key_bits(mesh.positions[3 * v + 2])};
    const auto [it, inserted] = at.try_emplace(key, std::int32_t(v));
    first[v] = it->second;
    if (!inserted) ++report.welded;
  }
  if (report.welded == 0 && report.unreferenced == 0) return report;

  // New numbering: the surviving vertices in their order.
  std::vector<std::int32_t> renumber(nv, -1);
  std::vector<float> positions;
  positions.reserve(3 * (nv - report.welded - report.unreferenced));
  for (std::size_t v = 0; v < nv; ++v)
    if (first[v] == std::int32_t(v)) {
      renumber[v] = std::int32_t(positions.size() / 3);
      positions.insert(positions.end(), mesh.positions.begin() + std::ptrdiff_t(3 * v),
                       mesh.positions.begin() + std::ptrdiff_t(3 * v + 3));
    }
  std::size_t out = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    std::int32_t t[3];
    for (int k = 0; k < 3; ++k) t[k] = renumber[std::size_t(first[std::size_t(mesh.triangles[3 * f + std::size_t(k)])])];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++report.collapsed;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      mesh.triangles[3 * out + std::size_t(k)] = t[k];
      if (mesh.has_uvs()) mesh.uv_triangles[3 * out + std::size_t(k)] = mesh.uv_triangles[3 * f + std::size_t(k)];
      if (mesh.has_normals()) mesh.normal_triangles[3 * out + std::size_t(k)] = mesh.normal_triangles[3 * f + std::size_t(k)];
    }
    if (mesh.has_labels()) mesh.face_labels[out] = mesh.face_labels[f];
    ++out;
  }
  mesh.triangles.resize(3 * out);
  if (mesh.has_uvs()) mesh.uv_triangles.resize(3 * out);
  if (mesh.has_normals()) mesh.normal_triangles.resize(3 * out);
  if (mesh.has_labels()) mesh.face_labels.resize(out);
  mesh.positions = std::move(positions);
  return report;
}

} // namespace vfit
