#pragma once
/// \file
/// The runtime apps link: it picks the compute backend and device and owns their state.
/// No backend types appear here (TBB arenas and OpenCL objects live in the implementation).

#include <memory>
#include <string>
#include <vector>

#include "geometry/mesh/mesh.h"
#include "kernels/backend.h"

namespace vfit {

struct EngineOptions {
  Backend backend = Backend::TBB;
  /// OpenCL device selector (see select_opencl_device()); empty: VFIT_OPENCL_DEVICE or the first.
  std::string device;
  /// Worker threads for the TBB backend; 0: all hardware threads.
  int threads = 0;
};

/// A configured compute engine. Construction fails with vfit::Error when the backend cannot
/// be had (OpenCL not built, no device, no device matching the selector).
class Engine {
public:
  explicit Engine(const EngineOptions& options = {});
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  Backend backend() const;
  /// "tbb (2 threads)", "serial", or "opencl: <device> (<platform>)".
  std::string description() const;
  /// Threads the CPU backends use.
  int thread_count() const;

  /// Area-weighted unit vertex normals of `mesh` (#V × 3, zero for isolated vertices) on this
  /// engine's backend; see kernels/vertex_normals.h.
  void vertex_normals(const Mesh& mesh, std::vector<float>& normals);

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
