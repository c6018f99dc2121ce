// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/layering.h"

#include <cmath>
#include <string>
#include <unordered_map>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

using Vec = Eigen::Vector3d;

Vec vertex(const Mesh& m, std::int32_t v) {
  const auto i = 3 * std::size_t(v);
  return {m.positions[i], m.positions[i + 1], m.positions[i + 2]};
}

// Whether the garment's faces point towards the body on balance: Σ_f (area-weighted normal) ·
// (centroid − its closest body point) < 0. Faces whose centroid is inside the body vote with
// the opposite sign, since there the direction to the body's surface is reversed.
bool faces_the_body(const Mesh& garment, const ProximityIndex& body) {
  const std::size_t nf = garment.face_count();
  std::vector<float> centroids(3 * nf);
  std::vector<Vec> normals(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const Vec a = vertex(garment, garment.triangles[3 * f]), b = vertex(garment, garment.triangles[3 * f + 1]),
              c = vertex(garment, garment.triangles[3 * f + 2]);
    normals[f] = 0.5 * (b - a).cross(c - a);
    const Vec m = (a + b + c) / 3.0;
    for (int k = 0; k < 3; ++k)
      centroids[3 * f + std::size_t(k)] = float(m[k]);
  }
  ClosestHits hits;
  body.closest_points(centroids, INFINITY, hits);
  double balance = 0;
  for (std::size_t f = 0; f < nf; ++f) {
    if (hits.triangles[f] < 0) continue;
    const Vec away(double(centroids[3 * f]) - hits.points[3 * f], double(centroids[3 * f + 1]) - hits.points[3 * f + 1],
                   double(centroids[3 * f + 2]) - hits.points[3 * f + 2]);
    balance += (hits.signed_distances[f] < 0 ? -1.0 : 1.0) * normals[f].dot(away);
  }
  return balance < 0;
}

// Per triangle: bit k for a boundary edge k (corner k → k + 1), bit 3 + k for a boundary
// corner k. An edge is on the boundary when exactly one triangle uses it.
std::vector<std::uint8_t> boundary_masks(const Mesh& garment, std::size_t& boundary_edges) {
  const std::size_t nf = garment.face_count();
  auto key = [](std::int32_t a, std::int32_t b) {
    if (a > b) std::swap(a, b);
    return (std::uint64_t(std::uint32_t(a)) << 32) | std::uint32_t(b);
  };
  std::unordered_map<std::uint64_t, int> uses;
  uses.reserve(3 * nf);
  for (std::size_t i = 0; i < 3 * nf; ++i)
    ++uses[key(garment.triangles[i], garment.triangles[i - i % 3 + (i % 3 + 1) % 3])];
  std::vector<char> boundary_vertex(garment.vertex_count(), 0);
  boundary_edges = 0;
  for (const auto& [k, n] : uses)
    if (n == 1) {
      ++boundary_edges;
      boundary_vertex[std::size_t(k >> 32)] = 1;
      boundary_vertex[std::size_t(k & 0xffffffffu)] = 1;
    }
  std::vector<std::uint8_t> masks(nf, 0);
  for (std::size_t f = 0; f < nf; ++f)
    for (std::size_t c = 0; c < 3; ++c) {
      const std::int32_t a = garment.triangles[3 * f + c], b = garment.triangles[3 * f + (c + 1) % 3];
      if (uses[key(a, b)] == 1) masks[f] |= std::uint8_t(1u << c);
      if (boundary_vertex[std::size_t(a)]) masks[f] |= std::uint8_t(1u << (3 + c));
    }
  return masks;
}

} // namespace

InnerLayer::InnerLayer(const Mesh& garment, const ProximityIndex& body, double clearance, double reach)
    : m_clearance(clearance), m_reach(reach) {
  if (!(clearance >= 0) || !(reach > 0))
    throw Error("inner layer: clearance " + std::to_string(clearance) + " m must be ≥ 0 and reach " +
                std::to_string(reach) + " m > 0");
  std::vector<std::int32_t> triangles = garment.triangles;
  m_flipped = garment.face_count() > 0 && faces_the_body(garment, body);
  if (m_flipped)
    for (std::size_t f = 0; 3 * f < triangles.size(); ++f)
      std::swap(triangles[3 * f + 1], triangles[3 * f + 2]);
  // Flipping swaps corners 1 and 2, so edge k of the flipped triangle is a different edge of
  // the original: compute the boundary masks on the triangles as indexed.
  Mesh oriented;
  oriented.positions = garment.positions;
  oriented.triangles = triangles;
  m_boundary = boundary_masks(oriented, m_boundary_edges);
  // One-sided: a garment is an open sheet, and its side is that of the sheet itself (capping
  // its openings, as a body with holes gets, would put the waistband's inside "inside").
  m_index = std::make_unique<ProximityIndex>(oriented.positions, oriented.triangles, OpenMeshSide::ONE_SIDED);
  const std::size_t nv = garment.vertex_count();
  m_edges = mesh_edge_endpoints(triangles, nv);
  m_edge_offsets.assign(nv + 1, 0);
  for (const std::int32_t v : m_edges)
    ++m_edge_offsets[std::size_t(v) + 1];
  for (std::size_t v = 0; v < nv; ++v)
    m_edge_offsets[v + 1] += m_edge_offsets[v];
  m_vertex_edges.resize(m_edges.size());
  std::vector<std::int32_t> fill(m_edge_offsets.begin(), m_edge_offsets.end() - 1);
  for (std::size_t e = 0; e < m_edges.size(); ++e)
    m_vertex_edges[std::size_t(fill[std::size_t(m_edges[e])]++)] = std::int32_t(e / 2);
  m_points = std::move(oriented.positions);
  m_triangles = std::move(triangles);
}

InnerLayer::~InnerLayer() = default;
InnerLayer::InnerLayer(InnerLayer&&) noexcept = default;
InnerLayer& InnerLayer::operator=(InnerLayer&&) noexcept = default;

LayerObstacle InnerLayer::obstacle() const {
  LayerObstacle o;
  o.surface = m_index.get();
  o.boundary = m_boundary;
  o.clearance = m_clearance;
  o.reach = m_reach;
  o.points = m_points;
  o.triangles = m_triangles;
  o.edges = m_edges;
  o.edge_offsets = m_edge_offsets;
  o.vertex_edges = m_vertex_edges;
  return o;
}

std::vector<PenetrationReport> resolve_layers(std::span<Mesh* const> garments, const ProximityIndex& body,
                                              const EdgeCrossingIndex& crossings, const LayeringOptions& options) {
  std::vector<InnerLayer> inner;
  std::vector<LayerObstacle> obstacles;
  std::vector<PenetrationReport> reports;
  inner.reserve(garments.size());
  for (std::size_t i = 0; i < garments.size(); ++i) {
    if (!garments[i]) throw Error("layered garment " + std::to_string(i), 0, "null mesh");
    reports.push_back(remove_penetration(*garments[i], body, crossings, obstacles, options.penetration));
    if (i + 1 == garments.size()) break; // the outermost garment is nobody's inner layer
    inner.emplace_back(*garments[i], body, options.layer_clearance, options.reach);
    obstacles.push_back(inner.back().obstacle());
  }
  return reports;
}

} // namespace vfit
