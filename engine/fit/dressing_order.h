// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The order in which a fit dresses its garments, inner first (seed 001 §6.3; seed 000 §6:
/// the top over the trousers). Internal to engine/fit/.

#include <cstddef>
#include <vector>

#include "vfit/engine/fit/fit_options.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/engine/fit/prepare.h"
#include "vfit/geometry/garment/garment.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit::fitting {

/// Trousers, shorts and skirts.
bool is_bottom(GarmentType type);

/// The dressing order (indices into `reports`, innermost first) under FitOptions::layer_order:
/// GIVEN keeps the input order; TYPE puts bottoms before tops; AUTO reads the order from the
/// garments' geometry as given (`as_given`: one mesh per garment, metres, in its file's frame;
/// infer_layer_order()) for garments of one outfit file or whose files look like one frame,
/// and puts bottoms first elsewhere. A garment whose place the geometry decided against
/// bottoms-first, or geometry that contradicts itself, gets a warning in `reports`.
std::vector<std::size_t> dressing_order(const FitOptions& options, const SplitInputs& split,
                                        const std::vector<Mesh>& as_given, std::vector<GarmentFitReport>& reports);

} // namespace vfit::fitting
