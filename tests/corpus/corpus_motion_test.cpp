// The corpus's motion-capture clips (motion/, see its MANIFEST): every file reads, its up axis
// and length unit come out as the MANIFEST describes the rigs, its frames are finite through
// forward kinematics, and it survives a round trip through bvh_text() exactly.
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "geometry/motion/bvh.h"
#include "test_support.h"

namespace vfit {
namespace {

struct Clip {
  const char* file;
  std::size_t frames;
  UpAxis up;
};
void PrintTo(const Clip& c, std::ostream* os) { *os << c.file; }

class CorpusMotion : public ::testing::TestWithParam<Clip> {};

TEST_P(CorpusMotion, ReadsWithItsAxesAndUnitsAndRoundTrips) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "corpus folder absent (VFIT_CORPUS_DIR)";
  const Clip& c = GetParam();
  const std::filesystem::path path = *corpus / "motion" / c.file;
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " absent";
  const BvhMotion m = read_bvh(path);
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

INSTANTIATE_TEST_SUITE_P(
    Clips, CorpusMotion,
    ::testing::Values(Clip{"mh_walk1.bvh", 14, UpAxis::POS_Z}, Clip{"mh_dance1.bvh", 1, UpAxis::POS_Z},
                      Clip{"mh_tpose.bvh", 1, UpAxis::POS_Z}, Clip{"cmu_02_02.bvh", 299, UpAxis::POS_Y},
                      Clip{"cmu_10_01.bvh", 201, UpAxis::POS_Y}, Clip{"cmu_12_03.bvh", 566, UpAxis::POS_Y}),
    [](const auto& param_info) {
      std::string name = param_info.param.file;
      return name.substr(0, name.find('.'));
    });

} // namespace
} // namespace vfit
