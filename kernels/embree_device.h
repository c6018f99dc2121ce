// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Private to kernels/ (includes Embree; never included by a public header): the Embree device,
/// scene and geometry owners and the error protocol every Embree user in kernels/ follows.
/// Embree reports errors through a callback, possibly from its build threads; the callback
/// only records the first error, and the wrapper throws after the call that caused it.

#include <embree3/rtcore.h>

#include <memory>
#include <mutex>
#include <string>

namespace vfit::embree {

/// The first error Embree reported since the last check.
struct ErrorLog {
  std::mutex mutex;
  RTCError code = RTC_ERROR_NONE;
  std::string message;
};

/// The device error callback: records (code, message) in the ErrorLog at `user` unless an
/// earlier error is still pending. Never throws (Embree calls it from its own threads).
void record_error(void* user, RTCError code, const char* message);

/// Throws std::runtime_error "Embree <call> failed (error <code>): <message>" when `log` holds
/// an error, and clears it; does nothing otherwise.
void throw_if_failed(ErrorLog& log, const char* call);

/// Deleters and owners of Embree handles (release on destruction).
struct DeviceRelease {
  void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
};
struct SceneRelease {
  void operator()(RTCScene s) const { rtcReleaseScene(s); }
};
struct GeometryRelease {
  void operator()(RTCGeometry g) const { rtcReleaseGeometry(g); }
};
using DevicePtr = std::unique_ptr<RTCDeviceTy, DeviceRelease>;
using ScenePtr = std::unique_ptr<RTCSceneTy, SceneRelease>;
using GeometryPtr = std::unique_ptr<RTCGeometryTy, GeometryRelease>;

/// A new default device whose errors go to `log` (which must outlive it). Throws
/// std::runtime_error when Embree cannot create a device.
DevicePtr make_device(ErrorLog& log);

} // namespace vfit::embree
