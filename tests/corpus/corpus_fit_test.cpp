// SPDX-License-Identifier: Apache-2.0
// The corpus run: every MakeHuman garment refitted to hm08
// (corpus/MANIFEST.md, makehuman/derived/parts_on_hm08/) fitted by fit_garments(), simulation
// included, onto the rigged hm08 body posed by its rig in three poses. The quality bars,
// recomputed on the returned mesh: the detected type is the one the file's name promises, no
// NaN, no vertex inside the body by more than 1 mm, no garment edge crossing the body. Pieces
// that are not garments on their own (a shirt collar, an inner shirt panel) must be refused
// with an error naming them. Skipped, saying why, when the corpus is absent.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/engine/dress/penetration.h"
#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/engine/fit/pipeline.h"
#include "vfit/geometry/body/gltf_body.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

// The bar: no garment vertex inside the body by more than this (m).
constexpr double MAX_INSIDE_DEPTH = 0.001;

// Arms down with a small abduction (15° from the body), the left knee bent 60° with the hip
// flexed 35° (arms in the rig's A-pose), arms raised 35° above horizontal.
const char* const POSES[] = {"arms_down", "knee_bent", "arms_raised"};

// Every garment of parts_on_hm08 (a test below checks the folder holds no other).
const char* const GARMENTS[] = {"female_casualsuit01__jeans",
                                "female_casualsuit01__tshirt",
                                "female_casualsuit02__shorts",
                                "female_casualsuit02__tshirt",
                                "female_elegantsuit01__blazer",
                                "female_elegantsuit01__skirt",
                                "female_sportsuit01__crop_top",
                                "female_sportsuit01__leggings",
                                "male_casualsuit02__jeans",
                                "male_casualsuit02__longsleeve_tshirt",
                                "male_casualsuit03__jeans",
                                "male_casualsuit03__longsleeve_shirt",
                                "male_casualsuit04__jeans",
                                "male_casualsuit04__tshirt",
                                "male_casualsuit05__inner_shirt",
                                "male_casualsuit05__jacket",
                                "male_casualsuit05__shirt_collar",
                                "male_casualsuit06__jeans",
                                "male_casualsuit06__tshirt",
                                "male_elegantsuit01__suit_jacket",
                                "male_elegantsuit01__suit_trousers",
                                "male_worksuit01__overalls",
                                "male_worksuit01__tshirt"};

// The type a garment's name promises; nullopt for pieces that are not garments on their own:
// the pipeline must refuse those.
std::optional<GarmentType> expected_type(const std::string& name) { return test::corpus_garment_type(name); }

// The rigged hm08 body, loaded once, and each pose's body with its indices, built once.
struct PosedBody {
  Body body;
  std::unique_ptr<ProximityIndex> index;
  std::unique_ptr<EdgeCrossingIndex> crossings;
};

class CorpusFit : public ::testing::TestWithParam<std::tuple<const char*, const char*>> {
protected:
  static void SetUpTestSuite() {
    s_corpus = test::corpus_dir();
    if (!s_corpus) return;
    const auto rig = *s_corpus / "makehuman" / "derived" / "hm08_body_rigged.glb";
    if (std::filesystem::is_regular_file(rig)) s_rest = read_gltf_body(rig.string());
  }
  static void TearDownTestSuite() {
    s_posed.clear();
    s_rest.reset();
  }
  void SetUp() override {
    if (!s_corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
    if (!s_rest) GTEST_SKIP() << "hm08_body_rigged.glb absent from the corpus";
  }

  static const PosedBody& posed(const std::string& pose) {
    auto it = s_posed.find(pose);
    if (it == s_posed.end()) {
      PosedBody p;
      p.body = pose_body(*s_rest, named_pose(pose, s_rest->rest_pose));
      p.index = std::make_unique<ProximityIndex>(p.body.mesh.positions, p.body.mesh.triangles);
      p.crossings = std::make_unique<EdgeCrossingIndex>(p.body.mesh.positions, p.body.mesh.triangles);
      it = s_posed.emplace(pose, std::move(p)).first;
    }
    return it->second;
  }

  static inline std::optional<std::filesystem::path> s_corpus;
  static inline std::optional<Body> s_rest;
  static inline std::map<std::string, PosedBody> s_posed;
};

TEST_P(CorpusFit, MeetsTheFitBars) {
  const std::string pose = std::get<0>(GetParam());
  const std::string name = std::get<1>(GetParam());
  const auto path = *s_corpus / "makehuman" / "derived" / "parts_on_hm08" / (name + ".obj");
  if (!std::filesystem::is_regular_file(path)) GTEST_SKIP() << path << " absent";
  Mesh garment = read_mesh(path).mesh;
  scale_positions(garment.positions, 0.1); // MakeHuman files are in decimetres
  const PosedBody& body = posed(pose);
  FitOptions options;
  options.garment_units = Units::M;

  const std::optional<GarmentType> want = expected_type(name);
  if (!want) {
    try {
      (void)fit_garments(body.body, {{name, garment}}, options);
      FAIL() << name << " is not a garment on its own: expected vfit::Error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name + ": not a recognisable garment"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
    return;
  }

  const FitResult r = fit_garments(body.body, {{name, garment}}, options);
  ASSERT_EQ(r.garments.size(), 1u);
  const Mesh& fitted = r.garments[0].mesh;
  const GarmentFitReport& g = r.report.garments[0];
  EXPECT_EQ(garment_type_name(g.type), garment_type_name(*want));
  ASSERT_EQ(fitted.positions.size(), garment.positions.size());
  ASSERT_TRUE(std::all_of(fitted.positions.begin(), fitted.positions.end(), [](float x) { return std::isfinite(x); }))
      << "NaN or infinite position";
  const PenetrationStats now = measure_penetration(fitted, *body.index, *body.crossings, options.clearance);
  std::printf("%-11s %-38s %-11s inside %3zu (max %.2f mm), crossing edges %3zu | before: inside %4zu (max %5.1f mm), "
              "crossing %3zu | after removal: inside %3zu (max %5.2f mm) | ms: segmentation %.1f, skeletons %.1f, "
              "driving %.1f, penetration %.1f, simulation %.0f "
              "(%s), total %.0f\n",
              pose.c_str(), name.c_str(), garment_type_name(g.type).c_str(), now.inside_count, now.max_depth * 1e3,
              now.crossing_edges, g.before.inside_count, g.before.max_depth * 1e3, g.before.crossing_edges,
              g.after_removal.inside_count, g.after_removal.max_depth * 1e3, g.timings.segmentation_ms,
              g.timings.skeletons_ms, g.timings.driving_ms, g.timings.penetration_ms, g.timings.simulation_ms,
              g.simulation_status.c_str(), g.timings.total_ms);
  for (const std::string& w : g.warnings)
    if (w.find("stretched to over twice") != std::string::npos) std::printf("    torn: %s\n", w.c_str());
  // The report describes the returned mesh.
  EXPECT_EQ(now.inside_count, g.after.inside_count);
  EXPECT_EQ(now.crossing_edges, g.after.crossing_edges);
  EXPECT_NE(g.simulation, SimulationOutcome::SKIPPED);

  EXPECT_LE(now.max_depth, MAX_INSIDE_DEPTH);
  EXPECT_EQ(now.crossing_edges, 0u);
}

// Penetration removal must not draw the garment far out: no edge of the garment after removal
// is longer than twice its length after driving by more than MAX_REMOVAL_ELONGATION. Before the
// direct rounds' pushes were limited (limit_stretch(), engine/penetration.cpp) they
// carried a sleeve vertex squeezed between arm and torso 25 cm out in front (the worksuit's tee
// on arms_down: edges up to 317 mm longer), a skirt's hem on knee_bent 280 mm, a long-sleeve
// shirt 146 mm and the casual jacket 140 mm. Without the simulation, so the stage is seen alone;
// driving is the same fit with the removal's rounds set to 0 (detection only).
// 0.12 m: the solved rounds still stretch edges where they push vertices deep inside out (the
// skirt's hem off the bent thigh 105 mm, the blazer 96 mm, the jacket 68 mm), a known defect
// this bar does not hide; the direct rounds' spikes lay above it.
constexpr double MAX_REMOVAL_ELONGATION = 0.12;

TEST_P(CorpusFit, PenetrationRemovalDrawsNoEdgeFarOut) {
  const std::string pose = std::get<0>(GetParam());
  const std::string name = std::get<1>(GetParam());
  const auto path = *s_corpus / "makehuman" / "derived" / "parts_on_hm08" / (name + ".obj");
  if (!std::filesystem::is_regular_file(path)) GTEST_SKIP() << path << " absent";
  if (!expected_type(name))
    GTEST_SKIP() << name << " is not a garment on its own (MeetsTheFitBars checks it is refused)";
  Mesh garment = read_mesh(path).mesh;
  scale_positions(garment.positions, 0.1); // MakeHuman files are in decimetres
  const PosedBody& body = posed(pose);
  FitOptions options;
  options.garment_units = Units::M;
  options.simulate = false;
  options.penetration_iterations = 0;
  const FitResult driven = fit_garments(body.body, {{name, garment}}, options);
  options.penetration_iterations = FitOptions{}.penetration_iterations;
  const FitResult removed = fit_garments(body.body, {{name, garment}}, options);
  ASSERT_EQ(driven.garments.size(), 1u);
  ASSERT_EQ(removed.garments.size(), 1u);
  const auto [torn, worst] = torn_cloth(removed.garments[0].mesh, driven.garments[0].mesh.positions);
  std::printf("%-11s %-38s removal: %zu edges torn, by up to %.0f mm; after removal inside %zu, crossing %zu\n",
              pose.c_str(), name.c_str(), torn, 1e3 * worst, removed.report.garments[0].after.inside_count,
              removed.report.garments[0].after.crossing_edges);
  EXPECT_LE(worst, MAX_REMOVAL_ELONGATION) << torn << " edges over twice their driven length";
}

INSTANTIATE_TEST_SUITE_P(PosesAndGarments, CorpusFit,
                         ::testing::Combine(::testing::ValuesIn(POSES), ::testing::ValuesIn(GARMENTS)),
                         [](const auto& param) {
                           return std::string(std::get<0>(param.param)) + "_" + std::get<1>(param.param);
                         });

TEST(CorpusFitGarments, TheListIsEveryGarmentOfTheFolder) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "shared corpus not found (set VFIT_CORPUS or place it at ../shared/corpus)";
  const auto dir = *corpus / "makehuman" / "derived" / "parts_on_hm08";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << dir << " absent";
  std::vector<std::string> found, listed(std::begin(GARMENTS), std::end(GARMENTS));
  for (const auto& path : test::files_with_extensions(dir, {".obj"}))
    found.push_back(path.stem().string());
  std::sort(listed.begin(), listed.end());
  EXPECT_EQ(found, listed);
}

} // namespace
} // namespace vfit
