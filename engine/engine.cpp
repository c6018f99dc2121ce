// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/engine.h"

#include <optional>

#include <tbb/global_control.h>

#include "vfit/engine/fit/pipeline.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/opencl_context.h"
#include "vfit/kernels/opencl_vertex_normals.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {

struct Engine::Impl {
  EngineOptions options;
  std::optional<tbb::global_control> thread_limit;
  std::unique_ptr<OpenClContext> opencl;
};

Engine::Engine(const EngineOptions& options) : m_impl(std::make_unique<Impl>()) {
  m_impl->options = options;
  if (options.threads > 0)
    m_impl->thread_limit.emplace(tbb::global_control::max_allowed_parallelism,
                                 static_cast<std::size_t>(options.threads));
  if (options.backend == Backend::OPENCL) m_impl->opencl = std::make_unique<OpenClContext>(options.device);
}

Engine::~Engine() = default;

Backend Engine::backend() const { return m_impl->options.backend; }

int Engine::thread_count() const { return m_impl->options.backend == Backend::SERIAL ? 1 : parallel_thread_count(); }

std::string Engine::description() const {
  switch (m_impl->options.backend) {
  case Backend::SERIAL: return "serial";
  case Backend::TBB: return "tbb (" + std::to_string(parallel_thread_count()) + " threads)";
  case Backend::OPENCL: {
    const auto& d = m_impl->opencl->device();
    return "opencl: " + d.device_name + " (" + d.platform_name + ")";
  }
  }
  return "unknown";
}

SourcedBody Engine::make_body(const BodySource& source) const { return vfit::make_body(source); }

std::vector<FitResult> Engine::fit(std::span<const Body* const> bodies, const std::vector<FitGarmentInput>& garments,
                                   FitOptions options) const {
  if (m_impl->options.backend == Backend::OPENCL)
    throw Error("engine", 0,
                "the fit's cloth simulation (implicit Euler) has no OpenCL path: create the engine with the serial or "
                "tbb backend");
  options.backend = m_impl->options.backend;
  return fit_garments_onto_bodies(bodies, garments, options);
}

FitResult Engine::fit(const Body& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options) const {
  const Body* bodies[] = {&body};
  return std::move(fit(bodies, garments, options).front());
}

FitResult Engine::fit(const BodySource& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options,
                      SourcedBody* made) const {
  SourcedBody sourced = make_body(body);
  FitResult result = fit(sourced.body, garments, options);
  if (made) *made = std::move(sourced);
  return result;
}

void Engine::vertex_normals(const Mesh& mesh, std::vector<float>& normals) {
  switch (m_impl->options.backend) {
  case Backend::SERIAL: vertex_normals_serial(mesh.position_view(), mesh.triangle_view(), normals); return;
  case Backend::TBB: vertex_normals_tbb(mesh.position_view(), mesh.triangle_view(), normals); return;
  case Backend::OPENCL: {
    OpenClVertexNormals kernel(*m_impl->opencl, mesh.triangle_view(), mesh.vertex_count());
    kernel.compute(mesh.position_view(), normals);
    return;
  }
  }
}

} // namespace vfit
