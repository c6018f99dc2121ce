// SPDX-License-Identifier: Apache-2.0
#include "pose_io.h"

#include <cmath>
#include <numbers>

#include <nlohmann/json.hpp>

#include "json_input.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr double DEG = std::numbers::pi / 180.0;

// Rotation that lowers a rest-pose arm by `degrees` below horizontal (left arm: about −Z).
// Share of an arm's raising or lowering taken by the collar (the shoulder girdle), the rest by
// the shoulder: the scapulohumeral rhythm of about 2:1 (Inman et al. 1944). With all of it on
// the shoulder, linear blend skinning folds the armpit and the top of the shoulder: lowering
// the mannequin's arms from A-pose to 75° made 84 of its 13,996 triangles sink inside the torso
// and left a web thinner than 4 mm at 31 vertices; a third on the collar leaves none of either
// (measured with a winding-number and a ray-thickness count), at the same arm angle. Only
// lowering below the rest pose takes the share: raising (arms_raised) keeps it all on the
// shoulder, where the share left a corpus tee (male_casualsuit04) with 10 edges through the
// shoulders after the fit and none without it.
constexpr double COLLAR_SHARE = 1.0 / 3.0;

void lower_arms(Pose& p, double degrees, RestPose rest) {
  const double already = rest == RestPose::APOSE ? 45.0 : 0.0;
  const double a = (degrees - already) * DEG;
  const double share = a > 0 ? COLLAR_SHARE : 0.0; // lowering only, see COLLAR_SHARE
  p.axis_angle.row(idx(Joint::LEFT_COLLAR)) << 0, 0, -a * share;
  p.axis_angle.row(idx(Joint::RIGHT_COLLAR)) << 0, 0, a * share;
  p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) << 0, 0, -a * (1 - share);
  p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) << 0, 0, a * (1 - share);
}

} // namespace

std::vector<std::string> named_pose_names() {
  return {"rest",    "tpose",     "apose",      "arms_down", "arms_raised", "elbows_bent",
          "walking", "knee_bent", "legs_apart", "demo",      "contrapposto"};
}

Pose named_pose(std::string_view name, RestPose rest) {
  Pose p;
  if (name == "rest") return p;
  if (name == "tpose") {
    lower_arms(p, 0, rest);
  } else if (name == "apose") {
    lower_arms(p, 45, rest);
  } else if (name == "arms_down") {
    lower_arms(p, 75, rest);
  } else if (name == "arms_raised") {
    lower_arms(p, -35, rest);
  } else if (name == "elbows_bent") {
    lower_arms(p, 70, rest);
    p.axis_angle.row(idx(Joint::LEFT_ELBOW)) << 0, -80 * DEG, 0; // forearms forward
    p.axis_angle.row(idx(Joint::RIGHT_ELBOW)) << 0, 80 * DEG, 0;
  } else if (name == "walking") {
    lower_arms(p, 72, rest);
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << -25 * DEG, 0, 0; // left leg forward (+Z)
    p.axis_angle.row(idx(Joint::RIGHT_HIP)) << 15 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 30 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) += Eigen::RowVector3d(15 * DEG, 0, 0);
    p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) += Eigen::RowVector3d(-15 * DEG, 0, 0);
  } else if (name == "knee_bent") {
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << -35 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::LEFT_KNEE)) << 60 * DEG, 0, 0;
  } else if (name == "legs_apart") {
    lower_arms(p, 70, rest);
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << 0, 0, 15 * DEG;
    p.axis_angle.row(idx(Joint::RIGHT_HIP)) << 0, 0, -15 * DEG;
  } else if (name == "demo") {
    lower_arms(p, 72, rest);
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << -30 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::LEFT_KNEE)) << 50 * DEG, 0, 0;
  } else if (name == "contrapposto") {
    lower_arms(p, 70, rest);
    p.axis_angle.row(idx(Joint::PELVIS)) << 0, 10 * DEG, 0;
    p.axis_angle.row(idx(Joint::SPINE2)) << 0, -8 * DEG, 4 * DEG;
    p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 15 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::LEFT_ELBOW)) << 0, -30 * DEG, 0;
  } else {
    std::string all;
    for (const auto& n : named_pose_names())
      all += (all.empty() ? "" : ", ") + n;
    throw Error("--pose", 0, "unknown pose '" + std::string(name) + "' (expected a JSON file or one of " + all + ")");
  }
  return p;
}

namespace {

// One pose object (read_pose_json()'s two forms); `where` prefixes the keys in messages
// ("frames[3]." for a sequence's fourth frame).
Pose pose_from_json(const nlohmann::json& j, const std::string& file, const std::string& where) {
  if (!j.is_object())
    throw Error(file, 0,
                (where.empty() ? "" : "'" + where.substr(0, where.size() - 1) + "': ") +
                    "expected a JSON object of joint names");
  auto vec3 = [&](const std::string& key, const nlohmann::json& v) { return json_input::vec3(v, file, where + key); };
  Pose p;
  for (const auto& [key, value] : j.items()) {
    if (key == "translation") {
      p.translation = vec3(key, value);
    } else if (key == "pose") {
      if (!value.is_array() || value.size() != 3 * JOINT_COUNT)
        throw Error(file, 0, "'" + where + "pose': expected 72 numbers");
      for (int k = 0; k < 3 * JOINT_COUNT; ++k) {
        if (!value[k].is_number() || !std::isfinite(value[k].get<double>()))
          throw Error(file, 0, "'" + where + "pose': not a finite number at " + std::to_string(k));
        p.axis_angle(k / 3, k % 3) = value[k].get<double>();
      }
    } else {
      const auto joint = key == "global_orient" ? std::optional<int>(0) : joint_from_name(key);
      if (!joint)
        throw Error(file, 0, "unknown joint '" + where + key + "' (expected SMPL joint names such as left_elbow)");
      const Eigen::Vector3d r = vec3(key, value);
      if (r.norm() > 2 * std::numbers::pi)
        throw Error(file, 0, "'" + where + key + "': rotation angle above 2π (radians expected)");
      p.axis_angle.row(*joint) = r.transpose();
    }
  }
  return p;
}

} // namespace

Pose read_pose_json(const std::filesystem::path& path) {
  const std::string file = path.string();
  return pose_from_json(json_input::read_file(path), file, "");
}

PoseSequence walk_cycle(RestPose rest, double fps, std::size_t frames) {
  if (!(fps > 0) || !std::isfinite(fps) || frames == 0)
    throw Error("walk cycle", 0, "needs a positive rate and at least one frame");
  PoseSequence out;
  out.fps = fps;
  for (std::size_t k = 0; k < frames; ++k) {
    const double phase = 2 * std::numbers::pi * double(k) / double(frames);
    const double swing = std::sin(phase);
    Pose p;
    lower_arms(p, 72, rest);
    // Thighs swing ±25° in opposition; each knee bends up to 45° while its leg swings forward.
    p.axis_angle.row(idx(Joint::LEFT_HIP)) << -25 * DEG * swing, 0, 0;
    p.axis_angle.row(idx(Joint::RIGHT_HIP)) << 25 * DEG * swing, 0, 0;
    p.axis_angle.row(idx(Joint::LEFT_KNEE)) << 45 * DEG * std::max(0.0, std::sin(phase + 0.8)), 0, 0;
    p.axis_angle.row(idx(Joint::RIGHT_KNEE)) << 45 * DEG * std::max(0.0, -std::sin(phase + 0.8)), 0, 0;
    // Arms swing ±15° against the legs, elbows a little bent.
    p.axis_angle.row(idx(Joint::LEFT_SHOULDER)) += Eigen::RowVector3d(15 * DEG * swing, 0, 0);
    p.axis_angle.row(idx(Joint::RIGHT_SHOULDER)) += Eigen::RowVector3d(-15 * DEG * swing, 0, 0);
    p.axis_angle.row(idx(Joint::LEFT_ELBOW)) << -15 * DEG, 0, 0;
    p.axis_angle.row(idx(Joint::RIGHT_ELBOW)) << -15 * DEG, 0, 0;
    // The pelvis dips 1 cm as the legs pass each other, twice a cycle.
    p.translation.y() = -0.01 * (1 - std::abs(std::cos(phase)));
    out.frames.push_back(p);
  }
  return out;
}

std::string pose_sequence_json(const PoseSequence& sequence) {
  std::string out = "{\"fps\": " + std::to_string(sequence.fps) + ", \"frames\": [\n";
  for (std::size_t k = 0; k < sequence.frames.size(); ++k)
    out += (k ? ",\n" : "") + pose_json(sequence.frames[k]);
  return out + "]}\n";
}

PoseSequence read_pose_sequence_json(const std::filesystem::path& path) {
  const std::string file = path.string();
  const nlohmann::json j = json_input::read_file(path);
  if (!j.is_object() || !j.contains("frames")) throw Error(file, 0, "expected {\"fps\": N, \"frames\": [pose, ...]}");
  PoseSequence out;
  if (!j.contains("fps") || !j["fps"].is_number() || !(j["fps"].get<double>() > 0) ||
      !std::isfinite(j["fps"].get<double>()) || j["fps"].get<double>() > 1000)
    throw Error(file, 0, "'fps': expected a number of frames per second in (0, 1000]");
  out.fps = j["fps"].get<double>();
  const nlohmann::json& frames = j["frames"];
  if (!frames.is_array() || frames.empty()) throw Error(file, 0, "'frames': expected a non-empty array of poses");
  for (std::size_t k = 0; k < frames.size(); ++k)
    out.frames.push_back(pose_from_json(frames[k], file, "frames[" + std::to_string(k) + "]."));
  for (const auto& [key, value] : j.items())
    if (key != "fps" && key != "frames") throw Error(file, 0, "unknown key '" + key + "' (expected fps and frames)");
  return out;
}

std::string pose_json(const Pose& pose) {
  nlohmann::ordered_json j;
  for (int k = 0; k < JOINT_COUNT; ++k)
    if (!pose.axis_angle.row(k).isZero(0.0))
      j[k == 0 ? std::string("global_orient") : std::string(joint_name(k))] = {
          pose.axis_angle(k, 0), pose.axis_angle(k, 1), pose.axis_angle(k, 2)};
  j["translation"] = {pose.translation.x(), pose.translation.y(), pose.translation.z()};
  return j.dump(2) + "\n";
}

} // namespace vfit
