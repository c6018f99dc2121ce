#include "skeleton_proxy.h"

#include <algorithm>
#include <numeric>
#include <queue>

#include <Eigen/Core>

#include "kernels/error.h"

namespace vfit {

SkeletonProxy simplify_for_skeleton(const Mesh& mesh, std::size_t target_vertices) {
  const std::size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (mesh.triangles[i] < 0 || std::size_t(mesh.triangles[i]) >= nv)
      throw Error("skeleton proxy", 0, "face " + std::to_string(i / 3 + 1) + " has a vertex index out of range");
  SkeletonProxy proxy;
  if (nv <= target_vertices) {
    proxy.mesh.positions = mesh.positions;
    proxy.mesh.triangles = mesh.triangles;
    proxy.vertex_proxy.resize(nv);
    std::iota(proxy.vertex_proxy.begin(), proxy.vertex_proxy.end(), 0);
    return proxy;
  }

  std::vector<std::int32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[std::size_t(x)] != x) x = parent[std::size_t(x)] = parent[std::size_t(parent[std::size_t(x)])];
    return x;
  };
  std::vector<Eigen::Vector3d> sum(nv);
  std::vector<double> count(nv, 1.0);
  for (std::size_t v = 0; v < nv; ++v) sum[v] = Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
  auto position = [&](std::int32_t r) -> Eigen::Vector3d { return sum[std::size_t(r)] / count[std::size_t(r)]; };

  std::vector<std::int32_t> tris = mesh.triangles;
  std::vector<char> alive(nf, 1);
  std::vector<std::vector<std::int32_t>> faces(nv), neighbours(nv);
  auto add_neighbour = [&](std::int32_t a, std::int32_t b) {
    auto& n = neighbours[std::size_t(a)];
    if (std::find(n.begin(), n.end(), b) == n.end()) n.push_back(b);
  };
  for (std::size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = tris[3 * f + std::size_t(k)], b = tris[3 * f + std::size_t(k + 1) % 3];
      faces[std::size_t(a)].push_back(std::int32_t(f));
      add_neighbour(a, b);
      add_neighbour(b, a);
    }

  struct Candidate {
    double length;
    std::int32_t a, b;
    bool operator>(const Candidate& o) const { return length > o.length; }
  };
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue;
  for (std::size_t a = 0; a < nv; ++a)
    for (std::int32_t b : neighbours[a])
      if (std::int32_t(a) < b) queue.push({(position(std::int32_t(a)) - position(b)).norm(), std::int32_t(a), b});

  std::size_t remaining = nv;
  std::vector<std::int32_t> shared;
  while (remaining > target_vertices && !queue.empty()) {
    const Candidate c = queue.top();
    queue.pop();
    std::int32_t a = find(c.a), b = find(c.b);
    if (a == b) continue;
    const double length = (position(a) - position(b)).norm();
    if (length > c.length * (1 + 1e-9)) {
      queue.push({length, a, b});
      continue;
    }
    auto& na = neighbours[std::size_t(a)];
    auto& nb = neighbours[std::size_t(b)];
    if (na.size() <= 3 || nb.size() <= 3) continue;
    // Link condition: a and b share exactly the two vertices across their edge.
    shared.clear();
    for (std::int32_t w : nb)
      if (w != a && std::find(na.begin(), na.end(), w) != na.end()) shared.push_back(w);
    if (shared.size() != 2) continue;
    if (faces[std::size_t(a)].size() < faces[std::size_t(b)].size()) std::swap(a, b); // merge the smaller into the larger
    for (std::int32_t f : faces[std::size_t(b)]) {
      std::int32_t* t = &tris[3 * std::size_t(f)];
      if (t[0] == a || t[1] == a || t[2] == a) {
        alive[std::size_t(f)] = 0;
        continue;
      }
      for (int k = 0; k < 3; ++k)
        if (t[k] == b) t[k] = a;
      faces[std::size_t(a)].push_back(f);
    }
    std::erase_if(faces[std::size_t(a)], [&](std::int32_t f) { return !alive[std::size_t(f)]; });
    faces[std::size_t(b)].clear();
    for (std::int32_t w : neighbours[std::size_t(b)]) {
      if (w == a) continue;
      auto& nw = neighbours[std::size_t(w)];
      std::erase(nw, b);
      add_neighbour(w, a);
      add_neighbour(a, w);
    }
    std::erase(neighbours[std::size_t(a)], b);
    neighbours[std::size_t(b)].clear();
    parent[std::size_t(b)] = a;
    sum[std::size_t(a)] += sum[std::size_t(b)];
    count[std::size_t(a)] += count[std::size_t(b)];
    --remaining;
  }

  std::vector<std::int32_t> compact(nv, -1);
  proxy.vertex_proxy.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const std::int32_t r = find(std::int32_t(v));
    if (compact[std::size_t(r)] < 0) {
      compact[std::size_t(r)] = std::int32_t(proxy.mesh.positions.size() / 3);
      const Eigen::Vector3d p = position(r);
      proxy.mesh.positions.insert(proxy.mesh.positions.end(), {float(p.x()), float(p.y()), float(p.z())});
    }
    proxy.vertex_proxy[v] = compact[std::size_t(r)];
  }
  for (std::size_t f = 0; f < nf; ++f)
    if (alive[f])
      for (int k = 0; k < 3; ++k) proxy.mesh.triangles.push_back(compact[std::size_t(tris[3 * f + std::size_t(k)])]);
  return proxy;
}

} // namespace vfit
