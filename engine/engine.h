// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The one object an app creates: it picks the compute backend, the device and the thread
/// count, owns their state, and runs the engine's work with them — a body made from what the
/// app has and garments fitted onto it (engine/fit/), vertex normals. `vfit` creates one per
/// command. No backend types appear here (TBB arenas and OpenCL objects live in the
/// implementation).

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vfit/engine/fit/body_source.h"
#include "vfit/engine/fit/fit_options.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/body/body.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/backend.h"

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

  /// The body of `source`, loaded and posed (make_body(), engine/fit/body_source.h).
  SourcedBody make_body(const BodySource& source) const;

  /// Fits `garments` onto each of `bodies` (fit_garments_onto_bodies(), engine/fit/pipeline.h)
  /// with this engine's threads, the cloth simulation on its backend (options.backend is set to
  /// it). Throws as fit_garments_onto_bodies() does, and vfit::Error on an OPENCL engine: the
  /// fit's cloth simulation (implicit Euler) has no OpenCL path.
  std::vector<FitResult> fit(std::span<const Body* const> bodies, const std::vector<FitGarmentInput>& garments,
                             FitOptions options = {}) const;
  /// One body, posed: as above for one body.
  FitResult fit(const Body& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options = {}) const;
  /// Body and garments in one call: make_body(body), then fit() onto it. `made`, when not null,
  /// receives the body (as loaded and posed).
  FitResult fit(const BodySource& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options = {},
                SourcedBody* made = nullptr) const;

  /// Area-weighted unit vertex normals of `mesh` (#V × 3, zero for isolated vertices) on this
  /// engine's backend; see kernels/vertex_normals.h.
  void vertex_normals(const Mesh& mesh, std::vector<float>& normals);

private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

} // namespace vfit
