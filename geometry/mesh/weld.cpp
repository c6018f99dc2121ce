#include "weld.h"

#include <bit>
#include <cstdint>
#include <vector>

namespace vfit {

namespace {

std::uint32_t key_bits(float x) { return std::bit_cast<std::uint32_t>(x == 0.0f ? 0.0f : x); }

std::uint64_t mix(std::uint64_t h) { // splitmix64's finaliser: every key bit reaches the slot
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

} // namespace

WeldReport weld_coincident_vertices(Mesh& mesh) {
  WeldReport report;
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<char> used(nv, 0);
  for (std::int32_t v : mesh.triangles)
    if (v >= 0 && std::size_t(v) < nv) used[std::size_t(v)] = 1;
  // Each used vertex → the first used vertex at its position: open addressing (linear
  // probing) over a power-of-two table at most half full, keyed by the coordinates' bits.
  std::vector<std::int32_t> first(nv, -1);
  std::size_t slots = 16;
  while (slots < 2 * nv) slots *= 2;
  std::vector<std::int32_t> table(slots, -1);
  const float* p = mesh.positions.data();
  auto same = [&](std::size_t a, std::size_t b) {
    for (std::size_t c = 0; c < 3; ++c)
      if (key_bits(p[3 * a + c]) != key_bits(p[3 * b + c])) return false;
    return true;
  };
  for (std::size_t v = 0; v < nv; ++v) {
    if (!used[v]) {
      ++report.unreferenced;
      continue;
    }
    const std::uint64_t h = mix((std::uint64_t(key_bits(p[3 * v])) << 32 | key_bits(p[3 * v + 1])) ^
                                (std::uint64_t(key_bits(p[3 * v + 2])) * 0x9e3779b97f4a7c15ull));
    for (std::size_t slot = h & (slots - 1);; slot = (slot + 1) & (slots - 1)) {
      if (table[slot] < 0) {
        table[slot] = std::int32_t(v);
        first[v] = std::int32_t(v);
        break;
      }
      if (same(std::size_t(table[slot]), v)) {
        first[v] = table[slot];
        ++report.welded;
        break;
      }
    }
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
