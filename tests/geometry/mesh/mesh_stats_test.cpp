// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/mesh/mesh_stats.h"

#include <gtest/gtest.h>

#include "vfit/geometry/mesh/units.h"

namespace vfit {
namespace {

// A 0.6 × 0.7 m quad (two triangles) stored in decimetres.
Mesh panel_in_dm() {
  Mesh m;
  m.positions = {0, 0, 0, 6, 0, 0, 6, 7, 0, 0, 7, 0};
  m.triangles = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(MeshStats, BoxIsTheSurfacesAndIgnoresVerticesNoFaceUses) {
  Mesh m = panel_in_dm();
  const MeshStats clean = mesh_stats(m);
  // One stray vertex 50 units away (an exporter's leftover point): not part of the surface.
  m.positions.insert(m.positions.end(), {50, 40, -30});
  const MeshStats stray = mesh_stats(m);
  EXPECT_EQ(stray.bbox_min, clean.bbox_min);
  EXPECT_EQ(stray.bbox_max, clean.bbox_max);
  EXPECT_FLOAT_EQ(stray.largest_extent, 7.0f);
  EXPECT_FLOAT_EQ(stray.max_abs_coordinate, 7.0f);
  // So the units are still read as decimetres, not centimetres.
  EXPECT_EQ(detect_mesh_units(stray.largest_extent, stray.max_abs_coordinate), Units::DM);
}

TEST(MeshStats, PointCloudCountsEveryVertex) {
  Mesh m;
  m.positions = {0, 0, 0, 1, 2, 3, -4, 0, 0};
  const MeshStats s = mesh_stats(m);
  EXPECT_FLOAT_EQ(s.bbox_min[0], -4.0f);
  EXPECT_FLOAT_EQ(s.bbox_max[2], 3.0f);
  EXPECT_FLOAT_EQ(s.largest_extent, 5.0f);
  EXPECT_FLOAT_EQ(s.max_abs_coordinate, 4.0f);
}

} // namespace
} // namespace vfit
