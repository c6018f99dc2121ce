// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The OpenCL context/queue/program owner. OpenCL types stay in the implementation; callers see
/// only device descriptions and this RAII handle. Available when opencl_built() is true; in a
/// build without OpenCL every constructor throws vfit::Error saying so.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace vfit {

/// One OpenCL device as the ICD loader reports it.
struct OpenClDeviceInfo {
  int platform_index = 0; ///< position of its platform in clGetPlatformIDs order
  int device_index = 0;   ///< position within the platform
  int flat_index = 0;     ///< position in the flat list over all platforms
  std::string platform_name;
  std::string device_name;
  std::string device_type; ///< "gpu" | "cpu" | "accelerator" | "other"
  std::string version;     ///< CL_DEVICE_VERSION
  std::uint64_t global_memory_bytes = 0;
  int compute_units = 0;
};

/// Every device of every platform, in platform order. Empty (never throws) when no ICD or
/// platform is installed or the build has no OpenCL.
std::vector<OpenClDeviceInfo> list_opencl_devices();

/// Picks a device. `selector`: empty → the environment variable VFIT_OPENCL_DEVICE → the first
/// device listed. Accepted forms: "N" (flat index), "P:D" (platform:device), "gpu" | "cpu"
/// (first of that type), or a case-insensitive substring of the device or platform name.
/// Throws vfit::Error with the list of devices when none matches or none exists.
OpenClDeviceInfo select_opencl_device(std::string_view selector = {});

/// Owns a context and an in-order command queue on one device, plus the programs built from
/// the embedded `.cl` sources (built once per context, on first use).
class OpenClContext {
public:
  /// See select_opencl_device() for `selector`.
  explicit OpenClContext(std::string_view selector = {});
  ~OpenClContext();
  OpenClContext(const OpenClContext&) = delete;
  OpenClContext& operator=(const OpenClContext&) = delete;

  const OpenClDeviceInfo& device() const;

  /// The device's memory bandwidth (GB/s, bytes read plus bytes written, as STREAM counts a
  /// copy) of a device-to-device clEnqueueCopyBuffer of `bytes` between two buffers of this
  /// context: the best of `repeats` timed copies after one untimed warm-up, host wall clock
  /// around enqueue + finish. The baseline the benchmarks compare a kernel's model traffic with.
  /// Throws vfit::Error when bytes is 0 or repeats < 1, and when the device cannot allocate two
  /// buffers of that size.
  double copy_bandwidth_gbps(std::size_t bytes, int repeats = 5);

  struct Impl; ///< defined in kernels/opencl/opencl_impl.h, for kernel implementations only
  Impl& impl() { return *m_impl; }

private:
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
