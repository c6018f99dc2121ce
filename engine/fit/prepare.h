// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Garment preparation, the stage of a fit between reading and segmentation (seed 000 §4's
/// input): each garment in metres (its length unit stated or detected against the body),
/// welded where pattern pieces duplicate their seams, wound consistently, and fitted by its
/// inner sheet when modelled with thickness; an outfit file (several garments in one mesh)
/// split into its garments. Internal to engine/fit/.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "vfit/engine/dress/dresser.h"
#include "vfit/engine/fit/fit_options.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/garment/thick_shell.h"
#include "vfit/geometry/mesh/mesh.h"
#include "vfit/geometry/mesh/units.h"

namespace vfit::fitting {

/// A garment's length unit: as stated (FitOptions::garment_units), or detected against the body
/// it is fitted on (`body_torso_depth`, m: torso_depth(); 0 for none: from its size alone).
/// `note`, when not null, receives how it was decided; `differs_alone`, when not null, is set
/// when the body decided a unit the garment's size alone would not have. Throws vfit::Error
/// naming the garment when no unit fits. O(#V).
Units garment_units(const Mesh& mesh, const std::string& name, const FitOptions& options, double body_torso_depth,
                    std::string* note = nullptr, bool* differs_alone = nullptr);

/// An outfit file: after welding (pattern pieces that share seams are one garment), each
/// connected piece with at least this share of the file's vertices is a garment of its own;
/// smaller pieces (buttons, labels, a detached collar) stay with the largest.
inline constexpr double OUTFIT_SHARE = 0.2;

/// The garments to fit once outfit files are split.
struct SplitInputs {
  std::vector<FitGarmentInput> garments;
  std::vector<std::string> notes;  ///< per garment: how it came out of its file ("" when whole)
  std::vector<std::size_t> source; ///< per garment: the input it came from
};

/// Splits every outfit among `inputs` into its garments, named "<name>#k" in the order of their
/// pieces by size (or "<name>:<group>" when one OBJ group holds 90 % of a piece); a garment in
/// one piece, or modelled with thickness as two sheets, stays whole. O(#V log #V) per input.
SplitInputs split_outfits(const std::vector<FitGarmentInput>& inputs, const FitOptions& options,
                          double body_torso_depth);

/// A garment modelled with thickness (thick_shell.h): the whole mesh as prepared (metres,
/// welded, wound consistently) and its inner sheet, which the stages fit in its place.
struct ShellGarment {
  ThickShell shell;
  Mesh whole;
};

/// The prepare stage: out.mesh becomes `input`'s mesh in metres, welded and wound
/// consistently, with a warning in `report` for each change; a garment modelled with thickness
/// is replaced by its inner sheet (`shell` receives the whole). `as_given`, when not null,
/// receives the garment before that replacement, still in its file's frame. Throws vfit::Error
/// naming the garment when its unit cannot be detected or its size is no garment's (0.05–10 m).
void prepare_garment(const FitGarmentInput& input, const FitOptions& options, double body_torso_depth,
                     FittedGarment& out, GarmentFitReport& report, std::optional<ShellGarment>& shell, Mesh* as_given);

/// The segment stage (seed 000 §4): out.mesh turned upright and to face +Z (segment_upright():
/// detected unless FitOptions states them), its type and part labels into out.segmentation,
/// with a warning for each turn. Throws vfit::Error naming the garment when it is not one.
void segment_upright_garment(const FitOptions& options, FittedGarment& out, GarmentFitReport& report);

/// A garment fitted by its inner sheet gets its whole mesh back: sheet vertices where the fit
/// put them, the others at their offsets from the sheet; per-vertex results spread to the
/// carried vertices from the nearest corner of their sheet triangle (ease measured afresh), and
/// what of the whole mesh is inside the body or an inner garment removed as any garment's.
void restore_shell(const ShellGarment& shell, const DressingBody& body, const DressOptions& options, FittedGarment& out,
                   GarmentFitReport& report);

} // namespace vfit::fitting
