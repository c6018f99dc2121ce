// SPDX-License-Identifier: Apache-2.0
// Hole filling and part skeletons (seed 000 §5.1, eq. 12): watertight caps, skeletons centred
// on known axes (straight and bent tubes), the vertex → node map, and the sleeves and legs of
// catalogue garments.
#include "vfit/geometry/garment/curve_skeleton.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/hole_fill.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/garment/skeleton_driving.h"
#include "vfit/geometry/garment/skeleton_parts.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

Eigen::Vector3d point(const Mesh& m, std::size_t v) {
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}

// Signed volume (m³): positive for an outward-oriented closed surface.
double signed_volume(const Mesh& m) {
  double volume = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    volume +=
        point(m, std::size_t(m.triangles[3 * f]))
            .dot(point(m, std::size_t(m.triangles[3 * f + 1])).cross(point(m, std::size_t(m.triangles[3 * f + 2])))) /
        6;
  return volume;
}

// A tube bent along an arc of radius `bend` (m) in the XY plane: the straight tube's axis
// point at height y goes to angle y / bend on the arc centred at (bend, 0, 0), its cross-section
// turned with it (an orientation-preserving map, so normals stay outward).
Mesh bent_tube(int rings, int segments, float radius, float length, double bend) {
  Mesh m = make_tube(rings, segments, radius, length);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const double x = m.positions[3 * v], y = m.positions[3 * v + 1];
    const double theta = y / bend;
    m.positions[3 * v] = float(bend - (bend - x) * std::cos(theta));
    m.positions[3 * v + 1] = float((bend - x) * std::sin(theta));
  }
  return m;
}

// Distance from p to the bent tube's axis arc (angles [0, length / bend]) and the arc
// parameter (m along the axis) of its nearest point.
std::pair<double, double> arc_distance(const Eigen::Vector3d& p, double bend, double length) {
  const Eigen::Vector2d rel(p.x() - bend, p.y());
  const double theta = std::clamp(std::atan2(rel.y(), -rel.x()), 0.0, length / bend);
  const Eigen::Vector3d nearest(bend - bend * std::cos(theta), bend * std::sin(theta), 0);
  return {(p - nearest).norm(), theta * bend};
}

// Every original vertex maps to exactly one node (eq. 12) and every node owns one.
void expect_disjoint_cover(const CurveSkeleton& s, std::size_t vertices) {
  ASSERT_EQ(s.vertex_node.size(), vertices);
  std::vector<std::size_t> owned(s.nodes.size(), 0);
  for (std::int32_t n : s.vertex_node) {
    ASSERT_GE(n, 0);
    ASSERT_LT(std::size_t(n), s.nodes.size());
    ++owned[std::size_t(n)];
  }
  for (std::size_t n = 0; n < owned.size(); ++n)
    EXPECT_GT(owned[n], 0u) << "node " << n;
}

TEST(HoleFill, ClosesATubeIntoAnOutwardSphereLikeSurface) {
  const float r = 0.05f, length = 0.4f;
  const int segments = 16;
  const Mesh tube = make_tube(20, segments, r, length);
  const FilledMesh filled = fill_holes(tube);
  EXPECT_EQ(filled.loops_filled, 2u);
  EXPECT_EQ(filled.original_vertices, tube.vertex_count());
  ASSERT_GT(filled.mesh.vertex_count(), tube.vertex_count());
  for (std::size_t i = 0; i < tube.positions.size(); ++i)
    ASSERT_EQ(filled.mesh.positions[i], tube.positions[i]);
  const TopologyReport t = analyse_topology(filled.mesh.triangle_view(), filled.mesh.vertex_count());
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler_characteristic, 2); // a sphere: caps add no handles
  // Volume of the 16-gon prism plus two domes (hemispheres over the polygon): the domes are
  // faceted, so they fall short of exact hemispheres by a few per cent of their own volume.
  const double polygon = 0.5 * segments * r * r * std::sin(2 * std::numbers::pi / segments);
  const double expected = polygon * length + 4.0 / 3.0 * polygon * r;
  EXPECT_NEAR(signed_volume(filled.mesh), expected, 0.03 * expected);
}

TEST(HoleFill, FlatCapsStayInTheOpeningsPlane) {
  const Mesh tube = make_tube(6, 12, 0.05f, 0.2f);
  const FilledMesh filled = fill_holes(tube, HoleFillOptions{.dome_height = 0});
  EXPECT_TRUE(analyse_topology(filled.mesh.triangle_view(), filled.mesh.vertex_count()).watertight());
  for (std::size_t v = tube.vertex_count(); v < filled.mesh.vertex_count(); ++v) {
    const double y = filled.mesh.positions[3 * v + 1];
    EXPECT_TRUE(std::abs(y) < 1e-6 || std::abs(y - 0.2) < 1e-6) << v;
  }
}

TEST(HoleFill, ClosesEveryOpeningOfAGarment) {
  GarmentOptions o;
  o.type = GarmentType::TEE;
  o.target_vertices = 2000;
  const Garment g = make_garment(o);
  const FilledMesh filled = fill_holes(g.mesh);
  EXPECT_EQ(filled.loops_filled, expected_openings(GarmentType::TEE));
  const TopologyReport t = analyse_topology(filled.mesh.triangle_view(), filled.mesh.vertex_count());
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_GT(signed_volume(filled.mesh), 0);
}

TEST(HoleFill, LeavesAClosedMeshAloneAndRejectsABowtie) {
  const Mesh closed = test::octahedron();
  const FilledMesh same = fill_holes(closed);
  EXPECT_EQ(same.loops_filled, 0u);
  EXPECT_EQ(same.mesh.triangles, closed.triangles);
  // Two triangles meeting at one vertex: that vertex starts two boundary edges.
  Mesh bowtie;
  bowtie.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0};
  bowtie.triangles = {0, 1, 2, 0, 3, 4};
  EXPECT_THROW(fill_holes(bowtie), Error);
}

// A long loop's cap is bounded by max_ring_vertices (rings of at most that many vertices, at
// most a quarter as many rings) and still closes the tube into a sphere; a loop within the
// bound gets the same cap as with no bound.
TEST(HoleFill, BoundsTheCapsOfLongLoops) {
  const int segments = 400; // two loops of 400 vertices
  const Mesh tube = make_tube(8, segments, 0.05f, 0.1f);
  const FilledMesh unbounded = fill_holes(tube, HoleFillOptions{.max_ring_vertices = 0});
  const FilledMesh bounded = fill_holes(tube, HoleFillOptions{.max_ring_vertices = 64});
  const std::size_t cap = (bounded.mesh.vertex_count() - tube.vertex_count()) / 2;
  // Rings k = 1 … 15 of round(64 cos θ_k) vertices, θ_k = k·90°/16, and the apex: ~650.
  EXPECT_LE(cap, 64u * 16u * 2u / 3u);
  EXPECT_GT(unbounded.mesh.vertex_count() - tube.vertex_count(), 2 * 10000u); // ~n²/2π each
  const TopologyReport t = analyse_topology(bounded.mesh.triangle_view(), bounded.mesh.vertex_count());
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_GT(signed_volume(bounded.mesh), 0);
  const Mesh short_loops = make_tube(8, 24, 0.05f, 0.1f);
  EXPECT_EQ(fill_holes(short_loops, HoleFillOptions{.max_ring_vertices = 64}).mesh.positions,
            fill_holes(short_loops, HoleFillOptions{.max_ring_vertices = 0}).mesh.positions);
}

// A node's slab two rings thick on one side of a tube: its centroid is pulled to that side by a
// third of the radius, its cross-section's centre is on the axis (each vertex weighs its share
// of the angle about it, so the doubled side counts once).
TEST(CurveSkeleton, CrossSectionCentresIgnoreHowASlabIsSpreadAroundTheAxis) {
  const double r = 0.05;
  const int segments = 24;
  std::vector<float> positions;
  std::vector<std::int32_t> vertices, vertex_node;
  auto add = [&](double angle, double y, std::int32_t node) {
    vertices.push_back(std::int32_t(positions.size() / 3));
    positions.insert(positions.end(), {float(r * std::cos(angle)), float(y), float(r * std::sin(angle))});
    vertex_node.push_back(node);
  };
  for (int node = 0; node < 3; ++node)
    for (int k = 0; k < segments; ++k) {
      const double angle = 2 * std::numbers::pi * k / segments;
      add(angle, 0.1 * node, node);
      if (node == 1 && std::cos(angle) > 0) add(angle, 0.1 * node + 0.01, node); // a second ring, half way round
    }
  std::vector<Eigen::Vector3d> centroids(3, Eigen::Vector3d::Zero());
  std::vector<double> count(3, 0);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    centroids[std::size_t(vertex_node[i])] +=
        Eigen::Vector3d(positions[3 * std::size_t(vertices[i])], positions[3 * std::size_t(vertices[i]) + 1],
                        positions[3 * std::size_t(vertices[i]) + 2]);
    count[std::size_t(vertex_node[i])] += 1;
  }
  for (std::size_t n = 0; n < 3; ++n)
    centroids[n] /= count[n];
  ASSERT_GT(std::hypot(centroids[1].x(), centroids[1].z()), 0.2 * r); // the bias the centres remove
  const std::vector<Eigen::Vector3d> centres = cross_section_centres(positions, vertices, vertex_node, centroids);
  ASSERT_EQ(centres.size(), 3u);
  for (std::size_t n = 0; n < 3; ++n) {
    // Full rings and a doubled half ring weigh their angles exactly about the axis; the angles
    // are taken about the centroid (0.3 r off) and then about the first result, which leaves
    // 0.05 r of the offset.
    EXPECT_LT(std::hypot(centres[n].x(), centres[n].z()), 0.06 * r) << n;
    EXPECT_NEAR(centres[n].y(), 0.1 * double(n), 0.01) << n;
  }
  // A half ring is no cross-section (a 180° gap): it keeps its entry.
  std::vector<std::int32_t> half_vertices, half_nodes;
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (vertex_node[i] != 1 || positions[3 * std::size_t(vertices[i])] > 0) {
      half_vertices.push_back(vertices[i]);
      half_nodes.push_back(vertex_node[i]);
    }
  EXPECT_EQ(cross_section_centres(positions, half_vertices, half_nodes, centroids)[1], centroids[1]);
}

// Straight tube: nodes on the axis, in order along it, spanning it.
TEST(CurveSkeleton, StraightTubeNodesLieOnTheAxisInOrder) {
  const float r = 0.05f, length = 0.5f;
  const Mesh tube = make_tube(40, 20, r, length);
  const FilledMesh filled = fill_holes(tube);
  CurveSkeletonOptions o;
  o.proxy_vertices = 0; // full resolution: the bent tube below goes through a proxy
  CurveSkeleton s = extract_curve_skeleton(filled.mesh, filled.original_vertices, o);
  orient_chain(s, Eigen::Vector3d::Zero());
  expect_disjoint_cover(s, tube.vertex_count());
  EXPECT_EQ(s.proxy_vertices, filled.mesh.vertex_count());
  ASSERT_GE(s.nodes.size(), 10u);
  EXPECT_LT(s.contraction.final_area_ratio, ContractionOptions{}.area_ratio);
  for (std::size_t n = 0; n < s.nodes.size(); ++n) {
    const Eigen::Vector3d& p = s.nodes[n];
    EXPECT_LT(std::hypot(p.x(), p.z()), 0.1 * r) << "node " << n; // the bar: 10 % of the radius
    EXPECT_GE(p.y(), 0);                                          // an end node may be exactly the end ring
    EXPECT_LE(p.y(), length);
    if (n > 0) {
      EXPECT_GT(p.y(), s.nodes[n - 1].y()) << "node " << n;
    }
  }
  // The ends: within two ring spacings of the openings (the end nodes are centroids of slabs).
  const double ring = length / 39;
  EXPECT_LT(s.nodes.front().y(), 2 * ring);
  EXPECT_GT(s.nodes.back().y(), length - 2 * ring);
}

TEST(CurveSkeleton, CotangentContractionGivesTheSameAxis) {
  const float r = 0.05f, length = 0.5f;
  const Mesh tube = make_tube(40, 20, r, length);
  const FilledMesh filled = fill_holes(tube);
  CurveSkeletonOptions o;
  o.contraction.laplacian = ContractionLaplacian::COTANGENT;
  CurveSkeleton s = extract_curve_skeleton(filled.mesh, filled.original_vertices, o);
  expect_disjoint_cover(s, tube.vertex_count());
  ASSERT_GE(s.nodes.size(), 10u);
  // Through the default proxy: the bar, 10 % of the radius (see BentTube).
  for (std::size_t n = 0; n < s.nodes.size(); ++n)
    EXPECT_LT(std::hypot(s.nodes[n].x(), s.nodes[n].z()), 0.1 * r) << n;
}

// The bar, 10 % of the radius, at full resolution and through the default proxy. The
// proxy's clusters leave ragged slab borders that the re-cut does not always straighten: plain
// centroids of such slabs were up to 0.17 r off the arc, their cross-section centres
// (cross_section_centres(), curve_skeleton.h) within 0.045 r.
class BentTube : public ::testing::TestWithParam<bool> {};

TEST_P(BentTube, NodesLieOnTheArcInOrder) {
  const bool through_proxy = GetParam();
  const float r = 0.05f, length = 0.6f;
  const double bend = 0.25; // 137° of arc: an elbow bent well past a right angle
  const Mesh tube = bent_tube(48, 20, r, length, bend);
  const FilledMesh filled = fill_holes(tube);
  EXPECT_TRUE(analyse_topology(filled.mesh.triangle_view(), filled.mesh.vertex_count()).watertight());
  CurveSkeletonOptions o;
  if (!through_proxy) o.proxy_vertices = 0;
  CurveSkeleton s = extract_curve_skeleton(filled.mesh, filled.original_vertices, o);
  orient_chain(s, Eigen::Vector3d::Zero());
  expect_disjoint_cover(s, tube.vertex_count());
  EXPECT_EQ(s.proxy_vertices < filled.mesh.vertex_count(), through_proxy);
  ASSERT_GE(s.nodes.size(), 10u);
  const double tolerance = 0.1;
  double previous = -1;
  for (std::size_t n = 0; n < s.nodes.size(); ++n) {
    const auto [distance, along] = arc_distance(s.nodes[n], bend, length);
    EXPECT_LT(distance, tolerance * r) << "node " << n;
    EXPECT_GT(along, previous) << "node " << n;
    previous = along;
  }
  // Each vertex's node is the one nearest its own place along the axis, give or take a node.
  std::vector<double> node_along(s.nodes.size());
  for (std::size_t n = 0; n < s.nodes.size(); ++n)
    node_along[n] = arc_distance(s.nodes[n], bend, length).second;
  std::size_t off = 0;
  for (std::size_t v = 0; v < tube.vertex_count(); ++v) {
    const double along = arc_distance(point(tube, v), bend, length).second;
    const auto nearest = std::min_element(node_along.begin(), node_along.end(), [&](double a, double b) {
      return std::abs(a - along) < std::abs(b - along);
    });
    off += std::abs(std::distance(node_along.begin(), nearest) - s.vertex_node[v]) > 1;
  }
  EXPECT_EQ(off, 0u);
}
INSTANTIATE_TEST_SUITE_P(CurveSkeleton, BentTube, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return i.param ? std::string("proxy") : std::string("full");
                         });

TEST(CurveSkeleton, RejectsBadInput) {
  const FilledMesh filled = fill_holes(make_tube(4, 6, 0.05f, 0.1f));
  EXPECT_THROW(extract_curve_skeleton(filled.mesh, 0), Error);
  EXPECT_THROW(extract_curve_skeleton(filled.mesh, filled.mesh.vertex_count() + 1), Error);
  EXPECT_THROW(extract_curve_skeleton(Mesh{}, 1), Error);
}

// A 6k-vertex tube through the part API: simplified proxy, the first rings labelled torso so
// that the chain must start there.
TEST(PartSkeleton, LargeTubeThroughAProxyStartsAtTheSeam) {
  const float r = 0.05f, length = 0.6f;
  const int rings = 250, segments = 24;
  const Mesh tube = make_tube(rings, segments, r, length);
  std::vector<GarmentPart> parts(tube.vertex_count(), GarmentPart::LEFT_SLEEVE);
  for (std::size_t v = 0; v < std::size_t(5 * segments); ++v)
    parts[v] = GarmentPart::TORSO;
  PartSkeletonOptions o;
  o.skeleton.proxy_vertices = 600;
  const PartSkeleton s = extract_part_skeleton(tube, parts, GarmentPart::LEFT_SLEEVE, o);
  EXPECT_EQ(s.proxy_vertices, 600u);
  ASSERT_EQ(s.vertices.size(), tube.vertex_count() - 5 * segments);
  ASSERT_EQ(s.vertex_node.size(), s.vertices.size());
  ASSERT_GE(s.nodes.size(), 8u);
  std::vector<std::size_t> owned(s.nodes.size(), 0);
  for (std::int32_t n : s.vertex_node) {
    ASSERT_GE(n, 0);
    ASSERT_LT(std::size_t(n), s.nodes.size());
    ++owned[std::size_t(n)];
  }
  for (std::size_t n = 0; n < owned.size(); ++n)
    EXPECT_GT(owned[n], 0u) << n;
  for (std::size_t n = 0; n < s.nodes.size(); ++n) {
    EXPECT_LT(std::hypot(s.nodes[n].x(), s.nodes[n].z()), 0.1 * r) << "node " << n; // the bar, see BentTube
    if (n > 0) {
      EXPECT_GT(s.nodes[n].y(), s.nodes[n - 1].y()) << "node " << n;
    }
  }
  const double seam_y = 4.5 * length / (rings - 1);
  EXPECT_LT(s.nodes.front().y() - seam_y, 2 * r);
  EXPECT_GT(s.nodes.back().y(), length - 2 * r);
}

// Catalogue garments with their ground-truth labels, and with segment_garment()'s.
struct GarmentCase {
  const char* name;
  GarmentType type;
  RestPose pose;
  bool segmented; ///< labels from segment_garment() rather than the catalogue's
};
void PrintTo(const GarmentCase& c, std::ostream* os) { *os << c.name; }

const Garment& garment(const GarmentCase& c) {
  static std::map<std::string, Garment> cache;
  const std::string key = garment_type_name(c.type) + (c.pose == RestPose::APOSE ? "-a" : "-t");
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  GarmentOptions o;
  o.type = c.type;
  o.pose = c.pose;
  o.target_vertices = 4000;
  return cache.emplace(key, make_garment(o)).first->second;
}

// Centroids and mean radii of the garment's openings, with the part of their vertices.
struct Opening {
  Eigen::Vector3d centre;
  double radius;
  GarmentPart part;
};
std::vector<Opening> openings(const Mesh& m, const std::vector<GarmentPart>& parts) {
  std::map<std::pair<std::int32_t, std::int32_t>, int> count;
  for (std::size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = m.triangles[3 * f + std::size_t(k)], b = m.triangles[3 * f + std::size_t(k + 1) % 3];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<std::vector<std::int32_t>> nbr(m.vertex_count());
  for (const auto& [e, c] : count)
    if (c == 1) {
      nbr[std::size_t(e.first)].push_back(e.second);
      nbr[std::size_t(e.second)].push_back(e.first);
    }
  std::vector<Opening> result;
  std::vector<char> seen(m.vertex_count(), 0);
  for (std::size_t s = 0; s < m.vertex_count(); ++s) {
    if (nbr[s].empty() || seen[s]) continue;
    std::vector<std::int32_t> loop{std::int32_t(s)}, stack{std::int32_t(s)};
    seen[s] = 1;
    while (!stack.empty()) {
      const std::int32_t v = stack.back();
      stack.pop_back();
      for (std::int32_t w : nbr[std::size_t(v)])
        if (!seen[std::size_t(w)]) {
          seen[std::size_t(w)] = 1;
          loop.push_back(w);
          stack.push_back(w);
        }
    }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    std::map<GarmentPart, int> votes;
    for (std::int32_t v : loop) {
      c += point(m, std::size_t(v));
      ++votes[parts[std::size_t(v)]];
    }
    c /= double(loop.size());
    double radius = 0;
    for (std::int32_t v : loop)
      radius += (point(m, std::size_t(v)) - c).norm() / double(loop.size());
    const auto best =
        std::max_element(votes.begin(), votes.end(), [](auto& a, auto& b) { return a.second < b.second; });
    result.push_back({c, radius, best->first});
  }
  return result;
}

// Distance from p to the segment ab.
double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return (p - (a + t * (b - a))).norm();
}

class GarmentSkeletons : public ::testing::TestWithParam<GarmentCase> {};

TEST_P(GarmentSkeletons, EachLimbIsOneChainFromAttachmentToOpening) {
  const GarmentCase& c = GetParam();
  const Garment& g = garment(c);
  const std::vector<GarmentPart> parts = c.segmented ? segment_garment(g.mesh).vertex_parts : g.vertex_parts;
  const std::vector<PartSkeleton> skeletons = extract_limb_skeletons(g.mesh, parts);
  const bool top = c.type == GarmentType::TEE || c.type == GarmentType::LONG_SLEEVE;
  ASSERT_EQ(skeletons.size(), 2u);
  const MannequinShape body(BodyMeasurements{}, g.pose);
  const std::vector<Opening> holes = openings(g.mesh, parts);
  for (const PartSkeleton& s : skeletons) {
    SCOPED_TRACE(garment_part_name(s.part));
    EXPECT_EQ(s.part, top ? (&s == &skeletons[0] ? GarmentPart::LEFT_SLEEVE : GarmentPart::RIGHT_SLEEVE)
                          : (&s == &skeletons[0] ? GarmentPart::LEFT_LEG : GarmentPart::RIGHT_LEG));
    ASSERT_GE(s.nodes.size(), 4u);
    std::size_t labelled = 0;
    for (GarmentPart p : parts)
      labelled += p == s.part;
    ASSERT_EQ(s.vertices.size(), labelled);
    for (std::size_t i = 0; i < s.vertices.size(); ++i) {
      ASSERT_EQ(parts[std::size_t(s.vertices[i])], s.part);
      ASSERT_GE(s.vertex_node[i], 0);
      ASSERT_LT(std::size_t(s.vertex_node[i]), s.nodes.size());
    }
    // The limb's bone: shoulder → wrist or hip → ankle of the mannequin the garment was made on.
    const bool left = s.part == GarmentPart::LEFT_SLEEVE || s.part == GarmentPart::LEFT_LEG;
    const Joint root =
        top ? (left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER) : (left ? Joint::LEFT_HIP : Joint::RIGHT_HIP);
    const Joint tip =
        top ? (left ? Joint::LEFT_WRIST : Joint::RIGHT_WRIST) : (left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE);
    const Eigen::Vector3d a = body.joints().row(idx(root)).transpose(), b = body.joints().row(idx(tip)).transpose();
    // The opening at the part's free end.
    const Opening* hole = nullptr;
    for (const Opening& h : holes)
      if (h.part == s.part) hole = &h;
    ASSERT_NE(hole, nullptr);
    // Inside the cloth: every node is nearer the bone than its own vertices are to it on
    // average (the local cloth radius), i.e. inside its cross-section around the limb.
    std::vector<double> spread(s.nodes.size(), 0.0), members(s.nodes.size(), 0.0);
    for (std::size_t i = 0; i < s.vertices.size(); ++i) {
      const auto n = std::size_t(s.vertex_node[i]);
      spread[n] += (point(g.mesh, std::size_t(s.vertices[i])) - s.nodes[n]).norm();
      members[n] += 1;
    }
    for (std::size_t n = 0; n < s.nodes.size(); ++n)
      EXPECT_LT(segment_distance(s.nodes[n], a, b), spread[n] / members[n]) << n;
    // Ends: the last node within one opening radius of the opening's centre (it is the centroid
    // of the last slab of cloth, about a radius deep); the first node nearer the attachment
    // joint than the opening, and the chain's projection on the bone increasing (small
    // back-steps of a centimetre allowed where slanted slabs at the seam overlap).
    EXPECT_LT((s.nodes.back() - hole->centre).norm(), hole->radius);
    EXPECT_LT((s.nodes.front() - a).norm(), (s.nodes.front() - hole->centre).norm());
    const Eigen::Vector3d axis = (b - a).normalized();
    for (std::size_t n = 1; n < s.nodes.size(); ++n)
      EXPECT_GT((s.nodes[n] - s.nodes[n - 1]).dot(axis), -0.01) << n;
  }
}

// Shorts are left out: their legs are wider than long, and one of their nodes lands 11 cm off
// the thigh bone (outside its cross-section); a known limitation.
INSTANTIATE_TEST_SUITE_P(
    Catalogue, GarmentSkeletons,
    ::testing::Values(GarmentCase{"tee_tpose", GarmentType::TEE, RestPose::TPOSE, false},
                      GarmentCase{"long_sleeve_tpose", GarmentType::LONG_SLEEVE, RestPose::TPOSE, false},
                      GarmentCase{"long_sleeve_apose_segmented", GarmentType::LONG_SLEEVE, RestPose::APOSE, true},
                      GarmentCase{"trousers", GarmentType::TROUSERS, RestPose::TPOSE, false},
                      GarmentCase{"trousers_segmented", GarmentType::TROUSERS, RestPose::TPOSE, true}),
    [](const ::testing::TestParamInfo<GarmentCase>& i) { return std::string(i.param.name); });

} // namespace
} // namespace vfit

namespace vfit {
namespace {

// A leg's label that runs further up one hip than the other (a side opening, a pocket or a
// flap there, as on the corpus's worksuit overalls) must not move where that leg's tube starts:
// both legs' tubes start at the crotch, mirror images of each other, and the key joints stay
// on the garment's mid-plane.
TEST(PartSkeleton, ALabelRunningUpOneHipLeavesTheTubesStartingAtTheCrotch) {
  const Garment& trousers = garment(GarmentCase{"trousers", GarmentType::TROUSERS, RestPose::TPOSE, true});
  GarmentSegmentation seg = segment_garment(trousers.mesh);
  ASSERT_TRUE(seg.key_points.crotch);
  const double crotch = seg.key_points.crotch->y();
  // The right leg's label run up the outer hip to 20 cm above the crotch (the waistband is 25
  // cm above it), over the outer quarter of the hips' width there.
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t v = 0; v < trousers.mesh.vertex_count(); ++v)
    if (std::abs(trousers.mesh.positions[3 * v + 1] - crotch) < 0.03) {
      lo = std::min(lo, double(trousers.mesh.positions[3 * v]));
      hi = std::max(hi, double(trousers.mesh.positions[3 * v]));
    }
  const double mid = 0.5 * (lo + hi);
  std::vector<GarmentPart> leaked = seg.vertex_parts;
  std::size_t moved = 0;
  for (std::size_t v = 0; v < trousers.mesh.vertex_count(); ++v) {
    const Eigen::Vector3d p = point(trousers.mesh, v);
    if (leaked[v] == GarmentPart::TORSO && p.y() < crotch + 0.20 && p.x() < mid - 0.75 * (mid - lo)) {
      leaked[v] = GarmentPart::RIGHT_LEG;
      ++moved;
    }
  }
  ASSERT_GT(moved, 20u);
  for (const auto* parts : {&seg.vertex_parts, &leaked}) {
    SCOPED_TRACE(parts == &leaked ? "leaked" : "as segmented");
    const std::vector<PartSkeleton> skeletons = extract_limb_skeletons(trousers.mesh, *parts);
    ASSERT_EQ(skeletons.size(), 2u);
    const PartSkeleton& left = skeletons[0];
    const PartSkeleton& right = skeletons[1];
    ASSERT_EQ(left.part, GarmentPart::LEFT_LEG);
    const Eigen::Vector3d l = left.nodes[left.tube_start], r = right.nodes[right.tube_start];
    std::printf("tube starts: left %zu/%zu (%.4f %.4f %.4f), right %zu/%zu (%.4f %.4f %.4f); first nodes left (%.4f "
                "%.4f) right (%.4f %.4f)\n",
                left.tube_start, left.nodes.size(), l.x(), l.y(), l.z(), right.tube_start, right.nodes.size(), r.x(),
                r.y(), r.z(), left.nodes.front().x(), left.nodes.front().y(), right.nodes.front().x(),
                right.nodes.front().y());
    const double spacing = (left.nodes.front() - left.nodes.back()).norm() / double(left.nodes.size() - 1);
    // The leak is real: the right chain's own first end climbs the hip with it (2.8 cm).
    if (parts == &leaked) {
      EXPECT_GT(right.nodes.front().y() - left.nodes.front().y(), spacing / 3);
    }
    // Mirror images within a third of the legs' node spacing (about 5 cm on these trousers):
    // the two tubes start at the same ring of the crotch, not a node apart.
    EXPECT_LT(std::abs((l.x() - mid) + (r.x() - mid)), spacing / 3);
    EXPECT_LT(std::abs(l.y() - r.y()), spacing / 3);
    // Both at the crotch: within a node spacing below the crotch key point, not above it.
    EXPECT_LT(l.y(), crotch);
    EXPECT_GT(l.y(), crotch - spacing);
    EXPECT_LT(r.y(), crotch);
    EXPECT_GT(r.y(), crotch - spacing);
    // The hips' midpoint stays on the mid-plane (5 mm; measured 0.6 and 1.1 mm, and 1.6 and
    // 2.8 mm from the whole chains: this leak is too low to tilt a whole chain's axis much).
    GarmentSegmentation with = seg;
    with.vertex_parts = *parts;
    const GarmentKeyJoints k = garment_key_joints(trousers.mesh, with, skeletons);
    EXPECT_LT(std::abs(0.5 * (k.j1.x() + k.j2.x()) - mid), 0.005);
  }
}

} // namespace
} // namespace vfit
