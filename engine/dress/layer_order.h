// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Which garment of an outfit is worn under which, read from the garments as they are given
/// (seed 001 §6.3 dresses layers inner to outer; it takes the order from the user). A design
/// tool's export of a look, or an outfit file holding several garments, has them in one frame,
/// already worn: where two garments overlap, the inner one's surface lies inside the outer
/// one's. A type rule (bottoms first) gets the usual tee over trousers right, but not a tee
/// under overalls' bib, a shirt tucked into trousers, or a jacket over a tee (two tops).
///
/// The evidence, per pair of garments A and B: every sampled vertex of A within `reach` of B
/// whose offset from its closest point on B lies along B's face normal there (a vertex facing
/// B's sheet, not one beyond B's hem or cuff) votes "A under B" when it is inside B, "A over
/// B" when outside, and the same for B's vertices against A. Inside is the side of B closed
/// by fan caps over its openings (hole_caps.h, as ProximityIndex decides it), with B turned so
/// that its capped volume is positive (outward normals, whatever the file's winding). A pair
/// whose votes are many and nearly unanimous is a relation; the order keeps every relation and
/// otherwise the caller's default order (a topological sort that takes the earliest garment of
/// the default order whenever several may come next). Relations that contradict one another (a
/// cycle) are all dropped, and the default order kept.

#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Tuning of infer_layer_order().
struct LayerOrderOptions {
  /// A vertex farther than this from the other garment casts no vote (m). Layers worn over each
  /// other lie within a few centimetres where they overlap (a tee under a jacket: 0.5–3 cm);
  /// farther surfaces say nothing about which is inside.
  double reach = 0.04;
  /// A vote needs |n·d| ≥ alignment·|d| for its offset d from the closest point and the face
  /// normal n there (0.8: within ~37° of the normal), so points past an opening's rim, whose
  /// offset runs along the sheet, do not vote.
  double alignment = 0.8;
  /// A pair is a relation when the larger side has at least this share of its votes (0.8: four
  /// votes in five; interpenetrating spots of an authored outfit are a few per cent).
  double majority = 0.8;
  /// ... and at least this many votes (a few stray contacts do not make a layer).
  std::size_t min_votes = 30;
  /// At most this many vertices of each garment's overlapping part are sampled (every k-th), so
  /// the queries stay cheap at 10^6 vertices.
  std::size_t max_samples = 20000;
};

/// The votes of one pair (first, second) of infer_layer_order()'s garments.
struct LayerPairVotes {
  std::size_t first = 0, second = 0; ///< garment indices, first < second
  std::size_t first_under = 0;       ///< votes that `first` is worn under `second`
  std::size_t first_over = 0;        ///< votes that `first` is worn over `second`
};

/// A decided relation: `under` is worn under `over`.
struct LayerRelation {
  std::size_t under = 0, over = 0;
  std::size_t agree = 0, total = 0; ///< the votes for it, of all the pair's votes
};

/// What infer_layer_order() found.
struct LayerOrder {
  std::vector<std::size_t> order;       ///< garment indices, innermost first
  std::vector<LayerPairVotes> votes;    ///< every compared pair's votes
  std::vector<LayerRelation> relations; ///< the decisive pairs (empty when they formed a cycle)
  bool contradictory = false;           ///< the decisive pairs formed a cycle; the default order was kept
};

/// Orders `garments` (each in metres, all in one frame: as given, before any per-garment move;
/// consistently wound, any global winding) inner to outer from their geometry, keeping
/// `default_order` (a permutation of the garment indices) where the geometry says nothing.
/// `comparable(i, j)` (i < j), when given, says whether a pair may be compared at all (e.g.
/// false for garments from two files whose frames need not agree); absent: every pair. A garment
/// without triangles casts and receives no vote. Only the part of each garment within `reach`
/// of the other's bounding box takes part (a tee's hem band against trousers), so the cost per
/// pair is one ProximityIndex over each part and up to max_samples closest-point queries from
/// each, plus one pass over each garment to wind it outward. Throws vfit::Error when
/// default_order is not a permutation of [0, #garments).
LayerOrder infer_layer_order(std::span<const Mesh* const> garments, std::span<const std::size_t> default_order,
                             const std::function<bool(std::size_t, std::size_t)>& comparable = {},
                             const LayerOrderOptions& options = {});

} // namespace vfit
