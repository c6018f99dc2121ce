// SPDX-License-Identifier: Apache-2.0
#include "../opencl_vertex_normals.h"

#include "../vertex_normals.h"
#include "opencl_impl.h"
#include "vfit_cl_sources.h"

namespace vfit {

struct OpenClVertexNormals::Impl {
  OpenClContext::Impl* cl = nullptr;
  std::size_t vertex_count = 0, face_count = 0;
  cl::Buffer triangles, offsets, faces, face_normals, positions, normals;
  cl::Kernel triangle_kernel, gather_kernel;
};

namespace {
// Rounds a global size up to a multiple of the work-group size we request.
constexpr std::size_t LOCAL_SIZE = 64;
std::size_t round_up(std::size_t n) { return (n + LOCAL_SIZE - 1) / LOCAL_SIZE * LOCAL_SIZE; }
} // namespace

OpenClVertexNormals::OpenClVertexNormals(OpenClContext& context, std::span<const std::int32_t> triangles,
                                         std::size_t vertex_count)
    : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.cl = &context.impl();
  m.vertex_count = vertex_count;
  m.face_count = triangles.size() / 3;
  VertexFaceAdjacency adj = build_vertex_face_adjacency(triangles, vertex_count);
  try {
    cl::Context& ctx = m.cl->context;
    auto upload = [&](const auto& v) {
      using T = typename std::decay_t<decltype(v)>::value_type;
      std::size_t bytes = std::max<std::size_t>(1, v.size()) * sizeof(T);
      cl::Buffer b(ctx, CL_MEM_READ_ONLY, bytes);
      if (!v.empty()) m.cl->queue.enqueueWriteBuffer(b, CL_TRUE, 0, v.size() * sizeof(T), v.data());
      return b;
    };
    m.triangles = upload(std::vector<std::int32_t>(triangles.begin(), triangles.end()));
    m.offsets = upload(adj.offsets);
    m.faces = upload(adj.faces);
    m.face_normals = cl::Buffer(ctx, CL_MEM_READ_WRITE, std::max<std::size_t>(1, 3 * m.face_count) * sizeof(float));
    m.positions = cl::Buffer(ctx, CL_MEM_READ_ONLY, std::max<std::size_t>(1, 3 * vertex_count) * sizeof(float));
    m.normals = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, std::max<std::size_t>(1, 3 * vertex_count) * sizeof(float));
    cl::Program& prog = m.cl->program("vertex_normals", vfit_cl_vertex_normals);
    m.triangle_kernel = cl::Kernel(prog, "triangle_area_normals");
    m.gather_kernel = cl::Kernel(prog, "gather_vertex_normals");
    m.triangle_kernel.setArg(0, m.positions);
    m.triangle_kernel.setArg(1, m.triangles);
    m.triangle_kernel.setArg(2, m.face_normals);
    m.triangle_kernel.setArg(3, static_cast<cl_int>(m.face_count));
    m.gather_kernel.setArg(0, m.face_normals);
    m.gather_kernel.setArg(1, m.offsets);
    m.gather_kernel.setArg(2, m.faces);
    m.gather_kernel.setArg(3, m.normals);
    m.gather_kernel.setArg(4, static_cast<cl_int>(vertex_count));
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "setting up vertex normals");
  }
}

OpenClVertexNormals::~OpenClVertexNormals() = default;

void OpenClVertexNormals::compute(std::span<const float> positions, std::vector<float>& normals) {
  Impl& m = *m_impl;
  normals.resize(3 * m.vertex_count);
  if (m.vertex_count == 0) return;
  try {
    cl::CommandQueue& q = m.cl->queue;
    q.enqueueWriteBuffer(m.positions, CL_FALSE, 0, 3 * m.vertex_count * sizeof(float), positions.data());
    if (m.face_count > 0)
      q.enqueueNDRangeKernel(m.triangle_kernel, cl::NullRange, cl::NDRange(round_up(m.face_count)),
                             cl::NDRange(LOCAL_SIZE));
    q.enqueueNDRangeKernel(m.gather_kernel, cl::NullRange, cl::NDRange(round_up(m.vertex_count)),
                           cl::NDRange(LOCAL_SIZE));
    q.enqueueReadBuffer(m.normals, CL_TRUE, 0, 3 * m.vertex_count * sizeof(float), normals.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "computing vertex normals");
  }
}

} // namespace vfit
