// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/geometry/mesh/primitives.h"

namespace vfit {
namespace {

TEST(Cli, HelpForEveryCommandExitsZero) {
  for (const char* cmd : {"info", "convert", "devices", "demo", "animate"}) {
    const auto r = test::run_cli({cmd, "--help"});
    EXPECT_EQ(r.exit_code, 0) << cmd;
    EXPECT_NE(r.out.find(std::string("usage: vfit ") + cmd), std::string::npos) << r.out;
  }
  EXPECT_EQ(test::run_cli({"--help"}).exit_code, 0);
  EXPECT_EQ(test::run_cli({}).exit_code, 2);
}

TEST(Cli, UsageErrorsExitTwo) {
  auto r = test::run_cli({"frobnicate"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown command 'frobnicate'"), std::string::npos) << r.err;
  r = test::run_cli({"info"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing argument"), std::string::npos) << r.err;
  r = test::run_cli({"info", "x.obj", "--bogus"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown option '--bogus'"), std::string::npos) << r.err;
  r = test::run_cli({"info", "x.obj", "--units", "furlong"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown unit 'furlong'"), std::string::npos) << r.err;
}

TEST(Cli, InfoSummarisesAMeshAsTextAndJson) {
  test::TempDir tmp;
  const auto path = tmp / "tube_cm.obj";
  Mesh tube = make_tube(10, 16, 6.0f, 55.0f); // a sleeve stored in centimetres
  write_mesh(path, tube);
  auto r = test::run_cli({"info", path.string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["vertices"], tube.vertex_count());
  EXPECT_EQ(j["faces"], tube.face_count());
  EXPECT_EQ(j["units"], "cm");
  EXPECT_EQ(j["boundary_loops"], 2);
  EXPECT_EQ(j["components"], 1);
  EXPECT_EQ(j["manifold"], true);
  EXPECT_EQ(j["watertight"], false);
  EXPECT_EQ(j["euler_characteristic"], 0);
  EXPECT_NEAR(j["largest_extent_m"].get<double>(), 0.55, 1e-6);
  r = test::run_cli({"info", path.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("cm (detected from the extent)"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("units detected as cm"), std::string::npos) << r.err;
  r = test::run_cli({"info", path.string(), "--units", "mm", "--json"});
  EXPECT_EQ(nlohmann::json::parse(r.out)["units"], "mm");
}

TEST(Cli, ConvertRoundTripsAndScalesToMetres) {
  test::TempDir tmp;
  const auto in = tmp / "s.obj";
  write_mesh(in, make_uv_sphere(8, 12, 20.0f)); // 40 cm across: read as cm
  const auto ply = tmp / "s.ply", glb = tmp / "s.glb";
  auto r = test::run_cli({"convert", in.string(), ply.string(), "--to-metres"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("converting to m"), std::string::npos) << r.err;
  const ParsedMesh p = read_mesh(ply);
  EXPECT_NEAR(p.mesh.positions[1], 0.2f, 1e-6f);
  r = test::run_cli({"convert", ply.string(), glb.string(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.out.empty());
  EXPECT_EQ(read_mesh(glb).mesh.face_count(), p.mesh.face_count());
}

TEST(Cli, ConvertRefusesToOverwriteItsInput) {
  test::TempDir tmp;
  const auto in = tmp / "s.obj";
  write_mesh(in, test::unit_square());
  const std::string before = test::read_file(in);
  for (const auto& out : {in.string(), (tmp.path() / "." / "s.obj").string()}) {
    const auto r = test::run_cli({"convert", in.string(), out});
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("refusing to overwrite the input"), std::string::npos) << r.err;
  }
  EXPECT_EQ(test::read_file(in), before);
  const auto r = test::run_cli({"convert", in.string(), (tmp / "x.fbx").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown mesh format '.fbx'"), std::string::npos) << r.err;
}

TEST(Cli, DevicesListsBackends) {
  const auto r = test::run_cli({"devices", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GE(j["tbb_threads"].get<int>(), 1);
  EXPECT_TRUE(j.contains("opencl_devices"));
}

TEST(Cli, DemoRunsOnBuiltInMeshesAndWritesItsOutputs) {
  test::TempDir tmp;
  const auto r = test::run_cli({"demo", "--out", (tmp / "demo").string(), "--corpus", (tmp / "none").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("builtin_sphere"), std::string::npos) << r.out;
  const ParsedMesh scene = read_mesh(tmp / "demo" / "demo.glb");
  // Mannequin, tee, trousers and the posed mannequin (the procedural meshes stay out).
  EXPECT_EQ(scene.mesh.label_names.size(), 4u);
  const auto j = nlohmann::json::parse(test::read_file(tmp / "demo" / "demo.json"));
  for (const auto& n : j["vertex_normals"])
    EXPECT_LT(n["max_deviation_deg"].get<double>(), 1e-3) << n.dump();
  // The fit: body and the two garments in one glTF, the report, the pictures.
  const ParsedMesh fit = read_mesh(tmp / "demo" / "fit.glb");
  EXPECT_EQ(fit.mesh.label_names.size(), 3u);
  const auto report = nlohmann::json::parse(test::read_file(tmp / "demo" / "fit_report.json"));
  for (const char* stage : {"segmentation", "skeletons", "driving", "penetration", "simulation", "total"})
    EXPECT_TRUE(report["timings_ms"].contains(stage)) << stage;
  // The demo's bar: nothing inside the body by more than 1 mm.
  EXPECT_LE(report["penetration"]["after"]["max_depth_mm"].get<double>(), 1.0);
  EXPECT_TRUE(std::filesystem::exists(tmp / "demo" / "fit_views.png"));
  // The walk: 30 frames of the outfit, animated, with its contact sheet.
  const auto walk = nlohmann::json::parse(test::read_file(tmp / "demo" / "walk_report.json"));
  EXPECT_EQ(walk["frames"].size(), 30u);
  EXPECT_EQ(walk["motion"]["mapping"], "poses");
  EXPECT_TRUE(std::filesystem::exists(tmp / "demo" / "walk.glb"));
  EXPECT_TRUE(std::filesystem::exists(tmp / "demo" / "walk_frames.png"));
}

} // namespace
} // namespace vfit
