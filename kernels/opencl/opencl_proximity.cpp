// SPDX-License-Identifier: Apache-2.0
// OpenClProximity: a flat BVH from Embree's builder, traversed by proximity.cl. Compiled in
// every build; without OpenCL the entry points throw vfit::Error saying so.
#include "../opencl_proximity.h"

#include "../error.h"

#ifdef VFIT_WITH_OPENCL

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "../embree_device.h"
#include "opencl_impl.h"
#include "vfit_cl_sources.h"

namespace vfit {
namespace {

// The builder's own nodes, allocated in Embree's thread-local allocator and freed with the
// RTCBVH: binary inner nodes with their children's boxes, and leaves holding capped-face ids.
struct BuildNode {
  bool leaf;
};
struct BuildInner : BuildNode {
  BuildNode* children[2];
  RTCBounds bounds[2];
};
struct BuildLeaf : BuildNode {
  unsigned count;
  unsigned faces[OPENCL_PROXIMITY_LEAF_SIZE];
};

void* create_inner(RTCThreadLocalAllocator alloc, unsigned int child_count, void*) {
  assert(child_count == 2 && "binary BVH requested");
  (void)child_count;
  auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(BuildInner), 16)) BuildInner;
  n->leaf = false;
  n->children[0] = n->children[1] = nullptr;
  return n;
}

void set_children(void* node, void** children, unsigned int child_count, void*) {
  auto* n = static_cast<BuildInner*>(node);
  for (unsigned k = 0; k < child_count && k < 2; ++k)
    n->children[k] = static_cast<BuildNode*>(children[k]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int child_count, void*) {
  auto* n = static_cast<BuildInner*>(node);
  for (unsigned k = 0; k < child_count && k < 2; ++k)
    n->bounds[k] = *bounds[k];
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* primitives, size_t count, void*) {
  assert(count <= OPENCL_PROXIMITY_LEAF_SIZE && "leaf larger than requested");
  auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(BuildLeaf), 16)) BuildLeaf;
  n->leaf = true;
  n->count = static_cast<unsigned>(std::min<std::size_t>(count, OPENCL_PROXIMITY_LEAF_SIZE));
  for (unsigned k = 0; k < n->count; ++k)
    n->faces[k] = primitives[k].primID;
  return n;
}

// The flat layout proximity.cl walks: per node a box (lo.xyz, 0, hi.xyz, 0) and (count, link);
// depth-first order, so an inner node's first child is the next node.
struct FlatBvh {
  std::vector<float> bounds;
  std::vector<std::int32_t> nodes;
  std::vector<std::int32_t> primitives;

  std::size_t size() const { return nodes.size() / 2; }

  void append(const BuildNode* node, const RTCBounds& box) {
    const std::size_t n = size();
    bounds.insert(bounds.end(),
                  {box.lower_x, box.lower_y, box.lower_z, 0.0f, box.upper_x, box.upper_y, box.upper_z, 0.0f});
    nodes.insert(nodes.end(), {0, 0});
    if (node->leaf) {
      const auto* leaf = static_cast<const BuildLeaf*>(node);
      nodes[2 * n] = static_cast<std::int32_t>(leaf->count);
      nodes[2 * n + 1] = static_cast<std::int32_t>(primitives.size());
      for (unsigned k = 0; k < leaf->count; ++k)
        primitives.push_back(static_cast<std::int32_t>(leaf->faces[k]));
      return;
    }
    const auto* inner = static_cast<const BuildInner*>(node);
    append(inner->children[0], inner->bounds[0]);
    nodes[2 * n + 1] = static_cast<std::int32_t>(size());
    append(inner->children[1], inner->bounds[1]);
  }
};

FlatBvh build_flat_bvh(const ProximitySideMesh& mesh) {
  FlatBvh flat;
  const std::size_t face_count = mesh.triangles.size() / 3;
  if (face_count == 0) return flat;
  std::vector<RTCBuildPrimitive> prims(face_count);
  RTCBounds all{INFINITY, INFINITY, INFINITY, 0.0f, -INFINITY, -INFINITY, -INFINITY, 0.0f};
  for (std::size_t f = 0; f < face_count; ++f) {
    RTCBuildPrimitive& p = prims[f];
    p.lower_x = p.lower_y = p.lower_z = INFINITY;
    p.upper_x = p.upper_y = p.upper_z = -INFINITY;
    for (std::size_t k = 0; k < 3; ++k) {
      const float* v = mesh.positions.data() + 3 * static_cast<std::size_t>(mesh.triangles[3 * f + k]);
      p.lower_x = std::min(p.lower_x, v[0]), p.upper_x = std::max(p.upper_x, v[0]);
      p.lower_y = std::min(p.lower_y, v[1]), p.upper_y = std::max(p.upper_y, v[1]);
      p.lower_z = std::min(p.lower_z, v[2]), p.upper_z = std::max(p.upper_z, v[2]);
    }
    p.geomID = 0;
    p.primID = static_cast<unsigned>(f);
    all.lower_x = std::min(all.lower_x, p.lower_x), all.upper_x = std::max(all.upper_x, p.upper_x);
    all.lower_y = std::min(all.lower_y, p.lower_y), all.upper_y = std::max(all.upper_y, p.upper_y);
    all.lower_z = std::min(all.lower_z, p.lower_z), all.upper_z = std::max(all.upper_z, p.upper_z);
  }
  embree::ErrorLog errors;
  embree::DevicePtr device = embree::make_device(errors);
  RTCBVH bvh = rtcNewBVH(device.get());
  embree::throw_if_failed(errors, "rtcNewBVH");
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.byteSize = sizeof(args);
  args.buildQuality = RTC_BUILD_QUALITY_MEDIUM; // SAH without spatial splits: no splitPrimitive
  args.maxBranchingFactor = 2;
  args.maxDepth = 48; // the kernel's stack (64) holds at most one entry per level plus one
  args.minLeafSize = 1;
  args.maxLeafSize = OPENCL_PROXIMITY_LEAF_SIZE;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = prims.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = create_inner;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = nullptr;
  args.buildProgress = nullptr;
  args.userPtr = nullptr;
  const auto* root = static_cast<const BuildNode*>(rtcBuildBVH(&args));
  try {
    embree::throw_if_failed(errors, "rtcBuildBVH");
    if (!root) throw std::runtime_error("Embree rtcBuildBVH returned no root");
    flat.bounds.reserve(8 * 2 * face_count);
    flat.nodes.reserve(2 * 2 * face_count);
    flat.primitives.reserve(face_count);
    flat.append(root, all);
  } catch (...) {
    rtcReleaseBVH(bvh);
    throw;
  }
  rtcReleaseBVH(bvh);
  return flat;
}

constexpr std::size_t LOCAL_SIZE = 64;
std::size_t round_up(std::size_t n) { return (n + LOCAL_SIZE - 1) / LOCAL_SIZE * LOCAL_SIZE; }

} // namespace

struct OpenClProximity::Impl {
  OpenClContext::Impl* cl = nullptr;
  std::size_t node_count = 0;
  cl::Buffer bounds, nodes, primitives, positions, triangles, triangle_edges, face_normals, edge_normals,
      vertex_normals;
  cl::Kernel kernel;
  // Per-call buffers, grown as needed.
  std::size_t capacity = 0;
  cl::Buffer queries, points, out_triangles, barycentrics, signed_distances, features;
};

OpenClProximity::OpenClProximity(OpenClContext& context, const ProximityIndex& index)
    : m_impl(std::make_unique<Impl>()) {
  Impl& m = *m_impl;
  m.cl = &context.impl();
  const ProximitySideMesh mesh = index.side_mesh();
  const FlatBvh flat = build_flat_bvh(mesh);
  m.node_count = flat.size();
  try {
    cl::Context& ctx = m.cl->context;
    auto upload = [&](const auto* data, std::size_t count) {
      using T = std::remove_cv_t<std::remove_pointer_t<decltype(data)>>;
      cl::Buffer b(ctx, CL_MEM_READ_ONLY, std::max<std::size_t>(1, count) * sizeof(T));
      if (count > 0) m.cl->queue.enqueueWriteBuffer(b, CL_TRUE, 0, count * sizeof(T), data);
      return b;
    };
    m.bounds = upload(flat.bounds.data(), flat.bounds.size());
    m.nodes = upload(flat.nodes.data(), flat.nodes.size());
    m.primitives = upload(flat.primitives.data(), flat.primitives.size());
    m.positions = upload(mesh.positions.data(), mesh.positions.size());
    m.triangles = upload(mesh.triangles.data(), mesh.triangles.size());
    m.triangle_edges = upload(mesh.triangle_edges.data(), mesh.triangle_edges.size());
    m.face_normals = upload(mesh.face_normals.data(), mesh.face_normals.size());
    m.edge_normals = upload(mesh.edge_normals.data(), mesh.edge_normals.size());
    m.vertex_normals = upload(mesh.vertex_normals.data(), mesh.vertex_normals.size());
    cl::Program& prog = m.cl->program("proximity", vfit_cl_proximity);
    m.kernel = cl::Kernel(prog, "closest_points");
    int a = 0;
    for (cl::Buffer* b : {&m.bounds, &m.nodes, &m.primitives, &m.positions, &m.triangles, &m.triangle_edges,
                          &m.face_normals, &m.edge_normals, &m.vertex_normals})
      m.kernel.setArg(a++, *b);
    m.kernel.setArg(a++, static_cast<cl_int>(mesh.mesh_face_count));
    m.kernel.setArg(a++, static_cast<cl_int>(m.node_count));
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "setting up proximity");
  }
}

OpenClProximity::~OpenClProximity() = default;

std::size_t OpenClProximity::node_count() const { return m_impl->node_count; }

void OpenClProximity::closest_points(std::span<const float> queries, float max_distance, ClosestHits& hits) {
  check_proximity_queries(queries, max_distance);
  Impl& m = *m_impl;
  const std::size_t count = queries.size() / 3;
  hits.resize(count);
  if (count == 0) return;
  try {
    cl::Context& ctx = m.cl->context;
    cl::CommandQueue& q = m.cl->queue;
    if (count > m.capacity) {
      m.capacity = count;
      m.queries = cl::Buffer(ctx, CL_MEM_READ_ONLY, 3 * count * sizeof(float));
      m.points = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, 3 * count * sizeof(float));
      m.out_triangles = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, count * sizeof(std::int32_t));
      m.barycentrics = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, 2 * count * sizeof(float));
      m.signed_distances = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, count * sizeof(float));
      m.features = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, count * sizeof(std::int8_t));
    }
    // Squared in float, as ProximityIndex does, so both cut off at the same distance.
    const float max_distance2 = max_distance * max_distance;
    m.kernel.setArg(11, m.queries);
    m.kernel.setArg(12, static_cast<cl_int>(count));
    m.kernel.setArg(13, max_distance2);
    m.kernel.setArg(14, m.points);
    m.kernel.setArg(15, m.out_triangles);
    m.kernel.setArg(16, m.barycentrics);
    m.kernel.setArg(17, m.signed_distances);
    m.kernel.setArg(18, m.features);
    q.enqueueWriteBuffer(m.queries, CL_FALSE, 0, 3 * count * sizeof(float), queries.data());
    q.enqueueNDRangeKernel(m.kernel, cl::NullRange, cl::NDRange(round_up(count)), cl::NDRange(LOCAL_SIZE));
    q.enqueueReadBuffer(m.points, CL_FALSE, 0, 3 * count * sizeof(float), hits.points.data());
    q.enqueueReadBuffer(m.out_triangles, CL_FALSE, 0, count * sizeof(std::int32_t), hits.triangles.data());
    q.enqueueReadBuffer(m.barycentrics, CL_FALSE, 0, 2 * count * sizeof(float), hits.barycentrics.data());
    q.enqueueReadBuffer(m.signed_distances, CL_FALSE, 0, count * sizeof(float), hits.signed_distances.data());
    q.enqueueReadBuffer(m.features, CL_TRUE, 0, count * sizeof(std::int8_t), hits.features.data());
  } catch (const cl::Error& e) {
    throw_opencl_error(e, "answering closest points");
  }
}

} // namespace vfit

#else // no OpenCL in this build

namespace vfit {
namespace {
[[noreturn]] void unavailable() {
  throw Error("opencl", 0, "this vfit was built without OpenCL (CMake option VFIT_WITH_OPENCL=OFF)");
}
} // namespace

struct OpenClProximity::Impl {};
OpenClProximity::OpenClProximity(OpenClContext&, const ProximityIndex&) { unavailable(); }
OpenClProximity::~OpenClProximity() = default;
std::size_t OpenClProximity::node_count() const { return 0; }
void OpenClProximity::closest_points(std::span<const float>, float, ClosestHits&) { unavailable(); }

} // namespace vfit

#endif
