// SPDX-License-Identifier: Apache-2.0
// A consumer of the installed vfit package: fits a catalogue tee onto the default mannequin
// through the Engine and prints one line the package test checks.
#include <cstdio>
#include <exception>
#include <vector>

#include "vfit/engine/engine.h"
#include "vfit/geometry/garment/catalogue.h"

int main() {
  try {
    vfit::EngineOptions options;
    options.threads = 2;
    const vfit::Engine engine(options);
    const vfit::SourcedBody body = engine.make_body(vfit::BodySource{});
    vfit::GarmentOptions tee;
    tee.type = vfit::GarmentType::TEE;
    tee.size = "M";
    tee.target_vertices = 1500;
    std::vector<vfit::FitGarmentInput> garments(1);
    garments[0].name = "tee";
    garments[0].mesh = vfit::make_garment(tee).mesh;
    const vfit::FitResult fit = engine.fit(body.body, garments);
    const vfit::GarmentFitReport& r = fit.report.garments.at(0);
    std::printf("consumer: fitted %s (%zu vertices) onto a %zu-vertex body: %zu vertices inside after the fit\n",
                r.name.c_str(), fit.garments.at(0).mesh.vertex_count(), fit.report.body_vertices, r.after.inside_count);
    return r.after.inside_count == 0 && fit.garments.at(0).mesh.vertex_count() > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
