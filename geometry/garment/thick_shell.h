// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Garments modelled with thickness: two parallel sheets of cloth a few millimetres apart,
/// either stitched into one closed surface at every opening (a "solidify" modifier, a design
/// tool's export with thickness, most game-ready clothes) or as two separate layers (a shell and
/// its lining). Segmentation needs a sheet with openings, and penetration removal one surface,
/// so the pipeline fits the inner sheet (the one against the body) and carries every other
/// vertex along with it: each keeps its offset from its closest point on the inner sheet, in the
/// frame of that sheet triangle, and is placed again from the fitted sheet. The mesh comes back
/// with its own vertices, triangles, UVs and normals' layout. Not in the seeds (their garments
/// are single sheets); it lets their pipeline (seed 000 §4–6) take such files.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// How find_thick_shell() decides.
struct ThickShellOptions {
  /// Sheets farther apart than this (m) are not one garment's thickness: padded jackets are
  /// about 1–2 cm thick; the two sides of a garment's tube are 8 cm apart or more.
  double max_thickness = 0.02;
  /// The share of the surface's area whose faces see a parallel face of the other sheet within
  /// max_thickness (a folded-back hem or a double collar alone covers far less).
  double min_paired_area = 0.8;
  /// Faces whose normals meet at an angle with |cos| below this are not parallel.
  double min_parallel_cos = 0.7;
};

/// A garment found to be two sheets: the inner one as a mesh of its own, and how every other
/// vertex hangs on it.
struct ThickShell {
  double thickness = 0;                       ///< median distance between the paired faces (m)
  Mesh sheet;                                 ///< the inner sheet (positions, triangles; no UVs or normals)
  std::vector<std::int32_t> sheet_vertices;   ///< sheet vertex k → its vertex in the whole mesh
  std::vector<std::int32_t> carried;          ///< the whole mesh's other vertices, ascending
  std::vector<std::int32_t> carried_triangle; ///< per carried vertex: the sheet triangle it hangs on
  std::vector<float> carried_barycentric;     ///< per carried vertex × 2: (u, v) of its closest point there
  /// Per carried vertex × 3: its offset from that closest point in the triangle's frame
  /// (edge 0's direction, the normal × it, the unit normal) (m).
  std::vector<float> carried_offset;
  std::vector<float> carried_world_offset; ///< per carried vertex × 3: the same offset in the mesh's axes (m)
  std::size_t whole_vertex_count = 0;      ///< #V of the whole mesh
};

/// Finds the two sheets of a garment modelled with thickness. From each face's centroid a ray
/// is cast along its normal both ways; the first face it meets within max_thickness facing the
/// opposite way (or either way, when it belongs to another connected piece of the mesh: a
/// separate lining may be wound like its shell) is its partner. When the paired faces cover min_paired_area of the
/// surface and, once the unpaired ones (the rims that join the sheets) are left out, fall into two connected pieces
/// paired with each other, the smaller piece by area is the inner sheet (a sheet offset outwards around the body is the
/// larger). Returns nullopt for any other mesh (a single sheet, the usual garment; a closed surface that is no shell):
/// the caller's path is then unchanged. garment: triangles indexing its positions (m), consistently wound per piece.
std::optional<ThickShell> find_thick_shell(const Mesh& garment, const ThickShellOptions& options = {});

/// The whole mesh's positions (#V × 3, m) from the inner sheet's (sheet_positions: #V_sheet × 3,
/// the sheet's triangles as in `shell.sheet`): sheet vertices where the sheet puts them, carried
/// vertices at their offsets in the frames of their triangles as the sheet now lies (a rigid
/// motion of the sheet moves the whole mesh rigidly). A triangle degenerate as found or as
/// placed carries its vertices at the offsets they had in the mesh's axes.
std::vector<float> place_thick_shell(const ThickShell& shell, std::span<const float> sheet_positions);

} // namespace vfit
