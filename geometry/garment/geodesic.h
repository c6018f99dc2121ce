// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Geodesic distance on a garment's edge graph, the Morse function of seed 000 §4.1.

#include <cstdint>
#include <vector>

#include "surface_graph.h"

namespace vfit {

/// A source of the distance field: a vertex and the distance it starts with (mesh units).
struct GeodesicSeed {
  std::int32_t vertex;
  double distance;
};

/// Shortest-path distance along edges from the seeds (Dijkstra, O(E log V)): an upper bound on
/// the geodesic distance that overestimates it by a few percent on irregular triangulations,
/// which is immaterial for level sets. #V values in mesh units; +∞ for vertices that no seed
/// reaches (other components, unreferenced vertices). With `stop` ≥ 0 the search ends once
/// that vertex is settled: values below its distance are exact, larger ones are upper bounds
/// or +∞.
std::vector<double> geodesic_distance(const SurfaceGraph& graph, const std::vector<GeodesicSeed>& seeds,
                                      std::int32_t stop = -1);

} // namespace vfit
