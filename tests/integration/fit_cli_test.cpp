// SPDX-License-Identifier: Apache-2.0
// `vfit fit`: a catalogue tee and trousers from OBJ files onto the mannequin → fitted mesh,
// JSON report, PNG; bad input → exit 2 and nothing written.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/engine/view/image.h"
#include "vfit/geometry/body/skeleton.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/primitives.h"

namespace vfit {
namespace {

std::size_t file_count(const std::filesystem::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir))
    ++n;
  return n;
}

void write_catalogue(const std::filesystem::path& path, GarmentType type) {
  GarmentOptions o;
  o.type = type;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2000;
  write_mesh(path, make_garment(o).mesh);
}

// Several --body: one output of each kind per body, named by the body, each the same file as the
// body's own `vfit fit` writes.
TEST(FitCli, SeveralBodiesGetTheirOwnOutputsEqualToFittingEachAlone) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const std::vector<std::string> flags = {"--pose-rest", "apose", "--vertices", "3000", "--no-simulation", "--quiet"};
  auto with_flags = [&](std::vector<std::string> a) {
    a.insert(a.end(), flags.begin(), flags.end());
    return a;
  };
  // A broader body than the default mannequin, rigged, as a file.
  const auto body = test::run_cli({"body", "--pose-rest", "apose", "--vertices", "3000", "--chest", "1.1", "--rigged",
                                   (dir / "broad.glb").string()});
  ASSERT_EQ(body.exit_code, 0) << body.err;
  const auto both = test::run_cli(with_flags({"fit", "--garment", (dir / "tee.obj").string(), "--body", "mannequin",
                                              "--body", (dir / "broad.glb").string(), "--out",
                                              (dir / "fit.obj").string(), "--report", (dir / "fit.json").string()}));
  ASSERT_EQ(both.exit_code, 0) << both.err;
  for (const char* tag : {"mannequin", "broad"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / ("fit." + std::string(tag) + ".obj"))) << tag;
    EXPECT_TRUE(std::filesystem::exists(dir / ("fit." + std::string(tag) + ".json"))) << tag;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "fit.obj"));
  const auto alone = test::run_cli(with_flags({"fit", "--garment", (dir / "tee.obj").string(), "--body",
                                               (dir / "broad.glb").string(), "--out", (dir / "alone.obj").string()}));
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  EXPECT_EQ(test::read_file(dir / "fit.broad.obj"), test::read_file(dir / "alone.obj"));
  EXPECT_NE(test::read_file(dir / "fit.broad.obj"), test::read_file(dir / "fit.mannequin.obj"));
  const nlohmann::json second = nlohmann::json::parse(test::read_file(dir / "fit.broad.json"));
  EXPECT_EQ(second["garments"][0]["timings_ms"]["segmentation"].get<double>(), 0.0)
      << "segmented once, for the first body";
  // One body file twice: numbered apart. --debug and --joints-in take one body.
  const auto twice = test::run_cli(with_flags({"fit", "--garment", (dir / "tee.obj").string(), "--body", "mannequin",
                                               "--body", "mannequin", "--report", (dir / "twice.json").string()}));
  ASSERT_EQ(twice.exit_code, 0) << twice.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "twice.mannequin_1.json"));
  EXPECT_TRUE(std::filesystem::exists(dir / "twice.mannequin_2.json"));
  const auto debug = test::run_cli(with_flags({"fit", "--garment", (dir / "tee.obj").string(), "--body", "mannequin",
                                               "--body", "mannequin", "--debug", (dir / "debug").string()}));
  EXPECT_EQ(debug.exit_code, 2) << debug.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "debug"));
}

TEST(FitCli, FitsObjGarmentsAndWritesMeshReportAndPicture) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  write_catalogue(dir / "trousers.obj", GarmentType::TROUSERS);
  const auto r = test::run_cli({"fit",
                                "--body",
                                "mannequin",
                                "--pose-rest",
                                "apose",
                                "--vertices",
                                "3000",
                                "--garment",
                                (dir / "tee.obj").string(),
                                "--garment",
                                (dir / "trousers.obj").string(),
                                "--out",
                                (dir / "fitted.glb").string(),
                                "--report",
                                (dir / "report.json").string(),
                                "--render",
                                (dir / "fit.png").string(),
                                "--no-simulation",
                                "--render-size",
                                "64"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("segmentation"), std::string::npos) << r.out;

  const nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "report.json"));
  for (const char* stage :
       {"segmentation", "skeletons", "driving", "coarse_move", "penetration", "simulation", "total"})
    EXPECT_TRUE(j["timings_ms"].contains(stage)) << stage;
  for (const char* when : {"before", "after"}) {
    EXPECT_TRUE(j["penetration"][when]["inside_count"].is_number_unsigned()) << when;
    EXPECT_TRUE(j["penetration"][when]["max_depth_mm"].is_number()) << when;
    EXPECT_TRUE(j["penetration"][when]["crossing_edges"].is_number_unsigned()) << when;
    EXPECT_TRUE(j["penetration"][when]["layer_inside_count"].is_number_unsigned()) << when;
  }
  EXPECT_LE(j["penetration"]["after"]["max_depth_mm"].get<double>(), 1.0);
  EXPECT_EQ(j["penetration"]["after"]["crossing_edges"].get<std::size_t>(), 0u);
  EXPECT_EQ(j["penetration"]["after"]["layer_inside_count"].get<std::size_t>(), 0u);
  // Layered: the trousers (listed second) go on first, the tee over them.
  EXPECT_EQ(j["garments"][1]["order"], 0);
  EXPECT_EQ(j["garments"][1]["inner_layers"], 0);
  EXPECT_EQ(j["garments"][0]["inner_layers"], 1);
  for (std::size_t g = 0; g < 2; ++g)
    EXPECT_EQ(j["garments"][g]["penetration"]["after"]["crossing_edges"].get<std::size_t>(), 0u) << g;
  const std::set<std::string> verdicts = {"falls off", "tight", "loose", "good"};
  EXPECT_TRUE(verdicts.contains(j["verdict"].get<std::string>())) << j["verdict"];
  for (const auto& g : j["garments"]) {
    EXPECT_TRUE(verdicts.contains(g["verdict"].get<std::string>())) << g["verdict"];
    EXPECT_FALSE(g["regions"].empty());
  }
  EXPECT_TRUE(j["machine"]["cpu_model"].is_string());
  ASSERT_EQ(j["garments"].size(), 2u);
  EXPECT_EQ(j["garments"][0]["type"], "tee");
  EXPECT_EQ(j["garments"][1]["type"], "trousers");
  EXPECT_EQ(j["garments"][0]["driving"].get<std::string>().rfind("driven", 0), 0u) << j["garments"][0]["driving"];

  // body + two garments as labelled meshes in one glb
  const ParsedMesh fitted = read_mesh(dir / "fitted.glb");
  EXPECT_EQ(fitted.mesh.label_names.size(), 3u);
  const Image image = read_png(dir / "fit.png");
  EXPECT_EQ(image.height, 64);
}

// The fitted .glb is a scene any glTF viewer or DCC tool can pose: body and garments skinned to
// one skeleton bound where the body stands (its posed joints), each with a material of its own
// colour; the Khronos validator finds no error (unnormalised weights included) and no warning.
TEST(FitCli, TheFittedGlbIsSkinnedAndColouredForAnyViewer) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto r =
      test::run_cli({"fit", "--body", "mannequin", "--vertices", "3000", "--pose", "demo", "--garment",
                     (dir / "tee.obj").string(), "--out", (dir / "fitted.glb").string(), "--no-simulation", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string glb = test::read_file(dir / "fitted.glb");
  const nlohmann::json doc = nlohmann::json::parse(test::glb_json_text(glb));
  ASSERT_EQ(doc["meshes"].size(), 2u);
  ASSERT_EQ(doc["skins"].size(), 1u);
  EXPECT_EQ(doc["skins"][0]["joints"].size(), std::size_t(JOINT_COUNT));
  std::set<std::string> colours;
  for (const auto& m : doc["materials"])
    colours.insert(m["pbrMetallicRoughness"]["baseColorFactor"].dump());
  EXPECT_EQ(colours.size(), 2u) << "body and tee look different";
  std::size_t skinned = 0;
  for (const auto& node : doc["nodes"])
    if (node.contains("mesh")) {
      EXPECT_EQ(node["skin"], 0) << node.dump();
      ++skinned;
      const auto& attributes = doc["meshes"][node["mesh"].get<std::size_t>()]["primitives"][0]["attributes"];
      EXPECT_TRUE(attributes.contains("JOINTS_0") && attributes.contains("WEIGHTS_0")) << attributes.dump();
    }
  EXPECT_EQ(skinned, 2u);

  const std::optional<std::string> validator = test::gltf_validator_report(dir / "fitted.glb");
  if (!validator) GTEST_SKIP() << "the Khronos glTF validator is not installed (tools/install_deps.sh style)";
  const nlohmann::json v = nlohmann::json::parse(*validator);
  EXPECT_EQ(v["errors"], 0) << *validator;
  EXPECT_EQ(v["warnings"], 0) << *validator;
}

TEST(FitCli, WritesAnObjOfTheGarments) {
  test::TempDir dir;
  write_catalogue(dir / "trousers.obj", GarmentType::TROUSERS);
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--pose-rest", "apose", "--vertices", "3000", "--garment",
                                (dir / "trousers.obj").string(), "--out", (dir / "fitted.obj").string(),
                                "--no-simulation", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_EQ(read_mesh(dir / "fitted.obj").mesh.vertex_count(), 2000u);
}

// Flags are named as given, and a fabric name is checked whether or not the cloth is simulated.
TEST(FitCli, AnUnknownFabricOrUnitIsRefusedNamingItsFlag) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--fabric", "kevlar", "--no-simulation",
                          "--out", (dir / "out.obj").string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("kevlar"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("denim"), std::string::npos) << "the known fabrics are listed: " << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.obj"));
  r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--garment-units", "furlong"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--garment-units"), std::string::npos) << r.err;
}

// A unit or scale under which the garment has no garment's size on the body is refused,
// naming both sizes and the units that would fit; --garment-scale states an exporter's scale
// that is no length unit (here 2 cm per file unit).
TEST(FitCli, AGarmentOfNoGarmentsSizeIsRefusedAndAScaleCanBeStated) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--garment-units", "dm", "--no-simulation",
                          "--out", (dir / "out.obj").string(), "--quiet"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("in dm (as stated): not a garment's size on this body"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("torso"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("across in m"), std::string::npos) << "the unit that fits is named: " << r.err;
  EXPECT_NE(r.err.find("--garment-scale"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.obj"));

  Mesh odd = read_mesh(dir / "tee.obj").mesh;
  for (float& x : odd.positions)
    x *= 50.0f;
  write_mesh(dir / "odd.ply", odd);
  r = test::run_cli({"fit", "--garment", (dir / "odd.ply").string(), "--garment-scale", "0.02", "--no-simulation",
                     "--report", (dir / "odd.json").string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "odd.json"));
  EXPECT_EQ(j["garments"][0]["units"], "m");
  EXPECT_NE(j["garments"][0]["warnings"].dump().find("scaled by 0.02 (as stated)"), std::string::npos) << j.dump();
  r = test::run_cli(
      {"fit", "--garment", (dir / "odd.ply").string(), "--garment-scale", "0.02", "--garment-units", "cm"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
}

// --threads N is every command's: the fit's engine runs on N threads and says so; a command
// without an engine of its own (vfit body) takes it too.
TEST(FitCli, EveryCommandTakesThreads) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--threads", "1", "--no-simulation",
                          "--report", (dir / "r.json").string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(test::read_file(dir / "r.json"))["machine"]["threads"], 1);
  r = test::run_cli({"body", "--threads", "1", "--vertices", "1000", "--out", (dir / "body.obj").string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli({"garment", "tee", "--threads", "0", "--out", (dir / "t.obj").string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--threads"), std::string::npos) << r.err;
}

TEST(FitCli, AMissingGarmentExits2AndWritesNothing) {
  test::TempDir dir;
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--garment", (dir / "nope.obj").string(), "--out",
                                (dir / "out.obj").string(), "--report", (dir / "r.json").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope.obj"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(file_count(dir.path()), 0u);
}

// Outputs are checked before the fit: before, --out over the garment's own file overwrote it
// (exit 0), and a --render into a missing folder failed only after the mesh and the report
// had been written.
TEST(FitCli, AnOutputOverAnInputOrInAMissingFolderExits2AndWritesNothing) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const std::string tee = test::read_file(dir / "tee.obj");
  const std::vector<std::string> base = {
      "fit",    "--body", "mannequin", "--vertices", "3000", "--garment", (dir / "tee.obj").string(), "--no-simulation",
      "--quiet"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = base;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  auto r = test::run_cli(with({"--out", (dir / "tee.obj").string()}));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("overwrite an input"), std::string::npos) << r.err;
  EXPECT_TRUE(test::read_file(dir / "tee.obj") == tee) << "the garment file was overwritten";
  r = test::run_cli(with({"--out", (dir / "fit.obj").string(), "--report", (dir / "r.json").string(), "--render",
                          (dir / "missing" / "r.png").string()}));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u) << "only the garment";
}

// A facing that is not one of +z, -z, +x, -x is refused before anything is read or written.
TEST(FitCli, AnUnknownGarmentFacingExits2) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto r = test::run_cli(
      {"fit", "--garment", (dir / "tee.obj").string(), "--garment-facing", "+y", "--out", (dir / "out.obj").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown facing"), std::string::npos) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u);
}

// A layer order that is not auto, type or given is refused naming the flag, before any work.
TEST(FitCli, AnUnknownLayerOrderExits2) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--layer-order", "outer-first", "--out",
                                (dir / "out.obj").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--layer-order"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("outer-first"), std::string::npos) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u);
}

TEST(FitCli, AnUnknownClothProxyModeExits2) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--cloth-proxy", "sometimes", "--out",
                                (dir / "out.obj").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--cloth-proxy"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("sometimes"), std::string::npos) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u);
}

// --cloth-proxy on: the report says the proxy was used, of --proxy-vertices, with its times.
TEST(FitCli, ReportsTheClothProxy) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto r = test::run_cli({"fit", "--garment", (dir / "tee.obj").string(), "--pose-rest", "apose", "--vertices",
                                "3000", "--cloth-proxy", "on", "--proxy-vertices", "700", "--max-sim-seconds", "0.02",
                                "--report", (dir / "report.json").string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "report.json"));
  EXPECT_EQ(j["options"]["cloth_proxy"], "on");
  const nlohmann::json& proxy = j["garments"][0]["cloth_proxy"];
  EXPECT_TRUE(proxy["used"].get<bool>());
  EXPECT_EQ(proxy["vertices"].get<std::size_t>(), 700u);
  for (const char* stage : {"build", "simulation", "reconstruct"})
    EXPECT_GT(proxy["timings_ms"][stage].get<double>(), 0.0) << stage;
}

// A garment with a degenerate and a duplicated face: refused naming the file, line and --repair;
// with --repair both are dropped, each with a warning, and the garment is fitted.
TEST(FitCli, RepairDropsDegenerateAndDuplicateFaces) {
  test::TempDir dir;
  write_catalogue(dir / "trousers.obj", GarmentType::TROUSERS);
  std::string text = test::read_file(dir / "trousers.obj");
  const auto first_face = text.find("\nf ");
  ASSERT_NE(first_face, std::string::npos);
  const std::string face = text.substr(first_face + 1, text.find('\n', first_face + 1) - first_face);
  text += face + "f 1 1 2\n";
  test::write_file(dir / "dirty.obj", text);
  std::vector<std::string> args = {"fit",
                                   "--body",
                                   "mannequin",
                                   "--pose-rest",
                                   "apose",
                                   "--vertices",
                                   "3000",
                                   "--garment",
                                   (dir / "dirty.obj").string(),
                                   "--out",
                                   (dir / "fitted.obj").string(),
                                   "--no-simulation"};
  const auto refused = test::run_cli(args);
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("dirty.obj:"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("--repair"), std::string::npos) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "fitted.obj"));
  args.push_back("--repair");
  const auto repaired = test::run_cli(args);
  ASSERT_EQ(repaired.exit_code, 0) << repaired.err;
  EXPECT_NE(repaired.err.find("degenerate"), std::string::npos) << repaired.err;
  EXPECT_NE(repaired.err.find("duplicate"), std::string::npos) << repaired.err;
  EXPECT_EQ(read_mesh(dir / "fitted.obj").mesh.vertex_count(), 2000u);
  // The report says so too (before, only stderr did, and --quiet lost it).
  args.insert(args.end(), {"--quiet", "--report", (dir / "r.json").string()});
  ASSERT_EQ(test::run_cli(args).exit_code, 0);
  const nlohmann::json report = nlohmann::json::parse(test::read_file(dir / "r.json"));
  const std::string warnings = report["garments"][0]["warnings"].dump();
  EXPECT_NE(warnings.find("dropped 1 degenerate face and 1 duplicate face"), std::string::npos) << warnings;
}

// The body's warnings (its units converted, ...) are in the report (before, only on stderr).
TEST(FitCli, ReportCarriesTheBodysWarnings) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  ASSERT_EQ(test::run_cli(
                {"body", "--pose-rest", "apose", "--vertices", "3000", "--out", (dir / "b.obj").string(), "--quiet"})
                .exit_code,
            0);
  Mesh body = read_mesh(dir / "b.obj").mesh;
  for (float& x : body.positions)
    x *= 100.0f; // centimetres
  write_mesh(dir / "b_cm.obj", body);
  const auto r = test::run_cli({"fit", "--body", (dir / "b_cm.obj").string(), "--garment", (dir / "tee.obj").string(),
                                "--no-simulation", "--quiet", "--report", (dir / "r.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(test::read_file(dir / "r.json"));
  const std::string warnings = report["body"]["warnings"].dump();
  EXPECT_NE(warnings.find("units detected as cm; converted to metres"), std::string::npos) << warnings;
}

// A body and a tee in inches (US CAD): the body read at its adult height, the tee against it.
// Before, the body was read as cm (a 0.6 m child) and the tee as dm (a tent). --units and
// --garment-units still win.
TEST(FitCli, ABodyAndATeeInInchesAreReadAsInches) {
  test::TempDir dir;
  ASSERT_EQ(test::run_cli(
                {"body", "--pose-rest", "apose", "--vertices", "3000", "--out", (dir / "b.obj").string(), "--quiet"})
                .exit_code,
            0);
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  for (const char* name : {"b", "tee"}) {
    Mesh m = read_mesh(dir / (std::string(name) + ".obj")).mesh;
    for (float& x : m.positions)
      x = static_cast<float>(x / 0.0254);
    write_mesh(dir / (std::string(name) + "_in.obj"), m);
  }
  auto r = test::run_cli({"measure", (dir / "b.obj").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const double height = nlohmann::json::parse(r.out)["measurements_m"]["height"].get<double>();
  r = test::run_cli({"measure", (dir / "b_in.obj").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Float coordinates in inches: the same height within a micrometre's rounding.
  const nlohmann::json measured = nlohmann::json::parse(r.out);
  EXPECT_NEAR(measured["measurements_m"]["height"].get<double>(), height, 1e-5);
  const std::string warnings = measured["warnings"].dump();
  EXPECT_NE(warnings.find("units detected as in"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("--units cm"), std::string::npos) << warnings;

  r = test::run_cli({"fit", "--body", (dir / "b_in.obj").string(), "--garment", (dir / "tee_in.obj").string(),
                     "--no-simulation", "--quiet", "--report", (dir / "r.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json report = nlohmann::json::parse(test::read_file(dir / "r.json"));
  EXPECT_EQ(report["garments"][0]["units"], "in");
  EXPECT_EQ(report["garments"][0]["type"], "tee");
  EXPECT_NE(report["garments"][0]["warnings"].dump().find("--garment-units"), std::string::npos);
  // Stated units win over the detection: the tee stated in cm, the body stated in cm.
  r = test::run_cli({"fit", "--body", (dir / "b_in.obj").string(), "--garment", (dir / "tee_in.obj").string(),
                     "--garment-units", "cm", "--no-simulation", "--quiet", "--report", (dir / "r2.json").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  report = nlohmann::json::parse(test::read_file(dir / "r2.json"));
  EXPECT_EQ(report["garments"][0]["units"], "cm");
  r = test::run_cli({"measure", (dir / "b_in.obj").string(), "--units", "cm", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["measurements_m"]["height"].get<double>(), height * 0.01 / 0.0254, 1e-5);
}

TEST(FitCli, AMeshThatIsNotAGarmentExits2AndWritesNothing) {
  test::TempDir dir;
  write_mesh(dir / "ball.obj", make_uv_sphere(8, 16, 0.3f));
  const auto r =
      test::run_cli({"fit", "--body", "mannequin", "--vertices", "3000", "--garment", (dir / "ball.obj").string(),
                     "--out", (dir / "out.obj").string(), "--report", (dir / "r.json").string(), "--no-simulation"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("ball.obj"), std::string::npos) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u); // only the input
}

std::size_t count_of(const std::string& text, const std::string& word) {
  std::size_t n = 0;
  for (auto at = text.find(word); at != std::string::npos; at = text.find(word, at + word.size()))
    ++n;
  return n;
}

// Stderr is a file here, not a terminal: no progress unless --progress asks for it, and
// --quiet silences it even then.
TEST(FitCli, PrintsProgressOnlyToATerminalOrWhenAsked) {
  test::TempDir dir;
  write_catalogue(dir / "trousers.obj", GarmentType::TROUSERS);
  const std::vector<std::string> base = {"fit",
                                         "--body",
                                         "mannequin",
                                         "--pose-rest",
                                         "apose",
                                         "--vertices",
                                         "3000",
                                         "--garment",
                                         (dir / "trousers.obj").string(),
                                         "--no-simulation"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = base;
    a.insert(a.end(), extra.begin(), extra.end());
    return test::run_cli(a);
  };
  const auto silent = with({});
  ASSERT_EQ(silent.exit_code, 0) << silent.err;
  EXPECT_EQ(silent.err.find("trousers.obj: segmentation"), std::string::npos) << silent.err;
  EXPECT_EQ(count_of(silent.err, " ms ("), 0u) << silent.err;

  const auto asked = with({"--progress"});
  ASSERT_EQ(asked.exit_code, 0) << asked.err;
  std::size_t at = 0;
  for (const char* stage : {"units", "segmentation", "skeletons", "driving", "coarse_move", "penetration", "simulation",
                            "feedback", "total"}) {
    const std::string line = "vfit: trousers.obj: " + std::string(stage) + " ";
    EXPECT_EQ(count_of(asked.err, line), 1u) << stage << "\n" << asked.err;
    const auto found = asked.err.find(line);
    EXPECT_TRUE(found != std::string::npos && found >= at) << stage << " out of order\n" << asked.err;
    if (found != std::string::npos) at = found;
  }
  EXPECT_NE(asked.err.find("segmentation"), std::string::npos);
  EXPECT_NE(asked.err.find("(trousers)"), std::string::npos) << asked.err;

  const auto quiet = with({"--progress", "--quiet"});
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  EXPECT_TRUE(quiet.out.empty()) << quiet.out;
}

TEST(FitCli, WritesEachStageIntoTheDebugFolder) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  const auto debug = dir / "stages";
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--pose-rest", "apose", "--vertices", "3000", "--garment",
                                (dir / "tee.obj").string(), "--no-simulation", "--quiet", "--debug", debug.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::is_regular_file(debug / "legend.txt"));
  EXPECT_GT(read_mesh(debug / "body.ply").mesh.vertex_count(), 1000u);
  for (const char* stage : {"01_segmentation", "02_skeleton_nodes", "03_driving", "04_coarse_move", "05_penetration"})
    EXPECT_EQ(read_mesh(debug / ("tee_" + std::string(stage) + ".ply")).mesh.vertex_count(), 2000u) << stage;
  EXPECT_TRUE(std::filesystem::is_regular_file(debug / "tee_02_skeletons.obj"));
  EXPECT_FALSE(std::filesystem::exists(debug / "tee_06_simulation.ply")); // --no-simulation
  EXPECT_EQ(file_count(debug), 8u);
}

// Bad input to `vfit fit`: a body with no recognisable skeleton, a garment that is
// not a garment, a missing file. Each gives one line `vfit: error: <file>: ...`, exit code 2,
// and no output file (mesh, report, picture, debug folder).
struct BadFit {
  const char* name;
  const char* body;    // "mannequin" or a file written by make(); "missing.obj" is never written
  const char* garment; // a file written by make(), or "tee.obj" (a catalogue tee), or missing
  const char* expect;  // a substring of the error line
};

void PrintTo(const BadFit& b, std::ostream* os) { *os << b.name; }

Mesh scaled(Mesh m, float sx, float sy, float sz, float lift) {
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    m.positions[3 * v] *= sx;
    m.positions[3 * v + 1] = m.positions[3 * v + 1] * sy + lift;
    m.positions[3 * v + 2] *= sz;
  }
  return m;
}

// A closed, box-shaped mesh: a sphere pushed out onto the cube of half-size `half`.
Mesh closed_box(float half, float lift) {
  Mesh m = make_uv_sphere(16, 32, 1.0f);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const float s = half / std::max({std::fabs(p[0]), std::fabs(p[1]), std::fabs(p[2])});
    p[0] *= s;
    p[1] = p[1] * s + lift;
    p[2] *= s;
  }
  return m;
}

void make(const std::filesystem::path& dir, const std::string& file) {
  const auto path = dir / file;
  if (file == "tee.obj")
    write_catalogue(path, GarmentType::TEE);
  else if (file == "triangle.obj")
    test::write_file(path, "v 0 1 0\nv 0.4 1 0\nv 0 1.4 0\nf 1 2 3\n");
  else if (file == "box.obj")
    write_mesh(path, closed_box(0.25f, 1.1f));
  else if (file == "ball.obj")
    write_mesh(path, scaled(make_uv_sphere(12, 24, 0.3f), 1, 1, 1, 1.1f));
  else if (file == "sheet.obj")
    write_mesh(path, scaled(make_grid(20, 20, 0.6f, 0.6f), 1, 1, 1, 1.1f));
  else if (file == "sphere_body.obj")
    write_mesh(path, scaled(make_uv_sphere(24, 48, 0.8f), 1, 1, 1, 0.8f));
  else if (file == "cube_body.obj")
    write_mesh(path, closed_box(0.8f, 0.8f));
  else if (file == "pillar_body.obj") // upright and human-sized, but no limbs: no crotch, no arms
    write_mesh(path, scaled(make_uv_sphere(32, 64, 1.0f), 0.22f, 0.85f, 0.14f, 0.85f));
}

class FitCliBadInput : public ::testing::TestWithParam<BadFit> {};

TEST_P(FitCliBadInput, OneLineExit2AndNoOutput) {
  const BadFit& b = GetParam();
  test::TempDir dir;
  if (std::string(b.body) != "mannequin") make(dir.path(), b.body);
  make(dir.path(), b.garment);
  const std::size_t inputs = file_count(dir.path());
  const std::string body = std::string(b.body) == "mannequin" ? "mannequin" : (dir / b.body).string();
  const auto r = test::run_cli({"fit", "--body", body, "--vertices", "3000", "--garment", (dir / b.garment).string(),
                                "--out", (dir / "out.glb").string(), "--report", (dir / "r.json").string(), "--render",
                                (dir / "r.png").string(), "--render-size", "32", "--debug", (dir / "debug").string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(r.err.rfind("vfit: error: ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(b.expect), std::string::npos) << "expected '" << b.expect << "' in: " << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_EQ(file_count(dir.path()), inputs) << "an output file was written";
}

INSTANTIATE_TEST_SUITE_P(
    Cases, FitCliBadInput,
    ::testing::Values(BadFit{"missing_garment", "mannequin", "missing.obj", "missing.obj: cannot open"},
                      BadFit{"missing_body", "missing.obj", "tee.obj", "missing.obj: cannot open"},
                      BadFit{"single_triangle", "mannequin", "triangle.obj",
                             "triangle.obj: not a recognisable garment"},
                      BadFit{"closed_box", "mannequin", "box.obj", "box.obj: not a recognisable garment"},
                      BadFit{"sphere", "mannequin", "ball.obj", "ball.obj: not a recognisable garment"},
                      BadFit{"flat_sheet", "mannequin", "sheet.obj", "sheet.obj: not a recognisable garment"},
                      BadFit{"sphere_body", "sphere_body.obj", "tee.obj", "sphere_body.obj: "},
                      BadFit{"cube_body", "cube_body.obj", "tee.obj", "cube_body.obj: "},
                      BadFit{"limbless_body", "pillar_body.obj", "tee.obj", "pillar_body.obj: "}),
    [](const auto& param) { return std::string(param.param.name); });

} // namespace
} // namespace vfit
