// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/units.h"

#include <gtest/gtest.h>

#include "vfit/kernels/error.h"

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

namespace vfit {
namespace {

// An adult 1.67 m tall (the corpus's MakeHuman body), stored in each unit, inches included.
// Before, detect_mesh_units() read its 65.6 inches as 0.656 m in centimetres.
TEST(Units, ABodyIsReadAtAnAdultsHeightInEveryUnitInchesIncluded) {
  const double height = 1.6659;
  for (Units u : {Units::M, Units::DM, Units::CM, Units::MM, Units::IN}) {
    const double extent = height / metres_per_unit(u);
    EXPECT_EQ(detect_body_units(extent, 0.5 * extent), u) << units_name(u);
    EXPECT_EQ(detect_body_units(extent, extent), u) << units_name(u);
  }
  // In inches, the alternative is named with the flag that overrides it.
  const std::string w = body_units_warning(height / 0.0254, height / 0.0254, Units::IN);
  EXPECT_NE(w.find("units detected as in"), std::string::npos) << w;
  EXPECT_NE(w.find("in cm it would be 0.656 m"), std::string::npos) << w;
  EXPECT_NE(w.find("--units cm"), std::string::npos) << w;
  // The other units keep the plain warning (its text is matched by the CLI's tests).
  EXPECT_EQ(body_units_warning(166.59, 166.59, Units::CM), "units detected as cm; converted to metres");
  EXPECT_EQ(body_units_warning(1.6659, 1.6659, Units::M), "");
}

TEST(Units, ABodyOfNoAdultsHeightKeepsTheUnitOfItsSize) {
  // A child 1.1 m tall in cm (2.8 m in inches, 0.11 m in dm: no unit gives an adult) and a
  // T-pose's 2.5 m arm span in mm: read as before.
  EXPECT_EQ(detect_body_units(110.0, 110.0), Units::CM);
  EXPECT_EQ(detect_body_units(2500.0, 2500.0), Units::MM);
  EXPECT_EQ(detect_body_units(1.1, 1.1), Units::M);
  // A toddler 0.8 m tall in cm is 2.03 m in inches: the adult wins, and the warning says
  // what it would be in cm (the shape cannot tell; --units can).
  EXPECT_EQ(detect_body_units(80.0, 80.0), Units::IN);
  EXPECT_NE(body_units_warning(80.0, 80.0, Units::IN).find("in cm it would be 0.8 m"), std::string::npos);
  EXPECT_FALSE(detect_body_units(0.0, 0.0).has_value());
  EXPECT_FALSE(detect_body_units(1e9, 1e9).has_value());
  EXPECT_FALSE(detect_body_units(std::numeric_limits<double>::quiet_NaN(), 1.0).has_value());
}

// The corpus's male_casualsuit04 tee: 0.534 m across, 0.282 m deep, on hm08 (torso 0.264 m
// deep), stored in each unit. Before, in inches (21 across) it was read as 2.1 m in dm.
TEST(Units, AGarmentIsReadInTheUnitThatWrapsTheBodysTorso) {
  const double across = 0.534, deep = 0.282, torso = 0.264;
  for (Units u : {Units::M, Units::DM, Units::CM, Units::MM, Units::IN}) {
    const double k = 1.0 / metres_per_unit(u);
    for (double reach : {0.5 * across, 3.0}) // at the origin, or worn 3 m up in the file's frame
      EXPECT_EQ(detect_garment_units(across * k, deep * k, reach * k, torso), u) << units_name(u) << " " << reach;
  }
  // Loose (the catalogue's XXL dress, 1.74 × the torso's depth) and tight (0.85 ×, the corpus's
  // shorts, by their height): still in their unit, in cm and in inches.
  for (double wrap : {0.85, 1.74}) {
    EXPECT_EQ(detect_garment_units(60.0, wrap * torso * 100.0, 60.0, torso), Units::CM) << wrap;
    EXPECT_EQ(detect_garment_units(60.0 / 2.54, wrap * torso / 0.0254, 60.0 / 2.54, torso), Units::IN) << wrap;
  }
  // No body, or a garment that wraps nothing (flat: no depth): detect_mesh_units() as before.
  EXPECT_EQ(detect_garment_units(across / 0.0254, deep / 0.0254, across / 0.0254, 0.0),
            detect_mesh_units(across / 0.0254, across / 0.0254));
  EXPECT_EQ(detect_garment_units(53.4, 0.0, 53.4, torso), Units::CM);
  EXPECT_EQ(detect_garment_units(53.4, 28.2, 53.4, std::numeric_limits<double>::quiet_NaN()), Units::CM);
  EXPECT_FALSE(detect_garment_units(1e9, 1e8, 1e9, torso).has_value());
}

} // namespace
} // namespace vfit
