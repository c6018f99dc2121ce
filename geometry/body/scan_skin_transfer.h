// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Skin weights carried from a posed template body onto a scan in the same pose (seed 001
/// §5.2: "each scan vertex takes the weights of its closest template point"), made safe where
/// the scan's parts touch: an arm held against the torso, hands folded in front of the belly.
/// Conventions: metres, Y up, the body facing +Z, +X = the body's left.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "body.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// The body part ("chain") a canonical joint belongs to: 0 the trunk (pelvis, spine, neck,
/// head, collars), 1 the left arm, 2 the right arm (shoulder to hand), 3 the left leg, 4 the
/// right leg (hip to foot).
int skin_chain_of_joint(int joint);

/// Skin weights of `target`'s vertices from `source` (a posed body whose vertices carry
/// `source_weights`), `target` lying on `source` within a few cm. Each target vertex is first
/// matched to the closest point of each chain of `source` (the triangles whose dominant joint
/// is in that chain); a chain is a candidate when that point is within 2.5 × `margin` of the
/// closest point of all of `source` and its surface faces the vertex's way (normals agreeing).
/// A vertex is sure of its chain when the best candidate is nearer than every other by
/// `margin` (m); the others take the chain of the nearest sure vertex over `target`'s edges (so
/// a hand resting on the other hand's template keeps its own arm's chain, which its wrist
/// passes on). A chain's vertices that are not connected (over `target`'s edges) to its
/// largest connected piece lose their chain and take a neighbour's the same way: a limb is one
/// piece. The weights are then those at the closest point of the vertex's chain (of all, where
/// that lies on the same chain or the chain has no surface within 15 cm; a chain farther than
/// the closest surface, or as near as another chain pressed into it, still gives them, so a
/// folded hand whose template hand lies a few cm off keeps its own arm's weights), blended
/// barycentrically, the 4 largest kept and renormalised. On `source` itself this returns its
/// weights except within `margin` of a chain border, where a vertex may take the neighbouring
/// chain's border weights. A target without faces (a point cloud) takes the closest point's
/// weights. Returns #target rows. Throws vfit::Error ("skin weight transfer: …") when `source`
/// has no faces or its weights fail validate_skin_weights().
SkinWeights transfer_skin_weights(const Mesh& source, const SkinWeights& source_weights, const Mesh& target,
                                  double margin = 0.02);

/// The weights at a point of a triangle (seed 001 §5.2's barycentric interpolation): the ≤ 12
/// influences of the triangle's corners (vertex ids into `weights`) blended with barycentrics
/// `bary` (summing to 1), and the 4 largest kept, largest first, not renormalised; unused
/// slots get joint 0 and weight 0. Shared by the scan fit and transfer_skin_weights(), which
/// each renormalise in their own precision.
void largest_blended_influences(const SkinWeights& weights, const std::array<std::int32_t, 3>& corners,
                                const std::array<double, 3>& bary, std::array<int, 4>& joint,
                                std::array<double, 4>& weight);

/// Unit area-weighted vertex normals (double precision) of a triangle mesh: positions #V × 3
/// (m), triangles #F × 3 vertex ids; a vertex on no face (or on zero-area faces only) gets zero.
std::vector<Eigen::Vector3d> area_weighted_vertex_normals(std::span<const float> positions,
                                                          std::span<const std::int32_t> triangles);

} // namespace vfit
