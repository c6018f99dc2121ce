// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/engine.h"

#include <gtest/gtest.h>

#include "vfit/engine/fit/pipeline.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

std::vector<FitGarmentInput> small_tee() {
  GarmentOptions g;
  g.type = GarmentType::TEE;
  g.target_vertices = 2000;
  return {{"tee", make_garment(g).mesh}};
}

// The body half and the garment half in one call: the engine makes the body (mannequin posed
// by name) and fits onto it exactly what fit_garments() fits onto that body, with the engine's
// backend in the report.
TEST(Engine, FitsABodySourceAsThePipelineDoesOnTheBodyItMade) {
  const Engine engine({Backend::SERIAL, "", 0});
  BodySource source;
  source.request.source = "mannequin";
  source.pose = "arms_down";
  FitOptions options;
  options.simulate = false;
  SourcedBody made;
  const FitResult by_engine = engine.fit(source, small_tee(), options, &made);
  EXPECT_EQ(made.body.mesh.vertex_count(), engine.make_body(source).body.mesh.vertex_count());
  const FitResult by_pipeline = fit_garments(made.body, small_tee(), options);
  ASSERT_EQ(by_engine.garments.size(), 1u);
  EXPECT_EQ(by_engine.garments[0].mesh.positions, by_pipeline.garments[0].mesh.positions);
  EXPECT_EQ(by_engine.report.backend, "serial");
  EXPECT_EQ(by_engine.report.garments[0].after.inside_count, 0u);
}

TEST(Engine, AnUnknownPoseIsAnError) {
  const Engine engine;
  BodySource source;
  source.pose = "no_such_pose";
  EXPECT_THROW((void)engine.make_body(source), Error);
}

} // namespace
} // namespace vfit
