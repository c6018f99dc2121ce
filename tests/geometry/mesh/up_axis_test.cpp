#include "geometry/mesh/up_axis.h"

#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "geometry/garment/catalogue.h"
#include "test_support.h"
#include "geometry/mesh/primitives.h"
#include "kernels/error.h"

namespace vfit {
namespace {

// The file's up vector and the file's facing direction for each axis (rotate_to_y_up()'s
// documented conventions).
Eigen::Vector3f up_vector(UpAxis up) {
  switch (up) {
  case UpAxis::POS_Y: return {0, 1, 0};
  case UpAxis::POS_Z: return {0, 0, 1};
  case UpAxis::NEG_Z: return {0, 0, -1};
  case UpAxis::NEG_Y: return {0, -1, 0};
  case UpAxis::POS_X: return {1, 0, 0};
  case UpAxis::NEG_X: return {-1, 0, 0};
  }
  return {0, 1, 0};
}
Eigen::Vector3f front_vector(UpAxis up) {
  switch (up) {
  case UpAxis::POS_Z: return {0, -1, 0}; // Blender: Z up, facing -Y
  case UpAxis::NEG_Z: return {0, 1, 0};
  default: return {0, 0, 1};
  }
}

Eigen::Vector3f rotated(Eigen::Vector3f p, UpAxis up) {
  rotate_to_y_up(std::span<float>(p.data(), 3), up);
  return p;
}

TEST(UpAxis, MapsEachFilesUpToYAndItsFrontToZByAProperRotation) {
  for (UpAxis up : UP_AXES) {
    SCOPED_TRACE(up_axis_name(up));
    // Exact: the rotations only permute and negate coordinates.
    EXPECT_EQ(rotated(up_vector(up), up), Eigen::Vector3f(0, 1, 0));
    EXPECT_EQ(rotated(front_vector(up), up), Eigen::Vector3f(0, 0, 1));
    Eigen::Matrix3f m;
    for (int c = 0; c < 3; ++c) m.col(c) = rotated(Eigen::Vector3f::Unit(c), up);
    EXPECT_EQ(m.determinant(), 1.0f); // a rotation, not a mirror: windings and normals survive
    EXPECT_TRUE((m.transpose() * m).isIdentity(0.0f));
  }
  // Many points at once, last partial triple untouched.
  std::vector<float> p = {1, 2, 3, 4, 5, 6, 7};
  rotate_to_y_up(p, UpAxis::POS_Z);
  EXPECT_EQ(p, (std::vector<float>{1, 3, -2, 4, 6, -5, 7}));
}

// Every catalogue garment type, in both poses and several sizes: read Y up as made, Z up once
// stored in Blender's frame (the inverse of rotate_to_y_up(+Z)).
TEST(UpAxis, DetectsCatalogueGarmentsStoredYUpOrZUp) {
  struct Case {
    GarmentType type;
    RestPose pose;
    const char* size;
  };
  for (const Case& c : {Case{GarmentType::TEE, RestPose::APOSE, "XL"}, Case{GarmentType::LONG_SLEEVE, RestPose::TPOSE, "S"},
                        Case{GarmentType::TROUSERS, RestPose::APOSE, "P3"}, Case{GarmentType::SHORTS, RestPose::TPOSE, "M"},
                        Case{GarmentType::DRESS, RestPose::APOSE, "XS"}, Case{GarmentType::SKIRT, RestPose::TPOSE, "XXL"}}) {
    GarmentOptions o;
    o.type = c.type;
    o.size.assign(c.size);
    o.pose = c.pose;
    o.target_vertices = 1000;
    const Mesh m = make_garment(o).mesh;
    SCOPED_TRACE(garment_type_name(c.type) + " " + c.size);
    EXPECT_EQ(detect_up_axis(m.positions, m.triangles), UpAxis::POS_Y);
    std::vector<float> z_up = m.positions;
    for (int k = 0; k < 3; ++k) rotate_to_y_up(z_up, UpAxis::POS_Z);
    EXPECT_EQ(detect_up_axis(z_up, m.triangles), UpAxis::POS_Z);
  }
}

// Shapes that are not garments say nothing rather than guess: a sphere (symmetric about every
// axis) and an empty mesh.
TEST(UpAxis, RefusesToGuessForShapesThatAreNotGarments) {
  const Mesh sphere = make_uv_sphere(16, 32, 1.0f);
  EXPECT_FALSE(detect_up_axis(sphere.positions, sphere.triangles).has_value());
  EXPECT_FALSE(detect_up_axis({}, {}).has_value());
  const auto a = mirror_asymmetry({}, {});
  EXPECT_EQ(a[0] + a[1] + a[2], 0.0);
}

// A standing body's file, mesh or point cloud, Y up or Z up: its height decides; the
// mannequin in A-pose and in T-pose (arm span ≈ height, still twice the depth).
TEST(UpAxis, DetectsStandingBodiesByTheirHeight) {
  for (RestPose pose : {RestPose::APOSE, RestPose::TPOSE}) {
    const Body& body = test::mannequin(pose, 4000);
    SCOPED_TRACE(pose == RestPose::APOSE ? "A-pose" : "T-pose");
    EXPECT_EQ(detect_body_up_axis(body.mesh.positions, body.mesh.triangles), UpAxis::POS_Y);
    std::vector<float> z_up = body.mesh.positions;
    for (int k = 0; k < 3; ++k) rotate_to_y_up(z_up, UpAxis::POS_Z);
    EXPECT_EQ(detect_body_up_axis(z_up, body.mesh.triangles), UpAxis::POS_Z);
    EXPECT_EQ(detect_body_up_axis(z_up, {}), UpAxis::POS_Z); // a point cloud
  }
}

TEST(UpAxis, ParsesNamesAndRejectsOthers) {
  for (UpAxis up : UP_AXES)
    EXPECT_EQ(parse_up_axis(up_axis_name(up)), up);
  EXPECT_EQ(parse_up_axis("Z"), UpAxis::POS_Z);
  EXPECT_EQ(parse_up_axis("y"), UpAxis::POS_Y);
  EXPECT_EQ(parse_up_axis("-X"), UpAxis::NEG_X);
  for (const char* bad : {"", "w", "up", "+yz", "--z"}) {
    try {
      (void)parse_up_axis(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("up axis"), std::string::npos) << e.what();
    }
  }
}

} // namespace
} // namespace vfit
