// SPDX-License-Identifier: Apache-2.0
#include "backend.h"

#include "error.h"

namespace vfit {

std::string backend_name(Backend backend) {
  switch (backend) {
  case Backend::SERIAL: return "serial";
  case Backend::TBB: return "tbb";
  case Backend::OPENCL: return "opencl";
  }
  return "unknown";
}

Backend parse_backend(std::string_view name) {
  if (name == "serial") return Backend::SERIAL;
  if (name == "tbb") return Backend::TBB;
  if (name == "opencl") return Backend::OPENCL;
  throw Error("--backend", 0, "unknown backend '" + std::string(name) + "' (expected serial, tbb or opencl)");
}

bool opencl_built() {
#ifdef VFIT_WITH_OPENCL
  return true;
#else
  return false;
#endif
}

} // namespace vfit
