#include "body_args.h"

#include <algorithm>
#include <cstdlib>

#include "kernels/error.h"

namespace vfit::cli {

BodyMeasurements measurements_from_args(Args& args) {
  BodyMeasurements m = body_preset(args.value("preset").value_or("average"));
  for (std::string_view name : BodyMeasurements::names()) {
    std::string flag(name);
    std::replace(flag.begin(), flag.end(), '_', '-');
    if (auto v = args.value(flag)) {
      char* end = nullptr;
      const double x = std::strtod(v->c_str(), &end);
      if (end == v->c_str() || *end != '\0') throw Error("--" + flag, 0, "expected a length in metres, got '" + *v + "'");
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
  if (auto n = args.value("vertices")) r.mannequin.target_vertices = static_cast<std::size_t>(Args::to_int("--vertices", *n, 1000, 2000000));
  if (auto b = args.value("betas")) {
    std::string s = *b;
    std::size_t start = 0;
    while (start <= s.size()) {
      const std::size_t comma = s.find(',', start);
      const std::string item = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      char* end = nullptr;
      const double x = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !std::isfinite(x)) throw Error("--betas", 0, "expected comma-separated numbers, got '" + *b + "'");
      r.betas.push_back(x);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  if (auto j = args.value("joints-in")) r.joints_file = *j;
  if (auto u = args.value("units")) r.units = parse_units(*u);
  if (auto m = args.value("rig-mapping")) r.rig_mapping_file = *m;
  return r;
}

} // namespace vfit::cli
