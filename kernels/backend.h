// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The compute backends a data-parallel primitive can run on.

#include <string>
#include <string_view>

namespace vfit {

/// SERIAL: the single-threaded reference; TBB: multi-core CPU; OPENCL: an OpenCL device
/// (PoCL on the CPU, or a GPU's ICD where one is installed).
enum class Backend { SERIAL, TBB, OPENCL };

/// "serial" | "tbb" | "opencl".
std::string backend_name(Backend backend);

/// Parses "serial" | "tbb" | "opencl"; throws vfit::Error naming the value otherwise.
Backend parse_backend(std::string_view name);

/// True when this build includes the OpenCL backend (CMake option VFIT_WITH_OPENCL).
bool opencl_built();

} // namespace vfit
