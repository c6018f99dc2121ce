// SPDX-License-Identifier: Apache-2.0
#include <iostream>
#include <thread>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "vfit/kernels/backend.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/parallel.h"

namespace vfit::cli {

int run_devices(Args& args) {
  const bool json = args.flag("json");
  args.positionals(0, 0);
  const auto devices = list_opencl_devices();
  nlohmann::json j;
  j["tbb_threads"] = parallel_thread_count();
  j["hardware_threads"] = std::thread::hardware_concurrency();
  j["opencl_built"] = opencl_built();
  j["opencl_devices"] = nlohmann::json::array();
  std::string default_name;
  if (opencl_built() && !devices.empty()) {
    try {
      default_name = select_opencl_device().device_name;
    } catch (const std::exception& e) {
      default_name = std::string("(VFIT_OPENCL_DEVICE does not match: ") + e.what() + ")";
    }
  }
  for (const auto& d : devices)
    j["opencl_devices"].push_back({{"index", d.flat_index},
                                   {"platform", d.platform_name},
                                   {"platform_index", d.platform_index},
                                   {"device_index", d.device_index},
                                   {"name", d.device_name},
                                   {"type", d.device_type},
                                   {"version", d.version},
                                   {"compute_units", d.compute_units},
                                   {"global_memory_bytes", d.global_memory_bytes}});
  j["opencl_default"] = default_name;
  if (json) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  std::cout << "tbb: " << parallel_thread_count() << " threads (" << std::thread::hardware_concurrency()
            << " hardware threads)\n";
  if (!opencl_built()) {
    std::cout << "opencl: not built (configure with -DVFIT_WITH_OPENCL=ON)\n";
    return 0;
  }
  if (devices.empty()) {
    std::cout << "opencl: no platform or device found (on Debian: apt-get install pocl-opencl-icd)\n";
    return 0;
  }
  for (const auto& d : devices)
    std::cout << "opencl [" << d.flat_index << "] " << d.platform_index << ":" << d.device_index << " " << d.device_name
              << " (" << d.platform_name << ", " << d.device_type << ", " << d.compute_units << " compute units, "
              << d.global_memory_bytes / (1024 * 1024) << " MiB, " << d.version << ")"
              << (d.device_name == default_name ? "  <- default" : "") << "\n";
  std::cout << "select with --device N | P:D | gpu | cpu | <name substring>, or VFIT_OPENCL_DEVICE\n";
  return 0;
}

} // namespace vfit::cli
