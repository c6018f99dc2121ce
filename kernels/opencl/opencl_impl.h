// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to kernels/: the OpenCL objects behind vfit::OpenClContext, for the files that
// implement OpenCL kernels. Never include this from a public header.

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <map>
#include <mutex>
#include <string>

#include "../opencl_context.h"

namespace vfit {

struct OpenClContext::Impl {
  OpenClDeviceInfo info;
  cl::Device device;
  cl::Context context;
  cl::CommandQueue queue;
  std::mutex programs_mutex;
  std::map<std::string, cl::Program> programs;

  /// The program built from the embedded source `source` (keyed by `name`), built on first use.
  /// Throws vfit::Error with the build log on a compile failure.
  cl::Program& program(const std::string& name, const char* source);
};

/// Rethrows an OpenCL error as a std::runtime_error naming the call and the error code.
[[noreturn]] void throw_opencl_error(const cl::Error& e, const char* what);

} // namespace vfit
