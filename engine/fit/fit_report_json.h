// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The fit report as JSON text: what `vfit fit --report` writes, and what the C API and the
/// Python module hand back. Keys and units are documented in docs/cli.md ("The fit report");
/// lengths in the keys' units (`_mm`, `_m`), times in milliseconds.
#include <map>
#include <string>
#include <vector>

#include "vfit/engine/fit/fit_options.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/body/body_loader.h"

namespace vfit {

/// What the report says beyond FitReport: how the body was made and what the caller did around
/// the fit.
struct FitReportContext {
  std::string body_source;                ///< Body::source
  std::string body_kind;                  ///< LoadedBody::kind ("mannequin", "smpl", ...)
  std::vector<std::string> body_warnings; ///< LoadedBody::warnings
  double body_ms = 0;                     ///< making the body
  double render_ms = -1;                  ///< drawing the pictures; negative: none drawn
  /// Per garment file, what reading it said (repairs); a garment's entry takes the notes of the
  /// file it is named by, or of "file" for "file#k" (the k-th garment of an outfit file).
  std::map<std::string, std::vector<std::string>> read_warnings;
};

/// The context of a fit onto `body` (as posed) made from `loaded`: its source, kind and
/// warnings; the times and read warnings left for the caller to fill.
FitReportContext fit_report_context(const Body& body, const LoadedBody& loaded);

/// The report of one body's fit as indented JSON (two spaces, a final newline), the vfit
/// version and commit that made it first. Penetration over all garments adds the counts and
/// keeps the deepest vertex.
std::string fit_report_json(const FitReport& report, const FitOptions& options, const FitReportContext& context);

} // namespace vfit
