// SPDX-License-Identifier: Apache-2.0
// Garment segmentation (seed 000 §4) against the catalogue's ground-truth labels, the Reeb
// graph's structure, invariances, and inputs that are not garments.
#include "vfit/geometry/garment/segment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

struct Case {
  const char* name;
  GarmentType type;
  const char* size;
  RestPose pose;
  std::size_t vertices;
  double min_accuracy; ///< share of vertices with the reference label
};
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

// Generated once per process: about a second per 5,000 vertices.
const Garment& garment(const Case& c) {
  static std::map<std::string, Garment> cache;
  auto it = cache.find(c.name);
  if (it != cache.end()) return it->second;
  GarmentOptions o;
  o.type = c.type;
  o.size = c.size;
  o.pose = c.pose;
  o.target_vertices = c.vertices;
  return cache.emplace(c.name, make_garment(o)).first->second;
}

const GarmentSegmentation& segmentation(const Case& c) {
  static std::map<std::string, GarmentSegmentation> cache;
  auto it = cache.find(c.name);
  if (it != cache.end()) return it->second;
  return cache.emplace(c.name, segment_garment(garment(c).mesh)).first->second;
}

double agreement(const std::vector<GarmentPart>& a, const std::vector<GarmentPart>& b) {
  std::size_t same = 0;
  for (std::size_t v = 0; v < a.size(); ++v)
    same += a[v] == b[v];
  return double(same) / double(a.size());
}

// Number of edge-connected pieces of the vertices labelled `part`.
std::size_t pieces(const Mesh& m, const std::vector<GarmentPart>& parts, GarmentPart part) {
  std::vector<std::vector<std::int32_t>> nbr(m.vertex_count());
  for (std::size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      nbr[m.triangles[3 * f + k]].push_back(m.triangles[3 * f + (k + 1) % 3]);
  std::vector<char> seen(m.vertex_count(), 0);
  std::size_t count = 0;
  for (std::size_t s = 0; s < m.vertex_count(); ++s) {
    if (parts[s] != part || seen[s]) continue;
    ++count;
    std::vector<std::int32_t> stack{std::int32_t(s)};
    seen[s] = 1;
    while (!stack.empty()) {
      const std::int32_t v = stack.back();
      stack.pop_back();
      for (std::int32_t u : nbr[v])
        if (parts[u] == part && !seen[u]) {
          seen[u] = 1;
          stack.push_back(u);
        }
    }
  }
  return count;
}

class Segment : public ::testing::TestWithParam<Case> {};

TEST_P(Segment, DetectsTheTypeAndLabelsAlmostEveryVertexRight) {
  const Case& c = GetParam();
  const Garment& g = garment(c);
  const GarmentSegmentation& s = segmentation(c);
  EXPECT_EQ(s.type, c.type) << garment_type_name(s.type);
  ASSERT_EQ(s.vertex_parts.size(), g.mesh.vertex_count());
  EXPECT_GE(agreement(s.vertex_parts, g.vertex_parts), c.min_accuracy);
}

TEST_P(Segment, EachSleeveOrLegIsOneRegionOnItsOwnSide) {
  const Case& c = GetParam();
  const Mesh& m = garment(c).mesh;
  const GarmentSegmentation& s = segmentation(c);
  for (GarmentPart part :
       {GarmentPart::LEFT_SLEEVE, GarmentPart::RIGHT_SLEEVE, GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG}) {
    const std::size_t n = pieces(m, s.vertex_parts, part);
    EXPECT_LE(n, 1u) << garment_part_name(part);
  }
  // The catalogue is centred on x = 0 and +X is the wearer's left.
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const GarmentPart p = s.vertex_parts[v];
    if (p == GarmentPart::LEFT_SLEEVE || p == GarmentPart::LEFT_LEG) {
      ASSERT_GT(m.positions[3 * v], -0.01f) << v;
    }
    if (p == GarmentPart::RIGHT_SLEEVE || p == GarmentPart::RIGHT_LEG) {
      ASSERT_LT(m.positions[3 * v], 0.01f) << v;
    }
  }
}

TEST_P(Segment, ReebGraphCoversEveryVertexWithArcsBetweenBands) {
  const GarmentSegmentation& s = segmentation(GetParam());
  const ReebGraph& rg = s.reeb_graph;
  ASSERT_GE(rg.levels.size(), 9u); // at least 8 bands
  std::vector<std::size_t> counted(rg.nodes.size(), 0);
  for (std::int32_t n : rg.vertex_node) {
    ASSERT_GE(n, 0);
    ++counted[n];
  }
  for (std::size_t n = 0; n < rg.nodes.size(); ++n) {
    EXPECT_EQ(counted[n], rg.nodes[n].vertex_count);
    EXPECT_LT(rg.nodes[n].level_min, rg.nodes[n].level_max);
  }
  for (const ReebArc& a : rg.arcs)
    EXPECT_LT(rg.nodes[a.from].band, rg.nodes[a.to].band);
  // Nodes from the source's band to the last; the geodesic field is finite on a one-piece garment.
  EXPECT_EQ(rg.nodes.front().band, 0);
  EXPECT_EQ(rg.nodes.back().band, int(rg.levels.size()) - 2);
  for (double d : s.geodesic)
    ASSERT_TRUE(std::isfinite(d));
}

TEST_P(Segment, KeyPointsAndPlanesFollowTheGarment) {
  const Case& c = GetParam();
  const GarmentSegmentation& s = segmentation(c);
  const auto& k = s.key_points;
  if (c.type == GarmentType::TEE || c.type == GarmentType::LONG_SLEEVE) {
    ASSERT_TRUE(k.p1 && k.p2 && k.s1 && k.s2);
    EXPECT_LT(k.p1->x(), -0.1); // P1 is the right (−X) armpit, eq. 1
    EXPECT_GT(k.p2->x(), 0.1);
    EXPECT_NEAR(k.s2->normal.norm(), 1.0, 1e-9);
    EXPECT_GT(k.s2->normal.x(), 0.5); // the left sleeve's plane faces out along +X (T) or down-out (A)
    EXPECT_LT(k.s1->normal.x(), -0.5);
    // The armpits sit below the shoulders (the arm's axis is about 1.39 m up on this body).
    EXPECT_LT(k.p1->y(), 1.39);
    EXPECT_GT(k.p1->y(), 1.2);
  }
  if (c.type == GarmentType::TROUSERS || c.type == GarmentType::SHORTS) {
    ASSERT_TRUE(k.crotch);
    EXPECT_NEAR(k.crotch->x(), 0.0, 0.02);
    EXPECT_NEAR(k.crotch->y(), BodyMeasurements{}.crotch_height, 0.03); // eq. 3's Pt near the body's crotch
  }
  if (c.type == GarmentType::DRESS) {
    ASSERT_TRUE(k.waist_height);
    // The waist is a shallow valley of girth: coarse meshes find its floor less surely.
    EXPECT_NEAR(*k.waist_height, 0.62 * BodyMeasurements{}.height, c.vertices >= 5000 ? 0.03 : 0.07);
  }
}

// Sizes and resolutions beyond M at 5,000 vertices. The catalogue puts the sleeve boundary
// through the body's shoulder joint, which a garment's geometry does not show: the looser the
// garment, the further its armpit lies outside the joint, so tops are held to 98 % in sizes
// S–M and less at the extremes (the plane cannot follow the ease).
INSTANTIATE_TEST_SUITE_P(
    Catalogue, Segment,
    ::testing::Values(Case{"tee_M_T", GarmentType::TEE, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"tee_M_A", GarmentType::TEE, "M", RestPose::APOSE, 5000, 0.98},
                      Case{"tee_S_A", GarmentType::TEE, "S", RestPose::APOSE, 5000, 0.98},
                      Case{"tee_XS_A", GarmentType::TEE, "XS", RestPose::APOSE, 5000, 0.94},
                      Case{"long_sleeve_M_T", GarmentType::LONG_SLEEVE, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"long_sleeve_M_A", GarmentType::LONG_SLEEVE, "M", RestPose::APOSE, 5000, 0.98},
                      Case{"long_sleeve_S_T", GarmentType::LONG_SLEEVE, "S", RestPose::TPOSE, 5000, 0.98},
                      Case{"long_sleeve_L_A", GarmentType::LONG_SLEEVE, "L", RestPose::APOSE, 5000, 0.96},
                      Case{"trousers_M_T", GarmentType::TROUSERS, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"trousers_M_A", GarmentType::TROUSERS, "M", RestPose::APOSE, 5000, 0.98},
                      Case{"trousers_P1_A", GarmentType::TROUSERS, "P1", RestPose::APOSE, 5000, 0.98},
                      Case{"trousers_P2_T", GarmentType::TROUSERS, "P2", RestPose::TPOSE, 5000, 0.98},
                      // Loose: the leg tubes touch between the knees (a second, lower saddle).
                      Case{"trousers_P3_T", GarmentType::TROUSERS, "P3", RestPose::TPOSE, 5000, 0.96},
                      Case{"shorts_M_T", GarmentType::SHORTS, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"shorts_M_A", GarmentType::SHORTS, "M", RestPose::APOSE, 5000, 0.98},
                      Case{"shorts_P1_T", GarmentType::SHORTS, "P1", RestPose::TPOSE, 5000, 0.98},
                      Case{"dress_M_T", GarmentType::DRESS, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"dress_M_A", GarmentType::DRESS, "M", RestPose::APOSE, 5000, 0.98},
                      Case{"dress_XS_T", GarmentType::DRESS, "XS", RestPose::TPOSE, 5000, 0.98},
                      Case{"dress_XXL_A", GarmentType::DRESS, "XXL", RestPose::APOSE, 5000, 0.98},
                      Case{"skirt_M_T", GarmentType::SKIRT, "M", RestPose::TPOSE, 5000, 0.98},
                      Case{"skirt_XXL_A", GarmentType::SKIRT, "XXL", RestPose::APOSE, 5000, 0.98},
                      Case{"tee_M_A_1k", GarmentType::TEE, "M", RestPose::APOSE, 1000, 0.97},
                      Case{"long_sleeve_M_T_1k", GarmentType::LONG_SLEEVE, "M", RestPose::TPOSE, 1000, 0.97},
                      Case{"trousers_M_A_1k", GarmentType::TROUSERS, "M", RestPose::APOSE, 1000, 0.98},
                      Case{"shorts_M_T_1k", GarmentType::SHORTS, "M", RestPose::TPOSE, 1000, 0.97},
                      Case{"dress_M_T_1k", GarmentType::DRESS, "M", RestPose::TPOSE, 1000, 0.97},
                      Case{"skirt_M_A_1k", GarmentType::SKIRT, "M", RestPose::APOSE, 1000, 0.98},
                      Case{"trousers_M_T_100k", GarmentType::TROUSERS, "M", RestPose::TPOSE, 100000, 0.98}),
    [](const auto& p) { return std::string(p.param.name); });

const Case TEE{"tee_M_T", GarmentType::TEE, "M", RestPose::TPOSE, 5000, 0.98};
const Case TROUSERS{"trousers_M_T", GarmentType::TROUSERS, "M", RestPose::TPOSE, 5000, 0.98};

TEST(SegmentRefinement, PlanesImproveOnTheCoarseReebBranches) {
  // Seed 000 Fig. 3: the coarse branches leave the upper arms and thighs in the torso.
  for (const Case& c : {TEE, TROUSERS}) {
    const GarmentSegmentation& s = segmentation(c);
    const auto& ref = garment(c).vertex_parts;
    EXPECT_GT(agreement(s.vertex_parts, ref), agreement(s.coarse_parts, ref) + 0.05) << c.name;
  }
}

TEST(SegmentReebGraph, BranchesSplitTheBands) {
  // Past the armpits a tee's bands hold torso and both sleeves; past the crotch trousers' hold
  // two legs and nothing else.
  auto widest = [](const ReebGraph& rg) {
    std::map<int, int> per_band;
    for (const ReebNode& n : rg.nodes)
      if (n.vertex_count >= 5) ++per_band[n.band];
    int most = 0;
    for (auto [band, count] : per_band)
      most = std::max(most, count);
    return most;
  };
  EXPECT_GE(widest(segmentation(TEE).reeb_graph), 3);
  const ReebGraph& rg = segmentation(TROUSERS).reeb_graph;
  const int last = rg.nodes.back().band;
  EXPECT_EQ(std::count_if(rg.nodes.begin(), rg.nodes.end(), [&](const ReebNode& n) { return n.band == last; }), 2);
  // Somewhere a node forks into the two legs.
  bool fork = false;
  for (std::size_t n = 0; n < rg.nodes.size(); ++n) {
    const auto kids = rg.children(std::int32_t(n));
    fork |= kids.size() == 2 && rg.nodes[kids[0]].centroid.x() * rg.nodes[kids[1]].centroid.x() < 0;
  }
  EXPECT_TRUE(fork);
}

TEST(SegmentInvariance, UnitsPositionAndFaceOrientationDoNotMatter) {
  const Mesh& m = garment(TEE).mesh;
  const GarmentSegmentation& base = segmentation(TEE);
  Mesh moved = m;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    moved.positions[3 * v] = 100 * m.positions[3 * v] + 30;         // centimetres, off to the side
    moved.positions[3 * v + 1] = 100 * m.positions[3 * v + 1] - 80; // and lower
    moved.positions[3 * v + 2] = 100 * m.positions[3 * v + 2];
  }
  for (std::size_t f = 0; f < m.face_count(); f += 3)
    std::swap(moved.triangles[3 * f + 1], moved.triangles[3 * f + 2]);
  const GarmentSegmentation s = segment_garment(moved);
  EXPECT_EQ(s.type, base.type);
  EXPECT_GE(agreement(s.vertex_parts, base.vertex_parts), 0.995); // float rounding moves a few ties
}

TEST(SegmentInvariance, ExtraComponentsAreLabelledAndNamedInAWarning) {
  Mesh m = garment(TROUSERS).mesh;
  const std::size_t nv = m.vertex_count();
  Mesh button = make_uv_sphere(4, 6, 0.01f);
  for (float& p : button.positions)
    p += 0.5f; // somewhere off the garment
  for (float p : button.positions)
    m.positions.push_back(p);
  for (std::int32_t t : button.triangles)
    m.triangles.push_back(t + std::int32_t(nv));
  const GarmentSegmentation s = segment_garment(m);
  EXPECT_EQ(s.type, GarmentType::TROUSERS);
  EXPECT_GE(agreement({s.vertex_parts.begin(), s.vertex_parts.begin() + std::ptrdiff_t(nv)},
                      segmentation(TROUSERS).vertex_parts),
            0.999);
  for (std::size_t v = nv; v < m.vertex_count(); ++v)
    EXPECT_EQ(s.vertex_parts[v], GarmentPart::TORSO);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings.front().find("component"), std::string::npos);
}

Mesh rotated_to_x(Mesh m) { // Y-up tube → lying along X
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    std::swap(m.positions[3 * v], m.positions[3 * v + 1]);
  for (std::size_t f = 0; f < m.face_count(); ++f)
    std::swap(m.triangles[3 * f + 1], m.triangles[3 * f + 2]);
  return m;
}

TEST(SegmentRejects, WhatIsNotAGarment) {
  EXPECT_THROW(segment_garment(Mesh{}), Error);
  EXPECT_THROW(segment_garment(test::octahedron()), Error);                           // closed
  EXPECT_THROW(segment_garment(make_uv_sphere(16, 24, 0.3f)), Error);                 // closed
  EXPECT_THROW(segment_garment(make_grid(20, 20, 1.0f, 1.0f)), Error);                // a sheet: one opening
  EXPECT_THROW(segment_garment(rotated_to_x(make_tube(30, 24, 0.05f, 0.6f))), Error); // a lying tube
  EXPECT_THROW(segment_garment(make_tube(40, 24, 0.03f, 0.9f)), Error);               // 15 diameters tall
  Mesh bad = test::unit_square();
  bad.triangles[2] = 7;
  EXPECT_THROW(segment_garment(bad), Error); // index out of range
  Mesh nan = garment(TEE).mesh;
  nan.positions[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(segment_garment(nan), Error);
  try {
    segment_garment(make_grid(5, 5, 1.0f, 1.0f));
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("garment"), std::string::npos); // names the input
  }
}

TEST(SegmentRejects, AnUprightOpenTubeIsTakenForASkirt) {
  // The documented fallback: two level openings, one above the other, ≤ 5 diameters apart.
  const GarmentSegmentation s = segment_garment(make_tube(20, 32, 0.2f, 0.5f));
  EXPECT_EQ(s.type, GarmentType::SKIRT);
  EXPECT_TRUE(
      std::all_of(s.vertex_parts.begin(), s.vertex_parts.end(), [](GarmentPart p) { return p == GarmentPart::SKIRT; }));
}

} // namespace
} // namespace vfit
