// SPDX-License-Identifier: Apache-2.0
// Garments modelled with thickness: two sheets found, the inner one kept, the rest carried.
#include "vfit/geometry/garment/thick_shell.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/orient.h"
#include "vfit/geometry/mesh/primitives.h"

namespace vfit {
namespace {

constexpr int RINGS = 12, SEGMENTS = 48;

Mesh tube() {
  Mesh t = make_tube(RINGS, SEGMENTS, 0.1f, 0.5f);
  t.uvs.clear();
  t.uv_triangles.clear();
  return t;
}

double max_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    d = std::max(d, double(std::fabs(a[i] - b[i])));
  return d;
}

TEST(ThickShell, FindsTheInnerSheetOfAStitchedTubeAndCarriesTheOuterOne) {
  const Mesh shell_mesh = make_solidified(tube(), 0.003f, true);
  const auto shell = find_thick_shell(shell_mesh);
  ASSERT_TRUE(shell.has_value());
  // Between the faces of two 48-gons 3 mm apart: 3 mm to within the polygon's sagitta.
  EXPECT_NEAR(shell->thickness, 0.003, 1e-4);
  EXPECT_EQ(shell->sheet.vertex_count(), tube().vertex_count());
  EXPECT_EQ(shell->carried.size(), tube().vertex_count());
  for (std::int32_t v : shell->sheet_vertices)
    EXPECT_GE(v, std::int32_t(tube().vertex_count())) << "the inner copy";
  // Placing the sheet where it is gives the mesh back; a rigid motion of the sheet moves it all.
  EXPECT_LT(max_difference(place_thick_shell(*shell, shell->sheet.positions), shell_mesh.positions), 1e-6);
  const Eigen::Matrix3f R = Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.3f, 1.0f, -0.2f).normalized()).toRotationMatrix();
  const Eigen::Vector3f shift(0.2f, -1.0f, 0.4f);
  auto moved = [&](std::vector<float> p) {
    for (std::size_t v = 0; 3 * v < p.size(); ++v)
      Eigen::Vector3f::Map(&p[3 * v]) = R * Eigen::Vector3f::Map(&p[3 * v]) + shift;
    return p;
  };
  // 1e-5 m: float rounding of the rotated positions and frames, metres from the origin.
  EXPECT_LT(max_difference(place_thick_shell(*shell, moved(shell->sheet.positions)), moved(shell_mesh.positions)),
            1e-5);
}

TEST(ThickShell, FindsASheetAndItsSeparateLining) {
  const auto shell = find_thick_shell(make_solidified(tube(), 0.005f, false));
  ASSERT_TRUE(shell.has_value());
  EXPECT_NEAR(shell->thickness, 0.005, 1e-4);
  EXPECT_EQ(shell->sheet.vertex_count(), tube().vertex_count());
}

TEST(ThickShell, LeavesASingleSheetAndFarApartSheetsAlone) {
  EXPECT_FALSE(find_thick_shell(tube()).has_value());
  EXPECT_FALSE(find_thick_shell(make_solidified(tube(), 0.03f, true)).has_value())
      << "3 cm: two garments, not one thick one";
  // A closed surface that is no shell.
  EXPECT_FALSE(find_thick_shell(make_uv_sphere(16, 32, 0.2f)).has_value());
  // Catalogue garments as they come (an A-pose tee's sleeves hang within a few cm of its sides).
  for (GarmentType type : {GarmentType::TEE, GarmentType::TROUSERS}) {
    GarmentOptions o;
    o.type = type;
    o.pose = RestPose::APOSE;
    o.target_vertices = 10000;
    EXPECT_FALSE(find_thick_shell(make_garment(o).mesh).has_value()) << garment_type_name(type);
  }
}

TEST(ThickShell, FindsTheSheetsOfAThickenedCatalogueTee) {
  GarmentOptions o;
  o.type = GarmentType::TEE;
  o.target_vertices = 3000;
  const Mesh tee = make_garment(o).mesh;
  Mesh plain = tee;
  plain.uvs.clear();
  plain.uv_triangles.clear();
  for (bool stitched : {true, false}) {
    const auto shell = find_thick_shell(make_solidified(plain, 0.003f, stitched));
    ASSERT_TRUE(shell.has_value()) << (stitched ? "stitched" : "lining");
    EXPECT_NEAR(shell->thickness, 0.003, 3e-4);
    EXPECT_EQ(shell->sheet.vertex_count(), tee.vertex_count());
    // The copy is the inner sheet (offset against the tee's outward normals). Stitched, a few
    // faces at the rims' sharpest corners can fall to the other sheet's piece (3 of 3,000
    // vertices measured); they are fitted or carried with their neighbours either way.
    std::size_t copies = 0;
    for (std::int32_t v : shell->sheet_vertices)
      copies += v >= std::int32_t(tee.vertex_count());
    EXPECT_GE(double(copies), 0.99 * double(tee.vertex_count()));
  }
}

} // namespace
} // namespace vfit
