// SPDX-License-Identifier: Apache-2.0
// `vfit measure`: the 11 measurements of any body, rigged or bare.
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "body_args.h"
#include "commands.h"
#include "vfit/geometry/body/measurements.h"

namespace vfit::cli {

int run_measure(Args& args) {
  const bool json = args.flag("json");
  // Peek at the positional first: the body flags depend on nothing else.
  BodyRequest request;
  std::vector<std::string> pos;
  {
    request = body_request_from_args(args, "");
    pos = args.positionals(1, 1);
    request.source = pos[0];
  }
  const LoadedBody body = load_body(request);
  const MeasuredBody m = measure_body(body.rest.mesh, body.rest.joints);
  if (json) {
    nlohmann::ordered_json j;
    j["body"] = pos[0];
    j["kind"] = body.kind;
    j["rest_pose"] = body.rest.rest_pose == RestPose::TPOSE   ? "tpose"
                     : body.rest.rest_pose == RestPose::APOSE ? "apose"
                                                              : "other";
    for (std::string_view n : BodyMeasurements::names())
      j["measurements_m"][std::string(n)] = m.values[n];
    j["landmark_heights_m"] = {{"floor", m.landmarks.floor}, {"crotch", m.landmarks.crotch},
                               {"chest", m.landmarks.chest}, {"waist", m.landmarks.waist},
                               {"hip", m.landmarks.hip},     {"thigh", m.landmarks.thigh},
                               {"calf", m.landmarks.calf},   {"top", m.landmarks.top}};
    for (int k = 0; k < JOINT_COUNT; ++k)
      j["joints"][std::string(joint_name(k))] = {body.rest.joints(k, 0), body.rest.joints(k, 1),
                                                 body.rest.joints(k, 2)};
    j["warnings"] = body.warnings;
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  for (const auto& w : body.warnings)
    std::cerr << "vfit: warning: " << w << "\n";
  std::printf("body: %s (%s, %zu vertices)\n", pos[0].c_str(), body.kind.c_str(), body.rest.mesh.vertex_count());
  for (std::string_view n : BodyMeasurements::names())
    std::printf("  %-15s %7.4f m\n", std::string(n).c_str(), m.values[n]);
  return 0;
}

} // namespace vfit::cli
