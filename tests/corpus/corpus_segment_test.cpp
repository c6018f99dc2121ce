// SPDX-License-Identifier: Apache-2.0
// Garment segmentation (seed 000 §4) on the MakeHuman garments refitted to hm08
// (corpus/MANIFEST.md): real meshes in the A-pose, quads split into triangles, open fronts,
// pockets and button holes. The detected type must match the file's name, and every sleeve
// and leg must be one connected region on its own side. Skipped, saying why, when the corpus
// is absent.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <optional>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/garment/segment.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

// The type a garment's name promises (test::corpus_garment_type); an unknown name fails.
std::optional<GarmentType> expected_type(const std::string& name) {
  bool known = false;
  const std::optional<GarmentType> type = test::corpus_garment_type(name, &known);
  if (!known) ADD_FAILURE() << "no expectation for " << name;
  return type;
}

std::size_t pieces(const Mesh& m, const std::vector<GarmentPart>& parts, GarmentPart part) {
  std::vector<std::vector<std::int32_t>> nbr(m.vertex_count());
  for (std::size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      nbr[m.triangles[3 * f + k]].push_back(m.triangles[3 * f + (k + 1) % 3]);
  std::vector<char> seen(m.vertex_count(), 0);
  std::size_t count = 0;
  for (std::size_t s = 0; s < m.vertex_count(); ++s) {
    if (parts[s] != part || seen[s]) continue;
    ++count;
    std::vector<std::int32_t> stack{std::int32_t(s)};
    seen[s] = 1;
    while (!stack.empty()) {
      const std::int32_t v = stack.back();
      stack.pop_back();
      for (std::int32_t u : nbr[v])
        if (parts[u] == part && !seen[u]) {
          seen[u] = 1;
          stack.push_back(u);
        }
    }
  }
  return count;
}

TEST(CorpusSegment, MakeHumanGarmentsGetTheirTypeAndOneRegionPerLimb) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "corpus absent (set VFIT_CORPUS)";
  const auto dir = *corpus / "makehuman" / "derived" / "parts_on_hm08";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << dir << " absent";
  const auto files = test::files_with_extensions(dir, {".obj"});
  ASSERT_GE(files.size(), 20u);
  for (const auto& path : files) {
    const std::string name = path.stem().string();
    SCOPED_TRACE(name);
    Mesh m = read_mesh(path).mesh;
    scale_positions(m.positions, 0.1); // MakeHuman files are in decimetres
    const std::optional<GarmentType> want = expected_type(name);
    if (!want) {
      EXPECT_THROW(segment_garment(m), Error);
      continue;
    }
    const GarmentSegmentation s = segment_garment(m);
    EXPECT_EQ(garment_type_name(s.type), garment_type_name(*want));
    const bool top = *want == GarmentType::TEE || *want == GarmentType::LONG_SLEEVE;
    const bool bottom = *want == GarmentType::TROUSERS || *want == GarmentType::SHORTS;
    float lo = INFINITY, hi = -INFINITY;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      lo = std::min(lo, m.positions[3 * v]);
      hi = std::max(hi, m.positions[3 * v]);
    }
    const float mid = 0.5f * (lo + hi);
    std::cout << "  " << name << ": " << garment_type_name(s.type) << ", " << m.vertex_count() << " vertices, "
              << s.timings.total_ms << " ms\n";
    for (GarmentPart part :
         {GarmentPart::LEFT_SLEEVE, GarmentPart::RIGHT_SLEEVE, GarmentPart::LEFT_LEG, GarmentPart::RIGHT_LEG}) {
      const bool sleeve = part == GarmentPart::LEFT_SLEEVE || part == GarmentPart::RIGHT_SLEEVE;
      const std::size_t n = pieces(m, s.vertex_parts, part);
      EXPECT_EQ(n, (sleeve ? top : bottom) ? 1u : 0u) << garment_part_name(part);
      // Sleeves stay on their side of the mid-plane, legs on theirs of the crotch (eq. 3's Pt).
      const bool left = part == GarmentPart::LEFT_SLEEVE || part == GarmentPart::LEFT_LEG;
      const float split = sleeve || !s.key_points.crotch ? mid : float(s.key_points.crotch->x());
      std::size_t wrong_side = 0, total = 0;
      for (std::size_t v = 0; v < m.vertex_count(); ++v)
        if (s.vertex_parts[v] == part) {
          ++total;
          wrong_side += (m.positions[3 * v] > split) != left;
        }
      EXPECT_EQ(wrong_side, 0u) << garment_part_name(part) << " of " << total;
    }
  }
}

} // namespace
} // namespace vfit
