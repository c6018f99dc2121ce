// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The fitting pipeline (seed 000 §4–6; seed 001 §6.3; seed 004 §3): body + garments → fitted
/// garments and a FitReport. Every garment goes through the stages in this order:
///
///   read → prepare → segment → skeletons → drive → place → dress → simulate → feedback
///
/// - read: the garments as meshes (FitGarmentInput; tools/ reads the files);
/// - prepare: metres, welded seams, consistent winding, the inner sheet of a garment modelled
///   with thickness, outfit files split into their garments (engine/fit/prepare.h);
/// - segment: upright, facing +Z, type and parts (§4, geometry/garment/segment.h);
/// - skeletons: the limbs' mean-curvature-flow skeletons (§5.1) and the skeleton driver;
/// - drive: orientation, limbs onto the body's bones, Laplacian continuity (§5.2–5.4), and the
///   torso placed by its contact with the body;
/// - place: the coarse move of eq. 16–17 for a garment that was not driven (§6.1);
/// - dress: penetration removal against the body and the garments dressed before it (§6.2,
///   eq. 18–21; seed 001 eq. 7), engine/dress/dresser.h;
/// - simulate: mass-spring cloth to rest (§6.3; on a coarse proxy for a large garment, seed 004
///   §3), colliding with the body and the inner garments, then the clean-up policy after it;
/// - feedback: strain, ease, regions and the size verdict (engine/fit/fit_feedback.h).
///
/// Read, prepare and segment run for every garment first (the type decides the dressing
/// order); the rest runs per garment in dressing order, inner to outer (FitOptions::layer_order),
/// each garment then becoming an inner layer of the next.

#include <span>
#include <vector>

#include "vfit/engine/fit/fit_options.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/body/body.h"

namespace vfit {

/// Fits `garments` onto `body` (a closed, outward-oriented mesh in metres with its joints).
/// Throws vfit::Error naming the garment when one is not a garment (segment_garment()'s
/// errors), when its units cannot be detected, or for an unknown fabric; the body is assumed
/// valid (load_body() checked it). A diverged simulation is not an error: it is reported and
/// the garment keeps its pre-simulation shape. Garments are dressed inner to outer
/// (FitOptions::layer_order: by default read from their geometry as given, else bottoms first),
/// each kept outside the ones before it: penetration removal pushes out its vertices inside
/// them and its triangles their edges pass through (engine/dress/layer_piercing.h), and its
/// simulation collides with them as well as with the body. A file holding several garments (an
/// outfit) is split into them; a garment modelled with thickness (geometry/garment/
/// thick_shell.h) is fitted by its inner sheet and returned whole, with a warning.
FitResult fit_garments(const Body& body, const std::vector<FitGarmentInput>& garments, const FitOptions& options = {});

/// Fits the same garments onto each of `bodies` (many bodies, one garment collection: sizes of a
/// design, a crowd, a shop's customers). Each garment is prepared, segmented, and its part
/// skeletons extracted and its skeleton driver set up (the band Laplacian factored, seed 000
/// §5.4) once, on the first body; every body then gets its own driving, penetration removal,
/// layering, simulation and feedback. Result k is what fit_garments(*bodies[k], garments,
/// options) returns, bit for bit (the shared stages do not depend on the body, but for a
/// garment unit left to detection, which is read against the first body's torso: state
/// FitOptions::garment_units to be free of it); the shared stages' times are reported with the
/// first body, as 0 ms for the others (whose driving line says "shared"), so the reports'
/// totals add up to the whole call. Throws as fit_garments() does, before any body is fitted,
/// and vfit::Error for a null body or for snapshots (FitOptions::observer) with more than one
/// body. No bodies: no results.
std::vector<FitResult> fit_garments_onto_bodies(std::span<const Body* const> bodies,
                                                const std::vector<FitGarmentInput>& garments,
                                                const FitOptions& options = {});

} // namespace vfit
