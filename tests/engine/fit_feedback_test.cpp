// SPDX-License-Identifier: Apache-2.0
// Fit feedback: strain against a known stretch, and the size verdicts of seed 000 Fig. 13 (the
// catalogue's trousers P1-P4 on one body: tight, good, loose, falls off) and of tops by size.
#include "vfit/engine/fit/fit_feedback.h"

#include <map>

#include <gtest/gtest.h>

#include "test_support.h"

#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

const Body& body() { return test::mannequin(RestPose::APOSE, 5000); }

const Garment& garment(GarmentType type, const char* size) {
  static std::map<std::string, Garment> cache;
  const std::string key = garment_type_name(type) + size;
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  GarmentOptions o;
  o.type = type;
  o.size = size;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2500;
  return cache.emplace(key, make_garment(o)).first->second;
}

TEST(FitFeedback, StrainIsTheEdgeStretchAndEaseTheSignedDistance) {
  const Garment& g = garment(GarmentType::TEE, "M");
  Mesh stretched = g.mesh;
  for (float& x : stretched.positions)
    x *= 1.05f; // every edge 5 % longer
  const FitFeedback f = fit_feedback(g.mesh, stretched, g.vertex_parts, GarmentType::TEE, body());
  ASSERT_EQ(f.strain.size(), g.mesh.vertex_count());
  for (float s : f.strain)
    ASSERT_NEAR(s, 0.05, 1e-4); // float rounding of the scaled positions
  const FitFeedback same = fit_feedback(g.mesh, g.mesh, g.vertex_parts, GarmentType::TEE, body());
  for (float s : same.strain)
    ASSERT_NEAR(s, 0.0f, 1e-6f); // rest lengths are stored as float
  // The catalogue tee is built 3 mm or more outside its body: every vertex's ease is positive.
  for (float e : same.ease)
    ASSERT_GT(e, 0.0f);
}

// Seed 000 Fig. 13: the four trousers on one body get four different, correct verdicts.
TEST(FitFeedback, TrousersP1ToP4AreTightGoodLooseAndFallOff) {
  const std::pair<const char*, SizeVerdict> cases[] = {{"P1", SizeVerdict::TIGHT},
                                                       {"P2", SizeVerdict::GOOD},
                                                       {"P3", SizeVerdict::LOOSE},
                                                       {"P4", SizeVerdict::FALLS_OFF}};
  for (const auto& [size, want] : cases) {
    const Garment& g = garment(GarmentType::TROUSERS, size);
    const FitFeedback f = fit_feedback(g.mesh, g.mesh, g.vertex_parts, GarmentType::TROUSERS, body());
    EXPECT_EQ(size_verdict_name(f.verdict), size_verdict_name(want)) << size << ": " << f.reason;
    for (const RegionFeedback& r : f.regions)
      std::cout << size << " " << r.name << ": " << r.vertices << " vertices, girth ease " << 100 * r.girth_ease
                << " cm, mean ease " << r.mean_ease_mm << " mm, verdict " << size_verdict_name(r.verdict) << "\n";
  }
}

TEST(FitFeedback, TeesByChestEase) {
  const std::pair<const char*, SizeVerdict> cases[] = {
      {"XS", SizeVerdict::TIGHT}, {"M", SizeVerdict::GOOD}, {"XXL", SizeVerdict::LOOSE}};
  for (const auto& [size, want] : cases) {
    const Garment& g = garment(GarmentType::TEE, size);
    const FitFeedback f = fit_feedback(g.mesh, g.mesh, g.vertex_parts, GarmentType::TEE, body());
    EXPECT_EQ(size_verdict_name(f.verdict), size_verdict_name(want)) << size << ": " << f.reason;
    for (const RegionFeedback& r : f.regions)
      std::cout << size << " " << r.name << ": " << r.vertices << " vertices, girth ease " << 100 * r.girth_ease
                << " cm, mean ease " << r.mean_ease_mm << " mm, verdict " << size_verdict_name(r.verdict) << "\n";
  }
}

TEST(FitFeedback, AWaistbandThatSlidDownFallsOffAndOneThatSettledStaysUp) {
  // Placed where it was built (the "before simulation" state), then moved down by the
  // simulation: by 3 cm it settled onto the hips and stays up; by 12 cm it slid off.
  const Garment& g = garment(GarmentType::TROUSERS, "P2");
  auto lowered = [&](float dy) {
    Mesh m = g.mesh;
    for (std::size_t v = 0; v < m.vertex_count(); ++v)
      m.positions[3 * v + 1] -= dy;
    return m;
  };
  FitFeedback f = fit_feedback(g.mesh, lowered(0.03f), g.vertex_parts, GarmentType::TROUSERS, body(), g.mesh.positions);
  EXPECT_EQ(f.verdict, SizeVerdict::GOOD) << f.reason;
  EXPECT_NEAR(f.waistband_drop, 0.03, 1e-5);
  f = fit_feedback(g.mesh, lowered(0.12f), g.vertex_parts, GarmentType::TROUSERS, body(), g.mesh.positions);
  EXPECT_EQ(f.verdict, SizeVerdict::FALLS_OFF) << f.reason;
  EXPECT_NE(f.reason.find("slid 12.0 cm"), std::string::npos) << f.reason;
}

TEST(FitFeedback, MismatchedInputsAreErrors) {
  const Garment& g = garment(GarmentType::TEE, "M");
  std::vector<GarmentPart> few(g.vertex_parts.begin(), g.vertex_parts.end() - 1);
  EXPECT_THROW(fit_feedback(g.mesh, g.mesh, few, GarmentType::TEE, body()), Error);
  Mesh other = g.mesh;
  other.triangles.resize(other.triangles.size() - 3);
  EXPECT_THROW(fit_feedback(g.mesh, other, g.vertex_parts, GarmentType::TEE, body()), Error);
  const std::vector<float> short_before(6, 0.0f);
  EXPECT_THROW(fit_feedback(g.mesh, g.mesh, g.vertex_parts, GarmentType::TEE, body(), short_before), Error);
}

// A cloth grid of 2 cm edges: uniformly stretched by 20 % nothing is torn; one vertex drawn 5 cm
// out of its plane tears its edges (over twice their 2 cm, by over 2 cm); a sliver edge of
// 0.1 mm stretched to 3× (0.2 mm longer) is no tear.
TEST(FitFeedback, TornClothIsWarnedAboutAndStretchOrSliversAreNot) {
  const Mesh grid = make_grid(11, 11, 0.2f, 0.2f); // edges 2 cm
  Mesh stretched = grid;
  for (float& x : stretched.positions)
    x *= 1.2f;
  EXPECT_EQ(torn_cloth_warning(stretched, grid.positions), "");
  Mesh pulled = grid;
  pulled.positions[3 * (5 * 11 + 5) + 1] += 0.05f; // the middle vertex, 5 cm up
  const std::string w = torn_cloth_warning(pulled, grid.positions);
  EXPECT_NE(w.find("edges stretched to over twice their modelled length"), std::string::npos) << w;
  EXPECT_EQ(w.substr(0, 2), "6 ") << w; // the middle vertex's 6 edges (the grid's triangulation)
  Mesh sliver;
  sliver.positions = {0, 0, 0, 1e-4f, 0, 0, 0, 0.02f, 0};
  sliver.triangles = {0, 1, 2};
  Mesh drawn = sliver;
  drawn.positions[3] = 3e-4f;
  EXPECT_EQ(torn_cloth_warning(drawn, sliver.positions), "");
}

} // namespace
} // namespace vfit
