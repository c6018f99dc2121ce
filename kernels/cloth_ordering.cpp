#include "cloth_ordering.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#include <numeric>

namespace vfit {
namespace {

// Bits per axis of the Morton code: three axes in a 63-bit key.
constexpr int MORTON_BITS = 21;

// The low 21 bits of v spread to every third bit (bit b moves to bit 3·b).
std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1fffffu;
  v = (v | v << 32) & 0x1f00000000ffffu;
  v = (v | v << 16) & 0x1f0000ff0000ffu;
  v = (v | v << 8) & 0x100f00f00f00f00fu;
  v = (v | v << 4) & 0x10c30c30c30c30c3u;
  v = (v | v << 2) & 0x1249249249249249u;
  return v;
}

} // namespace

double consecutive_column_fraction(const SpringAdjacency& adjacency) {
  std::size_t columns = 0, consecutive = 0;
  for (std::size_t s = 0; s < adjacency.slice_count(); ++s) {
    columns += std::size_t(adjacency.slice_offsets[s + 1] - adjacency.slice_offsets[s]) / CLOTH_SLICE_WIDTH;
    consecutive += std::size_t(std::popcount(adjacency.slice_consecutive_columns[s]));
  }
  return columns == 0 ? 0.0 : double(consecutive) / double(columns);
}

std::vector<std::int32_t> cloth_particle_order(std::span<const float> positions, const ClothSprings& springs) {
  const std::size_t n = positions.size() / 3;
  assert(n <= std::size_t(std::numeric_limits<std::int32_t>::max()) && "particle indices are 32-bit");
  std::vector<std::int32_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  if (consecutive_column_fraction(build_spring_adjacency(springs, n)) >= CLOTH_KEEP_NUMBERING_CONSECUTIVE) return order;
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const float p = positions[3 * i + c];
      if (!std::isfinite(p)) continue;
      lo[c] = std::min(lo[c], p);
      hi[c] = std::max(hi[c], p);
    }
  // One scale for all axes (the largest extent), so the curve's cells are cubes.
  double extent = 0;
  for (int c = 0; c < 3; ++c)
    if (hi[c] > lo[c]) extent = std::max(extent, double(hi[c]) - lo[c]);
  const double cells = double((std::uint64_t{1} << MORTON_BITS) - 1);
  const double scale = extent > 0 ? cells / extent : 0.0;
  std::vector<std::uint64_t> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t k = 0;
    for (int c = 0; c < 3; ++c) {
      const float p = positions[3 * i + c];
      const double q = std::isfinite(p) ? std::clamp((double(p) - lo[c]) * scale, 0.0, cells) : 0.0;
      k |= spread_bits(static_cast<std::uint64_t>(q)) << c;
    }
    key[i] = k;
  }
  std::stable_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
    return key[static_cast<std::size_t>(a)] < key[static_cast<std::size_t>(b)];
  });
  std::vector<std::int32_t> row_length(n, 0);
  for (std::int32_t p : springs.ends) {
    assert(p >= 0 && static_cast<std::size_t>(p) < n && "spring end out of range");
    ++row_length[static_cast<std::size_t>(p)];
  }
  for (std::size_t w = 0; w < n; w += CLOTH_ORDER_WINDOW) {
    const auto first = order.begin() + std::ptrdiff_t(w);
    const auto last = order.begin() + std::ptrdiff_t(std::min(n, w + CLOTH_ORDER_WINDOW));
    std::stable_sort(first, last, [&](std::int32_t a, std::int32_t b) {
      return row_length[static_cast<std::size_t>(a)] < row_length[static_cast<std::size_t>(b)];
    });
  }
  return order;
}

std::vector<std::int32_t> inverse_permutation(std::span<const std::int32_t> order) {
  std::vector<std::int32_t> rank(order.size(), -1);
  for (std::size_t k = 0; k < order.size(); ++k) {
    assert(order[k] >= 0 && static_cast<std::size_t>(order[k]) < order.size() && rank[order[k]] < 0 &&
           "not a permutation");
    rank[static_cast<std::size_t>(order[k])] = static_cast<std::int32_t>(k);
  }
  return rank;
}

ClothSprings renumber_cloth_springs(const ClothSprings& springs, std::span<const std::int32_t> rank) {
  ClothSprings out = springs;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t a = rank[static_cast<std::size_t>(springs.ends[2 * s])];
    const std::int32_t b = rank[static_cast<std::size_t>(springs.ends[2 * s + 1])];
    out.ends[2 * s] = std::min(a, b);
    out.ends[2 * s + 1] = std::max(a, b);
  }
  return out;
}

void gather_rows(std::span<const float> in, std::span<const std::int32_t> order, std::size_t width,
                 std::vector<float>& out) {
  out.resize(width * order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t from = width * static_cast<std::size_t>(order[k]);
    assert(from + width <= in.size() && "row out of range");
    std::copy_n(in.begin() + std::ptrdiff_t(from), width, out.begin() + std::ptrdiff_t(width * k));
  }
}

} // namespace vfit
