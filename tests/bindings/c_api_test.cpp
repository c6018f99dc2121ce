// SPDX-License-Identifier: Apache-2.0
// The C API (bindings/c/vfit.h) against the engine it wraps: the same fit bit for bit at the
// same thread count, errors as statuses and messages (never exceptions, nothing returned), the
// report's JSON, meshes in and out, and a dressed character stepped through it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "vfit/engine/animate/dressed_character.h"
#include "vfit/engine/engine.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/kernels/version.h"
#include "vfit/vfit.h"

namespace {

struct Context {
  vfit_context c = nullptr;
  Context() {
    EXPECT_EQ(vfit_context_create(VFIT_BACKEND_TBB, nullptr, 2, &c), VFIT_OK) << vfit_context_create_error();
  }
  ~Context() { vfit_context_release(c); }
  std::string message() const { return vfit_context_error_message(c); }
};

TEST(CApi, FitsBitForBitAsTheEngineDoes) {
  vfit::EngineOptions eo;
  eo.threads = 2;
  const vfit::Engine engine(eo);
  vfit::SourcedBody made = engine.make_body(vfit::BodySource{});
  const vfit::Body posed = made.loaded.posed(vfit::named_pose("demo", made.body.rest_pose));
  vfit::GarmentOptions go;
  go.type = vfit::GarmentType::TEE;
  go.target_vertices = 1500;
  std::vector<vfit::FitGarmentInput> inputs(1);
  inputs[0].name = "tee";
  inputs[0].mesh = vfit::make_garment(go).mesh;
  const vfit::FitResult expected = engine.fit(posed, inputs);

  Context ctx;
  vfit_body body = nullptr;
  ASSERT_EQ(vfit_body_mannequin(ctx.c, nullptr, nullptr, 0, &body), VFIT_OK) << ctx.message();
  ASSERT_EQ(vfit_body_set_named_pose(ctx.c, body, "demo"), VFIT_OK) << ctx.message();
  vfit_mesh tee = nullptr;
  ASSERT_EQ(vfit_mesh_catalogue(ctx.c, "tee", "M", "tpose", 1500, &tee), VFIT_OK) << ctx.message();
  const char* names[] = {"tee"};
  vfit_fit fit = nullptr;
  ASSERT_EQ(vfit_fit_garments(ctx.c, body, &tee, names, 1, nullptr, &fit), VFIT_OK) << ctx.message();
  vfit_mesh fitted = nullptr;
  ASSERT_EQ(vfit_fit_garment(ctx.c, fit, 0, &fitted), VFIT_OK);
  const std::vector<float> got(vfit_mesh_positions(fitted),
                               vfit_mesh_positions(fitted) + 3 * vfit_mesh_vertex_count(fitted));
  EXPECT_EQ(got, expected.garments[0].mesh.positions);
  const std::vector<std::int32_t> triangles(vfit_mesh_triangles(fitted),
                                            vfit_mesh_triangles(fitted) + 3 * vfit_mesh_triangle_count(fitted));
  EXPECT_EQ(triangles, expected.garments[0].mesh.triangles);

  const auto report = nlohmann::json::parse(vfit_fit_report_json(fit));
  EXPECT_EQ(report["vfit"]["version"], vfit::version());
  EXPECT_EQ(report["vfit"]["commit"], vfit::git_commit());
  EXPECT_EQ(report["garments"][0]["name"], "tee");
  EXPECT_EQ(report["verdict"], vfit_fit_verdict(fit));
  EXPECT_EQ(report["body"]["kind"], "mannequin");
  EXPECT_EQ(report["garments"][0]["penetration"]["after"]["inside_count"],
            expected.report.garments[0].after.inside_count);

  // Fitted onto a posed body: not animatable.
  vfit_character character = nullptr;
  EXPECT_EQ(vfit_character_create(ctx.c, body, fit, 1, 0, &character), VFIT_ERROR_ARGUMENT);
  EXPECT_EQ(character, nullptr);
  EXPECT_NE(ctx.message().find("posed body"), std::string::npos) << ctx.message();
  vfit_mesh_release(fitted);
  vfit_fit_release(fit);
  vfit_mesh_release(tee);
  vfit_body_release(body);
}

TEST(CApi, ErrorsAreStatusesWithAMessageAndReturnNothing) {
  Context ctx;
  vfit_mesh mesh = reinterpret_cast<vfit_mesh>(&ctx); // must be reset to NULL on failure
  const float positions[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::int32_t bad[] = {0, 1, 3};
  EXPECT_EQ(vfit_mesh_create(ctx.c, positions, 3, bad, 1, &mesh), VFIT_ERROR_INPUT);
  EXPECT_EQ(mesh, nullptr);
  EXPECT_NE(ctx.message().find("triangle 0 names vertex 3"), std::string::npos) << ctx.message();
  EXPECT_EQ(vfit_context_error(ctx.c), VFIT_ERROR_INPUT);

  const float nan_positions[] = {0, 0, 0, 1, std::numeric_limits<float>::quiet_NaN(), 0, 0, 1, 0};
  const std::int32_t good[] = {0, 1, 2};
  EXPECT_EQ(vfit_mesh_create(ctx.c, nan_positions, 3, good, 1, &mesh), VFIT_ERROR_INPUT);
  EXPECT_NE(ctx.message().find("vertex 1"), std::string::npos) << ctx.message();
  ASSERT_EQ(vfit_mesh_create(ctx.c, positions, 3, good, 1, &mesh), VFIT_OK);
  EXPECT_EQ(vfit_context_error(ctx.c), VFIT_OK) << "a call that succeeds clears the error";
  EXPECT_EQ(ctx.message(), "");
  EXPECT_EQ(vfit_mesh_vertex_count(mesh), 3u);
  EXPECT_EQ(vfit_mesh_triangle_count(mesh), 1u);

  vfit_mesh none = nullptr;
  EXPECT_EQ(vfit_mesh_create(nullptr, positions, 3, good, 1, &none), VFIT_ERROR_ARGUMENT);
  EXPECT_EQ(vfit_mesh_create(ctx.c, nullptr, 3, good, 1, &none), VFIT_ERROR_ARGUMENT);
  EXPECT_EQ(vfit_mesh_catalogue(ctx.c, "tee", "M", "lotus", 2000, &none), VFIT_ERROR_ARGUMENT);
  EXPECT_NE(ctx.message().find("lotus"), std::string::npos) << ctx.message();
  EXPECT_EQ(vfit_mesh_catalogue(ctx.c, "tee", "M", nullptr, 10, &none), VFIT_ERROR_INPUT) << "too few vertices";
  EXPECT_EQ(none, nullptr);

  vfit_body body = nullptr;
  EXPECT_EQ(vfit_body_read(ctx.c, "no/such/body.glb", &body), VFIT_ERROR_INPUT);
  EXPECT_EQ(body, nullptr);
  EXPECT_NE(ctx.message().find("no/such/body.glb"), std::string::npos) << ctx.message();
  double measurements[VFIT_MEASUREMENT_COUNT] = {5.0, 0.78, 0.48, 0.55, 0.25, 0.36, 0.96, 0.80, 0.98, 0.56, 0.37};
  EXPECT_EQ(vfit_body_mannequin(ctx.c, measurements, nullptr, 0, &body), VFIT_ERROR_INPUT);
  EXPECT_NE(ctx.message().find("height"), std::string::npos) << ctx.message();
  ASSERT_EQ(vfit_body_mannequin(ctx.c, nullptr, nullptr, 2000, &body), VFIT_OK) << ctx.message();
  EXPECT_EQ(vfit_body_set_named_pose(ctx.c, body, "lotus"), VFIT_ERROR_INPUT);
  double pose[75] = {};
  pose[5] = std::nan("");
  EXPECT_EQ(vfit_body_set_pose(ctx.c, body, pose), VFIT_ERROR_ARGUMENT);
  vfit_fit fit = nullptr;
  EXPECT_EQ(vfit_fit_garments(ctx.c, body, nullptr, nullptr, 0, nullptr, &fit), VFIT_ERROR_ARGUMENT);
  vfit_fit_options o = vfit_fit_options_default();
  o.fabric = "kevlar";
  EXPECT_EQ(vfit_fit_garments(ctx.c, body, &mesh, nullptr, 1, &o, &fit), VFIT_ERROR_INPUT);
  EXPECT_NE(ctx.message().find("kevlar"), std::string::npos) << ctx.message();
  EXPECT_EQ(fit, nullptr);
  o.fabric = nullptr;
  EXPECT_EQ(vfit_fit_garments(ctx.c, body, &mesh, nullptr, 1, &o, &fit), VFIT_ERROR_INPUT) << "one triangle";
  EXPECT_NE(ctx.message().find("garment0"), std::string::npos) << ctx.message();
  vfit_body_release(body);
  vfit_mesh_release(mesh);
  vfit_mesh_release(nullptr); // NULL is ignored
  vfit_context_release(nullptr);

  vfit_context no_context = nullptr;
  EXPECT_EQ(vfit_context_create(static_cast<vfit_backend>(7), nullptr, 0, &no_context), VFIT_ERROR_ARGUMENT);
  EXPECT_EQ(no_context, nullptr);
  EXPECT_EQ(vfit_context_create(VFIT_BACKEND_TBB, nullptr, -1, &no_context), VFIT_ERROR_ARGUMENT);
  EXPECT_NE(std::string(vfit_context_create_error()).find("threads"), std::string::npos);
}

TEST(CApi, MeshesRoundTripThroughFiles) {
  Context ctx;
  vfit_mesh tee = nullptr;
  ASSERT_EQ(vfit_mesh_catalogue(ctx.c, "tee", "M", nullptr, 1000, &tee), VFIT_OK) << ctx.message();
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "vfit_c_api_mesh";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "tee.ply").string();
  ASSERT_EQ(vfit_mesh_write(ctx.c, tee, path.c_str()), VFIT_OK) << ctx.message();
  vfit_mesh back = nullptr;
  ASSERT_EQ(vfit_mesh_read(ctx.c, path.c_str(), &back), VFIT_OK) << ctx.message();
  EXPECT_EQ(vfit_mesh_vertex_count(back), vfit_mesh_vertex_count(tee));
  EXPECT_EQ(vfit_mesh_triangle_count(back), vfit_mesh_triangle_count(tee));
  vfit_mesh_release(back);
  vfit_mesh_release(tee);
  std::filesystem::remove_all(dir);
}

TEST(CApi, StepsADressedCharacterAsTheEngineDoes) {
  Context ctx;
  vfit_body body = nullptr;
  ASSERT_EQ(vfit_body_mannequin(ctx.c, nullptr, "apose", 3000, &body), VFIT_OK) << ctx.message();
  vfit_mesh tee = nullptr;
  ASSERT_EQ(vfit_mesh_catalogue(ctx.c, "tee", "M", "apose", 1200, &tee), VFIT_OK) << ctx.message();
  vfit_fit_options o = vfit_fit_options_default();
  o.simulate = 0;
  vfit_fit fit = nullptr;
  ASSERT_EQ(vfit_fit_garments(ctx.c, body, &tee, nullptr, 1, &o, &fit), VFIT_OK) << ctx.message();
  vfit_character character = nullptr;
  ASSERT_EQ(vfit_character_create(ctx.c, body, fit, 1, 0, &character), VFIT_OK) << ctx.message();

  // The same character built in C++ from the same fit gives the same frames.
  vfit::EngineOptions eo;
  eo.threads = 2;
  const vfit::Engine engine(eo);
  vfit::BodySource source;
  source.request.mannequin.target_vertices = 3000;
  const vfit::SourcedBody made = engine.make_body(source);
  vfit::GarmentOptions go;
  go.type = vfit::GarmentType::TEE;
  go.pose = vfit::RestPose::APOSE;
  go.target_vertices = 1200;
  std::vector<vfit::FitGarmentInput> inputs(1);
  inputs[0].name = "garment0";
  inputs[0].mesh = vfit::make_garment(go).mesh;
  vfit::FitOptions fo;
  fo.simulate = false;
  const vfit::FitResult fitted = engine.fit(made.body, inputs, fo);
  vfit::AnimationOptions ao;
  ao.threads = 2;
  vfit::DressedCharacter expected(made.body, fitted.garments, ao);

  double pose[75] = {};
  for (int frame = 0; frame < 6; ++frame) {
    pose[3 * 18 + 1] = 0.1 * frame; // left elbow
    ASSERT_EQ(vfit_character_step(ctx.c, character, pose, 1.0 / 30), VFIT_OK) << ctx.message();
    vfit::Pose p;
    p.axis_angle(18, 1) = 0.1 * frame;
    expected.step(p, 1.0 / 30);
    std::size_t n = 0;
    const float* got = vfit_character_garment_positions(character, 0, &n);
    ASSERT_EQ(n, expected.garment_positions(0).size() / 3);
    EXPECT_TRUE(std::equal(got, got + 3 * n, expected.garment_positions(0).begin())) << "frame " << frame;
  }
  pose[0] = std::nan("");
  EXPECT_EQ(vfit_character_step(ctx.c, character, pose, 1.0 / 30), VFIT_ERROR_ARGUMENT);
  EXPECT_EQ(vfit_character_garment_positions(character, 1, nullptr), nullptr) << "one garment only";
  vfit_character_release(character);
  vfit_fit_release(fit);
  vfit_mesh_release(tee);
  vfit_body_release(body);
}

} // namespace
