// SPDX-License-Identifier: Apache-2.0
// The mannequin cache against make_mannequin() itself (the oracle): a body read back is
// bit-identical; a truncated or foreign entry is ignored and rewritten; VFIT_CACHE_DIR=off
// writes nothing. Builds with uncommitted changes never use the cache: the tests that need it
// skip there, saying so.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/body/mannequin_cache.h"
#include "vfit/kernels/version.h"

namespace vfit {
namespace {

// VFIT_CACHE_DIR set for the scope of a test, the previous value restored after.
class CacheDir {
public:
  explicit CacheDir(const std::string& value) {
    if (const char* old = std::getenv("VFIT_CACHE_DIR")) m_old = old;
    ::setenv("VFIT_CACHE_DIR", value.c_str(), 1);
  }
  ~CacheDir() {
    if (m_old)
      ::setenv("VFIT_CACHE_DIR", m_old->c_str(), 1);
    else
      ::unsetenv("VFIT_CACHE_DIR");
  }
  CacheDir(const CacheDir&) = delete;
  CacheDir& operator=(const CacheDir&) = delete;

private:
  std::optional<std::string> m_old;
};

void expect_same(const Body& a, const Body& b) {
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  EXPECT_EQ(a.mesh.normals, b.mesh.normals);
  EXPECT_EQ(a.mesh.uvs, b.mesh.uvs);
  EXPECT_EQ(a.mesh.face_labels, b.mesh.face_labels);
  EXPECT_TRUE(a.joints == b.joints);
  EXPECT_EQ(a.weights.joints, b.weights.joints);
  EXPECT_EQ(a.weights.weights, b.weights.weights);
  EXPECT_EQ(a.rest_pose, b.rest_pose);
  EXPECT_EQ(a.source, b.source);
}

std::size_t entries(const std::filesystem::path& dir) {
  if (!std::filesystem::exists(dir)) return 0;
  std::size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    n += e.path().filename().string().starts_with("mannequin-") ? 1 : 0;
  return n;
}

TEST(MannequinCache, ReadsBackTheBodyMakeMannequinBuildsBitForBit) {
  test::TempDir tmp;
  const CacheDir scope((tmp / "cache").string());
  if (!mannequin_cache_dir())
    GTEST_SKIP() << "this build (" << git_commit() << ") is not from a clean commit: the cache is off";
  MannequinOptions o;
  o.target_vertices = 1500;
  o.measurements.height = 1.62;
  const Body built = make_mannequin(o);
  const Body first = cached_mannequin(o); // a miss: built and stored
  EXPECT_EQ(entries(tmp / "cache"), 1u);
  const Body second = cached_mannequin(o); // a hit
  expect_same(first, built);
  expect_same(second, built);

  // Other options are another entry.
  o.pose = RestPose::TPOSE;
  expect_same(cached_mannequin(o), make_mannequin(o));
  EXPECT_EQ(entries(tmp / "cache"), 2u);
}

TEST(MannequinCache, IgnoresATruncatedOrForeignEntryAndRewritesIt) {
  test::TempDir tmp;
  const CacheDir scope((tmp / "cache").string());
  if (!mannequin_cache_dir())
    GTEST_SKIP() << "this build (" << git_commit() << ") is not from a clean commit: the cache is off";
  MannequinOptions o;
  o.target_vertices = 1200;
  const Body built = cached_mannequin(o);
  std::filesystem::path entry;
  for (const auto& e : std::filesystem::directory_iterator(tmp / "cache"))
    entry = e.path();
  ASSERT_FALSE(entry.empty());
  const auto size = std::filesystem::file_size(entry);
  std::filesystem::resize_file(entry, size / 2);
  expect_same(cached_mannequin(o), built);
  EXPECT_EQ(std::filesystem::file_size(entry), size) << "the truncated entry was rewritten";
  {
    std::ofstream junk(entry, std::ios::binary | std::ios::trunc);
    junk << "vfit mannequin cache 1\nnot a body";
  }
  expect_same(cached_mannequin(o), built);
}

TEST(MannequinCache, OffWritesNothing) {
  test::TempDir tmp;
  const CacheDir scope("off");
  EXPECT_FALSE(mannequin_cache_dir());
  MannequinOptions o;
  o.target_vertices = 1000;
  expect_same(cached_mannequin(o), make_mannequin(o));
}

} // namespace
} // namespace vfit
