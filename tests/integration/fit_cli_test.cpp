// `vfit fit`: a catalogue tee and trousers from OBJ files onto the mannequin → fitted mesh,
// JSON report, PNG; bad input → exit 2 and nothing written.
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "engine/image.h"
#include "geometry/garment/catalogue.h"
#include "geometry/mesh/mesh_io.h"
#include "geometry/mesh/primitives.h"
#include "test_support.h"

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

TEST(FitCli, FitsObjGarmentsAndWritesMeshReportAndPicture) {
  test::TempDir dir;
  write_catalogue(dir / "tee.obj", GarmentType::TEE);
  write_catalogue(dir / "trousers.obj", GarmentType::TROUSERS);
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--pose-rest", "apose", "--vertices", "3000", "--garment",
                                (dir / "tee.obj").string(), "--garment", (dir / "trousers.obj").string(), "--out",
                                (dir / "fitted.glb").string(), "--report", (dir / "report.json").string(), "--render",
                                (dir / "fit.png").string(), "--no-simulation", "--render-size", "64"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("segmentation"), std::string::npos) << r.out;

  const nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "report.json"));
  for (const char* stage : {"segmentation", "skeletons", "driving", "coarse_move", "penetration", "simulation", "total"})
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

TEST(FitCli, AMissingGarmentExits2AndWritesNothing) {
  test::TempDir dir;
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--garment", (dir / "nope.obj").string(), "--out",
                                (dir / "out.obj").string(), "--report", (dir / "r.json").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope.obj"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(file_count(dir.path()), 0u);
}

TEST(FitCli, AMeshThatIsNotAGarmentExits2AndWritesNothing) {
  test::TempDir dir;
  write_mesh(dir / "ball.obj", make_uv_sphere(8, 16, 0.3f));
  const auto r = test::run_cli({"fit", "--body", "mannequin", "--vertices", "3000", "--garment",
                                (dir / "ball.obj").string(), "--out", (dir / "out.obj").string(), "--report",
                                (dir / "r.json").string(), "--no-simulation"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("ball.obj"), std::string::npos) << r.err;
  EXPECT_EQ(file_count(dir.path()), 1u); // only the input
}

} // namespace
} // namespace vfit
