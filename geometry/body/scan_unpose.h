// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Internal to fit_scan() (scan_fit.h), stage 5: a posed scan moved back into a rest pose by
/// inverse linear blend skinning, so that the joint estimator (joint_estimation.h), which needs
/// an A- or T-pose, can read its joints. Not part of the public API.

#include <array>
#include <vector>

#include <Eigen/Geometry>

#include "skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit::scan_detail {

/// `scan` with each vertex v moved by the inverse of its blended transform Σ_k w_vk A[j_vk]
/// (A[j]: bone j's transform from the rest pose into the scan), i.e. inverse LBS with the
/// scan's own weights `w` (4 influences per vertex). Where that tears the surface (a vertex
/// most of whose edges come out more than twice their posed length plus 1 cm: a fingertip with
/// another part's weights), the torn vertices are moved as their intact neighbours moved,
/// ring by ring. Vertices whose blended transform is singular come out non-finite; the
/// weights of a fitted template never blend to a singular one in practice.
Mesh unpose_scan(const Mesh& scan, const SkinWeights& w, const std::array<Eigen::Isometry3d, JOINT_COUNT>& A);

/// The joints that start a limb: each joint whose skin chain (skin_chain_of_joint(),
/// scan_skin_transfer.h) differs from its parent's, i.e. the shoulders and the hips.
std::vector<int> limb_roots();

/// Moves the pivot of the limb that starts at joint `root` (a limb_roots() entry) to `pivot`
/// (m, rest-pose coordinates): every transform A[k] of the root's chain is translated, as one
/// rigid piece, by A[parent]·pivot − A[root]·pivot, so that afterwards the root bone and its
/// parent carry `pivot` to the same point. The limb's rotations, and the transforms of all other
/// bones, are kept. A limb turned about a pivot other than the body's own joint (the template's
/// shoulder a few cm off the scan's) slides against its parent when unposed: the seam between
/// them stretches (seam_stretch()). Throws vfit::Error for a joint that is no limb root.
void move_limb_pivot(std::array<Eigen::Isometry3d, JOINT_COUNT>& A, int root, const Eigen::Vector3d& pivot);

/// How much unposing `posed` with weights `w` and transforms `A` (as unpose_scan(), without its
/// mending of torn vertices) stretches the seam of skin chain `chain` (1–4: an arm or a leg):
/// the sum over `posed`'s triangle edges with an end on the seam of |unposed length − posed
/// length| (m; each interior edge counted twice, once per triangle). A seam vertex has weights
/// both on the chain and on another one; only the seam's edges are unposed, so this costs a few
/// hundred vertices, not the scan. A rigid move of the whole body gives 0 up to rounding.
/// Unposing with the transforms the skin was posed with leaves the blend's own distortion
/// (linear blend skinning is not rigid where weights mix); a limb pivot off the joint adds its
/// slide against the parent to that, so of two unposings the one with the truer pivot stretches
/// the seam less (a proxy, not a bound). 0 for a chain with no seam.
double seam_stretch(const Mesh& posed, const SkinWeights& w, const std::array<Eigen::Isometry3d, JOINT_COUNT>& A,
                    int chain);

} // namespace vfit::scan_detail
