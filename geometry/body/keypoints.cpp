// SPDX-License-Identifier: Apache-2.0
#include "keypoints.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <nlohmann/json.hpp>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

constexpr std::array<std::string_view, BODY_POINT_COUNT - JOINT_COUNT> LANDMARK_NAMES = {
    "nose",      "left_eye",      "right_eye",        "left_ear",          "right_ear",    "head_top",
    "neck_base", "mid_hip",       "left_hip_surface", "right_hip_surface", "left_big_toe", "left_small_toe",
    "left_heel", "right_big_toe", "right_small_toe",  "right_heel"};

// OpenPose BODY_25, in its order: Nose, Neck, RShoulder, RElbow, RWrist, LShoulder, LElbow,
// LWrist, MidHip, RHip, RKnee, RAnkle, LHip, LKnee, LAnkle, REye, LEye, REar, LEar, LBigToe,
// LSmallToe, LHeel, RBigToe, RSmallToe, RHeel.
constexpr std::array<std::string_view, 25> BODY25_NAMES = {
    "Nose", "Neck",    "RShoulder", "RElbow", "RWrist",  "LShoulder", "LElbow", "LWrist", "MidHip",
    "RHip", "RKnee",   "RAnkle",    "LHip",   "LKnee",   "LAnkle",    "REye",   "LEye",   "REar",
    "LEar", "LBigToe", "LSmallToe", "LHeel",  "RBigToe", "RSmallToe", "RHeel"};
const std::array<int, 25> BODY25_POINTS = {idx(Landmark::NOSE),
                                           idx(Landmark::NECK_BASE),
                                           idx(Joint::RIGHT_SHOULDER),
                                           idx(Joint::RIGHT_ELBOW),
                                           idx(Joint::RIGHT_WRIST),
                                           idx(Joint::LEFT_SHOULDER),
                                           idx(Joint::LEFT_ELBOW),
                                           idx(Joint::LEFT_WRIST),
                                           idx(Landmark::MID_HIP),
                                           idx(Landmark::RIGHT_HIP_SURFACE),
                                           idx(Joint::RIGHT_KNEE),
                                           idx(Joint::RIGHT_ANKLE),
                                           idx(Landmark::LEFT_HIP_SURFACE),
                                           idx(Joint::LEFT_KNEE),
                                           idx(Joint::LEFT_ANKLE),
                                           idx(Landmark::RIGHT_EYE),
                                           idx(Landmark::LEFT_EYE),
                                           idx(Landmark::RIGHT_EAR),
                                           idx(Landmark::LEFT_EAR),
                                           idx(Landmark::LEFT_BIG_TOE),
                                           idx(Landmark::LEFT_SMALL_TOE),
                                           idx(Landmark::LEFT_HEEL),
                                           idx(Landmark::RIGHT_BIG_TOE),
                                           idx(Landmark::RIGHT_SMALL_TOE),
                                           idx(Landmark::RIGHT_HEEL)};
// COCO-18 (OpenPose's COCO model): BODY_25 without MidHip and the feet, in its own order.
const std::array<int, 18> COCO18_POINTS = {
    idx(Landmark::NOSE),     idx(Landmark::NECK_BASE), idx(Joint::RIGHT_SHOULDER),
    idx(Joint::RIGHT_ELBOW), idx(Joint::RIGHT_WRIST),  idx(Joint::LEFT_SHOULDER),
    idx(Joint::LEFT_ELBOW),  idx(Joint::LEFT_WRIST),   idx(Landmark::RIGHT_HIP_SURFACE),
    idx(Joint::RIGHT_KNEE),  idx(Joint::RIGHT_ANKLE),  idx(Landmark::LEFT_HIP_SURFACE),
    idx(Joint::LEFT_KNEE),   idx(Joint::LEFT_ANKLE),   idx(Landmark::RIGHT_EYE),
    idx(Landmark::LEFT_EYE), idx(Landmark::RIGHT_EAR), idx(Landmark::LEFT_EAR)};
const std::array<int, 14> LSP14_POINTS = {idx(Joint::RIGHT_ANKLE),
                                          idx(Joint::RIGHT_KNEE),
                                          idx(Landmark::RIGHT_HIP_SURFACE),
                                          idx(Landmark::LEFT_HIP_SURFACE),
                                          idx(Joint::LEFT_KNEE),
                                          idx(Joint::LEFT_ANKLE),
                                          idx(Joint::RIGHT_WRIST),
                                          idx(Joint::RIGHT_ELBOW),
                                          idx(Joint::RIGHT_SHOULDER),
                                          idx(Joint::LEFT_SHOULDER),
                                          idx(Joint::LEFT_ELBOW),
                                          idx(Joint::LEFT_WRIST),
                                          idx(Joint::NECK),
                                          idx(Landmark::HEAD_TOP)};

bool is_torso_point(int p) {
  return p == idx(Joint::LEFT_SHOULDER) || p == idx(Joint::RIGHT_SHOULDER) || p == idx(Landmark::LEFT_HIP_SURFACE) ||
         p == idx(Landmark::RIGHT_HIP_SURFACE) || p == idx(Joint::LEFT_HIP) || p == idx(Joint::RIGHT_HIP);
}

double finite_number(const nlohmann::json& v, const std::string& source, const std::string& element) {
  if (!v.is_number() || !std::isfinite(v.get<double>())) throw Error(source, 0, element + ": not a finite number");
  return v.get<double>();
}

double confidence_value(const nlohmann::json& v, const std::string& source, const std::string& element) {
  const double c = finite_number(v, source, element + " confidence");
  if (c < 0 || c > 1) throw Error(source, 0, element + ": confidence " + std::to_string(c) + " outside [0, 1]");
  return c;
}

struct RawPerson {
  std::vector<Keypoint2D> all; // every keypoint read, confident or not
  double confidence_sum = 0;
};

// A flat x, y, c array of `layout`'s keypoints.
RawPerson read_flat(const nlohmann::json& arr, KeypointLayout layout, const std::string& source,
                    const std::string& element) {
  RawPerson p;
  const std::size_t count = arr.size() / 3;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string el = element + "[" + std::to_string(i) + "]";
    Keypoint2D k;
    k.point = keypoint_body_point(layout, static_cast<int>(i));
    k.pixel = {finite_number(arr[3 * i], source, el + " x"), finite_number(arr[3 * i + 1], source, el + " y")};
    k.confidence = confidence_value(arr[3 * i + 2], source, el);
    p.confidence_sum += k.confidence;
    p.all.push_back(k);
  }
  return p;
}

KeypointLayout openpose_layout(std::size_t numbers, KeypointLayout forced, const std::string& source,
                               const std::string& element) {
  const KeypointLayout detected = numbers == 75   ? KeypointLayout::BODY_25
                                  : numbers == 54 ? KeypointLayout::COCO_18
                                                  : KeypointLayout::AUTO;
  if (forced != KeypointLayout::AUTO && forced != KeypointLayout::BODY_25 && forced != KeypointLayout::COCO_18)
    throw Error(source, 0,
                "an OpenPose file holds BODY_25 or COCO-18 keypoints, not " +
                    std::string(keypoint_layout_name(forced)));
  if (detected == KeypointLayout::AUTO)
    throw Error(source, 0,
                element + ": unknown keypoint layout: " + std::to_string(numbers) +
                    " numbers (expected 75 for BODY_25 or 54 for COCO-18, as x, y, confidence)");
  if (forced != KeypointLayout::AUTO && forced != detected)
    throw Error(source, 0,
                element + ": " + std::to_string(numbers) + " numbers do not match the layout " +
                    std::string(keypoint_layout_name(forced)));
  return detected;
}

} // namespace

std::string_view body_point_name(int point) {
  if (point >= 0 && point < JOINT_COUNT) return joint_name(point);
  if (point >= JOINT_COUNT && point < BODY_POINT_COUNT)
    return LANDMARK_NAMES[static_cast<std::size_t>(point - JOINT_COUNT)];
  return "unknown";
}

std::string_view keypoint_layout_name(KeypointLayout layout) {
  switch (layout) {
  case KeypointLayout::AUTO: return "auto";
  case KeypointLayout::BODY_25: return "body25";
  case KeypointLayout::COCO_18: return "coco18";
  case KeypointLayout::LSP_14: return "lsp14";
  case KeypointLayout::NAMED: return "named";
  }
  return "auto";
}

std::optional<KeypointLayout> keypoint_layout_from_name(std::string_view name) {
  if (name == "auto") return KeypointLayout::AUTO;
  if (name == "body25" || name == "body_25") return KeypointLayout::BODY_25;
  if (name == "coco18" || name == "coco_18" || name == "coco") return KeypointLayout::COCO_18;
  if (name == "lsp14" || name == "lsp") return KeypointLayout::LSP_14;
  if (name == "named") return KeypointLayout::NAMED;
  return std::nullopt;
}

int keypoint_body_point(KeypointLayout layout, int index) {
  auto pick = [index](const auto& table) {
    return index >= 0 && index < static_cast<int>(table.size()) ? table[static_cast<std::size_t>(index)] : -1;
  };
  switch (layout) {
  case KeypointLayout::BODY_25: return pick(BODY25_POINTS);
  case KeypointLayout::COCO_18: return pick(COCO18_POINTS);
  case KeypointLayout::LSP_14: return pick(LSP14_POINTS);
  default: return -1;
  }
}

int named_body_point(std::string_view name) {
  if (auto j = joint_from_name(name)) return *j;
  for (std::size_t i = 0; i < BODY25_NAMES.size(); ++i)
    if (BODY25_NAMES[i] == name) return BODY25_POINTS[i];
  if (name == "head_top" || name == "HeadTop") return idx(Landmark::HEAD_TOP);
  return -1;
}

double default_focal_length(double width, double height) { return 1.2 * std::max(width, height); }

Keypoints parse_keypoints(const std::string& json_text, const std::string& source, const KeypointOptions& options) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(source, 0, std::string("invalid JSON: ") + e.what());
  }
  if (!doc.is_object()) throw Error(source, 0, "expected a JSON object with \"people\", \"keypoints\" or \"joints\"");
  Keypoints kp;
  kp.source = source;
  RawPerson person;

  if (doc.contains("people")) {
    const auto& people = doc["people"];
    if (!people.is_array()) throw Error(source, 0, "'people': expected an array");
    if (people.empty()) throw Error(source, 0, "no person: 'people' is empty");
    std::size_t best = 0;
    for (std::size_t i = 0; i < people.size(); ++i) {
      const std::string el = "people[" + std::to_string(i) + "].pose_keypoints_2d";
      if (!people[i].is_object() || !people[i].contains("pose_keypoints_2d")) throw Error(source, 0, el + ": missing");
      const auto& arr = people[i]["pose_keypoints_2d"];
      if (!arr.is_array()) throw Error(source, 0, el + ": expected an array of numbers");
      const KeypointLayout layout = openpose_layout(arr.size(), options.layout, source, el);
      RawPerson p = read_flat(arr, layout, source, el);
      if (i == 0 || p.confidence_sum > person.confidence_sum) {
        person = std::move(p);
        kp.layout = layout;
        best = i;
      }
    }
    if (people.size() > 1)
      kp.warnings.push_back(source + ": " + std::to_string(people.size()) + " people; using person " +
                            std::to_string(best) + " (highest summed keypoint confidence), ignoring the others");
  } else if (doc.contains("keypoints")) {
    const std::string layout_name =
        doc.contains("layout") && doc["layout"].is_string() ? doc["layout"].get<std::string>() : "";
    const auto layout = keypoint_layout_from_name(layout_name);
    if (!layout || *layout != KeypointLayout::LSP_14)
      throw Error(source, 0,
                  "'layout': unknown keypoint layout '" + layout_name + "' for \"keypoints\" (expected \"lsp\")");
    if (options.layout != KeypointLayout::AUTO && options.layout != KeypointLayout::LSP_14)
      throw Error(source, 0, "the file holds LSP keypoints, not " + std::string(keypoint_layout_name(options.layout)));
    kp.layout = KeypointLayout::LSP_14;
    const auto& arr = doc["keypoints"];
    if (!arr.is_array()) throw Error(source, 0, "'keypoints': expected an array");
    nlohmann::json flat = nlohmann::json::array();
    if (!arr.empty() && arr[0].is_array()) {
      for (std::size_t i = 0; i < arr.size(); ++i) {
        if (!arr[i].is_array() || arr[i].size() != 3)
          throw Error(source, 0, "keypoints[" + std::to_string(i) + "]: expected [x, y, v]");
        for (const auto& v : arr[i])
          flat.push_back(v);
      }
    } else {
      flat = arr;
    }
    if (flat.size() != 42)
      throw Error(source, 0,
                  "'keypoints': unknown keypoint layout: LSP has 14 keypoints (42 numbers), got " +
                      std::to_string(flat.size()) + " numbers");
    person = read_flat(flat, KeypointLayout::LSP_14, source, "keypoints");
  } else if (doc.contains("joints")) {
    if (options.layout != KeypointLayout::AUTO && options.layout != KeypointLayout::NAMED)
      throw Error(source, 0, "the file holds named joints, not " + std::string(keypoint_layout_name(options.layout)));
    kp.layout = KeypointLayout::NAMED;
    const auto& joints = doc["joints"];
    if (!joints.is_object()) throw Error(source, 0, "'joints': expected an object of name: [x, y, c]");
    for (const auto& [name, v] : joints.items()) {
      const int point = named_body_point(name);
      if (point < 0)
        throw Error(source, 0, "joints." + name + ": unknown joint name (use SMPL or OpenPose BODY_25 names)");
      if (!v.is_array() || (v.size() != 2 && v.size() != 3))
        throw Error(source, 0, "joints." + name + ": expected [x, y] or [x, y, c]");
      Keypoint2D k;
      k.point = point;
      k.pixel = {finite_number(v[0], source, "joints." + name + " x"),
                 finite_number(v[1], source, "joints." + name + " y")};
      k.confidence = v.size() == 3 ? confidence_value(v[2], source, "joints." + name) : 1.0;
      for (const auto& other : person.all)
        if (other.point == point) throw Error(source, 0, "joints." + name + ": the same body point is given twice");
      person.confidence_sum += k.confidence;
      person.all.push_back(k);
    }
  } else {
    throw Error(source, 0,
                "unknown keypoint layout: expected \"people\" (OpenPose), \"keypoints\" with \"layout\": \"lsp\", or "
                "\"joints\"");
  }

  // Image size and focal length: options, else the file.
  if (options.image_size) {
    kp.image_size = *options.image_size;
  } else if (doc.contains("image_size")) {
    const auto& s = doc["image_size"];
    if (!s.is_array() || s.size() != 2) throw Error(source, 0, "'image_size': expected [width, height]");
    kp.image_size = {finite_number(s[0], source, "image_size[0]"), finite_number(s[1], source, "image_size[1]")};
  } else {
    throw Error(source, 0, "image size unknown: the file has no \"image_size\": [W, H]; pass --image-size W H");
  }
  if (!(kp.image_size.minCoeff() > 0)) throw Error(source, 0, "image size must be positive");
  if (options.focal) {
    kp.focal = *options.focal;
    kp.focal_given = true;
  } else if (doc.contains("focal")) {
    kp.focal = finite_number(doc["focal"], source, "focal");
    kp.focal_given = true;
  } else {
    kp.focal = default_focal_length(kp.image_size.x(), kp.image_size.y());
  }
  if (!(kp.focal > 0)) throw Error(source, 0, "focal length must be positive (px)");

  int torso = 0;
  for (const Keypoint2D& k : person.all) {
    if (k.confidence <= options.min_confidence) continue;
    kp.points.push_back(k);
    torso += is_torso_point(k.point) ? 1 : 0;
  }
  const int n = static_cast<int>(kp.points.size());
  if (n < MIN_CONFIDENT_KEYPOINTS || torso < MIN_TORSO_KEYPOINTS)
    throw Error(source, 0,
                "too few confident keypoints: " + std::to_string(n) + " above confidence " +
                    std::to_string(options.min_confidence).substr(0, 4) + " (" + std::to_string(torso) +
                    " of the 4 shoulders and hips); a fit needs at least " + std::to_string(MIN_CONFIDENT_KEYPOINTS) +
                    ", including " + std::to_string(MIN_TORSO_KEYPOINTS) + " of the shoulders and hips");
  return kp;
}

Keypoints read_keypoints(const std::filesystem::path& path, const KeypointOptions& options) {
  return parse_keypoints(read_file_bytes(path), path.string(), options);
}

} // namespace vfit
