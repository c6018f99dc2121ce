// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Curve skeletons of watertight meshes by mesh contraction (seed 000 §5.1, after Tagliasacchi
/// et al. 2012 "Mean curvature skeletons" and Au et al. 2008 "Skeleton extraction by mesh
/// contraction"): the surface is contracted by implicit Laplacian flow until it has almost no
/// area, the contracted mesh is collapsed edge by edge into a graph, and the graph's longest
/// path becomes a chain of nodes, each at the centre of the original vertices it took in
/// (seed 000 eq. 12: every vertex belongs to exactly one node).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// The Laplacian of the contraction's smoothness rows.
enum class ContractionLaplacian {
  /// Graph Laplacian: the system [w_L·L; w_H·I] never changes, so AᵀA is factored once and
  /// each iteration is two triangular solves (refactored only if the flow stalls). Blind to
  /// geometry, it flattens cross-sections and bends alike; the skeleton does not care, since
  /// nodes are recentred on their original vertices.
  UNIFORM,
  /// Cotangent Laplacian at the current (contracted) positions, rebuilt and refactored every
  /// iteration, with w_L growing by `cotangent_growth` per iteration (Au et al. 2008 §4):
  /// closer to mean curvature flow, several times slower.
  COTANGENT,
};

/// Weights and stopping rule of the contraction min ‖w_L·L·x‖² + ‖w_H·(x − x_prev)‖² per
/// iteration (per coordinate; L and w_L are dimensionless, positions keep the mesh's units).
struct ContractionOptions {
  ContractionLaplacian laplacian = ContractionLaplacian::UNIFORM;
  /// UNIFORM: w_L at the first iteration. 16: an 800-vertex proxy of a sleeve or leg reaches
  /// area_ratio in 3–5 solves of one factorisation (2 took 13–17 solves and 2–3
  /// factorisations, for skeletons as centred).
  double contraction_weight = 16.0;
  /// COTANGENT: w_L at the first iteration (the weights follow the surface, so the flow is
  /// faster per step and a large first step overshoots the axis).
  double cotangent_weight = 2.0;
  double attraction_weight = 1.0; ///< w_H: ties each iteration to the previous positions
  double area_ratio = 0.01;       ///< stop once the surface area is below this share of the original
  int max_iterations = 40;        ///< and in any case after this many solves
  /// UNIFORM: solves per factorisation before w_L is multiplied by 4 and AᵀA refactored
  /// (the flow is too slow for this mesh's resolution).
  int iterations_per_factor = 8;
  double cotangent_growth = 2.0; ///< COTANGENT: w_L multiplier per iteration (Au et al.: s_L)
};

/// What the contraction did.
struct ContractionStats {
  int iterations = 0;          ///< solves
  int factorisations = 0;      ///< AᵀA factorisations
  double final_area_ratio = 1; ///< contracted area / original area
};

/// Contracts a closed mesh (#V × 3 positions, #F × 3 triangles): returns #V × 3 contracted
/// positions (same units). Each iteration solves min ‖w_L·L x‖² + w_H²‖x − x_prev‖² through
/// kernels/least_squares.h (seed 000 §5.1; Tagliasacchi et al. 2012 eq. 2 without the medial
/// attraction term, whose job, centredness, the recentring of the nodes does). An open mesh
/// contracts too, but its boundary drifts (no caps): fill holes first. Stops when the area is
/// below `area_ratio` of the original or after `max_iterations`. Throws vfit::Error for an
/// empty mesh or a bad index.
Eigen::MatrixXd contract_mesh(const Mesh& closed_mesh, const ContractionOptions& options = {},
                              ContractionStats* stats = nullptr);

/// Options of extract_curve_skeleton().
struct CurveSkeletonOptions {
  /// A mesh with more vertices is first simplified to about this many (skeleton_proxy.h) and
  /// skeletonised on that proxy; each input vertex then takes its proxy vertex's node. 0: never.
  std::size_t proxy_vertices = 800;
  ContractionOptions contraction;
};

/// Wall-clock time per stage of extract_curve_skeleton() (ms).
struct CurveSkeletonTimings {
  double proxy_ms = 0;       ///< simplify_for_skeleton()
  double contraction_ms = 0; ///< contract_mesh() on the proxy
  double graph_ms = 0;       ///< collapse into a graph, longest path, proxy vertices onto the chain
  double chain_ms = 0;       ///< nodes recentred on the input vertices, slabs re-cut
};

/// A curve skeleton as one chain of nodes.
struct CurveSkeleton {
  std::vector<Eigen::Vector3d> nodes;    ///< #N, in order from one end of the chain to the other (mesh units)
  std::vector<std::int32_t> vertex_node; ///< #original vertices: the node each belongs to, in [0, #N)
  std::size_t proxy_vertices = 0;        ///< vertices the contraction ran on (the proxy, or the whole mesh)
  std::size_t graph_nodes = 0;           ///< nodes of the collapsed graph (≥ #N: branches fold into the chain)
  ContractionStats contraction;
  CurveSkeletonTimings timings;
};

/// The curve skeleton of a watertight mesh whose first `original_vertices` vertices are the
/// ones that count (the rest: hole-filling caps, see hole_fill.h): simplify_for_skeleton() to
/// `proxy_vertices` when larger, contract_mesh(), then
/// collapse the shortest edge that still bounds a triangle until no triangle is left (Au et
/// al. 2008 §5; each graph node owns the vertices merged into it), then the longest path of the
/// graph's minimum spanning tree (edge lengths between the nodes' mean rest positions) is the
/// chain and every other graph node joins the chain node nearest along the graph. Chain nodes
/// that own no original vertex (cap tips) are dropped; each node is placed at the centroid of
/// its original vertices (seed 000 eq. 12: disjoint vertex sets). Through a proxy, whose
/// clusters make ragged node borders, the nodes are then re-cut as slabs across a smoothed
/// chain (three sweeps). Finally each node moves to its cross-section's centre
/// (cross_section_centres()). Centredness on tubes: exact at full resolution (nodes are whole
/// rings); through a proxy within 0.06 of the radius (plain centroids of the ragged slabs: up
/// to 0.17 near the ends and where a slab border crosses a ring). Which end comes first is
/// unspecified; orient_chain() fixes it. Throws vfit::Error when `original_vertices` is 0 or
/// exceeds the mesh.
CurveSkeleton extract_curve_skeleton(const Mesh& closed_mesh, std::size_t original_vertices,
                                     const CurveSkeletonOptions& options = {});

/// The centre of each node's cross-section (seed 000 eq. 12's node, made insensitive to how the
/// vertices are spread around the limb): the node's vertices, sorted by angle about the chain's
/// local direction (nodes[n+1] − nodes[n−1], one-sided at the ends) through their centroid, each
/// weigh half the angle between their angular neighbours (at most twice the mean spacing), and
/// the node is their weighted mean, twice (the second time about the first result): the
/// centroid of the cross-section curve by trapezoidal quadrature over the angle, which angles
/// about an off-centre point skew, so the second round removes most of the first's offset. A plain centroid is pulled
/// towards the side where the node's slab is thicker or its mesh denser: through a proxy, whose clusters leave ragged
/// slab borders, by up to 0.2 of the radius on a tube. A node with fewer than 3 vertices, or whose vertices leave an
/// angular gap wider than 90° (a sliver, a cap-like end) or span more along the axis than their mean distance from it
/// (an end cut slantwise, like a trouser leg's top at the crotch), keeps its entry. positions: #P × 3 (mesh units);
/// vertices: ids into positions; vertex_node: per entry of `vertices`, its node in [0, #N); nodes: #N current centres
/// in chain order (their centroids do). Returns #N centres.
std::vector<Eigen::Vector3d> cross_section_centres(std::span<const float> positions,
                                                   std::span<const std::int32_t> vertices,
                                                   std::span<const std::int32_t> vertex_node,
                                                   const std::vector<Eigen::Vector3d>& nodes);

/// Reverses the chain (nodes and vertex_node) when its last node is nearer to `start` than its
/// first, so that it runs from the end near `start`.
void orient_chain(CurveSkeleton& skeleton, const Eigen::Vector3d& start);

} // namespace vfit
