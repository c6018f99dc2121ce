// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/trim.h"

#include <algorithm>
#include <cmath>

#include "vfit/geometry/mesh/topology.h"
#include "vfit/kernels/proximity.h"

namespace vfit::fitting {

TrimPieces trim_pieces(const Mesh& mesh) {
  TrimPieces out;
  const std::size_t nv = mesh.vertex_count();
  const std::vector<std::int32_t> piece = vertex_piece_labels(mesh.triangles, nv);
  std::vector<std::size_t> size(nv, 0);
  std::vector<char> used(nv, 0);
  for (std::int32_t v : mesh.triangles)
    used[static_cast<std::size_t>(v)] = 1;
  for (std::size_t v = 0; v < nv; ++v)
    if (used[v]) ++size[static_cast<std::size_t>(piece[v])];
  const auto main = static_cast<std::int32_t>(std::max_element(size.begin(), size.end()) - size.begin());
  for (std::size_t v = 0; v < nv; ++v)
    if (used[v] && piece[v] != main) out.vertices.push_back(static_cast<std::int32_t>(v));
  if (out.vertices.empty()) return out;
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    if (piece[static_cast<std::size_t>(mesh.triangles[3 * f])] == main)
      out.main_triangles.insert(out.main_triangles.end(), mesh.triangles.begin() + std::ptrdiff_t(3 * f),
                                mesh.triangles.begin() + std::ptrdiff_t(3 * f + 3));
  return out;
}

void carry_trim(const TrimPieces& trim, std::span<const float> before, std::span<float> positions) {
  if (trim.vertices.empty() || trim.main_triangles.empty()) return;
  const ProximityIndex main(before, trim.main_triangles, OpenMeshSide::ONE_SIDED);
  std::vector<float> queries;
  queries.reserve(3 * trim.vertices.size());
  for (std::int32_t v : trim.vertices)
    queries.insert(queries.end(), before.begin() + 3 * v, before.begin() + 3 * v + 3);
  ClosestHits hits;
  main.closest_points(queries, INFINITY, hits);
  for (std::size_t k = 0; k < trim.vertices.size(); ++k) {
    const std::int32_t t = hits.triangles[k];
    if (t < 0) continue;
    const float u = hits.barycentrics[2 * k], w = hits.barycentrics[2 * k + 1];
    const float weight[3] = {1 - u - w, u, w};
    const auto v = static_cast<std::size_t>(trim.vertices[k]);
    for (int c = 0; c < 3; ++c) {
      float shift = 0;
      for (int corner = 0; corner < 3; ++corner) {
        const auto m =
            static_cast<std::size_t>(trim.main_triangles[3 * static_cast<std::size_t>(t) + std::size_t(corner)]);
        shift += weight[corner] * (positions[3 * m + std::size_t(c)] - before[3 * m + std::size_t(c)]);
      }
      positions[3 * v + std::size_t(c)] = before[3 * v + std::size_t(c)] + shift;
    }
  }
}

} // namespace vfit::fitting
