// SPDX-License-Identifier: Apache-2.0
// Scan fit (seed 001 §5.2) on synthetic scans: a mannequin of another shape, in its A-pose
// rest, posed by LBS and handed over as a bare mesh. Its own skeleton is the oracle.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <numbers>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/body/scan_fit.h"
#include "vfit/geometry/body/scan_pose_search.h"
#include "vfit/geometry/body/scan_skin_transfer.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr double DEG = std::numbers::pi / 180.0;

// A-pose-relative: left elbow bent 40° forward (about its hinge axis, perpendicular to the
// 45°-lowered arm and to +Z), right knee bent 25°, left thigh 15° forward, head turned 20°.
Pose scan_pose() {
  Pose p;
  p.axis_angle.row(idx(Joint::LEFT_ELBOW)) = 40 * DEG * Eigen::RowVector3d(-1, -1, 0).normalized();
  p.axis_angle.row(idx(Joint::RIGHT_KNEE)) = Eigen::RowVector3d(25 * DEG, 0, 0);
  p.axis_angle.row(idx(Joint::LEFT_HIP)) = Eigen::RowVector3d(-15 * DEG, 0, 0);
  p.axis_angle.row(idx(Joint::HEAD)) = Eigen::RowVector3d(0, 20 * DEG, 0);
  p.translation = Eigen::Vector3d(0.1, 0, -0.2);
  return p;
}

const ScanFitStage& stage(const ScanFit& fit, const std::string& name) {
  for (const ScanFitStage& s : fit.stages)
    if (s.name == name) return s;
  throw std::runtime_error("no stage " + name);
}

struct ScanFitTest : ::testing::Test {
  static void SetUpTestSuite() {
    MannequinOptions o;
    o.measurements = body_preset("tall");
    o.pose = RestPose::APOSE;
    o.target_vertices = 4000;
    s_source = make_mannequin(o);
    s_scan = pose_body(*s_source, scan_pose());
    s_fit = fit_scan(s_scan->mesh, "tall mannequin");
  }
  static void TearDownTestSuite() {
    s_source.reset();
    s_scan.reset();
    s_fit.reset();
  }
  static inline std::optional<Body> s_source, s_scan;
  static inline std::optional<ScanFit> s_fit;
};

TEST_F(ScanFitTest, RecoversTheJointsOfAPosedMannequinAndRigsTheScan) {
  const ScanFit& fit = *s_fit;
  EXPECT_TRUE(fit.initialised_from_joints);
  ASSERT_EQ(fit.stages.size(), 6u);
  for (const ScanFitStage& s : fit.stages)
    std::cout << s.name << ": " << s.iterations << " iterations, " << s.candidates << " candidates, " << s.ms
              << " ms, mean " << 1000 * s.mean_distance << " mm, p95 " << 1000 * s.p95_distance << " mm\n";
  const ScanFitStage& icp = stage(fit, "icp");
  EXPECT_GT(icp.iterations, 0);
  EXPECT_GT(stage(fit, "search").candidates, 0);
  // The template is the same family of shapes, so its surface can come within a few mm of the
  // scan everywhere (girths differ from the tall preset's only through the global scale).
  EXPECT_LT(icp.mean_distance, 0.006);
  EXPECT_LT(icp.p95_distance, 0.015);
  EXPECT_LE(icp.mean_distance, stage(fit, "init").mean_distance);
  std::cout << "scale " << fit.scale << ", beta " << fit.shape[1] << " " << fit.shape[2] << " " << fit.shape[3] << "\n";
  // The tall preset: 1.85 m against the template's 1.70 m.
  EXPECT_NEAR(fit.measurements.height, 1.85, 0.05);
  std::cout << std::fixed << std::setprecision(1);
  double worst = 0;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const double e = (fit.joints.row(j) - s_scan->joints.row(j)).norm();
    std::cout << "  " << std::setw(15) << std::left << joint_name(j) << std::right << std::setw(6) << 100 * e
              << " cm\n";
    worst = std::max(worst, e);
    // 3 cm, the bar for scans: the template's joints sit where the same generator puts
    // them, but limb lengths are fitted through 3 shape parameters and a scale, not 11.
    EXPECT_LT(e, 0.03) << joint_name(j);
  }
  std::cout << "worst joint error " << 100 * worst << " cm\n";

  // The rigged scan (one test: building the two mannequins dominates the time).
  const Body& rigged = fit.rigged;
  ASSERT_NO_THROW(validate_skin_weights(rigged.weights, rigged.mesh.vertex_count(), "rigged scan"));
  EXPECT_EQ(rigged.mesh.vertex_count(), s_scan->mesh.vertex_count());
  // Another pose: both arms raised 30° and the left knee bent 40°, the body turned 25°.
  Pose to = scan_pose();
  to.axis_angle.row(idx(Joint::LEFT_SHOULDER)) = Eigen::RowVector3d(0, 0, 30 * DEG);
  to.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) = Eigen::RowVector3d(0, 0, -30 * DEG);
  to.axis_angle.row(idx(Joint::LEFT_KNEE)) = Eigen::RowVector3d(40 * DEG, 0, 0);
  to.axis_angle.row(0) = Eigen::RowVector3d(0, 25 * DEG, 0);
  const Body expected = pose_body(*s_source, to);
  const Body got = pose_body(rigged, relative_pose(s_source->joints, scan_pose(), to, rigged.joints));
  double sum = 0, far = 0;
  const std::size_t n = got.mesh.vertex_count();
  for (std::size_t v = 0; v < n; ++v) {
    const double d =
        (Eigen::Vector3f::Map(&got.mesh.positions[3 * v]) - Eigen::Vector3f::Map(&expected.mesh.positions[3 * v]))
            .norm();
    sum += d;
    far = std::max(far, d);
  }
  std::cout << "re-posed rigged scan vs the source's own posing: mean " << 1000 * sum / double(n) << " mm, max "
            << 1000 * far << " mm\n";
  EXPECT_LT(sum / double(n), 0.01); // the bar
}

// A scan leaning sideways: the spine bent 6° to the body's right above the waist at spine2,
// the arms lowered to hang 70° below horizontal, the pelvis turned 10° and the lean twisted
// back 8° (the corpus body's contrapposto with 1.5 × its lean), on the fixture's tall
// mannequin. The lean belongs in the spine: with the neck's sideways lean held as weakly as any
// joint, the fit leaned the spine 2.6° and the neck 9.3° (the neck carries the head sideways as
// the spine does); holding it as firmly as a twist (scan_fit_solve.cpp), 4.5° and 0.4°.
// 2°: the template's T-pose spine is not the A-pose mannequin's to the degree.
TEST_F(ScanFitTest, FitsASidewaysLeanOfTheSpineInTheSpine) {
  Pose p;
  p.axis_angle.row(idx(Joint::PELVIS)) = Eigen::RowVector3d(0, 10 * DEG, 0);
  p.axis_angle.row(idx(Joint::SPINE2)) = Eigen::RowVector3d(0, -8 * DEG, 6 * DEG);
  p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) = Eigen::RowVector3d(0, 0, -25 * DEG);
  p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) = Eigen::RowVector3d(0, 0, 25 * DEG);
  p.axis_angle.row(idx(Joint::RIGHT_KNEE)) = Eigen::RowVector3d(15 * DEG, 0, 0);
  const Body scan = pose_body(*s_source, p);
  const ScanFit fit = fit_scan(scan.mesh, "leaning mannequin");
  // The spine's lean: the three joints' turns about Z (small angles add).
  double lean = 0;
  for (Joint j : {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3})
    lean += fit.pose.axis_angle(idx(j), 2);
  const double neck = fit.pose.axis_angle(idx(Joint::NECK), 2);
  std::cout << "spine lean " << lean / DEG << " deg (scan 6), neck lean " << neck / DEG << " deg (scan 0)\n";
  EXPECT_NEAR(lean, 6 * DEG, 2 * DEG);
  EXPECT_NEAR(neck, 0.0, 2 * DEG);
  double worst = 0;
  for (int j = 0; j < JOINT_COUNT; ++j)
    worst = std::max(worst, (fit.joints.row(j) - scan.joints.row(j)).norm());
  std::cout << "worst joint error " << 100 * worst << " cm\n";
  EXPECT_LT(worst, 0.03); // the bar
}

// A walking scan (arms 72° down and swinging, one thigh forward, the other back with its knee
// bent) handed over as a point cloud: the scan's vertices only, no faces, so joint estimation
// cannot start the fit and the part-by-part pose search must (the A-pose start alone ended
// 58 mm from the surface with joints up to 68 cm off).
TEST_F(ScanFitTest, FitsAWalkingPointCloud) {
  const Pose walking = named_pose("walking", RestPose::APOSE);
  const Body posed = pose_body(*s_source, walking);
  Mesh cloud;
  cloud.positions = posed.mesh.positions;
  const ScanFit fit = fit_scan(cloud, "walking cloud");
  EXPECT_FALSE(fit.initialised_from_joints);
  EXPECT_FALSE(fit.joints_estimated_unposed); // a cloud has no surface to estimate joints on
  EXPECT_EQ(fit.rigged.mesh.face_count(), 0u);
  EXPECT_EQ(fit.rigged.weights.vertex_count(), cloud.vertex_count());
  const ScanFitStage& icp = stage(fit, "icp");
  std::cout << "walking cloud: search " << stage(fit, "search").candidates << " candidates, " << stage(fit, "search").ms
            << " ms; icp " << icp.iterations << " iterations, mean " << 1000 * icp.mean_distance << " mm, p95 "
            << 1000 * icp.p95_distance << " mm\n";
  // Looser than the A-pose mesh above: a cloud gives only scan → template correspondences
  // (nothing pulls template parts onto the scan), so the bent knee's shank sits 2-3 cm off
  // (measured mean 6.1 mm, p95 26 mm).
  EXPECT_LT(icp.mean_distance, 0.010);
  EXPECT_LT(icp.p95_distance, 0.035);
  double sum = 0;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const double e = (fit.joints.row(j) - posed.joints.row(j)).norm();
    std::cout << "  " << std::setw(15) << std::left << joint_name(j) << std::right << std::setw(6) << 100 * e
              << " cm\n";
    sum += e;
    // 6.5 cm, not the 3 cm of a mesh: the joints are the fitted template's own (no estimation
    // on a surface), limb lengths come only from 3 shape parameters and a scale, and the bent
    // knee is under-fitted (see above; measured worst 5.4 cm, the right knee).
    EXPECT_LT(e, 0.065) << joint_name(j);
  }
  std::cout << "mean joint error " << 100 * sum / JOINT_COUNT << " cm\n";
  EXPECT_LT(sum / JOINT_COUNT, 0.03); // the bar, as a mean
}

TEST(ScanFitWeights, InterpolationReproducesTheWeightsAtTheMeshVertices) {
  const Body& t = scan_fit_template();
  const SkinWeights w = interpolate_skin_weights(t.mesh, t.weights, t.mesh.positions);
  ASSERT_EQ(w.vertex_count(), t.mesh.vertex_count());
  double worst = 0;
  for (std::size_t v = 0; v < w.vertex_count(); ++v) {
    std::array<double, JOINT_COUNT> a{}, b{};
    for (int k = 0; k < 4; ++k) {
      a[std::size_t(w.joints[4 * v + k])] += w.weights[4 * v + k];
      b[std::size_t(t.weights.joints[4 * v + k])] += t.weights.weights[4 * v + k];
    }
    for (int j = 0; j < JOINT_COUNT; ++j)
      worst = std::max(worst, std::abs(a[std::size_t(j)] - b[std::size_t(j)]));
  }
  // A vertex is its own closest point (barycentrics 1, 0, 0 up to float rounding of u, v).
  EXPECT_LT(worst, 1e-4);
}

// The local refinement of search_scan_pose() only ever improves the score, and does improve
// it from a start of 20° off on every limb.
TEST_F(ScanFitTest, PoseSearchRefinementImprovesTheScore) {
  const Body& t = scan_fit_template();
  Pose start = s_fit->pose;
  for (Joint j : {Joint::LEFT_SHOULDER, Joint::RIGHT_SHOULDER, Joint::LEFT_ELBOW, Joint::RIGHT_ELBOW})
    start.axis_angle(idx(j), 1) += 20 * DEG;
  ScanPoseSearchOptions coarse;
  coarse.passes = 1;
  coarse.refine_steps_deg.clear();
  coarse.limb_alternatives = 1; // the arms' alternatives refine too: off, to see this refinement alone
  ScanPoseSearchOptions refined = coarse;
  refined.refine_steps_deg = {16, 8, 4};
  const double log_scale = std::log(s_fit->scale);
  const ScanPoseSearch a = search_scan_pose(t, s_scan->mesh.positions, start, log_scale, coarse);
  const ScanPoseSearch b = search_scan_pose(t, s_scan->mesh.positions, start, log_scale, refined);
  std::cout << "search score " << 1000 * a.start_score << " mm -> " << 1000 * a.score << " (coarse), " << 1000 * b.score
            << " (refined)\n";
  EXPECT_TRUE(b.pose.axis_angle.allFinite());
  EXPECT_LT(b.score, a.score);
  // Per step: the spine's sideways lean (the base pose scored once, then ± the step), then per
  // limb joint the base pose scored once and ± a turn about 3 axes.
  EXPECT_EQ(b.evaluations, a.evaluations + 3 * (1 + 2) + 3 * 8 * (1 + 6));

  // The arms' alternatives, each refined, from the same start: one pass, so that the arms are
  // the last parts searched and the score cannot be worse than the plain best candidate's.
  ScanPoseSearchOptions alternatives = coarse;
  alternatives.limb_alternatives = 4;
  const ScanPoseSearch c = search_scan_pose(t, s_scan->mesh.positions, start, log_scale, alternatives);
  std::cout << "with 4 arm alternatives refined: " << 1000 * c.score << " mm\n";
  EXPECT_LT(c.score, a.score);
  // At most 4 alternatives per arm, each turned ± about 3 axes at 2 joints per step.
  EXPECT_GT(c.evaluations, a.evaluations);
  EXPECT_LE(c.evaluations, a.evaluations + 2 * 4 * 3 * 2 * 6);
}

// The search's score with the scan's normals (a template point more than inside_slack behind the
// nearest scan point's surface counts inside_factor × the depth beyond it more, within the cap)
// against a brute-force evaluation of the same definition: the posed template, levelled on the
// scan's floor, scored over the same samples by exhaustive nearest points. The scan is the
// synthetic one inflated 3 cm along its normals, so that most of the template lies inside it.
TEST_F(ScanFitTest, PoseSearchScoreWithNormalsMatchesBruteForce) {
  const Body& t = scan_fit_template();
  const std::vector<Eigen::Vector3d> normals =
      area_weighted_vertex_normals(s_scan->mesh.positions, s_scan->mesh.triangles);
  std::vector<float> scan = s_scan->mesh.positions;
  for (std::size_t v = 0; v < normals.size(); ++v)
    for (int a = 0; a < 3; ++a)
      scan[3 * v + a] += static_cast<float>(0.03 * normals[v][a]);
  ScanPoseSearchOptions o;
  o.passes = 1;
  o.refine_steps_deg.clear();
  o.limb_alternatives = 1;
  const double log_scale = std::log(s_fit->scale);
  const ScanPoseSearch with = search_scan_pose(t, scan, s_fit->pose, log_scale, o, normals);
  const ScanPoseSearch without = search_scan_pose(t, scan, s_fit->pose, log_scale, o);

  // The oracle: the template posed as the search poses it, then levelled.
  const double scale = std::exp(log_scale);
  std::vector<float> shaped(t.mesh.positions.size()), posed;
  for (std::size_t i = 0; i < shaped.size(); ++i)
    shaped[i] = static_cast<float>(scale) * t.mesh.positions[i];
  linear_blend_skinning(shaped, t.weights, skinning_transforms(scale * t.joints, s_fit->pose), posed);
  float floor = INFINITY, lowest = INFINITY;
  for (std::size_t v = 0; v < scan.size() / 3; ++v)
    floor = std::min(floor, scan[3 * v + 1]);
  for (std::size_t v = 0; v < posed.size() / 3; ++v)
    lowest = std::min(lowest, posed[3 * v + 1]);
  for (std::size_t v = 0; v < posed.size() / 3; ++v)
    posed[3 * v + 1] += floor - lowest;
  auto point = [](const std::vector<float>& xyz, std::size_t v) {
    return Eigen::Vector3d(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]);
  };
  const std::vector<std::size_t> grid = spread_indices(scan.size() / 3, o.scan_grid_points);
  auto score = [&](double factor) {
    double a = 0, b = 0;
    const auto scan_samples = spread_indices(scan.size() / 3, o.scan_samples);
    for (std::size_t i : scan_samples) {
      double best = INFINITY;
      for (std::size_t v = 0; v < posed.size() / 3; ++v)
        best = std::min(best, (point(posed, v) - point(scan, i)).norm());
      a += std::min(best, o.cap);
    }
    const auto tmpl_samples = spread_indices(t.mesh.vertex_count(), o.template_samples);
    int inside = 0;
    for (std::size_t v : tmpl_samples) {
      const Eigen::Vector3d q = point(posed, v);
      double best = INFINITY;
      std::size_t arg = 0;
      for (std::size_t k : grid)
        if (const double d = (point(scan, k) - q).norm(); d < best) best = d, arg = k;
      const double depth = -(q - point(scan, arg)).dot(normals[arg]);
      inside += depth > o.inside_slack;
      b += best >= o.cap            ? o.cap
           : depth > o.inside_slack ? std::min(o.cap, best + factor * (depth - o.inside_slack))
                                    : best;
    }
    std::cout << "template samples more than " << 100 * o.inside_slack << " cm inside: " << inside << " of "
              << tmpl_samples.size() << "\n";
    return a / static_cast<double>(scan_samples.size()) + b / static_cast<double>(tmpl_samples.size());
  };
  const double expected_with = score(o.inside_factor), expected_without = score(0);
  std::cout << "start score with normals " << 1000 * with.start_score << " mm (brute force " << 1000 * expected_with
            << "), without " << 1000 * without.start_score << " (" << 1000 * expected_without << ")\n";
  // Float positions and distances in the search against doubles here: ~1e-7 m per distance.
  EXPECT_NEAR(with.start_score, expected_with, 1e-6);
  EXPECT_NEAR(without.start_score, expected_without, 1e-6);
  EXPECT_GT(with.start_score, without.start_score + 1e-3); // the inflated scan puts the template inside
}

// An arm hanging against the torso with its forearm held out in front (like the corpus test's
// seed 11 random 4, whose elbow the search put 34 cm off): the forearm aimed at the scan points
// the rest of the template leaves unexplained. The source mannequin's own joints are the oracle
// for the search's.
TEST_F(ScanFitTest, PoseSearchAimsTheForearmAtTheScan) {
  Pose p;
  // From the A-pose: the right arm lowered 25° more and swung 20° back, its elbow bent 100°
  // forward (about the hinge axis of the lowered arm, as scan_pose() bends the left one).
  p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) = Eigen::RowVector3d(20 * DEG, 0, -25 * DEG);
  p.axis_angle.row(idx(Joint::RIGHT_ELBOW)) = 100 * DEG * Eigen::RowVector3d(-1, 1, 0).normalized();
  p.translation = Eigen::Vector3d(0.1, 0, -0.2);
  const Body scan = pose_body(*s_source, p);
  double worst[2] = {0, 0};
  int evaluations[2] = {0, 0};
  for (bool aimed : {false, true}) {
    ScanFitOptions o;
    o.search.aimed_forearms = aimed;
    const ScanFit fit = fit_scan(scan.mesh, "arm held out", o);
    const JointPositions& J = stage(fit, "search").joints;
    evaluations[aimed] = stage(fit, "search").candidates;
    for (Joint j : {Joint::RIGHT_ELBOW, Joint::RIGHT_WRIST}) {
      const double e = (J.row(idx(j)) - scan.joints.row(idx(j))).norm();
      std::cout << (aimed ? "aimed" : "fixed directions only") << ": " << joint_name(idx(j)) << " after the search "
                << 100 * e << " cm\n";
      worst[aimed] = std::max(worst[aimed], e);
    }
  }
  // Within the bone lengths' and shapes' difference of the two mannequins (the fixed directions
  // find this synthetic arm too, 1.3 cm; the corpus test's seed 11 random 4 is the case they miss).
  EXPECT_LT(worst[1], 0.04);
  // The aimed forearms were tried: the forearm's points are unexplained by the rest of the body.
  EXPECT_GT(evaluations[1], evaluations[0]);
}

// The dominant joint's chain (scan_skin_transfer.h) of vertex v.
int dominant_chain(const SkinWeights& w, std::size_t v) {
  std::size_t best = 4 * v;
  for (int k = 1; k < 4; ++k)
    if (w.weights[4 * v + k] > w.weights[best]) best = 4 * v + k;
  return skin_chain_of_joint(w.joints[best]);
}

TEST(ScanSkinTransfer, ReproducesTheWeightsOnTheSameMesh) {
  const Body& t = scan_fit_template();
  const SkinWeights w = transfer_skin_weights(t.mesh, t.weights, t.mesh);
  ASSERT_EQ(w.vertex_count(), t.mesh.vertex_count());
  double worst = 0, sum = 0;
  for (std::size_t v = 0; v < w.vertex_count(); ++v) {
    std::array<double, JOINT_COUNT> a{};
    for (int k = 0; k < 4; ++k) {
      a[std::size_t(w.joints[4 * v + k])] += w.weights[4 * v + k];
      a[std::size_t(t.weights.joints[4 * v + k])] -= t.weights.weights[4 * v + k];
    }
    for (double x : a) {
      worst = std::max(worst, std::abs(x));
      sum += std::abs(x);
    }
  }
  // Each vertex is its own closest point (float rounding of u, v: 1e-4), except within the
  // 2 cm margin of a chain border, where it may take the other chain's border point a
  // centimetre or two away: the weights change by a few % over that distance (10 % bound).
  EXPECT_LT(worst, 0.1);
  EXPECT_LT(sum / double(w.vertex_count()), 1e-3); // a few border vertices only
  // A point cloud (no faces, no normals) takes the plain closest point's weights.
  Mesh cloud;
  cloud.positions = t.mesh.positions;
  const SkinWeights c = transfer_skin_weights(t.mesh, t.weights, cloud);
  const SkinWeights p = interpolate_skin_weights(t.mesh, t.weights, cloud.positions);
  EXPECT_EQ(c.joints, p.joints);
  EXPECT_EQ(c.weights, p.weights);
}

// Arms hanging against the torso, the source's pressed 4° further in than the target's (a fit
// that is a few cm off): the target's arm vertices keep an arm's weights, where plain closest
// points hand the inside of the arm to the torso.
TEST(ScanSkinTransfer, ArmsAgainstTheTorsoKeepTheArmsWeights) {
  const Body& t = scan_fit_template();
  auto arms_down = [&](double degrees) {
    Pose p;
    p.axis_angle(idx(Joint::LEFT_SHOULDER), 2) = -degrees * DEG;
    p.axis_angle(idx(Joint::RIGHT_SHOULDER), 2) = degrees * DEG;
    return pose_body(t, p);
  };
  const Body target = arms_down(80), source = arms_down(84);
  const SkinWeights w = transfer_skin_weights(source.mesh, source.weights, target.mesh);
  const SkinWeights plain = interpolate_skin_weights(source.mesh, source.weights, target.mesh.positions);
  int arm = 0, lost = 0, lost_plain = 0;
  for (std::size_t v = 0; v < target.mesh.vertex_count(); ++v) {
    const int own = dominant_chain(target.weights, v);
    if (own != 1 && own != 2) continue;
    double top = 0;
    for (int k = 0; k < 4; ++k)
      top = std::max(top, double(target.weights.weights[4 * v + k]));
    if (top < 0.9) continue; // the shoulder's blend with the trunk: either chain is right
    ++arm;
    lost += dominant_chain(w, v) != own;
    lost_plain += dominant_chain(plain, v) != own;
  }
  std::cout << arm << " arm vertices; another chain's weights: " << lost << " (plain closest points " << lost_plain
            << ")\n";
  ASSERT_GT(arm, 100);
  EXPECT_GT(lost_plain, 10); // the case is a real one
  EXPECT_LE(lost, lost_plain / 4);
}

// Two chains pressed into each other: a left hand's patch 3.00 mm under the target and a right
// forearm and hand's patch 3.05 mm under it, the left one ending where the target's strip goes
// on over the right one alone. The strip is the right arm's (its sure vertices are past the
// left patch), so every vertex takes the right chain's weights, also where the left patch is
// nearer by less than any margin (50 µm).
TEST(ScanSkinTransfer, AChainPressedIntoAnotherKeepsItsOwnWeights) {
  auto grid = [](Mesh& m, double x0, double x1, double y0, double y1, double z, int nx, int ny) {
    const auto first = static_cast<std::int32_t>(m.vertex_count());
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        for (double c : {x0 + (x1 - x0) * i / nx, y0 + (y1 - y0) * j / ny, z})
          m.positions.push_back(static_cast<float>(c));
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::int32_t a = first + j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
        for (std::int32_t v : {a, b, d, a, d, c}) // counter-clockwise seen from +Z: normals +Z
          m.triangles.push_back(v);
      }
  };
  Mesh source;
  grid(source, 0.0, 0.1, 0.0, 0.1, 0.0, 10, 10); // the left hand
  const std::size_t left = source.vertex_count();
  grid(source, 0.0, 0.3, 0.0, 0.1, -0.00005, 30, 10); // the right forearm and hand
  SkinWeights w;
  for (std::size_t v = 0; v < source.vertex_count(); ++v) {
    w.joints.insert(w.joints.end(), {idx(v < left ? Joint::LEFT_HAND : Joint::RIGHT_HAND), 0, 0, 0});
    w.weights.insert(w.weights.end(), {1.f, 0.f, 0.f, 0.f});
  }
  Mesh target;
  grid(target, 0.005, 0.295, 0.005, 0.095, 0.003, 58, 18);
  const SkinWeights got = transfer_skin_weights(source, w, target);
  int other = 0, over_left = 0;
  for (std::size_t v = 0; v < target.vertex_count(); ++v) {
    other += dominant_chain(got, v) != 2;
    over_left += target.positions[3 * v] < 0.1;
  }
  ASSERT_GT(over_left, 300); // the case is a real one: a third of the strip lies over both patches
  EXPECT_EQ(other, 0);
}

TEST(ScanFitInput, RejectsTooFewPointsAndScansNotInMetres) {
  Mesh few;
  few.positions.assign(3 * 50, 0.f);
  EXPECT_THROW(fit_scan(few, "few.obj"), Error);
  Mesh cm = scan_fit_template().mesh;
  for (float& x : cm.positions)
    x *= 100.f; // a 170-unit-tall body: centimetres
  try {
    fit_scan(cm, "cm.obj");
    FAIL() << "a scan in centimetres was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cm.obj"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("m tall"), std::string::npos) << e.what();
  }
}

// A PLY of vertices only is a point cloud: rejected by default ("no faces": garments and
// bodies need faces), read with no triangles when the caller opts in (vfit body --scan does).
TEST(ScanFitInput, PointCloudPlyIsReadOnlyOnRequest) {
  test::TempDir tmp;
  const auto path = tmp / "cloud.ply";
  test::write_file(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0.5\n");
  try {
    read_mesh(path);
    FAIL() << "a point cloud was read as a mesh";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no faces"), std::string::npos) << e.what();
  }
  ReadOptions o;
  o.allow_point_cloud = true;
  const ParsedMesh cloud = read_mesh(path, o);
  EXPECT_EQ(cloud.mesh.vertex_count(), 3u);
  EXPECT_EQ(cloud.mesh.face_count(), 0u);
  EXPECT_FLOAT_EQ(cloud.mesh.positions[8], 0.5f);
  // Vertices are still required.
  test::write_file(path, "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n");
  EXPECT_THROW(read_mesh(path, o), Error);
}

} // namespace
} // namespace vfit
