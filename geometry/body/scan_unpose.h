#pragma once
/// \file
/// Internal to fit_scan() (scan_fit.h), stage 5: a posed scan moved back into a rest pose by
/// inverse linear blend skinning, so that the joint estimator (joint_estimation.h), which needs
/// an A- or T-pose, can read its joints. Not part of the public API.

#include <array>

#include <Eigen/Geometry>

#include "geometry/mesh/mesh.h"
#include "skeleton.h"

namespace vfit::scan_detail {

/// `scan` with each vertex v moved by the inverse of its blended transform Σ_k w_vk A[j_vk]
/// (A[j]: bone j's transform from the rest pose into the scan), i.e. inverse LBS with the
/// scan's own weights `w` (4 influences per vertex). Where that tears the surface (a vertex
/// most of whose edges come out more than twice their posed length plus 1 cm: a fingertip with
/// another part's weights), the torn vertices are moved as their intact neighbours moved,
/// ring by ring. Vertices whose blended transform is singular come out non-finite; the
/// weights of a fitted template never blend to a singular one in practice.
Mesh unpose_scan(const Mesh& scan, const SkinWeights& w, const std::array<Eigen::Isometry3d, JOINT_COUNT>& A);

} // namespace vfit::scan_detail
