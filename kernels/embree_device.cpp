// SPDX-License-Identifier: Apache-2.0
#include "embree_device.h"

#include <stdexcept>

namespace vfit::embree {

void record_error(void* user, RTCError code, const char* message) {
  auto* log = static_cast<ErrorLog*>(user);
  std::lock_guard<std::mutex> lock(log->mutex);
  if (log->code != RTC_ERROR_NONE) return;
  log->code = code;
  log->message = message ? message : "";
}

void throw_if_failed(ErrorLog& log, const char* call) {
  std::lock_guard<std::mutex> lock(log.mutex);
  if (log.code == RTC_ERROR_NONE) return;
  const std::string what =
      std::string("Embree ") + call + " failed (error " + std::to_string(int(log.code)) + "): " + log.message;
  log.code = RTC_ERROR_NONE;
  log.message.clear();
  throw std::runtime_error(what);
}

DevicePtr make_device(ErrorLog& log) {
  DevicePtr device(rtcNewDevice(nullptr));
  if (!device)
    throw std::runtime_error("Embree rtcNewDevice failed (error " + std::to_string(int(rtcGetDeviceError(nullptr))) +
                             ")");
  rtcSetDeviceErrorFunction(device.get(), record_error, &log);
  return device;
}

} // namespace vfit::embree
