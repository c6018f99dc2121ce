// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Skeleton-driven garment deformation (seed 000 §5.2–5.4): the garment's torso is turned and
/// moved onto the body's trunk (orientation, eq. 5–7, plus the translation of eq. 16–17), each
/// sleeve and leg skeleton is laid along the body's shoulder→elbow→wrist or hip→knee→ankle
/// bones by arc length (eq. 8–11), the part's vertices follow their node rigidly (eq. 13–15,
/// blended between neighbouring nodes), and a Laplacian surface deformation (Sorkine et al.
/// 2004, laplacian_deformation.h) over the band within seam_radius of the seams joins limbs
/// and torso continuously, the rest held at its rigid positions.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "laplacian_deformation.h"
#include "segment.h"
#include "skeleton_parts.h"
#include "vfit/geometry/body/skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

class ProximityIndex;

struct SkeletonDrivingOptions {
  /// Vertices closer than this to a limb's seam (the ring where a sleeve or leg meets the
  /// torso), in metres, are left free for the Laplacian solve; all others are handles.
  /// Handles are held at their rigid positions exactly (BandLaplacianDeformer), so only the
  /// free band around the seams is solved for.
  double seam_radius = 0.06;
  /// Blend each vertex's rigid transform with the neighbouring node's by its position along
  /// the chain, so that consecutive nodes leave no steps in the sleeve.
  bool blend_nodes = true;
  /// How the free band's Laplacian system is solved (laplacian_deformation.h): AUTO factors
  /// small bands with a simplicial LDLᵀ and large ones (≥ BAND_SUPERNODAL_UNKNOWNS free
  /// vertices, tees from about 90,000 vertices) with CHOLMOD's supernodal Cholesky.
  BandSolver band_solver = BandSolver::AUTO;
};

/// Wall-clock time per stage (ms).
struct SkeletonDrivingTimings {
  double orientation_ms = 0; ///< key joints, torso rotation (eq. 5–7) and translation
  /// The band's Laplacian factorisation, on a driver's first drive() only (0 after): it runs
  /// beside the orientation, so the two overlap in time.
  double factorisation_ms = 0;
  double driving_ms = 0;   ///< node targets (eq. 8–11), node rotations and per-vertex rigid transforms (eq. 13–15)
  double laplacian_ms = 0; ///< rotated differential coordinates and the three per-axis solves
  double setup_ms = 0;     ///< SkeletonDriver construction: key joints, seam distances, handles
  double total_ms = 0;     ///< wall time of all of the above (the factorisation overlapped)
};

/// One sleeve or leg after driving. Each node is placed by its distance from the garment's own
/// shoulder or hip joint along the limb's axis, which for the straight limbs of a garment
/// modelled in T- or A-pose is eq. 8's arc length, but is not thrown off by the wobble of a
/// short, wide sleeve's skeleton.
struct DrivenLimb {
  GarmentPart part = GarmentPart::LEFT_SLEEVE;
  std::vector<Eigen::Vector3d> targets; ///< #N node targets l'_k on the body's bones (m), eq. 11
  std::vector<Eigen::Matrix3d>
      rotations;            ///< #N node rotations Q_k (eq. 13–15): the limb's axis onto its bone, twist-free
  std::vector<int> segment; ///< #N: 0 on the upper bone (shoulder→elbow, hip→knee), 1 on the lower
};

/// Result of driving a garment onto a body.
struct SkeletonDriving {
  std::vector<float> positions;                                 ///< #V × 3 deformed positions (m)
  Eigen::Matrix3d torso_rotation = Eigen::Matrix3d::Identity(); ///< R = R_v R_h of eq. 5–7
  Eigen::Vector3d torso_translation = Eigen::Vector3d::Zero();  ///< after the rotation (eq. 16–17), contact included
  /// The part of torso_translation from contact with the body surface (m): contact_translation()
  /// (coarse_move.h, default ContactMoveOptions) over all the torso's vertices (those of no
  /// sleeve or leg skeleton); zero when drive() was given no body surface. The crotch alignment
  /// and the pocket offset of trousers are not included.
  Eigen::Vector3d contact_translation = Eigen::Vector3d::Zero();
  /// Trousers and shorts with a body surface: the offset along the body's trunk (m, + towards
  /// the neck) after the contact translation, to the height of the most clearance (see
  /// SkeletonDriver::drive()); included in torso_translation; zero otherwise.
  double pocket_offset = 0;
  std::vector<DrivenLimb> limbs; ///< in the skeletons' order
  SkeletonDrivingTimings timings;
  /// The band solve's iterations and residual when it ran iteratively (BandSolver::MULTIGRID,
  /// on request); zeros when it was factored.
  IterativeSolveStats laplacian_solve;
};

/// The garment's key joints and limb axes for orientation and placement (mesh units). For a
/// top, j1 and j2 are the right and left shoulder joints and the axes the upper sleeves' (the
/// sleeve boundary planes' points and normals of §4.2, eq. 1–2). For trousers and shorts they
/// are the right and left hip joints and the legs' axes: each leg's axis is the principal
/// direction through their centroid of its skeleton's nodes (all of them when the two legs'
/// first nodes are mirror images to within half the legs' spacing at the crotch, the wedges
/// above the crotch then reaching out towards the hips; else the tube's only, from
/// PartSkeleton::tube_start on), or, when the nodes span less than
/// the leg's hem is wide (shorts, whose short wide tube has a skeleton that zigzags across it),
/// the normal of the hem (the `garment` boundary vertices labelled with the leg, #V labels in
/// `segmentation`) through its centre, and the hip is the axis's point at a height above the
/// crotch key point proportional to the two tubes' axes' distance apart at the crotch (a body
/// proportion calibrated on the catalogue's mannequin, whatever the garment's rise or its
/// source opening: a waistband, a bib's top). Either pair is then made mirror-symmetric about the garment's mid-plane
/// x = (j1.x + j2.x) / 2 (mean height and depth; each axis the mean of its own and the other
/// side's mirrored), since segment_garment() requires a left/right symmetric garment and the
/// two sides' estimates differ by their noise alone. The garment's vertical is +Y. Throws
/// vfit::Error("skeleton driving", …) when the segmentation lacks the key points or skeletons
/// needed.
struct GarmentKeyJoints {
  Eigen::Vector3d j1 = Eigen::Vector3d::Zero();           ///< right shoulder or hip (−X side)
  Eigen::Vector3d j2 = Eigen::Vector3d::Zero();           ///< left shoulder or hip (+X side)
  Eigen::Vector3d right_axis = -Eigen::Vector3d::UnitX(); ///< unit, from j1 towards the right limb's open end
  Eigen::Vector3d left_axis = Eigen::Vector3d::UnitX();   ///< unit, from j2 towards the left limb's open end
  bool legs = false;                                      ///< true: hips (trousers, shorts); false: shoulders (tops)
  /// legs: the crotch key point (segment.h) in mesh units, like j1 and j2; zero for tops. Used
  /// by SkeletonDriver::drive() with a body surface to meet the body's crotch.
  Eigen::Vector3d crotch = Eigen::Vector3d::Zero();
};
GarmentKeyJoints garment_key_joints(const Mesh& garment, const GarmentSegmentation& segmentation,
                                    std::span<const PartSkeleton> skeletons);

/// Target points of a chain on a bone polyline (seed 000 eq. 8–11): node k, at arc length
/// f_seg(l_1, l_k) from the first node, goes to arc length `offset` + f_seg(l_1, l_k) along
/// `bones` (#B ≥ 2 joints, e.g. shoulder, elbow, wrist), continued along the last bone beyond
/// its end. `segment` (#N) receives the bone index each target lies on. Coincident joints are
/// skipped; a polyline of zero length maps every node to its first joint.
std::vector<Eigen::Vector3d> arc_length_targets(std::span<const Eigen::Vector3d> nodes,
                                                std::span<const Eigen::Vector3d> bones, double offset,
                                                std::vector<int>& segment);

/// The rotation taking unit-or-not vector `from` to `to` about their common normal (Rodrigues,
/// seed 000 eq. 6–7); identity for a zero vector; a half turn about an axis normal to `from`
/// for opposite vectors.
Eigen::Matrix3d rotation_between(const Eigen::Vector3d& from, const Eigen::Vector3d& to);

/// Precompute/solve skeleton driving for one garment: the handles (vertices further than
/// options.seam_radius from every limb seam) and the Laplacian factorisation depend on the
/// garment alone and are built once; drive() then places the garment on any body. The
/// factorisation is made by the first drive(), beside the torso's orientation and placement
/// (which do not need it), so that its serial work overlaps theirs; later calls reuse it.
///
/// garment: #V × 3 positions (m), #F × 3 triangles; segmentation: segment_garment()'s result
/// for it (labels and key points); skeletons: extract_limb_skeletons()'s for it (entries that
/// are not sleeves or legs are ignored). The constructor throws vfit::Error("skeleton
/// driving", …) when the labels or skeletons do not match the mesh or when the garment has no
/// key joints (skirts, sleeveless tops and dresses: see garment_key_joints()); drive() throws
/// it when a connected piece of the garment has no handle (the band's system is singular).
/// drive() may be called from several threads at once.
class SkeletonDriver {
public:
  SkeletonDriver(const Mesh& garment, const GarmentSegmentation& segmentation, std::span<const PartSkeleton> skeletons,
                 const SkeletonDrivingOptions& options = {});
  ~SkeletonDriver();
  SkeletonDriver(SkeletonDriver&&) noexcept;
  SkeletonDriver& operator=(SkeletonDriver&&) noexcept;

  /// Deforms the garment onto a body with joints `body_joints` (24 × 3, m, posed).
  /// With `body_surface` (an index of the body's closed mesh in the same pose), the torso's
  /// translation is refined by contact_translation() (coarse_move.h) over the torso's
  /// vertices, and each limb node is then measured from the body's joint (its projection on
  /// the limb's line) rather than from the garment's own key joint, along the upper limb's own
  /// axis for a sleeve reaching past the elbow (the principal direction of its nodes from a
  /// quarter to the whole of the upper arm's length, when they lie on a line: spread across
  /// it under 0.3 of their spread along it); for trousers and shorts the
  /// torso is first moved along the body's trunk so that the garment's crotch key point meets
  /// the body's crotch (where a line down the trunk from the hips' midpoint leaves the body),
  /// since the hips' height is estimated from the cut and contact can only push the garment
  /// out, not pull a garment placed too high down. The crotch is sought along the trunk axis
  /// (pelvis → neck) over one thigh's length below the hips' midpoint; when the midpoint is
  /// outside the body or the line never leaves it, the crotch step is skipped silently. After
  /// the contact translation, trousers and shorts are moved along the trunk (pocket_offset)
  /// to where the body holds them: a bottom sits in a pocket of the body, the hips widening
  /// below its waistband and seat, the crotch above its crotch seam, so the torso's clearance
  /// (the 1st percentile of its signed distances to the body) falls both below and above its
  /// best height. Offsets within ±50 mm of the contact placement are tried every 2 mm, and the
  /// lowest within 2 mm of the best clearance is taken (the garment slides down until held);
  /// when the clearance does not fall by 2 mm on both sides (no pocket), nothing moves. The
  /// crotch key point (the cloth's crotch raised by a calibrated fraction of the hips' width)
  /// cannot say how far a garment's crotch hangs below the body's (13–49 mm over the corpus's
  /// bottoms, a matter of cut), so it only starts the search.
  /// Without a surface, eq. 8–11 as DrivenLimb describes. The surface must index the same posed
  /// body as `body_joints` (m); it is queried, not modified. Throws vfit::Error ("proximity
  /// queries: …") when the placed garment has a non-finite coordinate; `body_joints` is not
  /// validated.
  /// engine/fit_pipeline.cpp passes the surface (FitOptions::contact_placement, on by
  /// default): driving then costs more, and the fitted garments cross the body less.
  SkeletonDriving drive(const JointPositions& body_joints, const ProximityIndex* body_surface = nullptr) const;
  /// Vertex ids held as handles in the Laplacian solve, ascending.
  const std::vector<std::int32_t>& handles() const { return m_handles; }
  /// #V distances (m) along edges from each vertex to the nearest limb seam vertex, up to
  /// seam_radius; +∞ beyond it and with no limb.
  const std::vector<double>& seam_distance() const { return m_seam_distance; }
  double setup_ms() const { return m_setup_ms; }

private:
  /// #V × 3 starting guess for an iterative band solve: `rigid` (the per-vertex rigid
  /// positions) with each band vertex moved to the torso's placement (R x + t) and its seam's
  /// limb placement (the limb's first node transform) blended by a smoothstep of its signed
  /// distance across the seam.
  Eigen::MatrixXd blended_guess(const Eigen::MatrixXd& rigid, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                const std::vector<DrivenLimb>& limbs,
                                const std::vector<std::vector<Eigen::Vector3d>>& node_feet) const;

  Mesh m_garment;
  std::vector<GarmentPart> m_parts;
  std::vector<PartSkeleton> m_skeletons;
  GarmentKeyJoints m_key_joints;
  SkeletonDrivingOptions m_options;
  std::vector<double> m_seam_distance;
  std::vector<std::int32_t> m_seam_limb; ///< #V: the limb whose seam is nearest, −1 when none within seam_radius
  std::vector<std::int32_t> m_handles;
  std::vector<std::int32_t> m_vertex_limb; ///< #V: index into m_skeletons, −1 for the torso
  std::vector<std::int32_t> m_vertex_node; ///< #V: node within its limb, −1 for the torso
  /// The band's factorisation and the rest's differential coordinates, built once by the first
  /// drive() (build_band()); on the heap, so a move of the driver leaves it in place.
  struct Band;
  std::unique_ptr<Band> m_band;
  double m_setup_ms = 0;

  /// Orientation and placement of the torso (eq. 5–7, 16–17, the crotch, contact and pocket
  /// steps drive() describes): the torso's rotation R and translation t, with out's
  /// contact_translation, pocket_offset, torso_rotation, torso_translation and orientation_ms.
  void orient(const JointPositions& body_joints, const ProximityIndex* body_surface, SkeletonDriving& out,
              Eigen::Matrix3d& R, Eigen::Vector3d& t) const;
  /// Builds m_band once (thread-safe); returns its factorisation's milliseconds on the call
  /// that built it, 0 on the others.
  double build_band() const;
};

/// One call: SkeletonDriver(garment, segmentation, skeletons, options).drive(body_joints,
/// body_surface), with the setup time in the timings; throws as the two do.
SkeletonDriving drive_garment(const Mesh& garment, const GarmentSegmentation& segmentation,
                              std::span<const PartSkeleton> skeletons, const JointPositions& body_joints,
                              const SkeletonDrivingOptions& options = {}, const ProximityIndex* body_surface = nullptr);

} // namespace vfit
