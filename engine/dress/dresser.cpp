// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/dress/dresser.h"

#include <algorithm>
#include <cstdio>

#include "vfit/engine/dress/removal.h"
#include "vfit/kernels/hole_caps.h"

namespace vfit {

DressingBody::DressingBody(const Mesh& body, double layer_clearance, double layer_reach)
    : m_body(body), m_index(body.positions, body.triangles), m_crossings(body.positions, body.triangles),
      m_layer_clearance(layer_clearance), m_layer_reach(layer_reach) {}

void DressingBody::add_layer(const Mesh& garment) {
  m_inner.emplace_back(garment, m_index, m_layer_clearance, m_layer_reach);
  m_layers.push_back(m_inner.back().obstacle());
}

void DressingBody::collision_surface(std::vector<float>& positions, std::vector<std::int32_t>& triangles) const {
  positions = m_body.positions;
  triangles = m_body.triangles;
  std::vector<float> capped;
  for (const LayerObstacle& layer : m_layers) {
    const std::size_t nv = layer.points.size() / 3;
    const HoleCaps caps = build_hole_caps(layer.triangles, nv);
    capped_positions(layer.points, caps, capped);
    const auto offset = static_cast<std::int32_t>(positions.size() / 3);
    positions.insert(positions.end(), capped.begin(), capped.end());
    for (const std::int32_t v : layer.triangles)
      triangles.push_back(v + offset);
    for (const std::int32_t v : caps.triangles)
      triangles.push_back(v + offset);
  }
}

Dresser::Dresser(const DressingBody& body, const Mesh& garment, const DressOptions& options)
    : m_body(body), m_options(options), m_layers(body.layers()),
      m_topology(std::make_unique<dress::GarmentTopology>(garment)) {}

Dresser::~Dresser() = default;
Dresser::Dresser(Dresser&&) noexcept = default;

PenetrationReport Dresser::remove(Mesh& garment) const {
  return dress::remove(garment, m_body.index(), &m_body.crossings(), m_layers, m_options.removal, m_topology.get());
}

PenetrationStats Dresser::measure(const Mesh& garment) const {
  return dress::measure(garment, m_body.index(), m_body.crossings(), m_layers, m_options.clearance, m_topology.get());
}

SettledReport Dresser::after_simulation(Mesh& garment, std::span<const float> before_simulation,
                                        const PenetrationStats& after_removal) const {
  SettledReport out;
  if (before_simulation.empty()) {
    out.after = measure(garment);
    return out;
  }
  const double tolerance = m_options.settled_tolerance;
  const auto offences = [](const PenetrationStats& st) {
    return st.inside_count + st.crossing_edges + st.layer_inside_count + st.layer_crossing_edges;
  };
  const auto layer_offences = [](const PenetrationStats& st) {
    return st.layer_inside_count + st.layer_crossing_edges;
  };
  out.simulated = measure(garment);
  out.after = out.simulated;
  const PenetrationStats& s = out.simulated;
  if (!(s.max_depth > tolerance || s.crossing_edges > 0 || s.layer_inside_count > 0 || s.layer_crossing_edges > 0))
    return out;
  out.cleaned = true;
  // A removal ends after stall_rounds without progress; another, from its best state, starts
  // afresh (a new region around what is left): repeated while the garment still offends and
  // the last removal reduced that. The knee-bent corpus overalls end their simulation with tens
  // of edges through the body that one removal may leave one of and a second clears; the
  // inner layers count too (a long-sleeve shirt over its trousers ended one removal with a
  // vertex inside them).
  PenetrationStats cleaned = remove(garment).after;
  for (int call = 1; call < m_options.settled_removals; ++call) {
    if (offences(cleaned) == 0 && cleaned.max_depth <= tolerance) break;
    const PenetrationStats again = remove(garment).after;
    const bool better = offences(again) < offences(cleaned) || again.max_depth < cleaned.max_depth;
    cleaned = again;
    if (!better) break;
  }
  // A settled garment that removal cannot bring back outside the body (cloth drawn into a fold
  // between limb and torso), or that ends with more offences against the inner layers (a few
  // more vertices inside but far fewer edges through is the better fit), is worse than no
  // simulation: the garment as removal left it before the simulation is returned, and why.
  cleaned = measure(garment);
  out.after = cleaned;
  if (cleaned.max_depth > std::max(tolerance, after_removal.max_depth) ||
      layer_offences(cleaned) > layer_offences(after_removal)) {
    std::copy(before_simulation.begin(), before_simulation.end(), garment.positions.begin());
    out.discarded = true;
    char line[320];
    std::snprintf(line, sizeof line,
                  "the simulated garment, cleaned up, was worse than before the simulation (%.1f mm inside "
                  "the body, %zu vertices inside inner layers, %zu of their edges through it; before: %.1f mm, "
                  "%zu, %zu): the mesh after penetration removal is kept",
                  1e3 * cleaned.max_depth, cleaned.layer_inside_count, cleaned.layer_crossing_edges,
                  1e3 * after_removal.max_depth, after_removal.layer_inside_count, after_removal.layer_crossing_edges);
    out.warning = line;
    out.after = measure(garment);
  }
  return out;
}

} // namespace vfit
