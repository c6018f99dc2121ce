// SPDX-License-Identifier: Apache-2.0
#include "opencl_impl.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <stdexcept>

#include "../error.h"

namespace vfit {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string type_name(cl_device_type t) {
  if (t & CL_DEVICE_TYPE_GPU) return "gpu";
  if (t & CL_DEVICE_TYPE_CPU) return "cpu";
  if (t & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
  return "other";
}

struct Enumerated {
  OpenClDeviceInfo info;
  cl::Device device;
};

std::vector<Enumerated> enumerate() {
  std::vector<Enumerated> out;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error&) {
    return out; // no ICD or no platform: CL_PLATFORM_NOT_FOUND_KHR
  }
  int flat = 0;
  for (std::size_t p = 0; p < platforms.size(); ++p) {
    std::vector<cl::Device> devices;
    try {
      platforms[p].getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue; // a platform with no devices
    }
    for (std::size_t d = 0; d < devices.size(); ++d) {
      Enumerated e;
      e.device = devices[d];
      e.info.platform_index = static_cast<int>(p);
      e.info.device_index = static_cast<int>(d);
      e.info.flat_index = flat++;
      e.info.platform_name = platforms[p].getInfo<CL_PLATFORM_NAME>();
      e.info.device_name = devices[d].getInfo<CL_DEVICE_NAME>();
      e.info.device_type = type_name(devices[d].getInfo<CL_DEVICE_TYPE>());
      e.info.version = devices[d].getInfo<CL_DEVICE_VERSION>();
      e.info.global_memory_bytes = devices[d].getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      e.info.compute_units = static_cast<int>(devices[d].getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>());
      out.push_back(std::move(e));
    }
  }
  return out;
}

std::string describe(const std::vector<Enumerated>& all) {
  if (all.empty()) return "no OpenCL device is installed (on Debian: apt-get install pocl-opencl-icd)";
  std::string s = "available devices:";
  for (const auto& e : all)
    s += " [" + std::to_string(e.info.flat_index) + "] " + e.info.device_name + " (" + e.info.platform_name + ", " +
         e.info.device_type + ");";
  s.pop_back();
  return s;
}

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

const Enumerated& pick(const std::vector<Enumerated>& all, std::string_view selector_in, std::string& source) {
  std::string selector(selector_in);
  source = "--device";
  if (selector.empty()) {
    if (const char* env = std::getenv("VFIT_OPENCL_DEVICE"); env && *env) {
      selector = env;
      source = "VFIT_OPENCL_DEVICE";
    }
  }
  if (all.empty()) throw Error(source.empty() ? "opencl" : "opencl", 0, describe(all));
  if (selector.empty()) return all.front();
  if (all_digits(selector)) {
    std::size_t i = std::stoul(selector);
    if (i < all.size()) return all[i];
  } else if (auto colon = selector.find(':'); colon != std::string::npos &&
                                              all_digits(std::string_view(selector).substr(0, colon)) &&
                                              all_digits(std::string_view(selector).substr(colon + 1))) {
    int p = std::stoi(selector.substr(0, colon)), d = std::stoi(selector.substr(colon + 1));
    for (const auto& e : all)
      if (e.info.platform_index == p && e.info.device_index == d) return e;
  } else {
    const std::string want = lower(selector);
    for (const auto& e : all)
      if (e.info.device_type == want) return e;
    for (const auto& e : all)
      if (lower(e.info.device_name).find(want) != std::string::npos ||
          lower(e.info.platform_name).find(want) != std::string::npos)
        return e;
  }
  throw Error(source, 0, "no OpenCL device matches '" + selector + "'; " + describe(all));
}

} // namespace

void throw_opencl_error(const cl::Error& e, const char* what) {
  throw std::runtime_error(std::string("OpenCL: ") + what + ": " + e.what() + " failed with code " +
                           std::to_string(e.err()));
}

std::vector<OpenClDeviceInfo> list_opencl_devices() {
  std::vector<OpenClDeviceInfo> out;
  for (auto& e : enumerate())
    out.push_back(e.info);
  return out;
}

OpenClDeviceInfo select_opencl_device(std::string_view selector) {
  auto all = enumerate();
  std::string source;
  return pick(all, selector, source).info;
}

OpenClContext::OpenClContext(std::string_view selector) : m_impl(std::make_unique<Impl>()) {
  auto all = enumerate();
  std::string source;
  const Enumerated& e = pick(all, selector, source);
  try {
    m_impl->info = e.info;
    m_impl->device = e.device;
    m_impl->context = cl::Context(e.device);
    m_impl->queue = cl::CommandQueue(m_impl->context, e.device);
  } catch (const cl::Error& err) {
    throw_opencl_error(err, "creating a context");
  }
}

OpenClContext::~OpenClContext() = default;

const OpenClDeviceInfo& OpenClContext::device() const { return m_impl->info; }

double OpenClContext::copy_bandwidth_gbps(std::size_t bytes, int repeats) {
  if (bytes == 0 || repeats < 1)
    throw Error("opencl", 0,
                "copy_bandwidth_gbps needs bytes > 0 and repeats >= 1 (got " + std::to_string(bytes) + ", " +
                    std::to_string(repeats) + ")");
  if (bytes > m_impl->info.global_memory_bytes / 2)
    throw Error("opencl", 0,
                "copy_bandwidth_gbps: two buffers of " + std::to_string(bytes) + " bytes exceed " +
                    m_impl->info.device_name + "'s " + std::to_string(m_impl->info.global_memory_bytes) + " bytes");
  try {
    cl::Buffer from(m_impl->context, CL_MEM_READ_WRITE, bytes);
    cl::Buffer to(m_impl->context, CL_MEM_READ_WRITE, bytes);
    const cl_uchar zero = 0;
    m_impl->queue.enqueueFillBuffer(from, zero, 0, bytes); // first touch: pages exist before timing
    m_impl->queue.enqueueFillBuffer(to, zero, 0, bytes);
    m_impl->queue.enqueueCopyBuffer(from, to, 0, 0, bytes); // warm-up
    m_impl->queue.finish();
    double best = 0.0;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      m_impl->queue.enqueueCopyBuffer(from, to, 0, 0, bytes);
      m_impl->queue.finish();
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (s > 0) best = std::max(best, 2.0 * double(bytes) / s / 1e9);
    }
    return best;
  } catch (const cl::Error& err) {
    throw_opencl_error(err, "measuring the copy bandwidth");
  }
}

cl::Program& OpenClContext::Impl::program(const std::string& name, const char* source) {
  std::lock_guard<std::mutex> lock(programs_mutex);
  auto it = programs.find(name);
  if (it != programs.end()) return it->second;
  cl::Program prog(context, std::string(source));
  try {
    // Correctly rounded sqrt/divide keeps device results within an ulp of the C++ reference.
    prog.build({device}, "-cl-fp32-correctly-rounded-divide-sqrt");
  } catch (const cl::BuildError& err) {
    std::string log;
    for (const auto& [dev, text] : err.getBuildLog())
      log += text;
    throw std::runtime_error("OpenCL: building " + name + ".cl failed on " + info.device_name + ":\n" + log);
  } catch (const cl::Error& err) {
    throw_opencl_error(err, ("building " + name + ".cl").c_str());
  }
  return programs.emplace(name, std::move(prog)).first->second;
}

} // namespace vfit
