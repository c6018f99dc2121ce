#include "geometry/mesh/units.h"

#include <gtest/gtest.h>

#include "kernels/error.h"

namespace vfit {
namespace {

TEST(Units, DetectsHumanScaleObjectsInEveryUnit) {
  // A 1.7 m body and a 0.6 m shirt, stored in each unit.
  for (double metres : {1.7, 0.6, 2.5}) {
    EXPECT_EQ(detect_units(metres), Units::M) << metres;
    EXPECT_EQ(detect_units(metres * 10), Units::DM) << metres;
    EXPECT_EQ(detect_units(metres * 100), Units::CM) << metres;
    EXPECT_EQ(detect_units(metres * 1000), Units::MM) << metres;
  }
  EXPECT_EQ(detect_units(16.659), Units::DM); // the MakeHuman body in the corpus
}

TEST(Units, RefusesToGuessImpossibleExtents) {
  EXPECT_FALSE(detect_units(0.0).has_value());
  EXPECT_FALSE(detect_units(-1.0).has_value());
  EXPECT_FALSE(detect_units(1e9).has_value());
  EXPECT_FALSE(detect_units(std::numeric_limits<double>::quiet_NaN()).has_value());
}

TEST(Units, ParsesNamesAndScales) {
  EXPECT_EQ(parse_units("cm"), Units::CM);
  EXPECT_EQ(parse_units("Millimetres"), Units::MM);
  EXPECT_EQ(parse_units("in"), Units::IN);
  EXPECT_EQ(parse_units("Inches"), Units::IN);
  EXPECT_EQ(units_name(Units::IN), "in");
  EXPECT_DOUBLE_EQ(metres_per_unit(Units::IN), 0.0254);
  EXPECT_THROW(parse_units("furlong"), Error);
  EXPECT_DOUBLE_EQ(metres_per_unit(Units::DM), 0.1);
  std::vector<float> p = {10.0f, 20.0f, -30.0f};
  scale_positions(p, metres_per_unit(Units::CM));
  EXPECT_FLOAT_EQ(p[0], 0.1f);
  EXPECT_FLOAT_EQ(p[2], -0.3f);
}

} // namespace
} // namespace vfit

namespace vfit {
namespace {

TEST(Units, SmallPiecesWornAwayFromTheOriginUseTheirPosition) {
  // A 27 cm collar stored in dm sits 6 dm above the origin: the extent alone says metres.
  EXPECT_EQ(detect_units(2.7), Units::M);
  EXPECT_EQ(detect_mesh_units(2.7, 6.1), Units::DM);
  // A metre-unit body standing on the origin, and a garment worn on it.
  EXPECT_EQ(detect_mesh_units(1.8, 1.8), Units::M);
  EXPECT_EQ(detect_mesh_units(0.5, 1.5), Units::M);
  EXPECT_FALSE(detect_mesh_units(1.0, std::numeric_limits<double>::infinity()).has_value());
  // A 53 cm tee in metres placed 4 m from the origin (a scene): still metres, not decimetres.
  EXPECT_EQ(detect_mesh_units(0.53, 4.2), Units::M);
  // A 25 cm garment in dm, on the origin: only decimetres give a garment's size.
  EXPECT_EQ(detect_mesh_units(2.5 * 1.1, 2.75), Units::DM);
  // Both plausible (a 2 m body in dm or a 20 cm piece in cm): the position decides.
  EXPECT_EQ(detect_mesh_units(20.0, 20.0), Units::DM);
  EXPECT_EQ(detect_mesh_units(20.0, 150.0), Units::CM);
  // Every unit of a human-scale object, at rest on the origin.
  for (double metres : {0.6, 1.7, 2.5}) {
    EXPECT_EQ(detect_mesh_units(metres, metres), Units::M) << metres;
    EXPECT_EQ(detect_mesh_units(metres * 10, metres * 10), Units::DM) << metres;
    EXPECT_EQ(detect_mesh_units(metres * 100, metres * 100), Units::CM) << metres;
    EXPECT_EQ(detect_mesh_units(metres * 1000, metres * 1000), Units::MM) << metres;
  }
}

} // namespace
} // namespace vfit
