// SPDX-License-Identifier: Apache-2.0
// The OpenCL entry points of a build configured with VFIT_WITH_OPENCL=OFF: they say so.
#include "../error.h"
#include "../opencl_context.h"
#include "../opencl_vertex_normals.h"

namespace vfit {
namespace {
[[noreturn]] void unavailable() {
  throw Error("opencl", 0, "this vfit was built without OpenCL (CMake option VFIT_WITH_OPENCL=OFF)");
}
} // namespace

struct OpenClContext::Impl {};
struct OpenClVertexNormals::Impl {};

std::vector<OpenClDeviceInfo> list_opencl_devices() { return {}; }
OpenClDeviceInfo select_opencl_device(std::string_view) { unavailable(); }
OpenClContext::OpenClContext(std::string_view) { unavailable(); }
OpenClContext::~OpenClContext() = default;
const OpenClDeviceInfo& OpenClContext::device() const { unavailable(); }
double OpenClContext::copy_bandwidth_gbps(std::size_t, int) { unavailable(); }
OpenClVertexNormals::OpenClVertexNormals(OpenClContext&, std::span<const std::int32_t>, std::size_t) { unavailable(); }
OpenClVertexNormals::~OpenClVertexNormals() = default;
void OpenClVertexNormals::compute(std::span<const float>, std::vector<float>&) { unavailable(); }

} // namespace vfit
