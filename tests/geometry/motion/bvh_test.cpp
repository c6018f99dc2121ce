// SPDX-License-Identifier: Apache-2.0
// BVH motion capture: the hierarchy and frames as written, forward kinematics against hand
// computations for every rotation channel order, the units and up axis inferred from the
// skeleton, an exact round trip through bvh_text(), and a catalogue of bad files.
#include "vfit/geometry/motion/bvh.h"

#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// A small Y-up skeleton in centimetres: hips 90 cm up, a spine to the head, two legs.
std::string skeleton(const std::string& root_channels = "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                     const std::string& joint_channels = "3 Zrotation Xrotation Yrotation") {
  return "HIERARCHY\n"
         "ROOT Hips\n{\n  OFFSET 0 90 0\n  CHANNELS " +
         root_channels +
         "\n"
         "  JOINT Spine\n  {\n    OFFSET 0 10 0\n    CHANNELS " +
         joint_channels +
         "\n"
         "    JOINT Head\n    {\n      OFFSET 0 60 0\n      CHANNELS " +
         joint_channels +
         "\n"
         "      End Site\n      {\n        OFFSET 0 20 0\n      }\n    }\n  }\n"
         "  JOINT LeftUpLeg\n  {\n    OFFSET 10 0 0\n    CHANNELS " +
         joint_channels +
         "\n"
         "    JOINT LeftLeg\n    {\n      OFFSET 0 -45 0\n      CHANNELS " +
         joint_channels +
         "\n"
         "      End Site\n      {\n        OFFSET 0 -45 0\n      }\n    }\n  }\n"
         "  JOINT RightUpLeg\n  {\n    OFFSET -10 0 0\n    CHANNELS " +
         joint_channels +
         "\n"
         "    JOINT RightLeg\n    {\n      OFFSET 0 -45 0\n      CHANNELS " +
         joint_channels +
         "\n"
         "      End Site\n      {\n        OFFSET 0 -45 0\n      }\n    }\n  }\n"
         "}\n";
}

// 6 + 6 × 3 channels.
std::string frames(const std::vector<std::string>& rows, const std::string& time = "0.0333333") {
  std::string out = "MOTION\nFrames: " + std::to_string(rows.size()) + "\nFrame Time: " + time + "\n";
  for (const std::string& r : rows)
    out += r + "\n";
  return out;
}

const std::string REST_ROW = "0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0";

Eigen::Matrix3d rot(char axis, double degrees) {
  const double a = degrees * std::numbers::pi / 180, c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  // Written out by hand (not through Eigen::AngleAxis, which the reader uses).
  if (axis == 'X')
    r << 1, 0, 0, 0, c, -s, 0, s, c;
  else if (axis == 'Y')
    r << c, 0, s, 0, 1, 0, -s, 0, c;
  else
    r << c, -s, 0, s, c, 0, 0, 0, 1;
  return r;
}

TEST(Bvh, ReadsTheHierarchyAndTheFrames) {
  const BvhMotion m = parse_bvh(skeleton() + frames({REST_ROW, REST_ROW}), "test.bvh");
  ASSERT_EQ(m.joints.size(), 10u); // 7 joints and 3 end sites
  EXPECT_EQ(m.joints[0].name, "Hips");
  EXPECT_EQ(m.joints[0].parent, -1);
  EXPECT_EQ(m.joints[3].name, "Head/End Site");
  EXPECT_TRUE(m.joints[3].end_site);
  EXPECT_EQ(m.joints[3].parent, 2);
  EXPECT_EQ(m.find("LeftLeg"), 5);
  EXPECT_EQ(m.find("Nope"), -1);
  EXPECT_EQ(m.columns, 24u);
  EXPECT_EQ(m.joints[4].first_column, 12u);
  EXPECT_EQ(m.frame_count(), 2u);
  EXPECT_NEAR(m.fps(), 30.0, 1e-4);
  EXPECT_EQ(m.unit, "cm");
  EXPECT_DOUBLE_EQ(m.metres_per_unit, 0.01);
  EXPECT_EQ(m.up, UpAxis::POS_Y);
}

// Every order of three rotation channels, on the root and on a joint, against the product of
// hand-written axis rotations in the listed order (R = R_first · R_second · R_third).
TEST(Bvh, RotationChannelsComposeInFileOrder) {
  const std::vector<std::string> orders = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  const double angle[3] = {30, -50, 70}; // per axis X, Y, Z
  for (const std::string& order : orders) {
    std::string channels = "3";
    for (char a : order)
      channels += std::string(" ") + a + "rotation";
    std::string row = "1 2 3";
    for (char a : order)
      row += " " + std::to_string(angle[a - 'X']);
    for (int j = 0; j < 6; ++j)
      for (char a : order)
        row += " " + std::to_string(j == 0 ? angle[a - 'X'] : 0.0);
    const BvhMotion m =
        parse_bvh(skeleton("6 Xposition Yposition Zposition" + channels.substr(1), channels) + frames({row}), "o.bvh");
    Eigen::Matrix3d expected = Eigen::Matrix3d::Identity();
    for (char a : order)
      expected = expected * rot(a, angle[a - 'X']);
    const std::vector<Eigen::Isometry3d> w = bvh_world_transforms(m, 0);
    EXPECT_LT((w[0].linear() - expected).norm(), 1e-12) << order;
    EXPECT_LT((w[0].translation() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12) << order;
    // Spine turned by the same angles: the head's end site at the chain's end.
    const Eigen::Matrix3d both = expected * expected;
    const Eigen::Vector3d head_end =
        Eigen::Vector3d(1, 2, 3) + expected * Eigen::Vector3d(0, 10, 0) + both * Eigen::Vector3d(0, 80, 0);
    EXPECT_LT((w[3].translation() - head_end).norm(), 1e-9) << order;
  }
}

// The root's position channels are its position (BVH's definition); a joint's position channels
// are added to its OFFSET when they hover about zero, and replace it when they hover about it.
TEST(Bvh, PositionChannelsOfTheRootAndOfJoints) {
  const std::string six = "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation";
  // Spine's channels 6–11 (6 channels on every joint below).
  auto row = [](const std::string& spine) {
    std::string r = "5 95 -3 0 0 0 " + spine;
    for (int j = 0; j < 5; ++j)
      r += " 0 0 0 0 0 0";
    return r;
  };
  const BvhMotion a = parse_bvh(skeleton(six, six) + frames({row("0 1 0 0 0 0")}), "a.bvh");
  EXPECT_TRUE(a.joints[0].absolute_position);
  EXPECT_FALSE(a.joints[1].absolute_position);
  std::vector<Eigen::Isometry3d> w = bvh_world_transforms(a, 0);
  EXPECT_LT((w[0].translation() - Eigen::Vector3d(5, 95, -3)).norm(), 1e-12);
  EXPECT_LT((w[1].translation() - Eigen::Vector3d(5, 106, -3)).norm(), 1e-12);
  const BvhMotion b = parse_bvh(skeleton(six, six) + frames({row("0 11 0 0 0 0")}), "b.bvh");
  EXPECT_TRUE(b.joints[1].absolute_position);
  w = bvh_world_transforms(b, 0);
  EXPECT_LT((w[1].translation() - Eigen::Vector3d(5, 106, -3)).norm(), 1e-12);
}

TEST(Bvh, InfersUnitsAndUpFromTheSkeleton) {
  // The same skeleton scaled: metres, millimetres, inches; Z up (old MakeHuman rigs).
  const BvhMotion cm = parse_bvh(skeleton() + frames({REST_ROW}), "cm.bvh");
  EXPECT_EQ(cm.unit, "cm");
  auto scaled = [](std::string text, double factor) {
    std::string out;
    std::size_t at = 0;
    for (;;) {
      const std::size_t o = text.find("OFFSET ", at);
      if (o == std::string::npos) break;
      const std::size_t end = text.find('\n', o);
      out += text.substr(at, o - at) + "OFFSET";
      double x, y, z;
      std::sscanf(text.c_str() + o + 7, "%lf %lf %lf", &x, &y, &z);
      out += " " + std::to_string(x * factor) + " " + std::to_string(y * factor) + " " + std::to_string(z * factor);
      at = end;
    }
    return out + text.substr(at);
  };
  const std::string row_scaled = "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0";
  EXPECT_EQ(parse_bvh(scaled(skeleton(), 0.01) + frames({row_scaled}), "m.bvh").unit, "m");
  EXPECT_EQ(parse_bvh(scaled(skeleton(), 10) + frames({row_scaled}), "mm.bvh").unit, "mm");
  EXPECT_EQ(parse_bvh(scaled(skeleton(), 1 / 2.54) + frames({row_scaled}), "in.bvh").unit, "inch");
  const BvhMotion odd = parse_bvh(scaled(skeleton(), 0.3) + frames({row_scaled}), "odd.bvh");
  EXPECT_EQ(odd.unit, "scaled");
  EXPECT_NEAR(odd.metres_per_unit * 0.3 * 180, 1.7, 1e-9); // the skeleton is 180 cm × 0.3 units tall
  // Z up: swap Y and Z in every OFFSET.
  std::string z = skeleton();
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{{"OFFSET 0 90 0", "OFFSET 0 0 90"},
                                                                                 {"OFFSET 0 10 0", "OFFSET 0 0 10"},
                                                                                 {"OFFSET 0 60 0", "OFFSET 0 0 60"},
                                                                                 {"OFFSET 0 20 0", "OFFSET 0 0 20"},
                                                                                 {"OFFSET 0 -45 0", "OFFSET 0 0 -45"}})
    for (std::size_t at = z.find(from); at != std::string::npos; at = z.find(from, at))
      z.replace(at, from.size(), to);
  EXPECT_EQ(parse_bvh(z + frames({REST_ROW}), "z.bvh").up, UpAxis::POS_Z);
  // Without a joint named like a head: from the legs (the hub's two smallest branches).
  std::string nameless = z;
  for (const std::string name : {"Head", "Spine"})
    for (std::size_t at = nameless.find(name); at != std::string::npos; at = nameless.find(name, at))
      nameless.replace(at, name.size(), "J" + std::to_string(at));
  EXPECT_EQ(parse_bvh(nameless + frames({REST_ROW}), "n.bvh").up, UpAxis::POS_Z);
}

TEST(Bvh, RoundTripIsExact) {
  std::string row = "1.5 92.25 -3.125 10.1 -20.2 30.3";
  for (int k = 0; k < 18; ++k)
    row += " " + std::to_string(0.1 * k - 0.7) + "e-1";
  const BvhMotion a = parse_bvh(skeleton() + frames({REST_ROW, row}, "0.008333"), "a.bvh");
  const BvhMotion b = parse_bvh(bvh_text(a), "b.bvh");
  ASSERT_EQ(b.joints.size(), a.joints.size());
  for (std::size_t j = 0; j < a.joints.size(); ++j) {
    EXPECT_EQ(b.joints[j].name, a.joints[j].name);
    EXPECT_EQ(b.joints[j].parent, a.joints[j].parent);
    EXPECT_EQ(b.joints[j].offset, a.joints[j].offset);
    EXPECT_EQ(b.joints[j].channels, a.joints[j].channels);
  }
  EXPECT_EQ(b.values, a.values);
  EXPECT_EQ(b.frame_time, a.frame_time);
  EXPECT_EQ(bvh_text(b), bvh_text(a));
}

TEST(Bvh, AcceptsCrlfTabsAndBlankLines) {
  std::string text = skeleton() + frames({REST_ROW, "", REST_ROW});
  // frames() counted 3 rows; the blank one is not a frame.
  text.replace(text.find("Frames: 3"), 9, "Frames: 2");
  std::string crlf;
  for (char c : text) {
    if (c == '\n')
      crlf += "\r\n";
    else
      crlf += c == ' ' ? '\t' : c;
  }
  const BvhMotion m = parse_bvh(crlf, "crlf.bvh");
  EXPECT_EQ(m.frame_count(), 2u);
  EXPECT_EQ(m.columns, 24u);
}

struct BadCase {
  const char* name;
  std::string text;
  const char* message; // a fragment of the error
  int line;            // the line the error names
};
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

std::vector<BadCase> bad_cases() {
  const std::string s = skeleton();
  const int motion_line = 1 + int(std::count(s.begin(), s.end(), '\n')); // the MOTION line
  std::string wrong_count = s;
  wrong_count.replace(wrong_count.find("CHANNELS 3"), 10, "CHANNELS 4");
  std::string unknown = s;
  unknown.replace(unknown.find("Zrotation Xrotation Yrotation"), 9, "Wrotation");
  std::string twice = s;
  twice.replace(twice.find("Zrotation Xrotation Yrotation"), 29, "Zrotation Xrotation Zrotation");
  std::string duplicate = s;
  duplicate.replace(duplicate.find("JOINT RightUpLeg"), 16, "JOINT LeftUpLeg");
  std::string nan_offset = s;
  nan_offset.replace(nan_offset.find("OFFSET 0 10 0"), 13, "OFFSET 0 nan 0");
  std::string unclosed = s.substr(0, s.rfind('}'));
  return {
      {"empty", "", "expected 'HIERARCHY'", 1},
      {"not_bvh", "solid cube\n", "expected 'HIERARCHY', found 'solid'", 1},
      {"truncated_hierarchy", s.substr(0, s.find("    JOINT LeftLeg")), "unexpected end of file", 0},
      {"unclosed_root", unclosed + frames({REST_ROW}), "expected JOINT, End Site or '}', found 'MOTION'",
       motion_line - 1},
      {"channel_count_mismatch", wrong_count + frames({REST_ROW}), "unknown channel 'JOINT'", 0},
      {"unknown_channel", unknown + frames({REST_ROW}), "unknown channel 'Wrotation'", 0},
      {"repeated_channel", twice + frames({REST_ROW}), "listed twice", 0},
      {"duplicate_joint", duplicate + frames({REST_ROW}), "a second joint named 'LeftUpLeg'", 0},
      {"nan_offset", nan_offset + frames({REST_ROW}), "'nan' is not finite", 0},
      {"zero_frames", s + "MOTION\nFrames: 0\nFrame Time: 0.03\n", "Frames: expected a whole number", motion_line + 1},
      {"absurd_frames", s + "MOTION\nFrames: 1e12\nFrame Time: 0.03\n", "Frames: expected a whole number",
       motion_line + 1},
      {"fractional_frames", s + "MOTION\nFrames: 2.5\nFrame Time: 0.03\n", "Frames: expected a whole number",
       motion_line + 1},
      {"zero_frame_time", s + frames({REST_ROW}, "0"), "Frame Time: expected seconds", motion_line + 2},
      {"negative_frame_time", s + frames({REST_ROW}, "-0.03"), "Frame Time: expected seconds", motion_line + 2},
      {"truncated_motion", s + "MOTION\nFrames: 3\nFrame Time: 0.03\n" + REST_ROW + "\n",
       "the file ends after 1 of the 3 frames", 0},
      {"short_frame", s + frames({REST_ROW, "0 90 0"}), "frame 2 has 3 values; the hierarchy has 24", motion_line + 4},
      {"long_frame", s + frames({REST_ROW + " 0"}), "frame 1 has more than 24 values", motion_line + 3},
      {"nan_value", s + frames({"0 90 nan" + REST_ROW.substr(6)}), "frame 1, value 3: 'nan' is not a finite number",
       motion_line + 3},
      {"inf_value", s + frames({"0 90 inf" + REST_ROW.substr(6)}), "is not a finite number", motion_line + 3},
      {"text_value", s + frames({"0 90 x" + REST_ROW.substr(6)}), "'x' is not a finite number", motion_line + 3},
      {"extra_frames", s + frames({REST_ROW}) + REST_ROW + "\n", "more frame lines than the 1", motion_line + 4},
      {"second_root", s + s.substr(s.find("ROOT")) + frames({REST_ROW}), "a second ROOT", 0},
  };
}

class BadBvh : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadBvh, IsRefusedNamingTheFileAndLine) {
  const BadCase& c = GetParam();
  try {
    (void)parse_bvh(c.text, "bad.bvh");
    FAIL() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad.bvh"), std::string::npos) << what;
    EXPECT_NE(what.find(c.message), std::string::npos) << what;
    if (c.line > 0) {
      EXPECT_EQ(e.line(), c.line) << what;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadBvh, ::testing::ValuesIn(bad_cases()),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

} // namespace
} // namespace vfit
