// SPDX-License-Identifier: Apache-2.0
#include "vfit/kernels/opencl_vertex_normals.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {
namespace {

bool have_device() { return !list_opencl_devices().empty(); }

#define REQUIRE_OPENCL_DEVICE()                                                                                        \
  if (!have_device()) GTEST_SKIP() << "no OpenCL device installed (apt-get install pocl-opencl-icd)"

TEST(OpenClContext, EnumeratesAndSelectsDevices) {
  REQUIRE_OPENCL_DEVICE();
  const auto devices = list_opencl_devices();
  EXPECT_EQ(select_opencl_device("0").device_name, devices[0].device_name);
  EXPECT_EQ(select_opencl_device("0:0").device_name, devices[0].device_name);
  OpenClContext ctx;
  EXPECT_FALSE(ctx.device().device_name.empty());
  EXPECT_THROW(select_opencl_device("no-such-device-xyz"), Error);
  EXPECT_THROW(select_opencl_device("999"), Error);
  try {
    select_opencl_device("no-such-device-xyz");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("available devices"), std::string::npos) << e.what();
  }
}

TEST(OpenClContext, CopyBandwidthIsPositiveAndRejectsEmptyCopies) {
  REQUIRE_OPENCL_DEVICE();
  OpenClContext ctx;
  const double gbps = ctx.copy_bandwidth_gbps(std::size_t(1) << 20, 2);
  EXPECT_TRUE(std::isfinite(gbps));
  EXPECT_GT(gbps, 0.0);
  EXPECT_THROW(ctx.copy_bandwidth_gbps(0), Error);
  EXPECT_THROW(ctx.copy_bandwidth_gbps(1024, 0), Error);
  EXPECT_THROW(ctx.copy_bandwidth_gbps(ctx.device().global_memory_bytes), Error); // two such buffers cannot fit
}

class OpenClNormalsParity : public ::testing::TestWithParam<int> {};

TEST_P(OpenClNormalsParity, AgreesWithSerialReference) {
  REQUIRE_OPENCL_DEVICE();
  Mesh m = make_uv_sphere(GetParam(), 2 * GetParam(), 1.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.005f, 0.005f);
  for (float& x : m.positions)
    x += jitter(rng);
  std::vector<float> ref, got;
  vertex_normals_serial(m.position_view(), m.triangle_view(), ref);
  OpenClContext ctx;
  OpenClVertexNormals kernel(ctx, m.triangle_view(), m.vertex_count());
  kernel.compute(m.position_view(), got);
  ASSERT_EQ(ref.size(), got.size());
  // The kernels evaluate the same float expressions in the same order with correctly rounded
  // sqrt/divide and FP_CONTRACT off, so results differ by at most a few ulps of a unit vector
  // (a device may still flush denormals or fuse differently); 1e-6 is ~8 ulps at 1.0.
  for (std::size_t i = 0; i < ref.size(); ++i)
    ASSERT_NEAR(ref[i], got[i], 1e-6f) << "component " << i;
  // A second call with moved positions reuses the uploaded topology.
  for (float& x : m.positions)
    x *= 2.0f;
  kernel.compute(m.position_view(), got);
  for (std::size_t i = 0; i < ref.size(); ++i)
    ASSERT_NEAR(ref[i], got[i], 1e-6f) << "component " << i;
}

INSTANTIATE_TEST_SUITE_P(Sizes, OpenClNormalsParity, ::testing::Values(2, 10, 50, 200));

} // namespace
} // namespace vfit
