// SPDX-License-Identifier: Apache-2.0
#pragma once
// The demo outfit for the animation tests: catalogue trousers P2 under a catalogue tee M, both
// modelled in the A-pose for the A-pose mannequin, given as garments fitted on it (unfitted:
// the catalogue's A-pose garments already sit on the mannequin), inner first.
#include <cstddef>
#include <utility>
#include <vector>

#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/garment/catalogue.h"

namespace vfit::test {

/// The trousers and the tee, `vertices` each (exactly, as make_garment() builds them).
inline std::vector<FittedGarment> demo_outfit(std::size_t vertices) {
  std::vector<FittedGarment> garments;
  for (const auto& [type, size] : {std::pair{GarmentType::TROUSERS, "P2"}, std::pair{GarmentType::TEE, "M"}}) {
    GarmentOptions o;
    o.type = type;
    o.size = size;
    o.pose = RestPose::APOSE;
    o.target_vertices = vertices;
    FittedGarment g;
    g.name = garment_type_name(type);
    g.mesh = make_garment(o).mesh;
    g.segmentation.type = type;
    garments.push_back(std::move(g));
  }
  return garments;
}

} // namespace vfit::test
