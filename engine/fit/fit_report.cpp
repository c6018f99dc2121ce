// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/fit/fit_report.h"

#include <fstream>

namespace vfit {

std::string to_string(SimulationOutcome outcome) {
  switch (outcome) {
  case SimulationOutcome::SKIPPED: return "skipped";
  case SimulationOutcome::CONVERGED: return "converged";
  case SimulationOutcome::TIME_LIMIT: return "time limit";
  case SimulationOutcome::DIVERGED: return "diverged";
  }
  return "unknown";
}

std::vector<std::pair<std::string, double>> FitStageTimes::named() const {
  return {{"units", units_ms},           {"segmentation", segmentation_ms}, {"skeletons", skeletons_ms},
          {"driving", driving_ms},       {"coarse_move", coarse_move_ms},   {"penetration", penetration_ms},
          {"simulation", simulation_ms}, {"feedback", feedback_ms},         {"total", total_ms}};
}

std::string cpu_model_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string name = line.substr(colon + 1);
    const auto first = name.find_first_not_of(" \t");
    return first == std::string::npos ? "unknown" : name.substr(first);
  }
  return "unknown";
}

} // namespace vfit
