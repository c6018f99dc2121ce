// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The dressing room's solver objects: penetration removal and layering (seed 000 §6.2,
/// eq. 18–21; seed 001 §6.3, eq. 7) with their state built once and reused.
///
/// DressingBody is one body, indexed once (proximity and edge-crossing indices), with the
/// garments already dressed on it as inner layers (add_layer()). Dresser is one garment on a
/// DressingBody: it owns the garment's Laplacian and edge table (built once, valid for any
/// positions of the garment's triangles) and holds the clean-up policy of a fit: remove()
/// before the cloth simulation, after_simulation() after it. Each removal factors the systems
/// of its own regions (they grow around that call's pushes).

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vfit/engine/dress/layering.h"
#include "vfit/engine/dress/penetration_types.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/kernels/edge_crossings.h"
#include "vfit/kernels/proximity.h"

namespace vfit {

namespace dress {
struct GarmentTopology;
}

/// A body to dress, indexed once, and the garments dressed on it so far (inner first).
class DressingBody {
public:
  /// body: a closed, outward-oriented mesh (m), which must outlive this object. layer_clearance:
  /// k of seed 001 eq. 7 (m, ≥ 0), the gap each later garment keeps outside an inner one;
  /// layer_reach (m, > 0): how far a layer point may be from a garment vertex and still count
  /// (LayerObstacle::reach). Throws vfit::Error for a body the indices refuse (non-finite
  /// coordinates, indices out of range). O(#F log #F).
  DressingBody(const Mesh& body, double layer_clearance, double layer_reach);

  const Mesh& mesh() const { return m_body; }
  const ProximityIndex& index() const { return m_index; }
  const EdgeCrossingIndex& crossings() const { return m_crossings; }
  /// The inner layers, innermost first (empty before the first add_layer()).
  std::span<const LayerObstacle> layers() const { return m_layers; }

  /// Adds a dressed garment (m, resolved against the body) as the next inner layer: later
  /// garments are kept outside of it. Invalidates the Dressers built before the call.
  void add_layer(const Mesh& garment);

  /// The surface a simulated garment collides with: the body and every inner layer, each closed
  /// by a fan over every opening (waistband, hems, cuffs: hole_caps.h) so the union is a set of
  /// closed surfaces whose side test and contact cache stay exact. The caps lie across the body
  /// (a waistband's across the waist), inside it or within the clearance of its surface, where
  /// an outer garment never is. positions: #V × 3 (m), triangles #F × 3, both replaced.
  void collision_surface(std::vector<float>& positions, std::vector<std::int32_t>& triangles) const;

private:
  const Mesh& m_body;
  ProximityIndex m_index;
  EdgeCrossingIndex m_crossings;
  std::deque<InnerLayer> m_inner; // stable addresses: m_layers views them
  std::vector<LayerObstacle> m_layers;
  double m_layer_clearance, m_layer_reach;
};

/// The clean-up policy of a fit around its cloth simulation.
struct DressOptions {
  PenetrationOptions removal; ///< each removal's options (κ, smoothness, rounds)
  double clearance = 0.003;   ///< κ (m) for near_count when measuring
  /// After the simulation, a vertex deeper than this (m), any edge through the body, any vertex
  /// inside an inner layer or any of a layer's edges through the garment calls for removal
  /// again: the cloth's contacts keep particles at the contact thickness, so anything deeper is
  /// a missed contact, and a contact keeps particles off a surface, not the edges between them.
  double settled_tolerance = 0.0005;
  /// Removals at most after the simulation: a removal ends after stall_rounds without progress
  /// and another, from its best state, starts afresh around what is left; repeated while the
  /// garment still offends the body or its inner layers and the last removal reduced that.
  int settled_removals = 3;
};

/// What after_simulation() found and did.
struct SettledReport {
  PenetrationStats simulated; ///< the garment as the simulation left it
  bool cleaned = false;       ///< removal ran again on the simulated garment
  bool discarded = false;     ///< the simulated shape was replaced by the one before the simulation
  PenetrationStats after;     ///< of the garment as returned
  std::string warning;        ///< why the simulated shape was discarded, "" when it was not
};

/// Penetration removal and measurement of one garment on a DressingBody (its current inner
/// layers). The garment passed to remove(), measure() and after_simulation() must have the
/// triangles of the one this was built for (any positions).
class Dresser {
public:
  /// garment: the garment's mesh (m); its triangles fix the topology. body must outlive this
  /// object and must not get a new layer while it is used. O(#V + #F).
  Dresser(const DressingBody& body, const Mesh& garment, const DressOptions& options);
  ~Dresser();
  Dresser(Dresser&&) noexcept;
  Dresser& operator=(Dresser&&) = delete;
  Dresser(const Dresser&) = delete;
  Dresser& operator=(const Dresser&) = delete;

  /// Removes penetration of the body and the inner layers in place (remove_penetration() with
  /// crossings and layers; penetration.h states the method). Returns before/after statistics.
  PenetrationReport remove(Mesh& garment) const;
  /// Where the garment stands: vertices inside the body and the layers, edges crossing the body,
  /// layer edges through the garment (measure_penetration() with crossings and layers).
  PenetrationStats measure(const Mesh& garment) const;
  /// The policy after the cloth simulation. `before_simulation` (#V × 3, m): the positions before
  /// it, or empty when the simulation did not run or its result was discarded: then the garment
  /// is only measured. Otherwise the simulated garment is measured; when it offends (see
  /// DressOptions::settled_tolerance) removal runs again, up to settled_removals times while it
  /// gains; when the cleaned garment is deeper in the body than max(settled_tolerance,
  /// after_removal.max_depth) or offends its inner layers more than after_removal did (vertices
  /// inside them and their edges through it, counted together), the simulated shape is worse
  /// than none and the garment gets `before_simulation` back (SettledReport::discarded).
  SettledReport after_simulation(Mesh& garment, std::span<const float> before_simulation,
                                 const PenetrationStats& after_removal) const;

private:
  const DressingBody& m_body;
  DressOptions m_options;
  std::span<const LayerObstacle> m_layers;
  std::unique_ptr<dress::GarmentTopology> m_topology;
};

} // namespace vfit
