// SPDX-License-Identifier: Apache-2.0
#include "body_args.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "vfit/geometry/body/pose_io.h"
#include "vfit/kernels/error.h"

namespace vfit::cli {

BodyMeasurements measurements_from_args(Args& args) {
  BodyMeasurements m = body_preset(args.value("preset").value_or("average"));
  for (std::string_view name : BodyMeasurements::names()) {
    std::string flag(name);
    std::replace(flag.begin(), flag.end(), '_', '-');
    if (auto v = args.value(flag)) {
      char* end = nullptr;
      const double x = std::strtod(v->c_str(), &end);
      if (end == v->c_str() || *end != '\0')
        throw Error("--" + flag, 0, "expected a length in metres, got '" + *v + "'");
      m[name] = x;
    }
  }
  return m;
}

RestPose parse_rest_pose(const std::string& flag, const std::string& value) {
  if (value == "tpose") return RestPose::TPOSE;
  if (value == "apose") return RestPose::APOSE;
  throw Error(flag, 0, "expected tpose or apose, got '" + value + "'");
}

BodyRequest body_request_from_args(Args& args, const std::string& source) {
  BodyRequest r;
  r.source = source;
  r.mannequin.measurements = measurements_from_args(args);
  if (auto p = args.value("pose-rest")) r.mannequin.pose = parse_rest_pose("--pose-rest", *p);
  if (auto n = args.value("vertices"))
    r.mannequin.target_vertices = static_cast<std::size_t>(Args::to_int("--vertices", *n, 1000, 2000000));
  if (auto b = args.value("betas")) {
    std::string s = *b;
    std::size_t start = 0;
    while (start <= s.size()) {
      const std::size_t comma = s.find(',', start);
      const std::string item = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      char* end = nullptr;
      const double x = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !std::isfinite(x))
        throw Error("--betas", 0, "expected comma-separated numbers, got '" + *b + "'");
      r.betas.push_back(x);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  if (auto j = args.value("joints-in")) r.joints_file = *j;
  if (auto u = args.value("units")) r.units = parse_units(*u);
  if (auto up = args.value("up"); up && *up != "auto") r.up = parse_up_axis(*up);
  if (auto facing = args.value("facing"); facing && *facing != "auto") r.facing = parse_facing(*facing);
  r.repair = args.flag("repair");
  if (auto m = args.value("rig-mapping")) r.rig_mapping_file = *m;
  return r;
}

namespace {

double positive_number(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (end == v.c_str() || *end != '\0' || !std::isfinite(x) || x <= 0)
    throw Error(flag, 0, "expected a positive number, got '" + v + "'");
  return x;
}

} // namespace

KeypointOptions keypoint_options_from_args(Args& args, bool& image_size_needs_token) {
  KeypointOptions o;
  if (auto f = args.value("focal")) o.focal = positive_number("--focal", *f);
  if (auto l = args.value("keypoint-layout")) {
    const auto layout = keypoint_layout_from_name(*l);
    if (!layout) throw Error("--keypoint-layout", 0, "expected auto, body25, coco18, lsp or named, got '" + *l + "'");
    o.layout = *layout;
  }
  image_size_needs_token = false;
  if (auto size = args.value("image-size")) {
    const std::size_t sep = size->find_first_of("x,");
    if (sep != std::string::npos)
      o.image_size = Eigen::Vector2d(positive_number("--image-size", size->substr(0, sep)),
                                     positive_number("--image-size", size->substr(sep + 1)));
    else {
      o.image_size = Eigen::Vector2d(positive_number("--image-size", *size), 0.0); // height: the next token
      image_size_needs_token = true;
    }
  }
  return o;
}

void finish_image_size(Args&, const std::vector<std::string>& rest, KeypointOptions& options) {
  if (!options.image_size || options.image_size->y() != 0.0) return;
  if (rest.empty()) throw Error("--image-size", 0, "expected W H (pixels)");
  options.image_size->y() = positive_number("--image-size", rest[0]);
}

KeypointFit fit_keypoint_file(const std::string& file, const KeypointOptions& options, bool quiet, Keypoints* read) {
  Keypoints kp = read_keypoints(file, options);
  if (!quiet)
    for (const auto& w : kp.warnings)
      std::cerr << "vfit: warning: " << w << "\n";
  KeypointFit fit = fit_keypoints(kp);
  if (read) *read = std::move(kp);
  return fit;
}

} // namespace vfit::cli
