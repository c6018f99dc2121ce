// SPDX-License-Identifier: Apache-2.0
#include "skeleton_parts.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include <Eigen/Geometry>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t LIMBS_PER_TASK = 1;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

class DisjointSets {
public:
  explicit DisjointSets(std::size_t n) : m_parent(n) { std::iota(m_parent.begin(), m_parent.end(), 0); }
  std::int32_t find(std::int32_t x) {
    while (m_parent[std::size_t(x)] != x) {
      m_parent[std::size_t(x)] = m_parent[std::size_t(m_parent[std::size_t(x)])];
      x = m_parent[std::size_t(x)];
    }
    return x;
  }
  void unite(std::int32_t a, std::int32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) m_parent[std::size_t(std::max(a, b))] = std::min(a, b);
  }

private:
  std::vector<std::int32_t> m_parent;
};

Eigen::Vector3d point(const std::vector<float>& positions, std::size_t v) {
  return {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]};
}

// The part's faces as a manifold piece: the largest edge-connected piece, with vertices where
// several fans meet split into one copy per fan. `garment_vertex` maps the piece's vertices back.
struct PartPiece {
  Mesh mesh;
  std::vector<std::int32_t> garment_vertex;
};

PartPiece cut_part(const Mesh& garment, const std::vector<std::int32_t>& faces) {
  const std::size_t nf = faces.size();
  auto corner_vertex = [&](std::size_t c) { return garment.triangles[3 * std::size_t(faces[c / 3]) + c % 3]; };
  // Half-edges keyed by undirected edge; corners c and c' of two faces sharing an edge at the
  // same vertex belong to the same fan around that vertex.
  struct HalfEdge {
    std::uint64_t key;
    std::uint32_t corner; // the half-edge runs from corner to the next corner of its face
  };
  std::vector<HalfEdge> half_edges(3 * nf);
  for (std::size_t c = 0; c < 3 * nf; ++c) {
    const std::int32_t a = corner_vertex(c), b = corner_vertex(c - c % 3 + (c + 1) % 3);
    half_edges[c] = {(std::uint64_t(std::uint32_t(std::min(a, b))) << 32) | std::uint32_t(std::max(a, b)),
                     std::uint32_t(c)};
  }
  std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key < y.key || (x.key == y.key && x.corner < y.corner);
  });
  DisjointSets fans(3 * nf), pieces(nf);
  auto next_corner = [](std::uint32_t c) { return c - c % 3 + (c + 1) % 3; };
  for (std::size_t i = 0; i < half_edges.size();) {
    std::size_t j = i;
    while (j < half_edges.size() && half_edges[j].key == half_edges[i].key)
      ++j;
    if (j - i > 2)
      throw Error("part skeleton", 0,
                  "edge " + std::to_string(half_edges[i].key >> 32) + "–" +
                      std::to_string(half_edges[i].key & 0xffffffffu) + " is shared by more than two faces");
    if (j - i == 2) {
      const std::uint32_t c0 = half_edges[i].corner, c1 = half_edges[i + 1].corner;
      // Consistently oriented faces traverse the edge in opposite directions, so c0's start
      // vertex is where c1's half-edge ends; inconsistent ones pair start with start.
      const bool opposite = corner_vertex(c0) == corner_vertex(next_corner(c1));
      fans.unite(std::int32_t(c0), std::int32_t(opposite ? next_corner(c1) : c1));
      fans.unite(std::int32_t(next_corner(c0)), std::int32_t(opposite ? c1 : next_corner(c1)));
      pieces.unite(std::int32_t(c0 / 3), std::int32_t(c1 / 3));
    }
    i = j;
  }
  std::vector<std::size_t> piece_size(nf, 0);
  for (std::size_t f = 0; f < nf; ++f)
    ++piece_size[std::size_t(pieces.find(std::int32_t(f)))];
  const auto largest = std::int32_t(std::max_element(piece_size.begin(), piece_size.end()) - piece_size.begin());

  PartPiece piece;
  std::unordered_map<std::int32_t, std::int32_t> fan_vertex; // fan root corner → piece vertex
  for (std::size_t f = 0; f < nf; ++f) {
    if (pieces.find(std::int32_t(f)) != largest) continue;
    for (int k = 0; k < 3; ++k) {
      const std::int32_t fan = fans.find(std::int32_t(3 * f + std::size_t(k)));
      auto [it, fresh] = fan_vertex.emplace(fan, std::int32_t(piece.garment_vertex.size()));
      if (fresh) {
        const std::int32_t g = corner_vertex(3 * f + std::size_t(k));
        piece.garment_vertex.push_back(g);
        for (int d = 0; d < 3; ++d)
          piece.mesh.positions.push_back(garment.positions[3 * std::size_t(g) + std::size_t(d)]);
      }
      piece.mesh.triangles.push_back(it->second);
    }
  }
  return piece;
}

// Mean edge length of a closed mesh of `vertices` vertices spread evenly over the piece's area:
// about two equilateral triangles per vertex.
double proxy_spacing(const Mesh& piece, std::size_t vertices) {
  double area = 0;
  for (std::size_t f = 0; f < piece.face_count(); ++f) {
    const Eigen::Vector3d a = point(piece.positions, std::size_t(piece.triangles[3 * f])),
                          b = point(piece.positions, std::size_t(piece.triangles[3 * f + 1])),
                          c = point(piece.positions, std::size_t(piece.triangles[3 * f + 2]));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return std::sqrt(2 * area / (std::sqrt(3.0) * double(vertices)));
}

// tube_start(): the tube starts at the node that holds the seam's far end, the first node past
// all but this share of the seam's vertices, so that a few stray seam vertices (a
// torso-labelled speck on the limb) do not pull the start down the limb.
constexpr double SEAM_END_QUANTILE = 0.95;
// ... and never past this share of the chain's nodes (a part whose seam runs along most of it
// is no tube with an attachment: its whole chain counts).
constexpr double MAX_TUBE_START = 0.5;

// The node of an oriented chain (attachment end first) where the part becomes a whole tube. A
// limb's seam with the torso is cut slantwise (a trouser leg's top runs from the crotch up the
// hip to the waist, seed 000 eq. 3–4; a sleeve's from the armpit over the shoulder), and the
// label can run further up one side than the other (a side opening, a pocket or a flap at the
// hip): before the seam's far end (the crotch, the armpit) the part is an open wedge, not a
// tube, and its skeleton wanders into that wedge wherever the contraction took it: the worksuit
// overalls' right leg started 18 cm out on the hip, its left leg at the crotch. The tube starts
// at the node holding the seam's far end (SEAM_END_QUANTILE); 0 when that is past
// MAX_TUBE_START of the chain or there is no seam.
std::size_t tube_start(const std::vector<char>& seam, const PartSkeleton& skeleton) {
  std::vector<std::int32_t> seam_nodes;
  for (std::size_t i = 0; i < skeleton.vertices.size(); ++i)
    if (seam[std::size_t(skeleton.vertices[i])]) seam_nodes.push_back(skeleton.vertex_node[i]);
  if (seam_nodes.empty()) return 0;
  const auto q = seam_nodes.begin() + std::ptrdiff_t(SEAM_END_QUANTILE * double(seam_nodes.size() - 1));
  std::nth_element(seam_nodes.begin(), q, seam_nodes.end());
  const std::int32_t first = *q;
  if (first <= 0 || double(first) > MAX_TUBE_START * double(skeleton.nodes.size())) return 0;
  return std::size_t(first);
}

} // namespace

PartSkeleton extract_part_skeleton(const Mesh& garment, std::span<const GarmentPart> vertex_parts, GarmentPart part,
                                   const PartSkeletonOptions& options) {
  const auto start = Clock::now();
  const std::size_t nv = garment.vertex_count();
  if (vertex_parts.size() != nv)
    throw Error("part skeleton", 0,
                std::to_string(vertex_parts.size()) + " part labels for " + std::to_string(nv) + " vertices");
  for (std::size_t i = 0; i < garment.triangles.size(); ++i)
    if (garment.triangles[i] < 0 || std::size_t(garment.triangles[i]) >= nv)
      throw Error("part skeleton", 0, "face " + std::to_string(i / 3 + 1) + " has a vertex index out of range");
  PartSkeleton result;
  result.part = part;
  std::vector<std::int32_t> faces;
  for (std::size_t f = 0; f < garment.face_count(); ++f) {
    const std::int32_t* t = &garment.triangles[3 * f];
    if (vertex_parts[std::size_t(t[0])] == part && vertex_parts[std::size_t(t[1])] == part &&
        vertex_parts[std::size_t(t[2])] == part)
      faces.push_back(std::int32_t(f));
  }
  if (faces.empty()) throw Error("part skeleton", 0, "no face lies in the " + garment_part_name(part));
  const PartPiece piece = cut_part(garment, faces);
  result.timings.cut_ms = ms_since(start);

  auto stage = Clock::now();
  HoleFillOptions hole_fill = options.hole_fill;
  if (options.caps_at_proxy_spacing && hole_fill.edge_length == 0 && options.skeleton.proxy_vertices > 0)
    hole_fill.edge_length = proxy_spacing(piece.mesh, options.skeleton.proxy_vertices);
  const FilledMesh closed = fill_holes(piece.mesh, hole_fill);
  result.timings.fill_ms = ms_since(stage);
  result.piece_vertices = closed.original_vertices;
  result.cap_vertices = closed.mesh.vertex_count() - closed.original_vertices;

  stage = Clock::now();
  const CurveSkeleton skeleton = extract_curve_skeleton(closed.mesh, closed.original_vertices, options.skeleton);
  result.contraction = skeleton.contraction;
  result.proxy_vertices = skeleton.proxy_vertices;
  result.timings.skeleton_ms = ms_since(stage);
  result.timings.skeleton_stages = skeleton.timings;

  stage = Clock::now();
  const std::vector<std::int32_t>& piece_node = skeleton.vertex_node;
  std::vector<std::int32_t> garment_node(nv, -1);
  for (std::size_t v = 0; v < piece_node.size(); ++v)
    if (piece_node[v] >= 0 && garment_node[std::size_t(piece.garment_vertex[v])] < 0)
      garment_node[std::size_t(piece.garment_vertex[v])] = piece_node[v];
  // Labelled vertices off the piece (other pieces, lone vertices) take the nearest node.
  for (std::size_t v = 0; v < nv; ++v) {
    if (vertex_parts[v] != part) continue;
    result.vertices.push_back(std::int32_t(v));
    if (garment_node[v] >= 0) continue;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t n = 0; n < skeleton.nodes.size(); ++n) {
      const double d = (point(garment.positions, v) - skeleton.nodes[n]).squaredNorm();
      if (d < best) {
        best = d;
        garment_node[v] = std::int32_t(n);
      }
    }
  }

  // Recentre on the full-resolution vertices (eq. 12); drop nodes left without vertices.
  const std::size_t chain = skeleton.nodes.size();
  std::vector<Eigen::Vector3d> sum(chain, Eigen::Vector3d::Zero());
  std::vector<double> count(chain, 0.0);
  for (std::int32_t v : result.vertices) {
    sum[std::size_t(garment_node[std::size_t(v)])] += point(garment.positions, std::size_t(v));
    count[std::size_t(garment_node[std::size_t(v)])] += 1;
  }
  std::vector<std::int32_t> renumber(chain, -1);
  for (std::size_t n = 0; n < chain; ++n)
    if (count[n] > 0) {
      renumber[n] = std::int32_t(result.nodes.size());
      result.nodes.push_back(sum[n] / count[n]);
    }
  result.vertex_node.reserve(result.vertices.size());
  for (std::int32_t v : result.vertices)
    result.vertex_node.push_back(renumber[std::size_t(garment_node[std::size_t(v)])]);
  result.nodes = cross_section_centres(garment.positions, result.vertices, result.vertex_node, result.nodes);

  // Attachment end: nearest the seam with the rest of the garment.
  std::vector<char> seam(nv, 0);
  for (std::size_t f = 0; f < garment.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = garment.triangles[3 * f + std::size_t(k)],
                         b = garment.triangles[3 * f + std::size_t(k + 1) % 3];
      if ((vertex_parts[std::size_t(a)] == part) != (vertex_parts[std::size_t(b)] == part))
        seam[std::size_t(vertex_parts[std::size_t(a)] == part ? a : b)] = 1;
    }
  Eigen::Vector3d seam_centre = Eigen::Vector3d::Zero();
  double seam_count = 0;
  for (std::int32_t v : result.vertices)
    if (seam[std::size_t(v)]) {
      seam_centre += point(garment.positions, std::size_t(v));
      seam_count += 1;
    }
  if (seam_count > 0 && result.nodes.size() > 1) {
    seam_centre /= seam_count;
    if ((result.nodes.back() - seam_centre).squaredNorm() < (result.nodes.front() - seam_centre).squaredNorm()) {
      std::reverse(result.nodes.begin(), result.nodes.end());
      const auto last = std::int32_t(result.nodes.size()) - 1;
      for (std::int32_t& n : result.vertex_node)
        n = last - n;
    }
    result.tube_start = tube_start(seam, result);
  }
  result.timings.map_ms = ms_since(stage);
  result.timings.total_ms = ms_since(start);
  return result;
}

std::vector<PartSkeleton> extract_limb_skeletons(const Mesh& garment, std::span<const GarmentPart> vertex_parts,
                                                 const PartSkeletonOptions& options) {
  if (vertex_parts.size() != garment.vertex_count())
    throw Error("part skeleton", 0,
                std::to_string(vertex_parts.size()) + " part labels for " + std::to_string(garment.vertex_count()) +
                    " vertices");
  std::vector<GarmentPart> parts;
  for (GarmentPart part :
       {GarmentPart::LEFT_SLEEVE, GarmentPart::RIGHT_SLEEVE, GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG}) {
    bool present = false;
    for (std::size_t f = 0; f < garment.face_count() && !present; ++f) {
      const std::int32_t* t = &garment.triangles[3 * f];
      present = t[0] >= 0 && t[1] >= 0 && t[2] >= 0 &&
                std::size_t(std::max({t[0], t[1], t[2]})) < vertex_parts.size() &&
                vertex_parts[std::size_t(t[0])] == part && vertex_parts[std::size_t(t[1])] == part &&
                vertex_parts[std::size_t(t[2])] == part;
    }
    if (present) parts.push_back(part);
  }
  // The limbs are independent: one task each (grain 1), results in the parts' order.
  std::vector<PartSkeleton> skeletons(parts.size());
  parallel_for_range(parts.size(), LIMBS_PER_TASK, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      skeletons[i] = extract_part_skeleton(garment, vertex_parts, parts[i], options);
  });
  return skeletons;
}

} // namespace vfit
