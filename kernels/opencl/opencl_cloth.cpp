// SPDX-License-Identifier: Apache-2.0
#include "../opencl_cloth.h"

#include <algorithm>

#include "../cloth_implicit.h"
#include "../cloth_rk4.h"
#include "../cloth_springs.h"
#include "opencl_impl.h"
#include "vfit_cl_sources.h"

namespace vfit {

struct OpenClClothRk4::Impl {
  OpenClContext::Impl* cl = nullptr;
  std::size_t count = 0;
  cl::Buffer slice_offsets, neighbor_offsets, rest, stiffness, damping, consecutive_columns, inverse_masses;
  cl::Buffer x, v, acc_x, acc_v, stage_x[2], stage_v[2], forces;
  cl::Kernel stage_kernel, forces_kernel;
  // A CPU device runs the stages one work-item per slice of 16 particles in float16
  // (cloth.cl's cloth_rk4_stage_slices, in groups of SLICES_PER_GROUP); any other device one
  // work-item per particle in groups of LOCAL_SIZE.
  bool per_slice = false;
  ClothParticles particles; // gravity and damping (the masses live on the device)
};

namespace {
constexpr std::size_t LOCAL_SIZE = 64;
static_assert(LOCAL_SIZE % CLOTH_SLICE_WIDTH == 0, "a work-group covers whole slices");
static_assert(CLOTH_SLICE_WIDTH == 16, "cloth_rk4_stage_slices runs 16 lanes");
// Slices per work-group of cloth_rk4_stage_slices: 128 particles, as few groups as the
// per-particle kernel's groups of 64 give twice over (PoCL's cost per group is small).
constexpr std::size_t SLICES_PER_GROUP = 8;
std::size_t round_up(std::size_t n, std::size_t multiple = LOCAL_SIZE) {
  return (n + multiple - 1) / multiple * multiple;
}
} // namespace

OpenClClothRk4::OpenClClothRk4(OpenClContext& context, const SpringAdjacency& adjacency,
                               const ClothParticles& particles)
    : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.cl = &context.impl();
  m.count = adjacency.particle_count();
  m.particles.gravity[0] = particles.gravity[0];
  m.particles.gravity[1] = particles.gravity[1];
  m.particles.gravity[2] = particles.gravity[2];
  m.particles.global_damping = particles.global_damping;
  try {
    cl::Context& ctx = m.cl->context;
    auto upload = [&](const auto& v) {
      using T = typename std::decay_t<decltype(v)>::value_type;
      cl::Buffer b(ctx, CL_MEM_READ_ONLY, std::max<std::size_t>(1, v.size()) * sizeof(T));
      if (!v.empty()) m.cl->queue.enqueueWriteBuffer(b, CL_TRUE, 0, v.size() * sizeof(T), v.data());
      return b;
    };
    m.slice_offsets = upload(adjacency.slice_offsets);
    m.neighbor_offsets = upload(adjacency.slice_neighbor_offsets);
    m.rest = upload(adjacency.slice_rest_lengths);
    m.stiffness = upload(adjacency.slice_stiffness);
    m.damping = upload(adjacency.slice_damping);
    m.consecutive_columns = upload(adjacency.slice_consecutive_columns);
    m.inverse_masses = upload(particles.inverse_masses);
    const std::size_t bytes = std::max<std::size_t>(1, 3 * m.count) * sizeof(float);
    for (cl::Buffer* b :
         {&m.x, &m.v, &m.acc_x, &m.acc_v, &m.stage_x[0], &m.stage_x[1], &m.stage_v[0], &m.stage_v[1], &m.forces})
      *b = cl::Buffer(ctx, CL_MEM_READ_WRITE, bytes);
    cl::Program& prog = m.cl->program("cloth", vfit_cl_cloth);
    m.per_slice = m.cl->info.device_type == "cpu";
    m.stage_kernel = cl::Kernel(prog, m.per_slice ? "cloth_rk4_stage_slices" : "cloth_rk4_stage");
    m.forces_kernel = cl::Kernel(prog, "cloth_spring_forces");
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "setting up the cloth RK4");
  }
}

OpenClClothRk4::~OpenClClothRk4() = default;

void OpenClClothRk4::set_state(std::span<const float> positions, std::span<const float> velocities) {
  Impl& m = *m_impl;
  if (m.count == 0) return;
  try {
    m.cl->queue.enqueueWriteBuffer(m.x, CL_FALSE, 0, 3 * m.count * sizeof(float), positions.data());
    m.cl->queue.enqueueWriteBuffer(m.v, CL_TRUE, 0, 3 * m.count * sizeof(float), velocities.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "uploading the cloth state");
  }
}

void OpenClClothRk4::step(float h, int count) {
  Impl& m = *m_impl;
  if (m.count == 0) return;
  try {
    cl::Kernel& k = m.stage_kernel;
    k.setArg(4, m.acc_x);
    k.setArg(5, m.acc_v);
    k.setArg(8, m.slice_offsets);
    k.setArg(9, m.neighbor_offsets);
    k.setArg(10, m.rest);
    k.setArg(11, m.stiffness);
    k.setArg(12, m.damping);
    k.setArg(13, m.inverse_masses);
    k.setArg(14, m.particles.gravity[0]);
    k.setArg(15, m.particles.gravity[1]);
    k.setArg(16, m.particles.gravity[2]);
    k.setArg(17, m.particles.global_damping);
    k.setArg(18, h);
    if (m.per_slice)
      k.setArg(20, m.consecutive_columns);
    else
      k.setArg(20, static_cast<cl_int>(CLOTH_SLICE_WIDTH));
    k.setArg(21, static_cast<cl_int>(m.count));
    const std::size_t slices = (m.count + CLOTH_SLICE_WIDTH - 1) / CLOTH_SLICE_WIDTH;
    const cl::NDRange global(m.per_slice ? round_up(slices, SLICES_PER_GROUP) : round_up(m.count));
    const cl::NDRange local(m.per_slice ? SLICES_PER_GROUP : LOCAL_SIZE);
    for (int s = 0; s < count; ++s) {
      // The same buffer rotation as the C++ driver: x → A → B → A → x.
      const cl::Buffer* read_x = &m.x;
      const cl::Buffer* read_v = &m.v;
      for (int stage = 0; stage < 4; ++stage) {
        const cl::Buffer* write_x = stage == 3 ? &m.x : &m.stage_x[stage % 2];
        const cl::Buffer* write_v = stage == 3 ? &m.v : &m.stage_v[stage % 2];
        k.setArg(0, *read_x);
        k.setArg(1, *read_v);
        k.setArg(2, m.x);
        k.setArg(3, m.v);
        k.setArg(6, *write_x);
        k.setArg(7, *write_v);
        k.setArg(19, static_cast<cl_int>(stage));
        m.cl->queue.enqueueNDRangeKernel(k, cl::NullRange, global, local);
        read_x = write_x;
        read_v = write_v;
      }
    }
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "running the cloth RK4 stages");
  }
}

void OpenClClothRk4::get_state(std::vector<float>& positions, std::vector<float>& velocities) {
  Impl& m = *m_impl;
  positions.resize(3 * m.count);
  velocities.resize(3 * m.count);
  if (m.count == 0) return;
  try {
    m.cl->queue.enqueueReadBuffer(m.x, CL_FALSE, 0, 3 * m.count * sizeof(float), positions.data());
    m.cl->queue.enqueueReadBuffer(m.v, CL_TRUE, 0, 3 * m.count * sizeof(float), velocities.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "reading the cloth state");
  }
}

void OpenClClothRk4::spring_forces(std::vector<float>& forces) {
  Impl& m = *m_impl;
  forces.resize(3 * m.count);
  if (m.count == 0) return;
  try {
    cl::Kernel& k = m.forces_kernel;
    k.setArg(0, m.x);
    k.setArg(1, m.v);
    k.setArg(2, m.slice_offsets);
    k.setArg(3, m.neighbor_offsets);
    k.setArg(4, m.rest);
    k.setArg(5, m.stiffness);
    k.setArg(6, m.damping);
    k.setArg(7, m.forces);
    k.setArg(8, static_cast<cl_int>(CLOTH_SLICE_WIDTH));
    k.setArg(9, static_cast<cl_int>(m.count));
    m.cl->queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(m.count)), cl::NDRange(LOCAL_SIZE));
    m.cl->queue.enqueueReadBuffer(m.forces, CL_TRUE, 0, 3 * m.count * sizeof(float), forces.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "computing the cloth spring forces");
  }
}

void OpenClClothRk4::finish() {
  try {
    m_impl->cl->queue.finish();
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "waiting for the cloth RK4");
  }
}

struct OpenClImplicitMultiply::Impl {
  OpenClContext::Impl* cl = nullptr;
  std::size_t count = 0, entries = 0, slots = 0;
  cl::Buffer slice_offsets, offsets, neighbors, particle_blocks, springs, free_rows, p, out;
  cl::Kernel kernel;
};

OpenClImplicitMultiply::OpenClImplicitMultiply(OpenClContext& context, const SpringAdjacency& adjacency)
    : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.cl = &context.impl();
  m.count = adjacency.particle_count();
  m.entries = adjacency.neighbors.size();
  m.slots = adjacency.slice_neighbor_offsets.size();
  try {
    cl::Context& ctx = m.cl->context;
    const auto buffer = [&](cl_mem_flags flags, std::size_t bytes) {
      return cl::Buffer(ctx, flags, std::max<std::size_t>(1, bytes));
    };
    m.slice_offsets = buffer(CL_MEM_READ_ONLY, adjacency.slice_offsets.size() * sizeof(std::int32_t));
    if (!adjacency.slice_offsets.empty())
      m.cl->queue.enqueueWriteBuffer(m.slice_offsets, CL_TRUE, 0, adjacency.slice_offsets.size() * sizeof(std::int32_t),
                                     adjacency.slice_offsets.data());
    m.offsets = buffer(CL_MEM_READ_ONLY, adjacency.offsets.size() * sizeof(std::int32_t));
    m.neighbors = buffer(CL_MEM_READ_ONLY, m.entries * sizeof(std::int32_t));
    if (!adjacency.offsets.empty())
      m.cl->queue.enqueueWriteBuffer(m.offsets, CL_TRUE, 0, adjacency.offsets.size() * sizeof(std::int32_t),
                                     adjacency.offsets.data());
    if (m.entries > 0)
      m.cl->queue.enqueueWriteBuffer(m.neighbors, CL_TRUE, 0, m.entries * sizeof(std::int32_t),
                                     adjacency.neighbors.data());
    m.particle_blocks = buffer(CL_MEM_READ_ONLY, 6 * m.count * sizeof(float));
    m.springs = buffer(CL_MEM_READ_ONLY, 5 * m.slots * sizeof(float));
    m.free_rows = buffer(CL_MEM_READ_ONLY, m.count);
    m.p = buffer(CL_MEM_READ_WRITE, 3 * m.count * sizeof(float));
    m.out = buffer(CL_MEM_READ_WRITE, 3 * m.count * sizeof(float));
    cl::Program& prog = m.cl->program("cloth", vfit_cl_cloth);
    m.kernel = cl::Kernel(prog, "cloth_implicit_multiply");
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "setting up the implicit cloth product");
  }
}

OpenClImplicitMultiply::~OpenClImplicitMultiply() = default;

void OpenClImplicitMultiply::set_system(const ImplicitSystem& system) {
  Impl& m = *m_impl;
  if (m.count == 0) return;
  try {
    cl::CommandQueue& q = m.cl->queue;
    q.enqueueWriteBuffer(m.particle_blocks, CL_FALSE, 0, 6 * m.count * sizeof(float), system.particle_blocks.data());
    if (m.slots > 0)
      q.enqueueWriteBuffer(m.springs, CL_FALSE, 0, 5 * m.slots * sizeof(float), system.sliced_springs.data());
    q.enqueueWriteBuffer(m.free_rows, CL_TRUE, 0, m.count, system.free.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "uploading the implicit cloth system");
  }
}

void OpenClImplicitMultiply::set_vector(std::span<const float> p) {
  Impl& m = *m_impl;
  if (m.count == 0) return;
  try {
    m.cl->queue.enqueueWriteBuffer(m.p, CL_TRUE, 0, 3 * m.count * sizeof(float), p.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "uploading the implicit product's vector");
  }
}

void OpenClImplicitMultiply::multiply_on_device(int count) {
  Impl& m = *m_impl;
  if (m.count == 0) return;
  try {
    cl::Kernel& k = m.kernel;
    k.setArg(0, m.particle_blocks);
    k.setArg(1, m.springs);
    k.setArg(2, m.slice_offsets);
    k.setArg(3, m.offsets);
    k.setArg(4, m.neighbors);
    k.setArg(5, m.free_rows);
    k.setArg(6, m.p);
    k.setArg(7, m.out);
    k.setArg(8, static_cast<cl_int>(m.count));
    k.setArg(9, static_cast<cl_int>(m.slots));
    k.setArg(10, static_cast<cl_int>(CLOTH_SLICE_WIDTH));
    for (int s = 0; s < count; ++s)
      m.cl->queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(round_up(m.count)), cl::NDRange(LOCAL_SIZE));
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "running the implicit cloth product");
  }
}

void OpenClImplicitMultiply::multiply(std::span<const float> p, std::vector<float>& out) {
  Impl& m = *m_impl;
  out.resize(3 * m.count);
  if (m.count == 0) return;
  set_vector(p);
  multiply_on_device(1);
  try {
    m.cl->queue.enqueueReadBuffer(m.out, CL_TRUE, 0, 3 * m.count * sizeof(float), out.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "reading the implicit cloth product");
  }
}

void OpenClImplicitMultiply::finish() {
  try {
    m_impl->cl->queue.finish();
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "waiting for the implicit cloth product");
  }
}

} // namespace vfit
