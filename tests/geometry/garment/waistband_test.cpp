// SPDX-License-Identifier: Apache-2.0
// The waistband of a bottom garment (geometry/garment/waistband.h).
#include "vfit/geometry/garment/waistband.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// The waistband of trousers (the band within 3 cm of the topmost opening) and nothing else.
TEST(Waistband, IsTheBandBelowTheTopmostOpening) {
  GarmentOptions go;
  go.type = GarmentType::TROUSERS;
  go.pose = RestPose::APOSE;
  go.target_vertices = 2500;
  const Mesh trousers = make_garment(go).mesh;
  const std::vector<std::int32_t> band = waistband_vertices(trousers.position_view(), trousers.triangle_view(), 0.03);
  ASSERT_FALSE(band.empty());
  float top = -INFINITY, band_low = INFINITY;
  for (std::size_t i = 0; i < trousers.vertex_count(); ++i)
    top = std::max(top, trousers.positions[3 * i + 1]);
  for (std::int32_t v : band)
    band_low = std::min(band_low, trousers.positions[3 * std::size_t(v) + 1]);
  // Distances along the cloth are at least vertical drops: the band ends within 3 cm of the
  // waist's lowest rim point, and the waist rim (near the top) is in it.
  EXPECT_GT(band_low, top - 0.03f - 0.02f); // 2 cm: the waist rim itself is not level
  EXPECT_LT(band.size(), trousers.vertex_count() / 4);
  EXPECT_TRUE(waistband_vertices(trousers.position_view(), trousers.triangle_view(), 0.0).size() > 0);
  EXPECT_THROW(waistband_vertices(trousers.position_view(), trousers.triangle_view(), -1.0), Error);
  const Mesh sphere = make_uv_sphere(8, 16, 0.25f);
  EXPECT_TRUE(waistband_vertices(sphere.position_view(), sphere.triangle_view(), 0.03).empty());
}

} // namespace
} // namespace vfit
