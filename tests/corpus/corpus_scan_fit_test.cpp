// SPDX-License-Identifier: Apache-2.0
// Scan fit (seed 001 §5.2) on the MakeHuman hm08 body posed by its own game_engine rig
// (corpus/MANIFEST.md) and handed over as a bare mesh: the rig's posed joints are the oracle
// for the recovered joints, and the rig's own posing of a second pose the oracle for the rigged
// scan re-posed by our LBS. Skipped, saying why, when the corpus is absent.
#include <algorithm>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/gltf_body.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/body/scan_fit.h"
#include "vfit/geometry/body/scan_skin_transfer.h"

namespace vfit {
namespace {

constexpr double DEG = std::numbers::pi / 180.0;

// Rotations relative to the rig's A-pose rest (arms 45° down). A forward elbow bend turns
// about the axis perpendicular to the lowered arm and to +Z: (−1, −1, 0)/√2 on the left,
// (−1, 1, 0)/√2 on the right; a knee bends about +X, a thigh comes forward about −X.
Eigen::RowVector3d elbow(bool left, double deg) {
  return deg * DEG * Eigen::RowVector3d(-1, left ? -1 : 1, 0).normalized();
}

struct PoseCase {
  const char* name;
  Pose scan;   ///< the pose of the "scan"
  Pose repose; ///< the pose the rigged scan is driven to afterwards
  /// Joints not yet within the 3 cm bar in this pose, each with its own limit (m): about
  /// 1.3 × the measured error, so that regressions show.
  std::vector<std::pair<Joint, double>> known_gaps;
  double repose_limit = 0.01; ///< mean re-pose error limit (m): the bar unless noted
};

std::vector<PoseCase> pose_cases() {
  std::vector<PoseCase> cases;
  {
    PoseCase c{"elbow and knee bent", {}, {}, {}};
    c.scan.axis_angle.row(idx(Joint::LEFT_ELBOW)) = elbow(true, 15);
    c.scan.axis_angle.row(idx(Joint::RIGHT_KNEE)) = Eigen::RowVector3d(30 * DEG, 0, 0);
    c.scan.axis_angle.row(idx(Joint::HEAD)) = Eigen::RowVector3d(0, 20 * DEG, 0);
    c.repose = c.scan;
    c.repose.axis_angle.row(idx(Joint::LEFT_ELBOW)) = elbow(true, 80);
    c.repose.axis_angle.row(idx(Joint::LEFT_KNEE)) = Eigen::RowVector3d(30 * DEG, 0, 0);
    cases.push_back(c);
  }
  {
    PoseCase c{"arms raised, walking", {}, {}, {}};
    c.scan.axis_angle.row(idx(Joint::LEFT_SHOULDER)) = Eigen::RowVector3d(0, 0, 30 * DEG);
    c.scan.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) = Eigen::RowVector3d(0, 0, -25 * DEG);
    c.scan.axis_angle.row(idx(Joint::LEFT_HIP)) = Eigen::RowVector3d(-20 * DEG, 0, 0);
    c.scan.axis_angle.row(idx(Joint::LEFT_KNEE)) = Eigen::RowVector3d(25 * DEG, 0, 0);
    c.scan.axis_angle.row(idx(Joint::RIGHT_HIP)) = Eigen::RowVector3d(10 * DEG, 0, 0);
    c.repose = c.scan;
    c.repose.axis_angle.row(idx(Joint::LEFT_HIP)) = Eigen::RowVector3d(10 * DEG, 0, 0);
    c.repose.axis_angle.row(idx(Joint::RIGHT_HIP)) = Eigen::RowVector3d(-20 * DEG, 0, 0);
    c.repose.axis_angle.row(idx(Joint::RIGHT_KNEE)) = Eigen::RowVector3d(25 * DEG, 0, 0);
    c.repose.axis_angle.row(idx(Joint::LEFT_KNEE)) = Eigen::RowVector3d(5 * DEG, 0, 0);
    cases.push_back(c);
  }
  {
    PoseCase c{"torso turned, elbows bent", {}, {}, {}};
    c.scan.axis_angle.row(idx(Joint::SPINE2)) = Eigen::RowVector3d(0, 10 * DEG, 0);
    c.scan.axis_angle.row(idx(Joint::SPINE1)) = Eigen::RowVector3d(8 * DEG, 0, 0);
    c.scan.axis_angle.row(idx(Joint::LEFT_ELBOW)) = elbow(true, 10);
    c.scan.axis_angle.row(idx(Joint::RIGHT_ELBOW)) = elbow(false, 15);
    c.scan.translation = Eigen::Vector3d(0.3, 0.0, -0.5);
    c.repose = c.scan;
    c.repose.axis_angle.row(idx(Joint::SPINE2)) = Eigen::RowVector3d(0, -10 * DEG, 0);
    c.repose.axis_angle.row(idx(Joint::RIGHT_ELBOW)) = elbow(false, 20);
    c.repose.axis_angle.row(idx(Joint::LEFT_SHOULDER)) = Eigen::RowVector3d(0, 0, 20 * DEG);
    cases.push_back(c);
  }
  // Stronger poses, which joint estimation on the bare scan rejects (arms above the A-pose, a
  // foot off the floor, legs wide, arms against the torso), so the fit starts from the pose
  // search (scan_pose_search.h); re-posed to the rig's rest.
  for (const char* name :
       {"arms_raised", "knee_bent", "legs_apart", "walking", "contrapposto", "elbows_bent", "arms_down"})
    cases.push_back({name, named_pose(name, RestPose::APOSE), Pose{}, {}});
  // The joints still past 3 cm, each guarded at about 1.3 × its measured error. (The fitted
  // elbow shift, the joints carried back by the mean of their two bones' transforms, the
  // per-leg sole, the neck's own mid-plane, the weights of folded hands from their own arm and
  // the torn vertices mended before estimation took 11 joints under 3 cm: bent elbows 4.0-5.6,
  // a bent leg's ankle and foot 3.5 and 3.3, collars and heads 3.1-3.5; and elbows_bent's
  // re-posing from 24.5 to 9.4 mm. The pose search's refined arm alternatives took walking's
  // head 3.0 -> 2.9, elbows_bent's left elbow 3.0 -> 1.9 (its re-posing 9.4 -> 7.6 mm) and
  // arms_down's left shoulder and elbow 3.2 and 3.1 -> under 2.7 cm.)
  // The head joint takes the depth of the neck's narrowest section in the unposed scan; the fit
  // pitches the template's neck 6-12° forward and its head back (the corpus body's head sits
  // further forward over its neck than the mannequin's), so a neck unposed with those rotations
  // leaned back and the head landed 1.3-2.9 cm in front over all poses; unposed with the
  // fitted neck and head kept (scan_fit.cpp, stage 5), 0.4-1.2 cm.
  // contrapposto's right shoulder, 3.1 cm (2.7 too high) while the fit left the rig's 4° lean
  // of spine2 to the template's neck (scan_fit_solve.cpp, the pose prior), is 2.0 cm since the
  // spine takes it; so is contrapposto x1.3's below.
  // elbows_bent's right shoulder was 3.1 cm, 2.7 too high (y), the left 2.3 cm: the rig lowers
  // the arms with a third of the lowering on the collars (pose_io.cpp); the fit leaves the
  // template's collars at the rest pose's turn and rolls them 45° forward about their bone to
  // fit the bent arms' twist, so its shoulder pivots stood 2-4 cm above the rig's, and the arms
  // unposed about them sheared the armpits the estimator reads. Unposed a second time about the
  // estimated shoulders (scan_fit.cpp, stage 5): right 2.4 cm, left 2.4 cm, elbows 2.2 and 1.7
  // -> 1.4 and 1.3 cm, re-posing 6.5 -> 5.0 mm.
  return cases;
}

// Poses the fit was not developed on, to check that a change helps in general: named poses with
// their angles scaled, and random poses within a standing person's range (fixed seed). Each is
// re-posed to the rig's rest, the rest itself to walking.
Pose scaled(Pose p, double k) {
  p.axis_angle *= k;
  return p;
}

Pose random_pose(std::mt19937& rng) {
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * (double(rng()) / 4294967296.0); };
  Pose p;
  for (bool left : {true, false}) {
    const double sign = left ? 1 : -1;
    // Raised by up to 30° or lowered by up to 28° from the A-pose (about Z), swung up to 20°
    // back (+X) or forward; the elbow bent up to 70° further than the rig's rest.
    const Eigen::Vector3d arm(uniform(-20, 20) * DEG, 0, -sign * uniform(-30, 28) * DEG);
    p.axis_angle.row(idx(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER)) = arm.transpose();
    p.axis_angle.row(idx(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW)) = elbow(left, uniform(0, 70));
    // Thigh forward (−X) or back, and out to the side; the knee bent.
    p.axis_angle.row(idx(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP)) =
        Eigen::RowVector3d(uniform(-30, 15) * DEG, 0, sign * uniform(0, 12) * DEG);
    p.axis_angle.row(idx(left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE)) = Eigen::RowVector3d(uniform(0, 45) * DEG, 0, 0);
  }
  p.axis_angle.row(idx(Joint::SPINE1)) = Eigen::RowVector3d(uniform(-5, 12) * DEG, 0, 0);
  p.axis_angle.row(idx(Joint::SPINE2)) = Eigen::RowVector3d(0, uniform(-12, 12) * DEG, 0);
  p.axis_angle.row(idx(Joint::HEAD)) = Eigen::RowVector3d(0, uniform(-25, 25) * DEG, 0);
  p.axis_angle.row(0) = Eigen::RowVector3d(0, uniform(-20, 20) * DEG, 0);
  p.translation = Eigen::Vector3d(uniform(-0.3, 0.3), 0, uniform(-0.3, 0.3));
  return p;
}

std::vector<PoseCase> extra_cases() {
  std::vector<PoseCase> cases;
  auto named = [](const char* name, double k) { return scaled(named_pose(name, RestPose::APOSE), k); };
  cases.push_back({"rest", Pose{}, named("walking", 1.0), {}});
  cases.push_back({"walking x0.6", named("walking", 0.6), Pose{}, {}});
  cases.push_back({"elbows_bent x0.6", named("elbows_bent", 0.6), Pose{}, {}});
  cases.push_back({"knee_bent x1.3", named("knee_bent", 1.3), Pose{}, {}});
  cases.push_back({"contrapposto x1.3", named("contrapposto", 1.3), Pose{}, {}});
  cases.push_back({"arms_raised x0.6", named("arms_raised", 0.6), Pose{}, {}});
  std::mt19937 rng(8);
  for (const char* name : {"random 1", "random 2", "random 3", "random 4"})
    cases.push_back({name, random_pose(rng), Pose{}, {}});
  // Random poses of other seeds (the survey below) whose arm the pose search misplaced before it
  // aimed forearms at the scan, tried arms swung further back and counted template points deep
  // inside the scan against a pose (scan_pose_search.h): seed 11's 4th (right elbow 40.2 cm off,
  // re-posing 60.6 mm -> 2.5 cm worst joint, 5.1 mm), seed 10's 4th (right shoulder 6.7 cm,
  // 11.7 mm -> 2.5 cm, 9.1 mm), seed 10's 1st (right elbow 4.9 cm, 10.7 mm -> 2.7 cm, 8.0 mm) and
  // seed 13's 2nd, held out while the change was made (right elbow 6.5 cm, 15.5 mm -> 2.6 cm,
  // 8.1 mm).
  auto kth = [](unsigned seed, int k) {
    std::mt19937 r(seed);
    Pose p;
    for (int i = 0; i < k; ++i)
      p = random_pose(r);
    return p;
  };
  cases.push_back({"seed 11 random 4", kth(11, 4), Pose{}, {}});
  cases.push_back({"seed 10 random 4", kth(10, 4), Pose{}, {}});
  cases.push_back({"seed 10 random 1", kth(10, 1), Pose{}, {}});
  cases.push_back({"seed 13 random 2", kth(13, 2), Pose{}, {}});
  // And two whose foot the estimator read short of the toes before the unposing kept the fitted
  // ankles (scan_fit.cpp, stage 5): seed 9's 4th (left foot 6.5 cm -> under 3) and 2nd (5.2).
  cases.push_back({"seed 9 random 4", kth(9, 4), Pose{}, {}});
  cases.push_back({"seed 9 random 2", kth(9, 2), Pose{}, {}});
  // And one whose left foot, raised far behind, put the legs' middle 22 cm behind the pelvis, so
  // that the template started there, past the search's shifts, and its right leg bent up to
  // cover the scan's left (body_centre(), scan_fit.cpp): seed 10's 2nd (left ankle 5.4 cm off,
  // right foot 9.6 with the wrists' firmer prior -> 2.6 cm worst joint).
  cases.push_back({"seed 10 random 2", kth(10, 2), Pose{}, {}});
  // No joint past 3 cm. (contrapposto x1.3's right shoulder, 3.1 cm with the spine's lean left to
  // the neck, is 2.0 cm. Its left elbow, 3.3 cm before the unposing kept the fitted collars,
  // neck and head, is under 3 cm; so are random 2's left elbow, 3.5 -> 2.8 cm, random 3's right
  // elbow, 3.1, and the re-posing of random 2 and random 4, 11.1 and 10.1 -> 9.9 and 9.1 mm mean,
  // most of which was the head: turned up to 22°, it re-posed 12-21 mm off about a head joint
  // 2.5 cm in front.)
  return cases;
}

struct CorpusScanFit : ::testing::TestWithParam<int> {
  static void SetUpTestSuite() {
    const auto corpus = test::corpus_dir();
    if (!corpus) return;
    s_rig = read_gltf_body((*corpus / "makehuman" / "derived" / "hm08_body_rigged.glb").string());
  }
  static void TearDownTestSuite() { s_rig.reset(); }
  void SetUp() override {
    if (!s_rig) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  }
  static inline std::optional<Body> s_rig;
};

// What a fit of the rig posed by `c.scan` gets right: per-joint errors against the rig's joints
// and the mean and worst re-posing error against the rig's own posing by `c.repose`; printed per stage.
struct FitErrors {
  std::array<double, JOINT_COUNT> joint{}; ///< m
  double repose_mean = 0;                  ///< m
  double repose_max = 0;                   ///< m, the vertex re-posed farthest off
  bool poor_fit_warned = false;            ///< fit_scan() warned of a poor fit
};

bool warns_of_poor_fit(const ScanFit& fit) {
  return std::any_of(fit.warnings.begin(), fit.warnings.end(), [](const std::string& w) {
    return w.find("from the scan at the 95th percentile") != std::string::npos;
  });
}

FitErrors fit_and_measure(const Body& rig, const PoseCase& c) {
  const Body scan = pose_body(rig, c.scan);
  Mesh bare = scan.mesh; // the mesh alone: no joints, no weights
  bare.uvs.clear();
  bare.uv_triangles.clear();
  bare.normals.clear();
  bare.normal_triangles.clear();
  const ScanFit fit = fit_scan(bare, c.name);
  std::cout << c.name << ": " << scan.mesh.vertex_count() << " vertices, " << fit.total_ms << " ms wall, "
            << fit.total_cpu_ms << " ms CPU" << (fit.initialised_from_joints ? "" : " (A-pose start)")
            << (fit.joints_estimated_unposed ? ", joints from the unposed scan" : "")
            << (fit.repivoted_limbs > 0 ? ", " + std::to_string(fit.repivoted_limbs) + " limb(s) re-pivoted" : "")
            << "\n";
  for (const std::string& w : fit.warnings)
    std::cout << "  warning: " << w << "\n";
  std::cout << "  fitted pose (deg):";
  for (Joint j :
       {Joint::SPINE1, Joint::SPINE2, Joint::SPINE3, Joint::NECK, Joint::HEAD, Joint::LEFT_COLLAR, Joint::RIGHT_COLLAR,
        Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW, Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW})
    std::cout << " " << joint_name(idx(j)) << " " << std::setprecision(0) << std::fixed
              << fit.pose.axis_angle.row(idx(j)) / DEG;
  std::cout << "\n  scan pose (deg):";
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (!c.scan.axis_angle.row(j).isZero(0.0))
      std::cout << " " << joint_name(j) << " " << c.scan.axis_angle.row(j) / DEG;
  std::cout << "\n";
  for (const ScanFitStage& s : fit.stages)
    std::cout << "  " << std::setw(8) << std::left << s.name << std::right << std::setw(4) << s.iterations
              << " iterations " << std::setw(5) << s.candidates << " candidates " << std::setw(7)
              << std::setprecision(1) << std::fixed << s.ms << " ms (CPU " << s.cpu_ms << " ms), mean "
              << 1000 * s.mean_distance << " mm, p95 " << 1000 * s.p95_distance << " mm\n";

  // Per stage, the joints it leaves (the posed template's, then the final ones) against the rig's.
  for (const ScanFitStage& s : fit.stages) {
    if (s.joints.isZero(0.0)) continue;
    double mean = 0, max = 0;
    int arg = 0;
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const double e = (s.joints.row(j) - scan.joints.row(j)).norm();
      mean += e / JOINT_COUNT;
      if (e > max) max = e, arg = j;
    }
    std::cout << "  joints after " << std::setw(8) << std::left << s.name << std::right << ": mean " << 100 * mean
              << " cm, max " << 100 * max << " cm (" << joint_name(arg) << ")\n";
  }
  // Joints: the rig's canonical joints (bone heads, the spine anchored at SMPL's heights by the
  // built-in mapping, rig_mapping.h) carried by the rig's posing.
  FitErrors out;
  std::cout << "  recovered joint - rig joint (cm)\n" << std::setprecision(2);
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const Eigen::RowVector3d d = fit.joints.row(j) - scan.joints.row(j);
    std::cout << "    " << std::setw(15) << std::left << joint_name(j) << std::right << std::setw(6) << 100 * d.norm()
              << "  (" << 100 * d.x() << ", " << 100 * d.y() << ", " << 100 * d.z() << ")\n";
    out.joint[static_cast<std::size_t>(j)] = d.norm();
  }
  std::cout << "  worst joint " << 100 * *std::max_element(out.joint.begin(), out.joint.end()) << " cm\n";

  // The vertices whose dominant joint lies on another body part (trunk, an arm, a leg) than the
  // rig's: the weights that tear a re-posed scan apart.
  auto chain = [](const SkinWeights& w, std::size_t v) {
    std::size_t best = 4 * v;
    for (std::size_t k = 4 * v + 1; k < 4 * v + 4; ++k)
      if (w.weights[k] > w.weights[best]) best = k;
    return skin_chain_of_joint(w.joints[best]);
  };
  std::array<int, 5> wrong{};
  for (std::size_t v = 0; v < scan.mesh.vertex_count(); ++v)
    if (chain(fit.rigged.weights, v) != chain(rig.weights, v)) ++wrong[static_cast<std::size_t>(chain(rig.weights, v))];
  std::cout << "  vertices on another part than the rig's (trunk, left arm, right arm, left leg, right leg):";
  for (int n : wrong)
    std::cout << " " << n;
  std::cout << "\n";

  // The rigged scan driven to the second pose by our LBS against the rig's own posing.
  const Body expected = pose_body(rig, c.repose);
  const Body got = pose_body(fit.rigged, relative_pose(rig.joints, c.scan, c.repose, fit.rigged.joints));
  double sum = 0, far = 0;
  const std::size_t n = got.mesh.vertex_count();
  for (std::size_t v = 0; v < n; ++v) {
    const double e =
        (Eigen::Vector3f::Map(&got.mesh.positions[3 * v]) - Eigen::Vector3f::Map(&expected.mesh.positions[3 * v]))
            .norm();
    sum += e;
    far = std::max(far, e);
  }
  out.repose_mean = sum / double(n);
  out.repose_max = far;
  out.poor_fit_warned = warns_of_poor_fit(fit);
  std::cout << "  re-posed rigged scan vs the rig's posing: mean " << 1000 * out.repose_mean << " mm, max "
            << 1000 * far << " mm\n";
  return out;
}

// The bars, 3 cm per joint and 1 cm mean re-posing, or the case's own guards.
void expect_within_bars(const PoseCase& c, const FitErrors& e) {
  for (int j = 0; j < JOINT_COUNT; ++j) {
    double limit = 0.03;
    for (const auto& [joint, gap] : c.known_gaps)
      if (idx(joint) == j) limit = gap;
    EXPECT_LT(e.joint[static_cast<std::size_t>(j)], limit) << c.name << ": " << joint_name(j);
  }
  EXPECT_LT(e.repose_mean, c.repose_limit) << c.name;
  // No vertex torn off its limb: a vertex given another part's weights stays behind with that
  // part, tens of cm off in these re-posings (elbows_bent's wrists, once given the other hand's
  // weights: 94 cm). The worst vertex of the 26 poses is 8.7 cm off (weights
  // blended a little differently from the rig's near the shoulders and hips).
  EXPECT_LT(e.repose_max, 0.15) << c.name;
  EXPECT_FALSE(e.poor_fit_warned) << c.name << ": a good fit warned of as poor";
}

// A scan in a pose the fit does not reach is not passed off as fitted: hm08 kneeling (both knees
// at 90°, the shins back along the floor) fits with 279 mm at the 95th percentile and the
// search's A-pose start, and fit_scan() says so.
TEST_F(CorpusScanFit, AKneelingScanIsWarnedOfAsAPoorFit) {
  Pose kneel;
  kneel.axis_angle.row(idx(Joint::LEFT_KNEE)) << std::numbers::pi / 2, 0, 0;
  kneel.axis_angle.row(idx(Joint::RIGHT_KNEE)) << std::numbers::pi / 2, 0, 0;
  Mesh bare = pose_body(*s_rig, kneel).mesh;
  bare.uvs.clear();
  bare.uv_triangles.clear();
  const ScanFit fit = fit_scan(bare, "kneeling");
  ASSERT_FALSE(fit.stages.empty());
  EXPECT_GT(fit.stages.back().p95_distance, 0.06);
  EXPECT_TRUE(warns_of_poor_fit(fit)) << fit.warnings.size() << " warnings, p95 " << fit.stages.back().p95_distance;
}

TEST_P(CorpusScanFit, RecoversTheRigJointsAndReposesLikeTheRig) {
  const PoseCase c = pose_cases()[static_cast<std::size_t>(GetParam())];
  expect_within_bars(c, fit_and_measure(*s_rig, c));
}

INSTANTIATE_TEST_SUITE_P(Poses, CorpusScanFit, ::testing::Range(0, 10));

using CorpusScanFitExtra = CorpusScanFit;

TEST_P(CorpusScanFitExtra, RecoversTheRigJointsAndReposesLikeTheRig) {
  const PoseCase c = extra_cases()[static_cast<std::size_t>(GetParam())];
  expect_within_bars(c, fit_and_measure(*s_rig, c));
}

INSTANTIATE_TEST_SUITE_P(Poses, CorpusScanFitExtra, ::testing::Range(0, 17));

// A survey, off unless VFIT_SCAN_SURVEY_SEEDS names seeds ("9,10,11"): random_pose() four times
// per seed, as extra_cases() does with seed 8, each fitted and summarised (worst joint, re-posing)
// so that a change can be checked on poses it was not developed on (VFIT_SCAN_SURVEY_ONLY=k fits
// only each seed's k-th). Reports; asserts nothing.
TEST_F(CorpusScanFit, SurveyOfRandomPoses) {
  const char* seeds = std::getenv("VFIT_SCAN_SURVEY_SEEDS");
  if (!seeds) GTEST_SKIP() << "set VFIT_SCAN_SURVEY_SEEDS=9,10,11 to survey random poses";
  std::vector<std::string> summary;
  std::stringstream list(seeds);
  for (std::string seed; std::getline(list, seed, ',');) {
    std::mt19937 rng(static_cast<unsigned>(std::stoul(seed)));
    for (int k = 1; k <= 4; ++k) {
      const Pose pose = random_pose(rng);
      if (const char* only = std::getenv("VFIT_SCAN_SURVEY_ONLY"); only && std::stoi(only) != k) continue;
      const std::string name = "seed " + seed + " random " + std::to_string(k);
      const PoseCase c{name.c_str(), pose, Pose{}, {}};
      const FitErrors e = fit_and_measure(*s_rig, c);
      std::ostringstream line;
      line << std::setprecision(2) << std::fixed << name << ": re-posing " << 1000 * e.repose_mean << " mm;";
      for (int j = 0; j < JOINT_COUNT; ++j)
        if (e.joint[static_cast<std::size_t>(j)] > 0.025)
          line << " " << joint_name(j) << " " << 100 * e.joint[static_cast<std::size_t>(j)];
      const auto worst = std::max_element(e.joint.begin(), e.joint.end());
      line << " | worst " << joint_name(static_cast<int>(worst - e.joint.begin())) << " " << 100 * *worst << " cm";
      summary.push_back(line.str());
    }
  }
  std::cout << "SURVEY (joints past 2.5 cm, cm)\n";
  for (const std::string& l : summary)
    std::cout << "SURVEY " << l << "\n";
}

} // namespace
} // namespace vfit
