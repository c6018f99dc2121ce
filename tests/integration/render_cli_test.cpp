// SPDX-License-Identifier: Apache-2.0
// `vfit render`: PNG pictures from mesh files, and the bad-input contract (exit 2, one line,
// nothing written).
#include <filesystem>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "test_support.h"
#include "vfit/engine/view/image.h"
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

TEST(RenderCli, RendersAnObjIntoAPngOfThreeViews) {
  test::TempDir dir;
  write_mesh(dir / "sphere.obj", make_uv_sphere(12, 24, 0.3f));
  const auto r =
      test::run_cli({"render", (dir / "sphere.obj").string(), "--out", (dir / "views.png").string(), "--size", "64"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("views.png"), std::string::npos) << r.out;
  const Image image = read_png(dir / "views.png");
  EXPECT_EQ(image.width, 3 * 64);
  EXPECT_EQ(image.height, 64);
  // The middle of the front view shows the sphere, not the background.
  EXPECT_NE(image.at(32, 32), (Rgb8{246, 246, 246}));
}

TEST(RenderCli, SplitsAGlbIntoBodyAndGarmentsAndDrawsAScalarLegend) {
  test::TempDir dir;
  const Mesh body = make_uv_sphere(12, 24, 0.3f);
  Mesh sleeve = make_tube(4, 16, 0.1f, 0.5f);
  const NamedMesh meshes[] = {{"body", &body, nullptr}, {"sleeve", &sleeve, nullptr}};
  write_meshes_glb(dir / "scene.glb", meshes);
  nlohmann::json scalar;
  scalar["name"] = "strain";
  scalar["values"] = std::vector<float>(sleeve.vertex_count(), 0.25f);
  scalar["values"][0] = 0.5f;
  test::write_file(dir / "strain.json", scalar.dump());
  const auto r = test::run_cli({"render", (dir / "scene.glb").string(), "--out", (dir / "v.png").string(), "--size",
                                "48", "--views", "front", "--scalar", (dir / "strain.json").string(), "--separate"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 meshes"), std::string::npos) << r.out;
  const Image image = read_png(dir / "v_front.png");
  EXPECT_GT(image.width, 48); // the legend panel is beside the view
  EXPECT_EQ(image.height, 48);
  EXPECT_FALSE(std::filesystem::exists(dir / "v.png"));
}

TEST(RenderCli, AMissingFileExitsTwoAndWritesNothing) {
  test::TempDir dir;
  const auto r = test::run_cli({"render", (dir / "missing.obj").string(), "--out", (dir / "views.png").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.obj"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(file_count(dir.path()), 0u);
}

TEST(RenderCli, BadOptionsExitTwo) {
  test::TempDir dir;
  write_mesh(dir / "sphere.obj", make_uv_sphere(6, 12, 0.3f));
  const std::string mesh = (dir / "sphere.obj").string();
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"render", mesh, "--out", (dir / "x.jpg").string()},
        std::vector<std::string>{"render", mesh, "--out", (dir / "x.png").string(), "--size", "0"},
        std::vector<std::string>{"render", mesh, "--out", (dir / "x.png").string(), "--views", "top"},
        std::vector<std::string>{"render", mesh},
        std::vector<std::string>{"render", "--out", (dir / "x.png").string()}}) {
    const auto r = test::run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args.back() << ": " << r.err;
    EXPECT_NE(r.err.find("vfit: error: "), std::string::npos) << r.err;
  }
  EXPECT_EQ(file_count(dir.path()), 1u);
}

} // namespace
} // namespace vfit
