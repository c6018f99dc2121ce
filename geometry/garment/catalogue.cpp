// SPDX-License-Identifier: Apache-2.0
#include "catalogue.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include "garment_shape.h"
#include "vfit/geometry/mesh/clip.h"
#include "vfit/geometry/mesh/decimate.h"
#include "vfit/geometry/mesh/isosurface.h"
#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

constexpr std::size_t MIN_VERTICES = 1000, MAX_VERTICES = 2000000;

std::vector<std::vector<std::int32_t>> one_rings(const Mesh& mesh) {
  std::vector<std::vector<std::int32_t>> nbr(mesh.vertex_count());
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      nbr[a].push_back(b);
      nbr[b].push_back(a);
    }
  return nbr;
}

// Newton steps onto the zero set of the garment's distance (numerical gradient).
Eigen::Vector3d project(const GarmentShape& g, Eigen::Vector3d p, int steps) {
  for (int k = 0; k < steps; ++k) {
    const double d = g.distance(p);
    if (std::abs(d) < 1e-6) break;
    const Eigen::Vector3d n = g.gradient(p);
    const double n2 = n.squaredNorm();
    if (n2 < 1e-8) break;
    p -= d * n / n2;
  }
  return p;
}

// Closes the holes beyond a garment's `openings` with a fan around each hole's centroid: the
// smallest first, and only holes of at most a fifth of the median hole's vertices (at least 8).
// Such holes are cut-outs, not openings: under a wide A-pose arm (a tee in XL) the plane that
// cuts the short sleeve's cuff crosses the torso's side in a few small patches. A mesh with no
// more holes than openings, or with per-face attributes, is returned unchanged.
void fill_extra_holes(Mesh& mesh, std::size_t openings) {
  if (!mesh.face_labels.empty() || !mesh.uv_triangles.empty() || !mesh.normal_triangles.empty())
    return; // clip output has none
  // The common case, no extra hole, costs one topology pass; the loops are walked only past it.
  if (analyse_topology(mesh.triangle_view(), mesh.vertex_count()).boundary_loops <= openings) return;
  std::map<std::pair<std::int32_t, std::int32_t>, int> uses;
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  // Directed boundary edges a -> b as the faces run; a hole is walked by following them.
  std::map<std::int32_t, std::int32_t> next;
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      if (uses[{std::min(a, b), std::max(a, b)}] == 1) next[a] = b;
    }
  std::vector<std::vector<std::int32_t>> loops;
  std::set<std::int32_t> seen;
  for (const auto& [start, unused] : next) {
    if (seen.count(start)) continue;
    std::vector<std::int32_t> loop;
    for (std::int32_t v = start; !seen.count(v) && next.count(v); v = next[v]) {
      seen.insert(v);
      loop.push_back(v);
    }
    loops.push_back(std::move(loop));
  }
  if (loops.size() <= openings) return;
  std::sort(loops.begin(), loops.end(), [](const auto& a, const auto& b) { return a.size() < b.size(); });
  const std::size_t small = std::max<std::size_t>(8, loops[loops.size() / 2].size() / 5);
  for (std::size_t i = 0; i + openings < loops.size() && loops[i].size() <= small; ++i) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::int32_t v : loops[i])
      c += Eigen::Vector3d(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
    c /= double(loops[i].size());
    const auto centre = std::int32_t(mesh.vertex_count());
    for (int k = 0; k < 3; ++k)
      mesh.positions.push_back(static_cast<float>(c[k]));
    // The faces run a -> b along the hole; the fan runs b -> a to continue their orientation.
    for (std::size_t j = 0; j < loops[i].size(); ++j) {
      const std::int32_t a = loops[i][j], b = loops[i][(j + 1) % loops[i].size()];
      mesh.triangles.insert(mesh.triangles.end(), {b, a, centre});
    }
  }
}

// Tangential relaxation of interior vertices; boundary vertices (the cut openings) stay put.
void relax(const GarmentShape& g, Mesh& mesh, int iterations) {
  const auto nbr = one_rings(mesh);
  // Boundary vertices: those on an edge used by one face.
  std::vector<char> boundary(mesh.vertex_count(), 0);
  {
    std::vector<std::pair<std::uint64_t, int>> edges;
    for (std::size_t f = 0; f < mesh.face_count(); ++f)
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
        edges.push_back({(std::uint64_t(std::min(a, b)) << 32) | std::max(a, b), 0});
      }
    std::sort(edges.begin(), edges.end());
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i;
      while (j < edges.size() && edges[j].first == edges[i].first)
        ++j;
      if (j - i == 1) {
        boundary[edges[i].first >> 32] = 1;
        boundary[edges[i].first & 0xffffffffu] = 1;
      }
      i = j;
    }
  }
  std::vector<float> next(mesh.positions.size());
  for (int it = 0; it < iterations; ++it) {
    parallel_for_range(mesh.vertex_count(), 512, [&](std::size_t b, std::size_t e) {
      for (std::size_t v = b; v < e; ++v) {
        const Eigen::Vector3d p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
        Eigen::Vector3d q = p;
        if (!boundary[v] && !nbr[v].empty()) {
          Eigen::Vector3d c = Eigen::Vector3d::Zero();
          for (std::int32_t u : nbr[v])
            c += Eigen::Vector3d(mesh.positions[3 * u], mesh.positions[3 * u + 1], mesh.positions[3 * u + 2]);
          c /= double(nbr[v].size());
          Eigen::Vector3d n = g.gradient(p);
          if (n.squaredNorm() > 0) n.normalize();
          Eigen::Vector3d d = c - p;
          d -= d.dot(n) * n;
          q = project(g, p + 0.5 * d, 3);
        }
        for (int k = 0; k < 3; ++k)
          next[3 * v + k] = static_cast<float>(q[k]);
      }
    });
    mesh.positions.swap(next);
  }
}

} // namespace

std::size_t expected_openings(GarmentType type) {
  switch (type) {
  case GarmentType::TEE:
  case GarmentType::LONG_SLEEVE:
  case GarmentType::DRESS: return 4;
  case GarmentType::TROUSERS:
  case GarmentType::SHORTS: return 3;
  case GarmentType::SKIRT: return 2;
  }
  return 0;
}

Garment make_garment(const GarmentOptions& options) {
  if (options.target_vertices < MIN_VERTICES || options.target_vertices > MAX_VERTICES)
    throw Error("garment", 0,
                "target vertex count " + std::to_string(options.target_vertices) + " is outside [" +
                    std::to_string(MIN_VERTICES) + ", " + std::to_string(MAX_VERTICES) + "]");
  const Ease ease = options.ease ? *options.ease : size_ease(options.size);
  const GarmentShape shape(options.type, options.body, ease, options.pose);

  // The grid is sized by a trial: a coarse garment gives the vertex count per unit of 1/h²,
  // then the final grid aims at 1.15× the target so decimation only trims (it is the slow
  // step), never coarser than a size that keeps cuffs and straps several cells wide.
  const double s = options.body.height / 1.70;
  auto build = [&](double cell) {
    const auto [lo, hi] = shape.bounding_box(3 * cell);
    IsosurfaceOptions iso;
    iso.box_min = {lo.x(), lo.y(), lo.z()};
    iso.box_max = {hi.x(), hi.y(), hi.z()};
    iso.cell_size = cell;
    Mesh closed = extract_isosurface([&](double x, double y, double z) { return shape.distance({x, y, z}); }, iso);
    Mesh kept = largest_component(clip_mesh(
        closed,
        [&](double x, double y, double z) {
          return shape.keep({x, y, z});
        },
        0.35 * cell));
    fill_extra_holes(kept, expected_openings(options.type));
    return kept;
  };
  const double max_cell = 0.016 * s, min_cell = 0.0015;
  const double trial_cell = max_cell;
  const Mesh trial = build(trial_cell);
  double cell =
      std::clamp(trial_cell * std::sqrt(double(trial.vertex_count()) / (1.15 * double(options.target_vertices))),
                 min_cell, max_cell);
  Mesh mesh = cell == trial_cell ? trial : build(cell);
  if (mesh.vertex_count() < options.target_vertices && cell > min_cell) {
    cell = std::max(min_cell, cell * std::sqrt(double(mesh.vertex_count()) / (1.25 * double(options.target_vertices))));
    mesh = build(cell);
  }
  while (mesh.vertex_count() < options.target_vertices) {
    mesh = subdivide_midpoints(mesh);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      const Eigen::Vector3d q =
          project(shape, {mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]}, 3);
      // Points on the openings stay on the cut: only move those well inside the kept region.
      if (shape.keep(q) > 0.5 * cell)
        for (int k = 0; k < 3; ++k)
          mesh.positions[3 * v + k] = static_cast<float>(q[k]);
    }
  }
  mesh = decimate_to_vertex_count(mesh, options.target_vertices, true);
  relax(shape, mesh, 3);
  parallel_for_range(mesh.vertex_count(), 512, [&](std::size_t b, std::size_t e) {
    for (std::size_t v = b; v < e; ++v) {
      const Eigen::Vector3d q =
          shape.clear_of_body({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]});
      for (int k = 0; k < 3; ++k)
        mesh.positions[3 * v + k] = static_cast<float>(q[k]);
    }
  });

  const TopologyReport t = analyse_topology(mesh.triangle_view(), mesh.vertex_count());
  if (!t.manifold() || t.components != 1 || t.boundary_loops != expected_openings(options.type))
    throw std::runtime_error("garment generation produced " + std::to_string(t.components) + " components, " +
                             std::to_string(t.boundary_loops) + " openings" + (t.manifold() ? "" : ", non-manifold") +
                             " for a " + garment_type_name(options.type));

  Garment g;
  g.type = options.type;
  g.size = options.ease ? "custom" : options.size;
  g.ease = ease;
  g.pose = options.pose;
  g.vertex_parts.resize(mesh.vertex_count());
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    g.vertex_parts[v] = shape.part_of({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]});
  g.mesh = std::move(mesh);
  shape.assign_uvs_and_face_labels(g);
  return g;
}

} // namespace vfit
