// SPDX-License-Identifier: Apache-2.0
#include "thick_shell.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include <Eigen/Geometry>

#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/proximity.h"
#include "vfit/kernels/ray_caster.h"

namespace vfit {
namespace {

using Vec = Eigen::Vector3d;

Vec point(std::span<const float> p, std::int32_t v) {
  const auto i = 3 * static_cast<std::size_t>(v);
  return {p[i], p[i + 1], p[i + 2]};
}

// Unit normal (zero when degenerate), centroid and area of triangle f.
struct Face {
  Vec normal = Vec::Zero(), centroid = Vec::Zero();
  double area = 0;
};

Face face_of(std::span<const float> p, std::span<const std::int32_t> t, std::size_t f) {
  const Vec a = point(p, t[3 * f]), b = point(p, t[3 * f + 1]), c = point(p, t[3 * f + 2]);
  const Vec n = (b - a).cross(c - a);
  Face out;
  out.area = 0.5 * n.norm();
  if (out.area > 0) out.normal = n.normalized();
  out.centroid = (a + b + c) / 3.0;
  return out;
}

// Frame of a triangle: edge 0's direction, normal × it, unit normal; false when degenerate.
bool frame_of(const Vec& a, const Vec& b, const Vec& c, Eigen::Matrix3d& frame) {
  const Vec n = (b - a).cross(c - a);
  const double e = (b - a).norm(), len = n.norm();
  if (!(e > 0) || !(len > 1e-12 * e * e)) return false;
  frame.col(0) = (b - a) / e;
  frame.col(2) = n / len;
  frame.col(1) = frame.col(2).cross(frame.col(0));
  return true;
}

// Connected pieces of the faces flagged in `keep`, joined across shared edges: per face its
// piece (−1 when not kept); returns the number of pieces.
int face_pieces(std::span<const std::int32_t> triangles, const std::vector<char>& keep, std::vector<int>& piece) {
  const std::size_t nf = triangles.size() / 3;
  std::unordered_map<std::uint64_t, std::int32_t> first; // edge → first kept face seen on it
  std::vector<std::int32_t> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](std::int32_t f) {
    while (parent[std::size_t(f)] != f)
      f = parent[std::size_t(f)] = parent[std::size_t(parent[std::size_t(f)])];
    return f;
  };
  for (std::size_t f = 0; f < nf; ++f) {
    if (!keep[f]) continue;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t a = std::uint32_t(triangles[3 * f + std::size_t(k)]),
                    b = std::uint32_t(triangles[3 * f + std::size_t((k + 1) % 3)]);
      if (a > b) std::swap(a, b);
      const auto [it, fresh] = first.emplace((std::uint64_t(a) << 32) | b, std::int32_t(f));
      if (!fresh) parent[std::size_t(root(std::int32_t(f)))] = root(it->second);
    }
  }
  piece.assign(nf, -1);
  std::unordered_map<std::int32_t, int> ids;
  for (std::size_t f = 0; f < nf; ++f)
    if (keep[f]) piece[f] = ids.emplace(root(std::int32_t(f)), int(ids.size())).first->second;
  return int(ids.size());
}

// Whether a vertex of the piece labelled `piece` (vertex_piece_labels()) has an open fan (a neighbour met by one of
// its triangles only): the piece has a boundary. Vertex → triangle lists (counting sort), then
// each vertex's neighbours sorted and counted.
bool has_open_fan(std::span<const std::int32_t> t, std::size_t nv, std::int32_t piece,
                  const std::vector<std::int32_t>& piece_of) {
  const std::size_t nf = t.size() / 3;
  std::vector<std::int32_t> offsets(nv + 1, 0), corners(t.size());
  for (const std::int32_t v : t)
    ++offsets[std::size_t(v) + 1];
  for (std::size_t v = 0; v < nv; ++v)
    offsets[v + 1] += offsets[v];
  std::vector<std::int32_t> fill(offsets.begin(), offsets.end() - 1);
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      corners[std::size_t(fill[std::size_t(t[3 * f + std::size_t(k)])]++)] = std::int32_t(3 * f) + k;
  std::vector<std::int32_t> around;
  for (std::size_t v = 0; v < nv; ++v) {
    if (offsets[v] == offsets[v + 1] || piece_of[v] != piece) continue;
    around.clear();
    for (auto c = offsets[v]; c < offsets[v + 1]; ++c) {
      const auto corner = std::size_t(corners[std::size_t(c)]), base = corner - corner % 3;
      around.push_back(t[base + (corner % 3 + 1) % 3]);
      around.push_back(t[base + (corner % 3 + 2) % 3]);
    }
    std::sort(around.begin(), around.end());
    for (std::size_t i = 0; i < around.size();) {
      std::size_t j = i;
      while (j < around.size() && around[j] == around[i])
        ++j;
      if (j - i == 1) return true;
      i = j;
    }
  }
  return false;
}

} // namespace

std::optional<ThickShell> find_thick_shell(const Mesh& garment, const ThickShellOptions& options) {
  const std::size_t nf = garment.face_count(), nv = garment.vertex_count();
  if (nf < 8) return std::nullopt;
  const std::span<const float> p = garment.positions;
  const std::span<const std::int32_t> t = garment.triangles;
  std::vector<Face> faces(nf);
  double total_area = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    faces[f] = face_of(p, t, f);
    total_area += faces[f].area;
  }
  if (!(total_area > 0)) return std::nullopt;

  // The mesh's connected pieces (by shared vertices): faces facing the same way can only be each
  // other's partners across two pieces (a lining wound like its shell). Within one closed shell
  // the sheets face opposite ways, and faces facing the same way are neighbours along a rim.
  const std::vector<std::int32_t> piece_of = vertex_piece_labels(t, nv);
  auto root = [&](std::int32_t v) { return piece_of[std::size_t(v)]; };
  // The usual garment, one sheet, is told apart before any ray is cast (at 10^6 vertices the
  // rays cost seconds): one dominant piece with an opening cannot be two sheets stitched into a
  // closed surface, and without a second piece of at least a fifth of the faces there is no
  // lining.
  {
    std::unordered_map<std::int32_t, std::size_t> faces_of_piece;
    for (std::size_t f = 0; f < nf; ++f)
      ++faces_of_piece[root(t[3 * f])];
    std::vector<std::pair<std::size_t, std::int32_t>> sizes;
    for (const auto& [r, count] : faces_of_piece)
      sizes.emplace_back(count, r);
    std::sort(sizes.rbegin(), sizes.rend());
    const bool lined = sizes.size() >= 2 && double(sizes[1].first) >= 0.2 * double(nf);
    if (!lined && has_open_fan(t, nv, sizes[0].second, piece_of)) return std::nullopt;
  }
  // Each face's partner: the first face met along its normal, either way, within the thickness
  // limit, if parallel. Two rays per face; the nearer valid hit wins.
  std::vector<float> origins(6 * nf), directions(6 * nf);
  for (std::size_t f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      origins[6 * f + std::size_t(c)] = origins[6 * f + 3 + std::size_t(c)] = float(faces[f].centroid[c]);
      directions[6 * f + std::size_t(c)] = float(faces[f].normal[c]);
      directions[6 * f + 3 + std::size_t(c)] = float(-faces[f].normal[c]);
    }
  const RayCastMesh scene_mesh{p, t};
  const RayCaster caster(std::span<const RayCastMesh>(&scene_mesh, 1));
  RayHits hits;
  // t_near: past the face itself (float rounding of the centroid is ~1e-7 m).
  caster.intersect(origins, directions, 1e-5f, float(options.max_thickness), hits);
  std::vector<std::int32_t> partner(nf, -1);
  std::vector<double> gap(nf, INFINITY);
  double paired_area = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    if (!(faces[f].area > 0)) continue;
    for (std::size_t r = 2 * f; r < 2 * f + 2; ++r) {
      const std::int32_t g = hits.triangles[r];
      if (g < 0 || std::size_t(g) == f || !(double(hits.distances[r]) < gap[f])) continue;
      const double cos = faces[f].normal.dot(faces[std::size_t(g)].normal);
      const bool apart = root(t[3 * f]) != root(t[3 * std::size_t(g)]);
      if (!(cos <= -options.min_parallel_cos || (apart && cos >= options.min_parallel_cos))) continue;
      partner[f] = g;
      gap[f] = hits.distances[r];
    }
    if (partner[f] >= 0) paired_area += faces[f].area;
  }
  if (paired_area < options.min_paired_area * total_area) return std::nullopt;

  // The two sheets: the paired faces fall into two pieces once the rims are left out.
  std::vector<char> keep(nf, 0);
  for (std::size_t f = 0; f < nf; ++f)
    keep[f] = partner[f] >= 0;
  std::vector<int> piece;
  const int pieces = face_pieces(t, keep, piece);
  if (pieces < 2) return std::nullopt;
  std::vector<double> piece_area(std::size_t(pieces), 0.0);
  for (std::size_t f = 0; f < nf; ++f)
    if (piece[f] >= 0) piece_area[std::size_t(piece[f])] += faces[f].area;
  std::vector<int> by_area(static_cast<std::size_t>(pieces));
  std::iota(by_area.begin(), by_area.end(), 0);
  std::sort(by_area.begin(), by_area.end(),
            [&](int a, int b) { return piece_area[std::size_t(a)] > piece_area[std::size_t(b)]; });
  const int big = by_area[0], second = by_area[1];
  if (piece_area[std::size_t(big)] + piece_area[std::size_t(second)] < options.min_paired_area * total_area)
    return std::nullopt;
  // Each sheet's faces are paired with the other sheet's (not with faces of their own sheet, as
  // two sides of a flat-pressed tube would be, which no garment is).
  double across = 0, within = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    if (piece[f] != big && piece[f] != second) continue;
    const int q = piece[std::size_t(partner[f])];
    (q != piece[f] && (q == big || q == second) ? across : within) += faces[f].area;
  }
  if (across < 0.9 * (across + within)) return std::nullopt;
  // An offset sheet or a lining has about the other's area (a few per cent apart); a jacket over
  // part of a shirt does not.
  if (piece_area[std::size_t(second)] < 0.8 * piece_area[std::size_t(big)]) return std::nullopt;
  const int inner = second; // the smaller of the two: the sheet against the body

  ThickShell shell;
  shell.whole_vertex_count = nv;
  std::vector<double> gaps;
  for (std::size_t f = 0; f < nf; ++f)
    if (piece[f] == big || piece[f] == second) gaps.push_back(gap[f]);
  std::nth_element(gaps.begin(), gaps.begin() + std::ptrdiff_t(gaps.size() / 2), gaps.end());
  shell.thickness = gaps[gaps.size() / 2];
  std::vector<std::int32_t> local(nv, -1);
  for (std::size_t f = 0; f < nf; ++f) {
    if (piece[f] != inner) continue;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t v = t[3 * f + std::size_t(k)];
      if (local[std::size_t(v)] < 0) {
        local[std::size_t(v)] = std::int32_t(shell.sheet_vertices.size());
        shell.sheet_vertices.push_back(v);
        const Vec x = point(p, v);
        shell.sheet.positions.insert(shell.sheet.positions.end(), {float(x.x()), float(x.y()), float(x.z())});
      }
      shell.sheet.triangles.push_back(local[std::size_t(v)]);
    }
  }
  std::vector<float> queries;
  for (std::size_t v = 0; v < nv; ++v)
    if (local[v] < 0) {
      shell.carried.push_back(std::int32_t(v));
      const Vec x = point(p, std::int32_t(v));
      queries.insert(queries.end(), {float(x.x()), float(x.y()), float(x.z())});
    }
  const ProximityIndex sheet_index(shell.sheet.positions, shell.sheet.triangles, OpenMeshSide::ONE_SIDED);
  ClosestHits closest;
  sheet_index.closest_points(queries, INFINITY, closest);
  const std::size_t nc = shell.carried.size();
  shell.carried_triangle.resize(nc);
  shell.carried_barycentric.resize(2 * nc);
  shell.carried_offset.resize(3 * nc);
  shell.carried_world_offset.resize(3 * nc);
  const std::span<const float> sp = shell.sheet.positions;
  const std::span<const std::int32_t> st = shell.sheet.triangles;
  for (std::size_t k = 0; k < nc; ++k) {
    const std::int32_t tri = closest.triangles[k];
    if (tri < 0) return std::nullopt; // an empty sheet: no shell after all
    shell.carried_triangle[k] = tri;
    shell.carried_barycentric[2 * k] = closest.barycentrics[2 * k];
    shell.carried_barycentric[2 * k + 1] = closest.barycentrics[2 * k + 1];
    const Vec at(closest.points[3 * k], closest.points[3 * k + 1], closest.points[3 * k + 2]);
    const Vec offset = point(queries, std::int32_t(k)) - at;
    Eigen::Matrix3d frame;
    const auto f = 3 * std::size_t(tri);
    // A triangle degenerate as found has no frame: NaN marks the offset to be taken in the
    // mesh's axes.
    const Vec local_offset = frame_of(point(sp, st[f]), point(sp, st[f + 1]), point(sp, st[f + 2]), frame)
                                 ? Vec(frame.transpose() * offset)
                                 : Vec::Constant(NAN);
    for (int c = 0; c < 3; ++c) {
      shell.carried_offset[3 * k + std::size_t(c)] = float(local_offset[c]);
      shell.carried_world_offset[3 * k + std::size_t(c)] = float(offset[c]);
    }
  }
  return shell;
}

std::vector<float> place_thick_shell(const ThickShell& shell, std::span<const float> sheet_positions) {
  std::vector<float> out(3 * shell.whole_vertex_count, 0.0f);
  for (std::size_t k = 0; k < shell.sheet_vertices.size(); ++k)
    for (int c = 0; c < 3; ++c)
      out[3 * std::size_t(shell.sheet_vertices[k]) + std::size_t(c)] = sheet_positions[3 * k + std::size_t(c)];
  const std::span<const std::int32_t> st = shell.sheet.triangles;
  for (std::size_t k = 0; k < shell.carried.size(); ++k) {
    const auto f = 3 * std::size_t(shell.carried_triangle[k]);
    const Vec a = point(sheet_positions, st[f]), b = point(sheet_positions, st[f + 1]),
              c = point(sheet_positions, st[f + 2]);
    const double u = shell.carried_barycentric[2 * k], v = shell.carried_barycentric[2 * k + 1];
    const Vec at = (1 - u - v) * a + u * b + v * c;
    Eigen::Matrix3d frame;
    const Vec local = point(shell.carried_offset, std::int32_t(k));
    const Vec offset = !std::isnan(local.x()) && frame_of(a, b, c, frame)
                           ? Vec(frame * local)
                           : point(shell.carried_world_offset, std::int32_t(k));
    const Vec x = at + offset;
    for (int d = 0; d < 3; ++d)
      out[3 * std::size_t(shell.carried[k]) + std::size_t(d)] = float(x[d]);
  }
  return out;
}

} // namespace vfit
