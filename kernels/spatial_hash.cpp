// SPDX-License-Identifier: Apache-2.0
#include "spatial_hash.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "error.h"
#include "hole_caps.h"
#include "parallel.h"
#include "pseudo_normals.h"
#include "vertex_normals.h"

namespace vfit {
namespace {
using std::sqrt;                // the shared math headers call sqrt(float) as OpenCL C does.
#include "closest_point_math.h" // first: the two below are written against its types

#include "capped_surface.h"
#include "closest_hit_row.h"

bool is_prime(std::size_t n) {
  if (n < 2) return false;
  for (std::size_t d = 2; d * d <= n; ++d)
    if (n % d == 0) return false;
  return true;
}

std::size_t next_prime(std::size_t n) {
  while (!is_prime(n))
    ++n;
  return n;
}

struct CellBox {
  std::int32_t lo[3], hi[3];
};

struct Query {
  std::uint32_t* seen; // per capped triangle: the stamp of the last query that tested it
  std::uint32_t stamp;
  vfit_vec3 q;
  vfit_closest_point best;
  std::uint32_t best_triangle;
  vfit_closest_point best_cap; // closest cap triangle seen (side decision only)
  std::uint32_t best_cap_triangle;
};
} // namespace

// The capped mesh as ProximityIndex has it (capped_surface.h), and the table over it.
struct SpatialHash::Impl : CappedSurface {
  float cell = 1.0f, inverse_cell = 1.0f;
  CellBox bounds{}; // cells covered by the mesh (empty when lo > hi)
  // Buckets in compressed sparse rows: the (capped) triangles of bucket b are
  // entries[offsets[b] .. offsets[b+1]).
  std::vector<std::uint32_t> offsets, entries;
  std::vector<CellBox> boxes; // per capped triangle, scratch of fill()
  std::vector<float> extents; // per capped triangle: its bounding box, lo xyz then hi xyz (m)

  std::int32_t cell_of(float x) const { return static_cast<std::int32_t>(std::floor(x * inverse_cell)); }

  std::uint32_t bucket(std::int32_t i, std::int32_t j, std::int32_t k) const {
    const std::uint32_t h = (static_cast<std::uint32_t>(i) * SPATIAL_HASH_PRIMES[0]) ^
                            (static_cast<std::uint32_t>(j) * SPATIAL_HASH_PRIMES[1]) ^
                            (static_cast<std::uint32_t>(k) * SPATIAL_HASH_PRIMES[2]);
    return h % static_cast<std::uint32_t>(offsets.size() - 1);
  }

  // Refills the table from the current positions (counting sort of the entries by bucket).
  void fill() {
    const std::size_t nf = capped_face_count;
    boxes.resize(nf);
    extents.resize(6 * nf);
    std::size_t count = 0;
    bounds = CellBox{{INT32_MAX, INT32_MAX, INT32_MAX}, {INT32_MIN, INT32_MIN, INT32_MIN}};
    for (std::size_t f = 0; f < nf; ++f) {
      CellBox& b = boxes[f];
      for (int a = 0; a < 3; ++a) {
        float lo = INFINITY, hi = -INFINITY;
        for (int c = 0; c < 3; ++c) {
          const float x = positions[3 * static_cast<std::size_t>(triangles[3 * f + c]) + a];
          lo = std::min(lo, x);
          hi = std::max(hi, x);
        }
        extents[6 * f + a] = lo;
        extents[6 * f + 3 + a] = hi;
        b.lo[a] = cell_of(lo);
        b.hi[a] = cell_of(hi);
        bounds.lo[a] = std::min(bounds.lo[a], b.lo[a]);
        bounds.hi[a] = std::max(bounds.hi[a], b.hi[a]);
      }
      count +=
          std::size_t(b.hi[0] - b.lo[0] + 1) * std::size_t(b.hi[1] - b.lo[1] + 1) * std::size_t(b.hi[2] - b.lo[2] + 1);
    }
    // The table size is chosen on the first fill and kept by update() while the entries stay
    // within twice the table size (a body whose cell entries grow fourfold gets a new table).
    if (offsets.size() < 2 || count > 2 * (offsets.size() - 1)) offsets.assign(next_prime(2 * count + 1) + 1, 0);
    std::fill(offsets.begin(), offsets.end(), 0u);
    const auto each_entry = [&](auto&& visit) {
      for (std::size_t f = 0; f < nf; ++f) {
        const CellBox& b = boxes[f];
        for (std::int32_t i = b.lo[0]; i <= b.hi[0]; ++i)
          for (std::int32_t j = b.lo[1]; j <= b.hi[1]; ++j)
            for (std::int32_t k = b.lo[2]; k <= b.hi[2]; ++k)
              visit(bucket(i, j, k), static_cast<std::uint32_t>(f));
      }
    };
    each_entry([&](std::uint32_t b, std::uint32_t) { ++offsets[b + 1]; });
    for (std::size_t b = 1; b < offsets.size(); ++b)
      offsets[b] += offsets[b - 1];
    entries.resize(count);
    // Entries of a bucket in ascending triangle order; `offsets[b]` walks as the cursor, then is
    // shifted back.
    each_entry([&](std::uint32_t b, std::uint32_t f) { entries[offsets[b]++] = f; });
    for (std::size_t b = offsets.size() - 1; b > 0; --b)
      offsets[b] = offsets[b - 1];
    offsets[0] = 0;
  }

  void visit_cell(Query& s, std::int32_t i, std::int32_t j, std::int32_t k) const {
    // A cell whose box is farther than the best hit cannot hold a better one.
    const float box_lo[3] = {float(i) * cell, float(j) * cell, float(k) * cell};
    const float q[3] = {s.q.x, s.q.y, s.q.z};
    float d2 = 0.0f;
    for (int a = 0; a < 3; ++a) {
      const float below = box_lo[a] - q[a], above = q[a] - (box_lo[a] + cell);
      const float d = std::max(0.0f, std::max(below, above));
      d2 += d * d;
    }
    if (d2 > s.best.distance2) return;
    const std::uint32_t b = bucket(i, j, k);
    for (std::uint32_t e = offsets[b]; e < offsets[b + 1]; ++e) {
      const std::uint32_t f = entries[e];
      // A triangle spans several cells and a bucket holds other cells' triangles too (hash
      // collisions): each is tested once per query, and only if its box is within reach. Its
      // box only gets farther relative to the shrinking best, so skipping it for good is safe.
      if (s.seen[f] == s.stamp) continue;
      s.seen[f] = s.stamp;
      const float* box = extents.data() + 6 * static_cast<std::size_t>(f);
      float b2 = 0.0f;
      for (int a = 0; a < 3; ++a) {
        const float d = std::max(0.0f, std::max(box[a] - q[a], q[a] - box[3 + a]));
        b2 += d * d;
      }
      if (b2 > s.best.distance2) continue;
      const vfit_closest_point c = closest_on(s.q, f);
      if (f >= face_count) {
        if (c.distance2 < s.best_cap.distance2) {
          s.best_cap = c;
          s.best_cap_triangle = f;
        }
        continue;
      }
      if (!improves(c.distance2, f, s.best.distance2, s.best_triangle)) continue;
      s.best = c;
      s.best_triangle = f;
    }
  }

  // Visits shells of cells at Chebyshev radius r = 0, 1, 2, … around the query's cell. After
  // shell r every triangle overlapping the cube of cells within r has been seen; any other lies
  // outside the cube, at least `reach` (the distance from the query to the cube's faces) away.
  void search(Query& s, float max_distance) const {
    const std::int32_t c[3] = {cell_of(s.q.x), cell_of(s.q.y), cell_of(s.q.z)};
    const float q[3] = {s.q.x, s.q.y, s.q.z};
    for (std::int32_t r = 0;; ++r) {
      const std::int32_t lo[3] = {std::max(c[0] - r, bounds.lo[0]), std::max(c[1] - r, bounds.lo[1]),
                                  std::max(c[2] - r, bounds.lo[2])};
      const std::int32_t hi[3] = {std::min(c[0] + r, bounds.hi[0]), std::min(c[1] + r, bounds.hi[1]),
                                  std::min(c[2] + r, bounds.hi[2])};
      for (std::int32_t i = lo[0]; i <= hi[0]; ++i)
        for (std::int32_t j = lo[1]; j <= hi[1]; ++j) {
          const bool side = i == c[0] - r || i == c[0] + r || j == c[1] - r || j == c[1] + r;
          if (side) {
            for (std::int32_t k = lo[2]; k <= hi[2]; ++k)
              visit_cell(s, i, j, k);
          } else {
            if (c[2] - r >= lo[2]) visit_cell(s, i, j, c[2] - r);
            if (r > 0 && c[2] + r <= hi[2]) visit_cell(s, i, j, c[2] + r);
          }
        }
      float reach = INFINITY;
      for (int a = 0; a < 3; ++a)
        reach = std::min({reach, q[a] - float(c[a] - r) * cell, float(c[a] + r + 1) * cell - q[a]});
      if (s.best.distance2 < reach * reach || reach >= max_distance) return;
      // The cube covers every cell of the mesh: nothing is left to see.
      if (c[0] - r <= bounds.lo[0] && c[1] - r <= bounds.lo[1] && c[2] - r <= bounds.lo[2] &&
          c[0] + r >= bounds.hi[0] && c[1] + r >= bounds.hi[1] && c[2] + r >= bounds.hi[2])
        return;
    }
  }

  // The row of query i: ProximityIndex's write_hit, the side decided by the closest feature's
  // pseudo-normal on the capped mesh (a cap strictly closer than the mesh decides instead).
  void write_hit(const Query& s, std::size_t i, ClosestHits& hits) const {
    write_closest_hit(
        s.q, s.best, s.best_triangle, s.best_cap, s.best_cap_triangle,
        [&](std::uint32_t t, int feature) { return feature_normal(t, feature); }, i, hits);
  }

  void query_range(std::span<const float> queries, float max_distance, ClosestHits& hits, std::size_t begin,
                   std::size_t end) const {
    std::vector<std::uint32_t> seen(capped_face_count, 0);
    for (std::size_t i = begin; i < end; ++i) {
      const auto stamp = static_cast<std::uint32_t>(i - begin + 1);
      Query s{};
      s.seen = seen.data();
      s.stamp = stamp;
      s.q = vfit_vec3{queries[3 * i], queries[3 * i + 1], queries[3 * i + 2]};
      s.best_triangle = NO_TRIANGLE;
      s.best_cap_triangle = NO_TRIANGLE;
      s.best.distance2 = max_distance * max_distance;
      s.best_cap.distance2 = s.best.distance2;
      if (face_count > 0) search(s, max_distance);
      write_hit(s, i, hits);
    }
  }
};

SpatialHash::SpatialHash(std::span<const float> positions, std::span<const std::int32_t> triangles, float cell_size,
                         OpenMeshSide open_side)
    : m_impl(std::make_unique<Impl>()) {
  if (positions.size() % 3 != 0 || triangles.size() % 3 != 0)
    throw Error("spatial hash mesh", 0, "positions and triangles must be rows of 3");
  if (!(cell_size >= 0.0f) || !std::isfinite(cell_size))
    throw Error("spatial hash mesh", 0, "cell_size must be finite and ≥ 0, got " + std::to_string(cell_size));
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (!std::isfinite(positions[i]))
      throw Error("spatial hash mesh", 0, "vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  Impl& m = *m_impl;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= positions.size() / 3)
      throw Error("spatial hash mesh", 0,
                  "triangle " + std::to_string(i / 3) + " has vertex index " + std::to_string(triangles[i]) +
                      " outside [0, " + std::to_string(positions.size() / 3) + ")");
  assert(triangles.size() / 3 < NO_TRIANGLE / 2 && "mesh too large for 32-bit indices");
  m.build(positions, triangles, open_side, 0);

  if (cell_size == 0.0f) {
    // Mean length over the triangles' edges (interior edges counted twice, as Teschner's
    // average over the primitives).
    double total = 0;
    for (std::size_t f = 0; f < m.face_count; ++f)
      for (int k = 0; k < 3; ++k) {
        const vfit_vec3 d = vfit_v3_sub(load(positions.data(), triangles[3 * f + k]),
                                        load(positions.data(), triangles[3 * f + (k + 1) % 3]));
        total += std::sqrt(double(vfit_v3_dot(d, d)));
      }
    cell_size = m.face_count > 0 ? static_cast<float>(total / double(3 * m.face_count)) : 0.0f;
    if (!(cell_size > 0.0f)) cell_size = 1.0f;
  }
  m.cell = cell_size;
  m.inverse_cell = 1.0f / cell_size;
  m.fill();
}

SpatialHash::~SpatialHash() = default;
SpatialHash::SpatialHash(SpatialHash&&) noexcept = default;
SpatialHash& SpatialHash::operator=(SpatialHash&&) noexcept = default;

void SpatialHash::update(std::span<const float> positions) {
  Impl& m = *m_impl;
  if (positions.size() != 3 * m.vertex_count)
    throw Error("spatial hash update", 0,
                "expected " + std::to_string(m.vertex_count) + " × 3 coordinates, got " +
                    std::to_string(positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (!std::isfinite(positions[i]))
      throw Error("spatial hash update", 0, "vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  std::copy(positions.begin(), positions.end(), m.positions.begin());
  m.update_normals();
  m.fill();
}

void SpatialHash::closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) const {
  check_proximity_queries(queries, max_distance);
  const std::size_t count = queries.size() / 3;
  hits.resize(count);
  parallel_for_range(count, SPATIAL_HASH_QUERY_GRAIN,
                     [&](std::size_t b, std::size_t e) { m_impl->query_range(queries, max_distance, hits, b, e); });
}

void SpatialHash::closest_points_serial(std::span<const float> queries, float max_distance, ClosestHits& hits) const {
  check_proximity_queries(queries, max_distance);
  hits.resize(queries.size() / 3);
  m_impl->query_range(queries, max_distance, hits, 0, queries.size() / 3);
}

float SpatialHash::cell_size() const { return m_impl->cell; }
std::size_t SpatialHash::table_size() const { return m_impl->offsets.size() - 1; }
std::size_t SpatialHash::entry_count() const { return m_impl->entries.size(); }
std::size_t SpatialHash::vertex_count() const { return m_impl->vertex_count; }
std::size_t SpatialHash::face_count() const { return m_impl->face_count; }

} // namespace vfit
