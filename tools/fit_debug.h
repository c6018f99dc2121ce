// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Debug output of the fitting pipeline (`vfit fit --debug DIR`): after each stage of each
/// garment a mesh a person can open in any viewer (MeshLab, Blender) to see what the stage did — the
/// segmentation labels as vertex colours, the part skeletons as polylines, the garment after
/// driving, the coarse move, penetration removal and simulation. Every file is written
/// atomically (a temporary file renamed), so a file present is a file complete.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "vfit/engine/fit/fit_options.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/garment/skeleton_parts.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// 8-bit RGB colour of a garment part in debug meshes (legend.txt lists them): torso grey
/// (170, 170, 170), left sleeve red (220, 50, 40), right sleeve blue (40, 90, 220), left leg
/// orange (245, 150, 30), right leg green (40, 170, 70), skirt purple (150, 70, 200). "Left" is
/// the wearer's left, +X. White (255, 255, 255) for a value outside the enum. Never throws.
std::array<std::uint8_t, 3> garment_part_colour(GarmentPart part);

/// A garment's name as a file-name stem: the file stem of `name` (a path such as
/// "in/tee.obj" → "tee"), every character other than a letter, digit, '-' or '_' replaced by
/// '_'; "garment" when that leaves nothing. Never throws.
std::string debug_file_stem(const std::string& name);

/// Writes the per-stage files of fit_garments() into one folder:
/// - `legend.txt`: the colours of the parts and what each file holds;
/// - `body.ply`: the posed body the garments are fitted onto;
/// - `<garment>_<NN>_<stage>.ply`: the garment after stage NN (ASCII PLY, metres, per-vertex
///   `red green blue` from garment_part_colour() of the vertex's segmentation label, the stage
///   and its outcome in `comment` lines);
/// - `<garment>_<NN>_skeletons.obj`: one object (`o <part>`) per sleeve or leg, its nodes as
///   `v` lines joined by one `l` polyline from the attachment end to the open end; a comment
///   only when the garment has none;
/// - `<garment>_<NN>_skeleton_nodes.ply`: the garment with each limb vertex coloured by its
///   skeleton node (bands alternating between the part's colour and a darker shade along the
///   chain), other vertices by their label.
class FitDebugWriter {
public:
  /// Creates `dir` (and its parents) when absent and writes legend.txt (atomically). Throws
  /// vfit::Error naming `dir` ("cannot create the debug folder") when it cannot be created or
  /// is not a directory, and vfit::Error naming the legend's path when it cannot be written.
  explicit FitDebugWriter(std::filesystem::path dir);

  /// The output folder, as given.
  const std::filesystem::path& dir() const { return m_dir; }

  /// Writes `body.ply` (binary PLY via write_mesh(), metres, no colours); throws vfit::Error
  /// naming the file when it cannot be written.
  void write_body(const Mesh& body) const;

  /// Writes `<stem>_<NN>_<stage>.ply` (NN = `number`, two digits at least: "%02d"): `mesh`
  /// (#V × 3 positions, m; #F × 3 triangles) as ASCII PLY coloured by `vertex_parts` (#V;
  /// empty: all torso). `note` (one line; newlines become spaces) is stored as a PLY comment.
  /// Returns the path written. Throws vfit::Error naming the file when vertex_parts is neither
  /// empty nor #V long, or the file cannot be written. `stem` is used as given (pass it
  /// through debug_file_stem()).
  std::filesystem::path write_garment(const std::string& stem, int number, const std::string& stage, const Mesh& mesh,
                                      std::span<const GarmentPart> vertex_parts, const std::string& note) const;

  /// Writes `<stem>_<NN>_skeletons.obj` and `<stem>_<NN>_skeleton_nodes.ply` for `skeletons`
  /// (extract_limb_skeletons() of `mesh`, node positions in the same frame as `mesh`, m).
  /// vertex_parts as for write_garment() (same error, naming the .ply). A skeleton with one
  /// node gets its `v` line but no polyline; skeleton vertex ids outside the mesh are skipped.
  /// Throws vfit::Error naming the file when either file cannot be written.
  void write_skeletons(const std::string& stem, int number, const Mesh& mesh, std::span<const GarmentPart> vertex_parts,
                       std::span<const PartSkeleton> skeletons) const;

private:
  std::filesystem::path m_dir;
};

/// A fit's observer (FitOptions::observer) that writes its snapshots with a FitDebugWriter:
/// nothing until the fit starts (every garment segmented), then the folder, legend.txt and
/// body.ply, then each stage's files as the stage finishes. Garment files are named by
/// debug_file_stem() of the garment's name, made unique by its index ("_<k>") when two names
/// share one. Throws vfit::Error as FitDebugWriter does (the fit is then aborted).
class FitDebugFiles : public FitObserver {
public:
  explicit FitDebugFiles(std::filesystem::path dir);

  void start(const Mesh& body, std::span<const std::string> garment_names) override;
  void garment(std::size_t garment, const std::string& name, int number, const std::string& stage, const Mesh& mesh,
               std::span<const GarmentPart> vertex_parts, const std::string& note) override;
  void skeletons(std::size_t garment, const std::string& name, int number, const Mesh& mesh,
                 std::span<const GarmentPart> vertex_parts, std::span<const PartSkeleton> skeletons) override;

private:
  std::filesystem::path m_dir;
  std::optional<FitDebugWriter> m_writer;
  std::vector<std::string> m_stems; // per garment
};

} // namespace vfit
