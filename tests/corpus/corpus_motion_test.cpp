// SPDX-License-Identifier: Apache-2.0
// The corpus's motion-capture clips (motion/, see its MANIFEST): every file reads, its up axis
// and length unit come out as the MANIFEST describes the rigs, its frames are finite through
// forward kinematics, and it survives a round trip through bvh_text() exactly; played on the demo
// outfit with the cloth, no frame is ever non-finite.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "demo_outfit.h"
#include "test_support.h"
#include "vfit/engine/animate/dressed_character.h"
#include "vfit/geometry/body/gltf_body.h"
#include "vfit/geometry/body/mannequin_shape.h"
#include "vfit/geometry/motion/bvh.h"
#include "vfit/geometry/motion/retarget.h"

namespace vfit {
namespace {

struct Clip {
  const char* file;
  std::size_t frames;
  UpAxis up;
  const char* mapping; // the convention detected
  bool walk;           // a walk: its feet are checked for sliding while planted
};
void PrintTo(const Clip& c, std::ostream* os) { *os << c.file; }

class CorpusMotion : public ::testing::TestWithParam<Clip> {};

// The corpus's clip `file`, or nullopt when the corpus or the clip is absent (the test skips).
std::optional<std::filesystem::path> clip_path(const char* file) {
  const auto corpus = test::corpus_dir();
  if (!corpus || !std::filesystem::exists(*corpus / "motion" / file)) return std::nullopt;
  return *corpus / "motion" / file;
}

TEST_P(CorpusMotion, ReadsWithItsAxesAndUnitsAndRoundTrips) {
  const Clip& c = GetParam();
  const auto path = clip_path(c.file);
  if (!path) GTEST_SKIP() << "the corpus clip " << c.file << " is absent";
  const BvhMotion m = read_bvh(*path);
  EXPECT_EQ(m.frame_count(), c.frames);
  EXPECT_EQ(m.up, c.up) << up_axis_name(m.up);
  // The skeleton at rest is an adult's height in metres, whatever the file's unit.
  const std::vector<Eigen::Vector3d> rest = bvh_rest_positions(m);
  double lo = INFINITY, hi = -INFINITY;
  const int axis = m.up == UpAxis::POS_Z || m.up == UpAxis::NEG_Z   ? 2
                   : m.up == UpAxis::POS_X || m.up == UpAxis::NEG_X ? 0
                                                                    : 1;
  for (const Eigen::Vector3d& p : rest) {
    lo = std::min(lo, p[axis]);
    hi = std::max(hi, p[axis]);
  }
  const double height = (hi - lo) * m.metres_per_unit;
  std::printf("%s: %zu joints, %zu channels, %zu frames at %.1f fps, up %s, unit %s (%.4f m), height %.2f m\n", c.file,
              m.joints.size(), m.columns, m.frame_count(), m.fps(), up_axis_name(m.up).c_str(), m.unit.c_str(),
              m.metres_per_unit, height);
  EXPECT_GE(height, 1.4);
  EXPECT_LE(height, 2.1);
  for (std::size_t f = 0; f < m.frame_count(); ++f)
    for (const Eigen::Isometry3d& w : bvh_world_transforms(m, f))
      ASSERT_TRUE(w.matrix().allFinite()) << "frame " << f;
  const BvhMotion back = parse_bvh(bvh_text(m), "round trip");
  EXPECT_EQ(back.values, m.values);
  ASSERT_EQ(back.joints.size(), m.joints.size());
  for (std::size_t j = 0; j < m.joints.size(); ++j)
    EXPECT_EQ(back.joints[j].absolute_position, m.joints[j].absolute_position) << m.joints[j].name;
  EXPECT_EQ(back.unit, m.unit);
  EXPECT_EQ(back.up, m.up);
}

// The largest horizontal drift (m) of a foot joint while planted: runs of frames where it is
// within 2 cm of the lowest it goes in the clip, each measured from where the run starts.
double planted_slide(const std::vector<JointPositions>& frames, Joint foot) {
  double floor = INFINITY;
  for (const JointPositions& p : frames)
    floor = std::min(floor, p(idx(foot), 1));
  double worst = 0;
  bool planted = false;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  for (const JointPositions& p : frames) {
    const Eigen::Vector2d at(p(idx(foot), 0), p(idx(foot), 2));
    if (p(idx(foot), 1) > floor + 0.02) {
      planted = false;
      continue;
    }
    if (!planted) start = at;
    planted = true;
    worst = std::max(worst, (at - start).norm());
  }
  return worst;
}

// Retargeted onto the mannequin (A- and T-pose rests) and onto the corpus's rigged body: the
// convention the MANIFEST names is found, every frame is finite, no joint flips (turns by more
// than 60° between frames, unless the clip's own joint does), and a walk's planted feet slide
// at most 3 cm more than the clip's own.
TEST_P(CorpusMotion, RetargetsOntoOurBodiesWithoutFlipsOrSliding) {
  const Clip& c = GetParam();
  const auto path = clip_path(c.file);
  if (!path) GTEST_SKIP() << "the corpus clip " << c.file << " is absent";
  const BvhMotion m = read_bvh(*path);
  const MotionMapping mapping = detect_motion_mapping(m);
  EXPECT_EQ(mapping.name, c.mapping);
  std::vector<std::pair<std::string, JointPositions>> bodies = {
      {"mannequin A", MannequinShape(BodyMeasurements{}, RestPose::APOSE).joints()},
      {"mannequin T", MannequinShape(BodyMeasurements{}, RestPose::TPOSE).joints()}};
  const std::filesystem::path rigged = *test::corpus_dir() / "makehuman" / "derived" / "hm08_body_rigged.glb";
  if (std::filesystem::exists(rigged)) bodies.emplace_back("hm08", read_gltf_body(rigged.string()).joints);
  for (const auto& [body, rest] : bodies) {
    const RetargetedMotion r = retarget_bvh(m, rest, mapping);
    ASSERT_EQ(r.frames.size(), m.frame_count());
    // Per canonical joint, its largest turn between two frames, and the clip's own largest turn of
    // the BVH joint that drives it (the nearest mapped joint at or above it).
    std::vector<JointPositions> joints;
    std::array<double, JOINT_COUNT> turn{}, source_turn{};
    std::array<std::int32_t, JOINT_COUNT> driver{};
    for (int j = 0; j < JOINT_COUNT; ++j) {
      int k = j;
      while (k >= 0 && mapping.joint[std::size_t(k)].empty())
        k = joint_parent(k);
      driver[std::size_t(j)] = m.find(mapping.joint[std::size_t(k)]);
    }
    std::array<Eigen::Isometry3d, JOINT_COUNT> last{};
    std::vector<Eigen::Isometry3d> last_source;
    for (std::size_t f = 0; f < r.frames.size(); ++f) {
      const auto world = joint_world_transforms(rest, r.frames[f]);
      const std::vector<Eigen::Isometry3d> world_source = bvh_world_transforms(m, f);
      joints.push_back(posed_joints(rest, r.frames[f]));
      ASSERT_TRUE(joints.back().allFinite()) << body << " frame " << f;
      for (int j = 0; f > 0 && j < JOINT_COUNT; ++j) {
        const auto angle = [](const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
          return Eigen::AngleAxisd(a.transpose() * b).angle();
        };
        turn[std::size_t(j)] =
            std::max(turn[std::size_t(j)], angle(last[std::size_t(j)].linear(), world[std::size_t(j)].linear()));
        const auto d = std::size_t(driver[std::size_t(j)]);
        source_turn[std::size_t(j)] =
            std::max(source_turn[std::size_t(j)], angle(last_source[d].linear(), world_source[d].linear()));
      }
      last = world;
      last_source = world_source;
    }
    // The largest turn beyond the clip's own, and where.
    int worst = 0;
    for (int j = 1; j < JOINT_COUNT; ++j)
      if (turn[std::size_t(j)] - source_turn[std::size_t(j)] >
          turn[std::size_t(worst)] - source_turn[std::size_t(worst)])
        worst = j;
    const double slide =
        c.walk ? std::max(planted_slide(joints, Joint::LEFT_ANKLE), planted_slide(joints, Joint::RIGHT_ANKLE)) : 0;
    // The same measure on the clip itself (its ankles in metres, its up axis as Y), scaled by the
    // leg ratio: what the motion slides before any retargeting.
    std::vector<JointPositions> source;
    const int up = m.up == UpAxis::POS_Z || m.up == UpAxis::NEG_Z ? 2 : 1;
    for (std::size_t f = 0; c.walk && f < m.frame_count(); ++f) {
      const std::vector<Eigen::Isometry3d> w = bvh_world_transforms(m, f);
      JointPositions p = JointPositions::Zero();
      for (const Joint ankle : {Joint::LEFT_ANKLE, Joint::RIGHT_ANKLE}) {
        const Eigen::Vector3d a = r.leg_ratio * m.metres_per_unit *
                                  w[std::size_t(m.find(mapping.joint[std::size_t(idx(ankle))]))].translation();
        p.row(idx(ankle)) << a[0], a[up], a[up == 2 ? 1 : 2];
      }
      source.push_back(p);
    }
    const double source_slide =
        c.walk ? std::max(planted_slide(source, Joint::LEFT_ANKLE), planted_slide(source, Joint::RIGHT_ANKLE)) : 0;
    std::printf(
        "%s on %s: mapping %s, leg ratio %.3f, %zu unmapped; largest turn between frames beyond the clip's own: "
        "%s %.1f deg (clip %.1f deg); planted ankles slide %.1f mm (the clip itself %.1f mm)\n",
        c.file, body.c_str(), mapping.name.c_str(), r.leg_ratio, r.unmapped.size(), joint_name(worst).data(),
        turn[std::size_t(worst)] * 180 / std::numbers::pi, source_turn[std::size_t(worst)] * 180 / std::numbers::pi,
        slide * 1000, source_slide * 1000);
    // No flip of our own: a joint turns by no more than 60° between frames, or by no more than
    // the clip's own joint does (1° for round-off and the rest alignment).
    for (int j = 0; j < JOINT_COUNT; ++j)
      EXPECT_LE(turn[std::size_t(j)],
                std::max(60 * std::numbers::pi / 180, source_turn[std::size_t(j)] + std::numbers::pi / 180))
          << body << " " << joint_name(j);
    // Planted feet slide no more than 3 cm beyond what the clip's own ankles slide (an in-place
    // walk cycle slides by design).
    if (c.walk) {
      EXPECT_LE(slide, source_slide + 0.03) << body;
    }
  }
}

// MakeHuman's T-pose clip on the A-pose mannequin: the arms come up level with the shoulders
// (the rest alignment turns the A-pose's lowered arms into the rig's T).
TEST(CorpusMotionTPose, LiftsAnAPoseBodysArmsLevel) {
  const auto path = clip_path("mh_tpose.bvh");
  if (!path) GTEST_SKIP() << "the corpus clip mh_tpose.bvh is absent";
  const BvhMotion m = read_bvh(*path);
  const JointPositions rest = MannequinShape(BodyMeasurements{}, RestPose::APOSE).joints();
  const RetargetedMotion r = retarget_bvh(m, rest, detect_motion_mapping(m));
  const JointPositions p = posed_joints(rest, r.frames.front());
  for (const auto& [shoulder, wrist] :
       {std::pair{Joint::LEFT_SHOULDER, Joint::LEFT_WRIST}, std::pair{Joint::RIGHT_SHOULDER, Joint::RIGHT_WRIST}}) {
    const double drop = p(idx(shoulder), 1) - p(idx(wrist), 1);
    std::printf("%s: wrist %.1f mm below the shoulder (at rest %.1f mm)\n", joint_name(idx(wrist)).data(), drop * 1000,
                (rest(idx(shoulder), 1) - rest(idx(wrist), 1)) * 1000);
    EXPECT_LT(std::abs(drop), 0.05);
  }
}

// Every clip played on the demo outfit (catalogue trousers under a tee, 2,000 vertices each, on
// the A-pose mannequin) with the cloth on, 45 frames at 30 fps at most: no frame is ever
// non-finite and no cloth diverges; what the clean-up leaves (vertices over 1 mm inside, edges
// through the body, layer offences, measured as the fit measures a garment) is printed per clip
// (docs/benchmarks.md keeps the figures; the armpits of a skinned body cut into themselves where
// a clip's arms hang close to the torso).
TEST_P(CorpusMotion, PlaysOnTheDemoOutfitWithTheCloth) {
  const Clip& c = GetParam();
  const auto path = clip_path(c.file);
  if (!path) GTEST_SKIP() << "the corpus clip " << c.file << " is absent";
  const Body& body = test::mannequin(RestPose::APOSE, 7000);
  const std::vector<FittedGarment> garments = test::demo_outfit(2000);
  const BvhMotion m = read_bvh(*path);
  RetargetedMotion r = retarget_bvh(m, body.joints, detect_motion_mapping(m));
  const std::vector<Pose> frames = resample_poses(r.frames, r.fps, 30);
  DressedCharacter character(body, garments);
  std::size_t inside = 0, crossing = 0, layer = 0, bad_frames = 0;
  double step_ms = 0;
  const std::size_t n = std::min<std::size_t>(frames.size(), 45);
  for (std::size_t f = 0; f < n; ++f) {
    const FrameReport& s = character.step(frames[f], 1.0 / 30);
    step_ms += s.total_ms;
    EXPECT_EQ(s.diverged, 0u) << "frame " << f;
    EXPECT_EQ(s.non_finite, 0u) << "frame " << f;
    for (std::size_t g = 0; g < character.garment_count(); ++g)
      for (const float x : character.garment_positions(g))
        ASSERT_TRUE(std::isfinite(x)) << "frame " << f;
    const FramePenetration p = character.measure();
    inside = std::max(inside, p.inside_1mm);
    crossing = std::max(crossing, p.crossing_edges);
    layer = std::max(layer, p.layer_inside + p.layer_crossing_edges);
    bad_frames += p.inside_1mm + p.crossing_edges + p.layer_inside + p.layer_crossing_edges > 0 ? 1 : 0;
  }
  std::printf("%s on the demo outfit: %zu frames, %.1f ms per frame; worst frame: %zu vertices over 1 mm inside, %zu "
              "edges through the body, %zu layer offences; %zu frames not clean\n",
              c.file, n, step_ms / double(n), inside, crossing, layer, bad_frames);
}

INSTANTIATE_TEST_SUITE_P(Clips, CorpusMotion,
                         ::testing::Values(Clip{"mh_walk1.bvh", 14, UpAxis::POS_Z, "makehuman_old", true},
                                           Clip{"mh_dance1.bvh", 1, UpAxis::POS_Z, "makehuman_old", false},
                                           Clip{"mh_tpose.bvh", 1, UpAxis::POS_Z, "makehuman", false},
                                           Clip{"cmu_02_02.bvh", 299, UpAxis::POS_Y, "daz", true},
                                           Clip{"cmu_10_01.bvh", 201, UpAxis::POS_Y, "motionbuilder", false},
                                           Clip{"cmu_12_03.bvh", 566, UpAxis::POS_Y, "cmu", false}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.file;
                           return name.substr(0, name.find('.'));
                         });

} // namespace
} // namespace vfit
