// SPDX-License-Identifier: Apache-2.0
// Coarse move (seed 000 §6.1, eq. 16–17): a catalogue garment made for the mannequin lands on
// it, wherever it starts; the move is a pure translation.
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.h"

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/garment/coarse_move.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/garment/skeleton_parts.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

const Body& mannequin() { return test::mannequin(RestPose::APOSE, 3000); }

Garment catalogue(GarmentType type) {
  GarmentOptions o;
  o.type = type;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2000;
  return make_garment(o);
}

CoarseMove move_of(const Mesh& mesh) {
  const GarmentSegmentation seg = segment_garment(mesh);
  const auto skeletons = extract_limb_skeletons(mesh, seg.vertex_parts);
  return compute_coarse_move(seg.type, seg.key_points, skeletons, mannequin().joints);
}

struct Case {
  GarmentType type;
  CoarseMoveRule rule;
};

class CoarseMoveTest : public ::testing::TestWithParam<Case> {};

TEST_P(CoarseMoveTest, BringsAShiftedCatalogueGarmentBackOntoTheMannequin) {
  Garment g = catalogue(GetParam().type);
  const CoarseMove in_place = move_of(g.mesh);
  EXPECT_EQ(in_place.rule, GetParam().rule);
  // The catalogue garment is generated around this mannequin, so the ideal move is zero.
  // 6 cm: eq. 16–17 compare the sleeve/leg roots (centroids of the first skeleton node's
  // vertices) with joint centres; in A-pose a sleeve root lies along the slanted arm, 3–5 cm
  // below the shoulder joint depending on resolution, and eq. 16 lifts the tee by that much.
  EXPECT_LT(in_place.translation.norm(), 0.06) << in_place.translation.transpose();

  const Eigen::Vector3d shift(0.21, -0.37, 0.13);
  translate_positions(g.mesh.positions, shift);
  const CoarseMove shifted = move_of(g.mesh);
  EXPECT_EQ(shifted.rule, GetParam().rule);
  // Segmentation and skeletons are translation invariant; 1 mm covers float rounding of the
  // shifted coordinates through the geodesics and the contraction.
  EXPECT_LT((shifted.translation - (in_place.translation - shift)).norm(), 1e-3)
      << shifted.translation.transpose() << " vs " << (in_place.translation - shift).transpose();
  EXPECT_LT((shifted.body_anchor - in_place.body_anchor).norm(), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Catalogue, CoarseMoveTest,
                         ::testing::Values(Case{GarmentType::TEE, CoarseMoveRule::SLEEVE_ROOTS_TO_SHOULDERS},
                                           Case{GarmentType::TROUSERS, CoarseMoveRule::LEG_ROOTS_TO_HIPS}),
                         [](const auto& param_info) { return garment_type_name(param_info.param.type); });

TEST(CoarseMove, FallsBackToTheSourceOpeningWithoutSkeletons) {
  SegmentationKeyPoints kp;
  kp.source = Eigen::Vector3d(0.1, 1.2, 0.05);
  const JointPositions& j = mannequin().joints;
  const CoarseMove top = compute_coarse_move(GarmentType::DRESS, kp, {}, j);
  EXPECT_EQ(top.rule, CoarseMoveRule::COLLAR_TO_NECK);
  EXPECT_TRUE(top.translation.isApprox(j.row(idx(Joint::NECK)).transpose() - kp.source));
  const CoarseMove skirt = compute_coarse_move(GarmentType::SKIRT, kp, {}, j);
  EXPECT_EQ(skirt.rule, CoarseMoveRule::WAISTBAND_TO_PELVIS);
  const Eigen::Vector3d waist = 0.5 * (j.row(idx(Joint::PELVIS)) + j.row(idx(Joint::SPINE1))).transpose();
  EXPECT_TRUE(skirt.translation.isApprox(waist - kp.source));
}

TEST(CoarseMove, UsesBothRootsOrNeither) {
  // One sleeve skeleton alone is not a pair of key joints: fall back rather than halve it.
  PartSkeleton left;
  left.part = GarmentPart::LEFT_SLEEVE;
  left.nodes = {Eigen::Vector3d(0.2, 1.4, 0.0)};
  SegmentationKeyPoints kp;
  kp.source = Eigen::Vector3d(0, 1.5, 0);
  const std::vector<PartSkeleton> one{left};
  EXPECT_EQ(compute_coarse_move(GarmentType::TEE, kp, one, mannequin().joints).rule, CoarseMoveRule::COLLAR_TO_NECK);
  PartSkeleton right = left;
  right.part = GarmentPart::RIGHT_SLEEVE;
  right.nodes = {Eigen::Vector3d(-0.2, 1.2, 0.1)};
  const std::vector<PartSkeleton> two{left, right};
  const CoarseMove m = compute_coarse_move(GarmentType::TEE, kp, two, mannequin().joints);
  EXPECT_EQ(m.rule, CoarseMoveRule::SLEEVE_ROOTS_TO_SHOULDERS);
  EXPECT_TRUE(m.garment_anchor.isApprox(Eigen::Vector3d(0, 1.3, 0.05)));
}

TEST(CoarseMove, TranslatesEveryVertex) {
  std::vector<float> p = {0, 0, 0, 1, 2, 3};
  translate_positions(p, Eigen::Vector3d(0.5, -1, 2));
  EXPECT_EQ(p, (std::vector<float>{0.5f, -1, 2, 1.5f, 1, 5}));
}

// contact_translation(): bodies of revolution about Y from 0 to 1 m (make_tube's open tube,
// 41 rings × 64 segments, each ring scaled to the profile's radius), and "garments" that are
// rings of points around them, 0.3 to 0.7 m up.
struct Trunk {
  Mesh mesh;
  std::unique_ptr<ProximityIndex> index;
};
template <class Radius> Trunk make_trunk(Radius radius) {
  Trunk t;
  t.mesh = make_tube(41, 64, 1.0f, 1.0f);
  for (std::size_t i = 0; i + 2 < t.mesh.positions.size(); i += 3) {
    const auto r = static_cast<float>(radius(double(t.mesh.positions[i + 1])));
    t.mesh.positions[i] *= r;
    t.mesh.positions[i + 2] *= r;
  }
  t.index = std::make_unique<ProximityIndex>(t.mesh.positions, t.mesh.triangles);
  return t;
}
double cylinder_radius(double) { return 0.1; }
// Widest (0.13 m) half way up, like hips: a garment around it is held in height.
double barrel_radius(double y) { return 0.1 + 0.03 * std::sin(3.14159265358979 * y); }
// Narrowing steadily upwards, like a waist above the hips (the slope that lifted garments).
double cone_radius(double y) { return 0.12 - 0.04 * y; }

const Trunk& cylinder() {
  static const Trunk t = make_trunk(cylinder_radius);
  return t;
}
const Trunk& barrel() {
  static const Trunk t = make_trunk(barrel_radius);
  return t;
}
const Trunk& cone() {
  static const Trunk t = make_trunk(cone_radius);
  return t;
}

// 5 rings of 48 points, at heights 0.3 to 0.7 m (before `centre`), each of radius
// profile(height) + offset, then moved by `centre`.
template <class Radius>
std::vector<float> ring_of_points(Radius profile, double offset, const Eigen::Vector3d& centre) {
  std::vector<float> p;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 48; ++j) {
      const double phi = 2 * 3.14159265358979 * (j + 0.5) / 48, y = 0.3 + 0.1 * i;
      const double r = profile(y) + offset;
      const Eigen::Vector3d x = centre + Eigen::Vector3d(r * std::sin(phi), y, r * std::cos(phi));
      p.insert(p.end(), {float(x.x()), float(x.y()), float(x.z())});
    }
  return p;
}

// Within this of the exact answer (m): the 64-gon lies up to r(1 − cos(π/64)) = 0.15 mm inside
// the circle (r ≤ 0.13 m), the profile's 2.5 cm rings cut its curve by up to 0.1 mm, and the
// iteration stops once a round moves less than 0.1 mm.
constexpr double CONTACT_TOLERANCE = 0.5e-3;

TEST(ContactTranslation, LeavesAGarmentModelledIntoTheBodyInPlace) {
  // A garment modelled on its body a few mm into it (the MakeHuman jeans sit 8 mm in) is where
  // it belongs: on the barrel, whose girth holds it in height, and on the cone, narrowing
  // upwards like a waist, where pushing every point out (the rule before the envelope fit)
  // lifted it by 5 mm / 0.04 = 12.5 cm.
  for (double offset : {-0.005}) {
    const Eigen::Vector3d d = contact_translation(ring_of_points(barrel_radius, offset, {0, 0, 0}), *barrel().index);
    EXPECT_LT(d.norm(), CONTACT_TOLERANCE) << "barrel, offset " << offset << ": " << d.transpose();
    const Eigen::Vector3d e = contact_translation(ring_of_points(cone_radius, offset, {0, 0, 0}), *cone().index);
    EXPECT_LT(e.norm(), CONTACT_TOLERANCE) << "cone, offset " << offset << ": " << e.transpose();
  }
}

TEST(ContactTranslation, BringsAGarmentFiveCentimetresOffBackIntoContact) {
  // A ring that fits the cylinder, 5 cm off its axis towards +X: its −X side 5 cm inside the
  // body, its +X side 5 cm out. It is brought back onto the body all round.
  const Eigen::Vector3d d = contact_translation(ring_of_points(cylinder_radius, 0.0, {0.05, 0, 0}), *cylinder().index);
  EXPECT_NEAR(d.x(), -0.05, CONTACT_TOLERANCE);
  EXPECT_NEAR(d.y(), 0.0, CONTACT_TOLERANCE); // nothing constrains the axis: it stays put
  EXPECT_NEAR(d.z(), 0.0, CONTACT_TOLERANCE);
  // A ring cut for the barrel's hips, 3 cm too high and 2 cm to −Z (a hip height estimated
  // off): along the trunk the barrel's girth says where it belongs.
  const Eigen::Vector3d e = contact_translation(ring_of_points(barrel_radius, 0.0, {0, 0.03, -0.02}), *barrel().index);
  EXPECT_NEAR(e.x(), 0.0, CONTACT_TOLERANCE);
  EXPECT_NEAR(e.y(), -0.03, 2 * CONTACT_TOLERANCE); // the girth changes slowly near the widest point
  EXPECT_NEAR(e.z(), 0.02, CONTACT_TOLERANCE);
}

TEST(ContactTranslation, CentresAGarmentPressedInAllRound) {
  // A ring smaller than the body, 1 cm off its axis towards +Z, inside everywhere: the envelope
  // is level when it is centred on the body.
  const Eigen::Vector3d d =
      contact_translation(ring_of_points(cylinder_radius, -0.01, {0, 0, 0.01}), *cylinder().index);
  EXPECT_NEAR(d.x(), 0.0, CONTACT_TOLERANCE);
  EXPECT_NEAR(d.y(), 0.0, CONTACT_TOLERANCE);
  EXPECT_NEAR(d.z(), -0.01, CONTACT_TOLERANCE);
}

TEST(ContactTranslation, LeavesAGarmentTouchingNothing) {
  // Larger than the body and off its axis, but outside it everywhere: no contact to level.
  EXPECT_TRUE(contact_translation(ring_of_points(cylinder_radius, 0.05, {0.02, 0, -0.01}), *cylinder().index).isZero());
}

TEST(ContactTranslation, IsZeroWithoutPoints) {
  EXPECT_TRUE(contact_translation(std::vector<float>{}, *cylinder().index).isZero());
  ContactMoveOptions none;
  none.max_iterations = 0;
  EXPECT_TRUE(
      contact_translation(ring_of_points(cylinder_radius, 0.0, {0.05, 0, 0}), *cylinder().index, none).isZero());
}

} // namespace
} // namespace vfit
