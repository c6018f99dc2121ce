// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/body/mannequin.h"

#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "vfit/geometry/body/cross_section.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

struct Case {
  const char* name;
  const char* preset;
  RestPose pose;
  std::size_t vertices;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

// Generated once per case: the mannequin takes about a second in a release build.
const Body& mannequin(const Case& c) {
  static std::map<std::string, Body> cache;
  auto it = cache.find(c.name);
  if (it != cache.end()) return it->second;
  MannequinOptions o;
  o.measurements = body_preset(c.preset);
  o.pose = c.pose;
  o.target_vertices = c.vertices;
  return cache.emplace(c.name, make_mannequin(o)).first->second;
}

// Generalised winding number of a closed mesh around p: 1 inside, 0 outside.
double winding_number(const Mesh& m, const Eigen::Vector3d& p) {
  double total = 0;
  for (std::size_t f = 0; f < m.face_count(); ++f) {
    Eigen::Vector3d v[3];
    for (int k = 0; k < 3; ++k) {
      const float* q = &m.positions[3 * static_cast<std::size_t>(m.triangles[3 * f + k])];
      v[k] = Eigen::Vector3d(q[0], q[1], q[2]) - p;
    }
    const double la = v[0].norm(), lb = v[1].norm(), lc = v[2].norm();
    const double num = v[0].dot(v[1].cross(v[2]));
    const double den = la * lb * lc + v[0].dot(v[1]) * lc + v[1].dot(v[2]) * la + v[2].dot(v[0]) * lb;
    total += 2 * std::atan2(num, den);
  }
  return total / (4 * M_PI);
}

class MannequinGrid : public ::testing::TestWithParam<Case> {};

void is_watertight_manifold_oriented_genus_zero(const Case& param) {
  const Body& b = mannequin(param);
  EXPECT_EQ(b.mesh.vertex_count(), param.vertices);
  const TopologyReport t = analyse_topology(b.mesh.triangle_view(), b.mesh.vertex_count());
  EXPECT_TRUE(t.watertight());
  EXPECT_TRUE(t.manifold());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler_characteristic, 2);
  // Outward orientation: the signed volume is positive.
  double volume = 0;
  for (std::size_t f = 0; f < b.mesh.face_count(); ++f) {
    Eigen::Vector3d v[3];
    for (int k = 0; k < 3; ++k) {
      const float* q = &b.mesh.positions[3 * static_cast<std::size_t>(b.mesh.triangles[3 * f + k])];
      v[k] = Eigen::Vector3d(q[0], q[1], q[2]);
    }
    volume += v[0].dot(v[1].cross(v[2])) / 6.0;
  }
  // A 1.55–1.88 m adult displaces roughly 0.04–0.1 m³.
  EXPECT_GT(volume, 0.03);
  EXPECT_LT(volume, 0.12);
}

void reproduces_every_requested_measurement(const Case& param) {
  const Body& b = mannequin(param);
  const BodyMeasurements want = body_preset(param.preset);
  const MeasuredBody got = measure_body(b.mesh, b.joints);
  for (std::string_view n : BodyMeasurements::names())
    EXPECT_NEAR(got.values[n] / want[n], 1.0, 0.01) << n << ": requested " << want[n] << ", measured " << got.values[n];
  // Girths are calibrated much tighter than the 1 % bar.
  for (std::string_view n : {"chest", "waist", "hip", "thigh", "calf"})
    EXPECT_NEAR(got.values[n] / want[n], 1.0, 0.003) << n;
}

// The mannequin is left–right symmetric: its mirror image (x → −x, joints swapped) measures
// nearly the same calf, and the legs' sections agree. Not exactly: the two sides are meshed and
// decimated independently (measured: calf within 1.3 %, sections 5 and 15 cm below the crotch
// within 3.3 %). The bars catch one leg calibrated on its own (it came out 12–20 % wider). The
// thigh girth itself is not compared: its landmark is the largest section in the 8 cm under
// the crotch, which lands in the saddle's last half centimetre, where a body and its mirror
// image measure 5–15 % apart (a known limitation of that landmark rule).
void both_sides_measure_the_same(const Case& param) {
  const Body& b = mannequin(param);
  Mesh mirrored = b.mesh;
  for (std::size_t v = 0; v < mirrored.vertex_count(); ++v)
    mirrored.positions[3 * v] = -mirrored.positions[3 * v];
  for (std::size_t f = 0; f < mirrored.face_count(); ++f)
    std::swap(mirrored.triangles[3 * f + 1], mirrored.triangles[3 * f + 2]);
  JointPositions joints = b.joints;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    joints.row(j) = b.joints.row(mirrored_joint(j));
    joints(j, 0) = -joints(j, 0);
  }
  const MeasuredBody left = measure_body(b.mesh, b.joints), right = measure_body(mirrored, joints);
  EXPECT_NEAR(right.values.calf / left.values.calf, 1.0, 0.02);
  // Away from the landmarks too: the legs' sections 5 and 15 cm below the crotch.
  for (double below : {0.05, 0.15}) {
    const double y = left.landmarks.crotch - below;
    const Eigen::RowVector3d lk = b.joints.row(idx(Joint::LEFT_KNEE)), rk = b.joints.row(idx(Joint::RIGHT_KNEE));
    const double gl = girth_around(b.mesh, y, 0.5 * (b.joints(idx(Joint::LEFT_HIP), 0) + lk.x()), lk.z());
    const double gr = girth_around(b.mesh, y, 0.5 * (b.joints(idx(Joint::RIGHT_HIP), 0) + rk.x()), rk.z());
    EXPECT_NEAR(gr / gl, 1.0, 0.04) << below << " m below the crotch";
  }
}

void joints_lie_inside_the_body(const Case& param) {
  const Body& b = mannequin(param);
  for (int j = 0; j < JOINT_COUNT; ++j)
    EXPECT_NEAR(winding_number(b.mesh, b.joints.row(j).transpose()), 1.0, 1e-3) << joint_name(j);
}

void skin_weights_are_normalised_and_smooth(const Case& param) {
  const Body& b = mannequin(param);
  EXPECT_NO_THROW(validate_skin_weights(b.weights, b.mesh.vertex_count(), "mannequin"));
  // Smoothness: no joint's weight changes faster than 1 per 2 cm along the surface: bones
  // blend over a few centimetres at every resolution (a hard partition would jump by 1 across
  // one edge: 100 per metre on a 7k body).
  auto weight = [&](std::size_t v, int j) {
    double s = 0;
    for (int k = 0; k < 4; ++k)
      if (b.weights.joints[4 * v + k] == j) s += b.weights.weights[4 * v + k];
    return s;
  };
  double worst = 0;
  for (std::size_t f = 0; f < b.mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::size_t u = b.mesh.triangles[3 * f + k], v = b.mesh.triangles[3 * f + (k + 1) % 3];
      const float* a = &b.mesh.positions[3 * u];
      const float* c = &b.mesh.positions[3 * v];
      const double len = std::sqrt(double(a[0] - c[0]) * (a[0] - c[0]) + double(a[1] - c[1]) * (a[1] - c[1]) +
                                   double(a[2] - c[2]) * (a[2] - c[2]));
      for (int j = 0; j < JOINT_COUNT; ++j)
        worst = std::max(worst, std::abs(weight(u, j) - weight(v, j)) / len);
    }
  EXPECT_LT(worst, 50.0) << "per metre";
}

void rest_pose_skinning_returns_the_rest_mesh(const Case& param) {
  const Body& b = mannequin(param);
  const Body posed = pose_body(b, Pose{});
  EXPECT_EQ(posed.mesh.positions, b.mesh.positions);
  Pose raise;
  raise.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0, 0, 0.6;
  const Body raised = pose_body(b, raise);
  // The right side does not move; the left wrist does.
  EXPECT_TRUE(raised.joints.row(idx(Joint::RIGHT_WRIST)).isApprox(b.joints.row(idx(Joint::RIGHT_WRIST)), 1e-12));
  EXPECT_GT((raised.joints.row(idx(Joint::LEFT_WRIST)) - b.joints.row(idx(Joint::LEFT_WRIST))).norm(), 0.1);
}

// One test per case: each case builds its mesh once (tests run in separate processes).
TEST_P(MannequinGrid, MeetsEveryBar) {
  {
    SCOPED_TRACE("IsWatertightManifoldOrientedGenusZero");
    is_watertight_manifold_oriented_genus_zero(GetParam());
  }
  {
    SCOPED_TRACE("ReproducesEveryRequestedMeasurement");
    reproduces_every_requested_measurement(GetParam());
  }
  {
    SCOPED_TRACE("BothSidesMeasureTheSame");
    both_sides_measure_the_same(GetParam());
  }
  {
    SCOPED_TRACE("JointsLieInsideTheBody");
    joints_lie_inside_the_body(GetParam());
  }
  {
    SCOPED_TRACE("SkinWeightsAreNormalisedAndSmooth");
    skin_weights_are_normalised_and_smooth(GetParam());
  }
  {
    SCOPED_TRACE("RestPoseSkinningReturnsTheRestMesh");
    rest_pose_skinning_returns_the_rest_mesh(GetParam());
  }
}

INSTANTIATE_TEST_SUITE_P(Bodies, MannequinGrid,
                         ::testing::Values(Case{"average_apose_7k", "average", RestPose::APOSE, 7000},
                                           Case{"pear_tpose_3k", "pear", RestPose::TPOSE, 3000},
                                           Case{"apple_apose_1k", "apple", RestPose::APOSE, 1000},
                                           Case{"tall_tpose_20k", "tall", RestPose::TPOSE, 20000},
                                           Case{"petite_apose_7k", "petite", RestPose::APOSE, 7000}),
                         [](const auto& p) { return std::string(p.param.name); });

// MannequinShape::uncalibrated() promises the calibrated shape's skeleton and the shapes the
// calibration does not touch, bit for bit (the keypoint model reads them from it): compared
// exactly, on two presets and both rest poses.
TEST(MannequinShape, UncalibratedKeepsTheSkeletonAndTheShapesCalibrationLeaves) {
  for (const auto& [preset, pose] : {std::pair{"average", RestPose::TPOSE}, std::pair{"pear", RestPose::APOSE},
                                     std::pair{"tall", RestPose::APOSE}}) {
    SCOPED_TRACE(preset);
    const BodyMeasurements m = body_preset(preset);
    const MannequinShape calibrated(m, pose), raw = MannequinShape::uncalibrated(m, pose);
    EXPECT_EQ(raw.joints(), calibrated.joints());
    ASSERT_EQ(raw.bone_segments().size(), calibrated.bone_segments().size());
    for (std::size_t i = 0; i < raw.bone_segments().size(); ++i) {
      EXPECT_EQ(raw.bone_segments()[i].a, calibrated.bone_segments()[i].a);
      EXPECT_EQ(raw.bone_segments()[i].b, calibrated.bone_segments()[i].b);
    }
    auto untouched = [](int joint) {
      const Joint j = static_cast<Joint>(joint);
      return j != Joint::LEFT_HIP && j != Joint::RIGHT_HIP && j != Joint::LEFT_KNEE && j != Joint::RIGHT_KNEE;
    };
    ASSERT_EQ(raw.ellipsoids().size(), calibrated.ellipsoids().size());
    int compared = 0;
    for (std::size_t i = 0; i < raw.ellipsoids().size(); ++i) {
      const Ellipsoid &a = raw.ellipsoids()[i], &b = calibrated.ellipsoids()[i];
      EXPECT_EQ(a.joint, b.joint);
      if (!untouched(a.joint)) continue; // buttocks: scaled with the hip girth
      EXPECT_EQ(a.centre, b.centre);
      EXPECT_EQ(a.axes, b.axes);
      EXPECT_EQ(a.radii, b.radii);
      ++compared;
    }
    EXPECT_EQ(compared, 5); // head, two hands, two feet
    ASSERT_EQ(raw.cones().size(), calibrated.cones().size());
    for (std::size_t i = 0; i < raw.cones().size(); ++i) {
      const RoundCone &a = raw.cones()[i], &b = calibrated.cones()[i];
      EXPECT_EQ(a.joint, b.joint);
      if (!untouched(a.joint)) continue; // thighs and calves: scaled with their girths
      EXPECT_EQ(a.p, b.p);
      EXPECT_EQ(a.q, b.q);
      EXPECT_EQ(a.rp, b.rp);
      EXPECT_EQ(a.rq, b.rq);
    }
    // And it is the uncalibrated body: the torso as first placed differs from the calibrated one.
    const double y = calibrated.joints()(idx(Joint::SPINE3), 1);
    EXPECT_NE(raw.torso_section(y).a, calibrated.torso_section(y).a);
  }
}

// distance() skips shapes whose lower bound shows they cannot change the smooth union; that
// must not change a single bit. Oracle: the same function evaluating every shape. Points fill
// the bounding box (most far from some shapes, where the bounds skip) and crowd the surface
// (within the blend widths, where the bounds must not skip), under inflations of either sign.
TEST(MannequinShape, BoundedDistanceEqualsEveryShapeBitForBit) {
  const MannequinShape shape(body_preset("pear"), RestPose::APOSE);
  ShapeInflation grown;
  grown.torso_offset = [](double y) { return 0.01 + 0.02 * y; };
  grown.leg_offset = [](double y) { return 0.03 - 0.01 * y; };
  grown.arm_offset = 0.012;
  grown.neck_offset = 0.006;
  ShapeInflation shrunk;
  shrunk.torso_offset = [](double) { return -0.008; };
  shrunk.leg_offset = [](double) { return -0.004; };
  shrunk.arm_offset = -0.003;
  ShapeInflation shorts;
  shorts.leg_offset = [](double) { return 0.06; };
  shorts.legs_gap = 0.01;
  shorts.with_arms = false;
  const ShapeInflation* inflations[] = {nullptr, &grown, &shrunk, &shorts};
  const auto [lo, hi] = shape.bounding_box(0.05);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int near = 0, total = 0;
  for (int i = 0; i < 40000; ++i) {
    Eigen::Vector3d p = lo + (hi - lo).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    // Half the points: pulled onto the surface by a few steps along the distance's gradient.
    if (i % 2) {
      for (int step = 0; step < 4; ++step) {
        const double h = 1e-4, d = shape.distance(p.x(), p.y(), p.z());
        const Eigen::Vector3d g((shape.distance(p.x() + h, p.y(), p.z()) - d) / h,
                                (shape.distance(p.x(), p.y() + h, p.z()) - d) / h,
                                (shape.distance(p.x(), p.y(), p.z() + h) - d) / h);
        if (g.norm() < 1e-6) break;
        p -= d * g / g.squaredNorm();
      }
      p += 0.02 * (u(rng) - 0.5) * Eigen::Vector3d(u(rng), u(rng), u(rng)); // straddle the blends
    }
    for (const ShapeInflation* inf : inflations) {
      const double got = shape.distance(p.x(), p.y(), p.z(), inf),
                   want = shape.distance_of_every_shape(p.x(), p.y(), p.z(), inf);
      ASSERT_EQ(got, want) << "at " << p.transpose() << " inflation " << (inf ? "set" : "none");
      near += std::abs(want) < 0.02;
      ++total;
    }
  }
  EXPECT_GT(near, total / 4); // the surface, where shapes blend, is well covered
}

TEST(Mannequin, RejectsImplausibleRequests) {
  MannequinOptions o;
  o.measurements.height = 3.0;
  EXPECT_THROW(make_mannequin(o), Error);
  o = MannequinOptions{};
  o.measurements.waist = -1;
  EXPECT_THROW(make_mannequin(o), Error);
  o = MannequinOptions{};
  o.target_vertices = 10;
  EXPECT_THROW(make_mannequin(o), Error);
  EXPECT_THROW(body_preset("giraffe"), Error);
}

} // namespace
} // namespace vfit
