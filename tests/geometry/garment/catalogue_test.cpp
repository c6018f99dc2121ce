// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/table1.h"

#include <map>

#include <gtest/gtest.h>

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/geometry/mesh/validate.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

struct Case {
  const char* name;
  GarmentType type;
  const char* size;
  RestPose pose;
  std::size_t vertices;
};
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

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

class Catalogue : public ::testing::TestWithParam<Case> {};

void is_one_open_manifold_surface_with_its_openings(const Case& param) {
  const Garment& g = garment(param);
  EXPECT_EQ(g.mesh.vertex_count(), param.vertices); // exact: decimated to the request
  const TopologyReport t = analyse_topology(g.mesh.triangle_view(), g.mesh.vertex_count());
  EXPECT_TRUE(t.manifold());
  EXPECT_TRUE(t.oriented());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.boundary_loops, expected_openings(param.type));
  EXPECT_EQ(t.unreferenced_vertices, 0u);
  // Valid as a file would be: no degenerate or duplicate faces, UV indices in range.
  Mesh copy = g.mesh;
  MeshSource src{"garment", false, {}};
  std::vector<std::string> warnings;
  EXPECT_NO_THROW(validate_mesh(copy, src, {}, warnings));
}

void normals_point_away_from_the_body_and_cloth_stays_outside(const Case& param) {
  const Garment& g = garment(param);
  const MannequinShape body(BodyMeasurements{}, param.pose);
  std::size_t outward = 0;
  const Mesh& m = g.mesh;
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    Eigen::Vector3d p[3];
    for (int k = 0; k < 3; ++k)
      p[k] = Eigen::Vector3d(m.positions[3 * m.triangles[3 * f + k]], m.positions[3 * m.triangles[3 * f + k] + 1],
                             m.positions[3 * m.triangles[3 * f + k] + 2]);
    const Eigen::Vector3d c = (p[0] + p[1] + p[2]) / 3, n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double h = 1e-4;
    const Eigen::Vector3d grad((body.distance(c.x() + h, c.y(), c.z()) - body.distance(c.x() - h, c.y(), c.z())),
                               (body.distance(c.x(), c.y() + h, c.z()) - body.distance(c.x(), c.y() - h, c.z())),
                               (body.distance(c.x(), c.y(), c.z() + h) - body.distance(c.x(), c.y(), c.z() - h)));
    outward += n.dot(grad) > 0;
  }
  // Loose cloth folds around concave spots (armpits, crotch) where the body's gradient turns;
  // 97 % of faces facing away from the body is far from a flipped mesh (0 %).
  EXPECT_GT(double(outward) / double(m.face_count()), 0.97);
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    ASSERT_GT(body.distance(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]), 0.0) << "vertex " << v;
}

// The catalogue's garments are built around the mannequin's implicit shape; the meshed
// mannequin (make_mannequin: meshed, decimated, then its girths calibrated) must not poke
// through them either. 1 mm: the meshed surface's chords and calibration bands may graze the
// cloth's clearance, never more.
void cloth_stays_outside_the_meshed_mannequin(const Case& param) {
  static std::map<RestPose, Body> bodies;
  if (!bodies.contains(param.pose)) {
    MannequinOptions o;
    o.pose = param.pose;
    bodies.emplace(param.pose, make_mannequin(o));
  }
  const Body& body = bodies.at(param.pose);
  const ProximityIndex index(body.mesh.positions, body.mesh.triangles);
  ClosestHits hits;
  const Mesh& m = garment(param).mesh;
  index.closest_points(m.positions, 0.05f, hits);
  std::size_t inside = 0;
  float deepest = 0;
  for (std::size_t v = 0; v < hits.size(); ++v)
    if (hits.signed_distances[v] < -1e-3f) {
      ++inside;
      deepest = std::min(deepest, hits.signed_distances[v]);
    }
  EXPECT_EQ(inside, 0u) << "deepest " << -1000 * deepest << " mm";
}

void labels_and_uvs_cover_every_part(const Case& param) {
  const Garment& g = garment(param);
  ASSERT_EQ(g.vertex_parts.size(), g.mesh.vertex_count());
  std::map<GarmentPart, std::size_t> count;
  for (GarmentPart p : g.vertex_parts)
    ++count[p];
  std::vector<GarmentPart> want;
  switch (param.type) {
  case GarmentType::TEE:
  case GarmentType::LONG_SLEEVE:
    want = {GarmentPart::TORSO, GarmentPart::LEFT_SLEEVE, GarmentPart::RIGHT_SLEEVE};
    break;
  case GarmentType::TROUSERS:
  case GarmentType::SHORTS: want = {GarmentPart::TORSO, GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG}; break;
  case GarmentType::DRESS: want = {GarmentPart::TORSO, GarmentPart::SKIRT}; break;
  case GarmentType::SKIRT: want = {GarmentPart::SKIRT}; break;
  }
  EXPECT_EQ(count.size(), want.size());
  for (GarmentPart p : want)
    EXPECT_GT(count[p], g.mesh.vertex_count() / 20) << garment_part_name(p);
  // Left parts are on the body's left (+X).
  for (std::size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    const GarmentPart p = g.vertex_parts[v];
    if (p == GarmentPart::LEFT_SLEEVE || p == GarmentPart::LEFT_LEG) {
      ASSERT_GT(g.mesh.positions[3 * v], 0.0f);
    }
    if (p == GarmentPart::RIGHT_SLEEVE || p == GarmentPart::RIGHT_LEG) {
      ASSERT_LT(g.mesh.positions[3 * v], 0.0f);
    }
  }
  ASSERT_TRUE(g.mesh.has_uvs());
  for (float u : g.mesh.uvs) {
    ASSERT_GE(u, 0.0f);
    ASSERT_LE(u, 1.0f);
  }
  ASSERT_EQ(g.mesh.face_labels.size(), g.mesh.face_count());
}

// One test per case: each case builds its mesh once (tests run in separate processes).
TEST_P(Catalogue, MeetsEveryBar) {
  {
    SCOPED_TRACE("IsOneOpenManifoldSurfaceWithItsOpenings");
    is_one_open_manifold_surface_with_its_openings(GetParam());
  }
  {
    SCOPED_TRACE("NormalsPointAwayFromTheBodyAndClothStaysOutside");
    normals_point_away_from_the_body_and_cloth_stays_outside(GetParam());
  }
  {
    SCOPED_TRACE("LabelsAndUvsCoverEveryPart");
    labels_and_uvs_cover_every_part(GetParam());
  }
  {
    SCOPED_TRACE("ClothStaysOutsideTheMeshedMannequin");
    cloth_stays_outside_the_meshed_mannequin(GetParam());
  }
}

INSTANTIATE_TEST_SUITE_P(
    Garments, Catalogue,
    ::testing::Values(Case{"tee_M_tpose", GarmentType::TEE, "M", RestPose::TPOSE, 1500},
                      Case{"tee_XS_apose", GarmentType::TEE, "XS", RestPose::APOSE, 2000},
                      // The short sleeve's cuff plane crosses the torso's side under a wide
                      // A-pose arm: that side keeps its cloth (no holes).
                      Case{"tee_XL_apose", GarmentType::TEE, "XL", RestPose::APOSE, 1500},
                      Case{"long_sleeve_L_apose", GarmentType::LONG_SLEEVE, "L", RestPose::APOSE, 3000},
                      Case{"trousers_P2_tpose", GarmentType::TROUSERS, "P2", RestPose::TPOSE, 2500},
                      Case{"shorts_S_apose", GarmentType::SHORTS, "S", RestPose::APOSE, 1000},
                      // 16 cm of thigh ease where the thighs nearly touch: legs cut apart at the
                      // mid-plane (they grew into one tube with one hem, and generation failed).
                      Case{"shorts_P4_tpose", GarmentType::SHORTS, "P4", RestPose::TPOSE, 1500},
                      Case{"dress_M_apose", GarmentType::DRESS, "M", RestPose::APOSE, 4000},
                      Case{"skirt_XXL_tpose", GarmentType::SKIRT, "XXL", RestPose::TPOSE, 1200},
                      Case{"tee_M_20k", GarmentType::TEE, "M", RestPose::TPOSE, 20000}),
    [](const auto& p) { return std::string(p.param.name); });

TEST(CatalogueSizes, TrouserSizesGrowFromP1ToP4AndP4IsWiderThanTheHips) {
  const BodyMeasurements body;
  double previous = 0;
  for (const char* size : {"P1", "P2", "P3", "P4"}) {
    const Ease e = size_ease(size);
    EXPECT_GT(e.waist + e.hip + e.thigh, previous) << size;
    previous = e.waist + e.hip + e.thigh;
  }
  // P4's waistband is larger than the body's hips: nothing holds it up (seed 000 Fig. 13).
  EXPECT_GT(body.waist + size_ease("P4").waist, body.hip);
  EXPECT_LT(body.waist + size_ease("P3").waist, body.hip);
  EXPECT_THROW(size_ease("XXXL"), Error);
  EXPECT_THROW(parse_garment_type("cape"), Error);
  GarmentOptions o;
  o.target_vertices = 500;
  EXPECT_THROW(make_garment(o), Error);
}

} // namespace
} // namespace vfit

namespace vfit {
namespace {

TEST(Table1Twins, NineRowsWithThePapersCountsAndKnownPoses) {
  const auto& rows = table1_rows();
  ASSERT_EQ(rows.size(), 9u);
  double total = 0;
  for (const auto& r : rows) {
    total += r.paper_total_ms;
    EXPECT_NO_THROW(named_pose(r.body_pose, RestPose::APOSE)) << r.garment;
    // The paper's totals include small unlisted steps (coarse move): a few ms above the columns.
    const double columns = r.paper_segmentation_ms + r.paper_deformation_ms + r.paper_penetration_ms;
    if (r.garment == "Pant 2") { // the paper prints a total below its own columns (6593 ms): kept as printed
      EXPECT_LT(r.paper_total_ms, columns);
      continue;
    }
    EXPECT_GE(r.paper_total_ms, columns) << r.garment;
    EXPECT_LE(r.paper_total_ms, columns + 20) << r.garment;
    EXPECT_NO_THROW(size_ease(r.size));
  }
  EXPECT_EQ(rows[4].size, "P1");
  EXPECT_EQ(rows[6].size, "P3");
  EXPECT_NEAR(total, 72830, 1.0); // the sum of the paper's Total column
  // One twin generated: the paper's vertex count exactly.
  const Garment g = make_garment(table1_garment_options(rows[7]));
  EXPECT_EQ(g.mesh.vertex_count(), 3062u);
}

} // namespace
} // namespace vfit
