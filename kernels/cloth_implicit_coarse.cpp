// SPDX-License-Identifier: Apache-2.0
// The coarse level of the implicit solve's two-level preconditioner (cloth_implicit_coarse.h).
#include "cloth_implicit_coarse.h"

#include <algorithm>
#include <cassert>

#include "cloth_implicit.h"
#include "cloth_implicit_blocks.h"
#include "parallel.h"

namespace vfit {
namespace cloth_detail {
namespace {

// Row-major 3×3 block in double.
struct Block9 {
  double m[9] = {};
};

Block9 from_sym(vfit_sym3 s) { return Block9{{s.xx, s.xy, s.xz, s.xy, s.yy, s.yz, s.xz, s.yz, s.zz}}; }

// The filter S_i of a free particle as a block: I − n·nᵀ (normals non-null), I otherwise.
Block9 filter_block(const float* normals, std::size_t i) {
  Block9 s{{1, 0, 0, 0, 1, 0, 0, 0, 1}};
  if (normals == nullptr) return s;
  const double n[3] = {normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      s.m[3 * r + c] -= n[r] * n[c];
  return s;
}

Block9 multiply(const Block9& a, const Block9& b) {
  Block9 p;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      p.m[3 * r + c] = a.m[3 * r] * b.m[c] + a.m[3 * r + 1] * b.m[3 + c] + a.m[3 * r + 2] * b.m[6 + c];
  return p;
}

void add_to(double* dst, const Block9& b, double sign) {
  for (int k = 0; k < 9; ++k)
    dst[k] += sign * b.m[k];
}

// S_e of adjacency entry e (ImplicitSystem::off_diagonal, component-major).
vfit_sym3 entry_block(const ImplicitSystem& s, std::size_t entries, std::size_t e) {
  const float* p = s.off_diagonal.data();
  return vfit_sym3{
      p[e], p[entries + e], p[2 * entries + e], p[3 * entries + e], p[4 * entries + e], p[5 * entries + e]};
}

// Relative shift of the coarse diagonal blocks (of their trace / 3): keeps the factorisation
// away from a direction the filter removed from a whole aggregate (every particle constrained
// along one normal, so Ac is singular there in exact arithmetic and its float image is
// rounding noise); P maps that direction to (almost) zero, so the shift's effect on M⁻¹ is
// negligible, and it only adds a positive term elsewhere.
constexpr double COARSE_SHIFT = 0x1p-20;

// Runs kernel(a) over the aggregates, each by one task (in order, or in parallel by fixed
// blocks of aggregates): every aggregate's sums keep their member order.
template <typename Kernel> void run_aggregates(const ImplicitCoarseSpace& c, bool parallel, const Kernel& kernel) {
  constexpr std::size_t GRAIN = 64;
  const auto body = [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b)
      for (std::size_t a = b * GRAIN; a < std::min(c.aggregates, (b + 1) * GRAIN); ++a)
        kernel(a);
  };
  const std::size_t blocks = (c.aggregates + GRAIN - 1) / GRAIN;
  if (parallel)
    parallel_for_range(blocks, 1, body);
  else
    body(0, blocks);
}

// Greedy aggregation of a graph (CSR offsets/neighbors over n nodes; self-loops ignored), in
// node order: (1) a node whose neighbours are all free starts an aggregate with them; (2) each
// node left joins the aggregate of its first aggregated neighbour from (1); (3) the rest
// (neighbours all left over) aggregate as (1). Returns the labels, count in `count`.
std::vector<std::int32_t> greedy_aggregates(const std::vector<std::int32_t>& offsets,
                                            const std::vector<std::int32_t>& neighbors, std::size_t n,
                                            std::size_t& count) {
  std::vector<std::int32_t> label(n, -1);
  std::int32_t next = 0;
  const auto start = [&](std::size_t i, bool require_free) {
    if (label[i] >= 0) return;
    if (require_free)
      for (std::int32_t e = offsets[i]; e < offsets[i + 1]; ++e)
        if (label[std::size_t(neighbors[std::size_t(e)])] >= 0) return;
    label[i] = next;
    for (std::int32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
      const auto j = std::size_t(neighbors[std::size_t(e)]);
      if (label[j] < 0) label[j] = next;
    }
    ++next;
  };
  for (std::size_t i = 0; i < n; ++i)
    start(i, true);
  std::vector<std::int32_t> joined = label;
  for (std::size_t i = 0; i < n; ++i) {
    if (label[i] >= 0) continue;
    for (std::int32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
      const std::int32_t l = label[std::size_t(neighbors[std::size_t(e)])];
      if (l >= 0) {
        joined[i] = l;
        break;
      }
    }
  }
  label = joined;
  for (std::size_t i = 0; i < n; ++i)
    start(i, false);
  count = std::size_t(next);
  return label;
}

} // namespace

std::vector<std::int32_t> coarse_aggregates(const SpringAdjacency& adj, std::size_t target, std::size_t& count) {
  const std::size_t nv = adj.particle_count();
  std::vector<std::int32_t> label = greedy_aggregates(adj.offsets, adj.neighbors, nv, count);
  // Coarsen the aggregates' graph until they reach the size asked for (or the limit's).
  for (;;) {
    const bool small = target > 0 ? double(nv) < 0.5 * double(target) * double(count) : count > COARSE_AGGREGATE_LIMIT;
    if (!small || count <= 1) break;
    std::vector<std::vector<std::int32_t>> links(count);
    for (std::size_t i = 0; i < nv; ++i)
      for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
        const std::int32_t a = label[i], b = label[std::size_t(adj.neighbors[std::size_t(e)])];
        if (a != b) links[std::size_t(a)].push_back(b);
      }
    std::vector<std::int32_t> offsets(count + 1, 0), neighbors;
    for (std::size_t a = 0; a < count; ++a) {
      std::sort(links[a].begin(), links[a].end());
      links[a].erase(std::unique(links[a].begin(), links[a].end()), links[a].end());
      neighbors.insert(neighbors.end(), links[a].begin(), links[a].end());
      offsets[a + 1] = std::int32_t(neighbors.size());
    }
    std::size_t coarser = 0;
    const std::vector<std::int32_t> merged = greedy_aggregates(offsets, neighbors, count, coarser);
    if (coarser == count) break;
    for (std::int32_t& l : label)
      l = merged[std::size_t(l)];
    count = coarser;
  }
  return label;
}

} // namespace cloth_detail

std::vector<std::int32_t> implicit_coarse_aggregates(const SpringAdjacency& adjacency,
                                                     const ImplicitSolveOptions& options, std::size_t& count) {
  return cloth_detail::coarse_aggregates(adjacency, options.aggregate_particles, count);
}

namespace cloth_detail {

bool use_two_level(const ImplicitSolveOptions& options, std::size_t particle_count, const ImplicitCoarseSpace& coarse) {
  if (particle_count == 0) return false;
  switch (options.preconditioner) {
  case ImplicitPreconditioner::BLOCK_JACOBI: return false;
  case ImplicitPreconditioner::TWO_LEVEL: return true;
  case ImplicitPreconditioner::AUTO: break;
  }
  return coarse.engaged;
}

void prepare_coarse_space(ImplicitCoarseSpace& c, const SpringAdjacency& adj, const ImplicitSolveOptions& options) {
  const std::size_t target = options.aggregate_particles;
  if (c.target == target && c.offsets_data == adj.offsets.data() && c.neighbors_data == adj.neighbors.data() &&
      c.entries == adj.neighbors.size() && c.offsets == adj.offsets)
    return;
  c.offsets = adj.offsets;
  c.offsets_data = adj.offsets.data();
  c.neighbors_data = adj.neighbors.data();
  c.entries = adj.neighbors.size();
  c.target = target;
  c.factored = false;
  const std::size_t nv = adj.particle_count();
  std::size_t na = 0;
  c.aggregate_of = coarse_aggregates(adj, target, na);
  c.aggregates = na;
  c.member_offsets.assign(na + 1, 0);
  for (std::int32_t a : c.aggregate_of)
    ++c.member_offsets[std::size_t(a) + 1];
  for (std::size_t a = 0; a < na; ++a)
    c.member_offsets[a + 1] += c.member_offsets[a];
  c.members.assign(nv, 0);
  {
    std::vector<std::int32_t> fill(c.member_offsets.begin(), c.member_offsets.end() - 1);
    for (std::size_t i = 0; i < nv; ++i)
      c.members[std::size_t(fill[std::size_t(c.aggregate_of[i])]++)] = std::int32_t(i);
  }
  c.row_offsets.assign(na + 1, 0);
  c.columns.clear();
  c.diagonal_block.assign(na, 0);
  c.entry_block.assign(adj.neighbors.size(), 0);
  std::vector<std::int32_t> cols;
  for (std::size_t a = 0; a < na; ++a) {
    cols.assign(1, std::int32_t(a));
    for (std::int32_t m = c.member_offsets[a]; m < c.member_offsets[a + 1]; ++m) {
      const auto i = std::size_t(c.members[std::size_t(m)]);
      for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e)
        cols.push_back(c.aggregate_of[std::size_t(adj.neighbors[std::size_t(e)])]);
    }
    std::sort(cols.begin(), cols.end());
    cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
    const auto base = std::int32_t(c.columns.size());
    c.columns.insert(c.columns.end(), cols.begin(), cols.end());
    c.row_offsets[a + 1] = std::int32_t(c.columns.size());
    const auto find = [&](std::int32_t b) {
      return base + std::int32_t(std::lower_bound(cols.begin(), cols.end(), b) - cols.begin());
    };
    c.diagonal_block[a] = find(std::int32_t(a));
    for (std::int32_t m = c.member_offsets[a]; m < c.member_offsets[a + 1]; ++m) {
      const auto i = std::size_t(c.members[std::size_t(m)]);
      for (std::int32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e)
        c.entry_block[std::size_t(e)] = find(c.aggregate_of[std::size_t(adj.neighbors[std::size_t(e)])]);
    }
  }
  const std::size_t nb = c.columns.size();
  c.blocks.assign(9 * nb, 0.0);
  // The lower triangle's pattern, then each block component's place in its values.
  std::vector<Eigen::Triplet<ImplicitCoarseSpace::Scalar>> triplets;
  triplets.reserve(6 * nb);
  for (std::size_t a = 0; a < na; ++a)
    for (std::int32_t k = c.row_offsets[a]; k < c.row_offsets[a + 1]; ++k)
      for (std::size_t r = 0; r < 3; ++r)
        for (std::size_t col = 0; col < 3; ++col) {
          const std::size_t row = 3 * a + r, column = 3 * std::size_t(c.columns[std::size_t(k)]) + col;
          if (row >= column) triplets.emplace_back(int(row), int(column), ImplicitCoarseSpace::Scalar(1));
        }
  c.matrix.resize(int(3 * na), int(3 * na));
  c.matrix.setFromTriplets(triplets.begin(), triplets.end());
  c.matrix.makeCompressed();
  c.value_index.assign(9 * nb, -1);
  for (std::size_t a = 0; a < na; ++a)
    for (std::int32_t k = c.row_offsets[a]; k < c.row_offsets[a + 1]; ++k)
      for (std::size_t r = 0; r < 3; ++r)
        for (std::size_t col = 0; col < 3; ++col) {
          const std::size_t row = 3 * a + r, column = 3 * std::size_t(c.columns[std::size_t(k)]) + col;
          if (row >= column)
            c.value_index[9 * std::size_t(k) + 3 * r + col] =
                std::int32_t(&c.matrix.coeffRef(int(row), int(column)) - c.matrix.valuePtr());
        }
  c.factor.analyzePattern(c.matrix);
  c.restricted.assign(3 * na, 0.0);
  c.rhs.resize(Eigen::Index(3 * na));
  c.solution.resize(Eigen::Index(3 * na));
}

bool factor_coarse_space(ImplicitCoarseSpace& c, const ImplicitSystem& s, const SpringAdjacency& adj,
                         const float* normals, bool parallel) {
  const std::size_t entries = adj.neighbors.size();
  assert(s.off_diagonal.size() == 6 * entries && "assembled with_off_diagonal");
  ImplicitCoarseSpace::Scalar* values = c.matrix.valuePtr();
  // Aggregate a's blocks: Σ_{i ∈ a, j} S_i·A_ij·S_j over free i, j (A_ii on the diagonal, −S_e
  // per entry i → j), each aggregate summed by one task in particle and entry order.
  run_aggregates(c, parallel, [&](std::size_t a) {
    {
      double* row = c.blocks.data() + 9 * std::size_t(c.row_offsets[a]);
      std::fill(row, c.blocks.data() + 9 * std::size_t(c.row_offsets[a + 1]), 0.0);
      double* diag = c.blocks.data() + 9 * std::size_t(c.diagonal_block[a]);
      for (std::int32_t m = c.member_offsets[a]; m < c.member_offsets[a + 1]; ++m) {
        const auto i = std::size_t(c.members[std::size_t(m)]);
        if (!s.free[i]) continue;
        const Block9 aii = from_sym(load_sym(s.diagonal.data(), i));
        if (normals == nullptr) {
          add_to(diag, aii, 1.0);
          for (std::int32_t k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k) {
            const auto j = std::size_t(adj.neighbors[std::size_t(k)]);
            if (!s.free[j]) continue;
            add_to(c.blocks.data() + 9 * std::size_t(c.entry_block[std::size_t(k)]),
                   from_sym(entry_block(s, entries, std::size_t(k))), -1.0);
          }
          continue;
        }
        const Block9 si = filter_block(normals, i);
        add_to(diag, multiply(si, multiply(aii, si)), 1.0);
        for (std::int32_t k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k) {
          const auto j = std::size_t(adj.neighbors[std::size_t(k)]);
          if (!s.free[j]) continue;
          add_to(c.blocks.data() + 9 * std::size_t(c.entry_block[std::size_t(k)]),
                 multiply(si, multiply(from_sym(entry_block(s, entries, std::size_t(k))), filter_block(normals, j))),
                 -1.0);
        }
      }
      const double trace = diag[0] + diag[4] + diag[8];
      if (!(trace > 0)) { // every particle pinned: an identity keeps the factor regular (Pᵀ·r = 0 there)
        std::fill(diag, diag + 9, 0.0);
        diag[0] = diag[4] = diag[8] = 1.0;
      } else {
        const double shift = COARSE_SHIFT * trace / 3;
        diag[0] += shift;
        diag[4] += shift;
        diag[8] += shift;
      }
      for (std::int32_t k = c.row_offsets[a]; k < c.row_offsets[a + 1]; ++k)
        for (std::size_t q = 0; q < 9; ++q) {
          const std::int32_t at = c.value_index[9 * std::size_t(k) + q];
          if (at >= 0) values[at] = ImplicitCoarseSpace::Scalar(c.blocks[9 * std::size_t(k) + q]);
        }
    }
  });
  c.factor.factorize(c.matrix);
  c.factored = c.factor.info() == Eigen::Success;
  return c.factored;
}

namespace {
// v −= (v·n)·n: B&W's filter I − n·nᵀ of a contact normal n (unit, or zero for none), in double.
void remove_normal_part(double (&v)[3], const float* n) {
  const double vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
  for (std::size_t k = 0; k < 3; ++k)
    v[k] -= vn * n[k];
}
} // namespace

double coarse_correct(ImplicitCoarseSpace& c, const ImplicitSystem& s, const float* normals, const float* r, float* z,
                      bool parallel) {
  run_aggregates(c, parallel, [&](std::size_t a) {
    double sum[3] = {0, 0, 0};
    for (std::int32_t m = c.member_offsets[a]; m < c.member_offsets[a + 1]; ++m) {
      const auto i = std::size_t(c.members[std::size_t(m)]);
      double ri[3] = {r[3 * i], r[3 * i + 1], r[3 * i + 2]};
      if (normals != nullptr) remove_normal_part(ri, normals + 3 * i);
      for (std::size_t k = 0; k < 3; ++k)
        sum[k] += ri[k];
    }
    for (std::size_t k = 0; k < 3; ++k)
      c.restricted[3 * a + k] = sum[k];
  });
  // y = Pᵀ·L⁻ᵀ·D⁻¹·L⁻¹·P·(Pᵀ·r) in place (factor.solve() allocates temporaries per call).
  const Eigen::Map<const Eigen::VectorXd> restricted(c.restricted.data(), Eigen::Index(c.restricted.size()));
  c.solution = c.factor.solve(restricted);
  const double dot = restricted.dot(c.solution.cast<double>());
  const ImplicitCoarseSpace::Scalar* y = c.solution.data();
  run_chunks(c.aggregate_of.size(), parallel, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      if (!s.free[i]) continue;
      const ImplicitCoarseSpace::Scalar* ya = y + 3 * std::size_t(c.aggregate_of[i]);
      double d[3] = {ya[0], ya[1], ya[2]};
      if (normals != nullptr) remove_normal_part(d, normals + 3 * i);
      for (std::size_t k = 0; k < 3; ++k)
        z[3 * i + k] += static_cast<float>(d[k]);
    }
  });
  return dot;
}

} // namespace cloth_detail
} // namespace vfit

namespace vfit {
ImplicitCoarseHolder::ImplicitCoarseHolder() = default;
ImplicitCoarseHolder::ImplicitCoarseHolder(const ImplicitCoarseHolder&) {}
ImplicitCoarseHolder& ImplicitCoarseHolder::operator=(const ImplicitCoarseHolder& other) {
  if (this != &other) m_space.reset();
  return *this;
}
ImplicitCoarseHolder::ImplicitCoarseHolder(ImplicitCoarseHolder&&) noexcept = default;
ImplicitCoarseHolder& ImplicitCoarseHolder::operator=(ImplicitCoarseHolder&&) noexcept = default;
ImplicitCoarseHolder::~ImplicitCoarseHolder() = default;
ImplicitCoarseSpace& ImplicitCoarseHolder::get() {
  if (!m_space) m_space = std::make_unique<ImplicitCoarseSpace>();
  return *m_space;
}
} // namespace vfit
