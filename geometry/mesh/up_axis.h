// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The up axis of a mesh file, and the rotation that brings such a file into our frame (Y up,
/// facing +Z). Formats disagree: OBJ and glTF are Y-up facing +Z (our frame); Blender, many
/// scanners and CAD tools write Z-up with the figure facing −Y.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace vfit {

/// Which file axis points up. The facing direction that goes with each is fixed by
/// rotate_to_y_up() below.
enum class UpAxis { POS_Y, POS_Z, NEG_Z, NEG_Y, POS_X, NEG_X };

/// Every up axis: our frame, Blender's Z up, then the rarer upside-down and sideways files.
inline constexpr std::array<UpAxis, 6> UP_AXES = {UpAxis::POS_Y, UpAxis::POS_Z, UpAxis::NEG_Z,
                                                  UpAxis::NEG_Y, UpAxis::POS_X, UpAxis::NEG_X};

/// "+y" | "+z" | "-z" | "-y" | "+x" | "-x".
std::string up_axis_name(UpAxis up);

/// The unit vector of `up` in the file's own axes: +Y is (0, 1, 0), −Z is (0, 0, −1), ...
std::array<double, 3> up_axis_vector(UpAxis up);

/// Parses "+y", "y", "+z", "z", "-z", "-y", "+x", "x", "-x" (case-insensitive); throws
/// vfit::Error naming `name` otherwise.
UpAxis parse_up_axis(std::string_view name);

/// How far a surface is from mirror symmetric across the mid-plane of its bounding box normal to
/// each axis (X, Y, Z): the surface's area is binned by triangle centroid into an 8³ grid over
/// the bounding box (coarse enough that a shell following a body's front and back lands in
/// mirrored cells), and asymmetry[a] = Σ|area(cell) − area(mirror of cell across a)| / (2 Σ area),
/// in [0, 1]: 0 for a surface equal to its mirror image (at this grid's resolution), 1 for one
/// whose mirror image shares no cell with it. A garment is nearly symmetric left–right and
/// front–back and far from it top–bottom (neck and sleeves against hem, waist against legs).
/// `positions` #V × 3, `triangles` #F × 3 (indices checked by the caller). All zeros for a
/// surface without area or with a flat bounding box.
std::array<double, 3> mirror_asymmetry(std::span<const float> positions, std::span<const std::int32_t> triangles);

/// Per axis (X, Y, Z), the area-weighted share of the surface's normals along that axis:
/// Σ_f area_f n_f,a² / Σ_f area_f, summing to 1 (all zeros without area). A garment wraps
/// around the body, its normals point out sideways, front and back, rarely up: the up axis
/// holds the smallest share, the front–back axis the largest.
std::array<double, 3> normal_direction_shares(std::span<const float> positions,
                                              std::span<const std::int32_t> triangles);

/// The up axis of a garment file whose left–right axis is X, as a file is written in either
/// convention (Y up facing +Z: OBJ, glTF; Z up facing −Y: Blender, scanners): +Y or +Z, or
/// nullopt when the geometry does not say. Of Y and Z, the up axis is the one with the smaller
/// normal share (normal_direction_shares()), by a factor of 1.5 at least, and it must be less
/// mirror-symmetric than X (mirror_asymmetry(), by 0.05 at least: a garment is symmetric left
/// to right, never top to bottom). On the 21 MakeHuman garments of the corpus (tops, open
/// jackets, trousers, shorts, skirt, overalls) the up axis' normal share is 2.4–16× smaller
/// than the front–back axis', and X's asymmetry is ≤ 0.17 against ≥ 0.39 for the up axis. The
/// sign is not detected: an upside-down file reads as upright. Linear in the mesh.
std::optional<UpAxis> detect_up_axis(std::span<const float> positions, std::span<const std::int32_t> triangles);

/// The up axis of a standing body's file (mesh or point cloud, left–right axis X), +Y or +Z: the
/// one of the two bounding-box extents at least twice the other (a standing body is far taller
/// than deep, in any arm pose); else detect_up_axis() on its triangles (nullopt without).
std::optional<UpAxis> detect_body_up_axis(std::span<const float> positions, std::span<const std::int32_t> triangles);

/// Rotates `positions` (#V × 3, any unit) in place from a file whose up axis is `up` into our
/// frame, by a proper rotation (no mirror) that maps `up` onto +Y:
///   +Y: identity;
///   +Z: (x, y, z) → (x, z, −y), −90° about X: a Z-up file facing −Y (Blender, scanners) ends
///       facing +Z;
///   −Z: (x, y, z) → (x, −z, y), +90° about X: facing +Y ends facing +Z;
///   −Y: (x, y, z) → (−x, −y, z), 180° about Z: upside down, facing +Z stays;
///   +X: (x, y, z) → (−y, x, z), +90° about Z; −X: (x, y, z) → (y, −x, z), −90° about Z
///       (lying on a side, facing +Z stays).
/// Triangles keep their winding (a rotation keeps outward normals outward).
void rotate_to_y_up(std::span<float> positions, UpAxis up);
/// The same for double coordinates (e.g. a row-major #J × 3 joint matrix).
void rotate_to_y_up(std::span<double> positions, UpAxis up);

/// Which way the front of an upright (Y-up) garment faces in its file, about the up axis. Our
/// frame is POS_Z; tools disagree (some export figures facing −Z, or +X with Z as their
/// left–right axis).
enum class Facing { POS_Z, NEG_Z, POS_X, NEG_X };

/// "+z" | "-z" | "+x" | "-x".
std::string facing_name(Facing facing);
/// Parses "+z", "z", "-z", "+x", "x", "-x" (case-insensitive); throws vfit::Error naming
/// `name` otherwise.
Facing parse_facing(std::string_view name);

/// Whether an upright garment's left–right axis is Z rather than X (it faces ±X): only when both
/// cues agree by a margin: its Z extent is at least 1.2× its X extent (a garment is wider than
/// deep: 1.28–5.1× over the 21 MakeHuman garments of the corpus and the catalogue's types,
/// sizes and poses; only a lone shirt collar is deeper than wide, 0.91×), and it is more
/// mirror-symmetric across Z than across X by 0.02 (mirror_asymmetry(): left to right 0.00–0.17,
/// front to back 0.04–0.88 on the same garments). False when either cue is missing (a skirt as
/// deep as wide stays as given). `positions` #V × 3 in any unit, `triangles` #F × 3. Linear.
bool lateral_axis_is_z(std::span<const float> positions, std::span<const std::int32_t> triangles);

/// Where the top edge of an upright garment lies along horizontal axis `axis` (0 = X, 2 = Z):
/// the mean coordinate of the vertices in the top 5 % of its height, less the middle of its
/// bounding box, over its extent along `axis` (in [−0.5, 0.5]). A top's neckline dips at the
/// front, so its top edge (the back of the collar) leans back: −0.06 to −0.30 along Z over the
/// 13 corpus and 2 catalogue tops facing +Z. Bottoms do not agree (waistbands are level or
/// higher at the back), so the cue is for tops only. 0 without vertices or extent.
double top_edge_lean(std::span<const float> positions, int axis);

/// Rotates `positions` (#V × 3) about +Y so that a garment facing `facing` faces +Z:
///   +Z: identity; −Z: (x, y, z) → (−x, y, −z); +X: (x, y, z) → (−z, y, x); −X: (x, y, z) → (z, y, −x).
void rotate_to_face_z(std::span<float> positions, Facing facing);
/// The same for double coordinates (e.g. a row-major #J × 3 joint matrix).
void rotate_to_face_z(std::span<double> positions, Facing facing);

/// The facing of a garment turned by `first`, then by `then` (both rotate_to_face_z()): the
/// single rotation that equals the two.
Facing compose_facing(Facing first, Facing then);

} // namespace vfit
