// SPDX-License-Identifier: Apache-2.0
#include "retarget.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>

#include <nlohmann/json.hpp>

#include "vfit/geometry/body/rig_mapping.h"
#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

using J = Joint;

// The conventions BVH rigs use beyond the glTF rigs' own (rig_mapping.h: SMPL and Mixamo
// names, taken from there): per canonical joint, its BVH name, or alternatives separated by
// '|', or "".
struct Convention {
  const char* name;
  std::array<const char*, JOINT_COUNT> joint;
};

// Canonical order: pelvis, left_hip, right_hip, spine1, left_knee, right_knee, spine2,
// left_ankle, right_ankle, spine3, left_foot, right_foot, neck, left_collar, right_collar, head,
// left_shoulder, right_shoulder, left_elbow, right_elbow, left_wrist, right_wrist, left_hand,
// right_hand.
const std::vector<Convention>& conventions() {
  static const std::vector<Convention> all = {
      {"cmu", {"Hips",        "LeftUpLeg",    "RightUpLeg",    "LowerBack", "LeftLeg",        "RightLeg",
               "Spine",       "LeftFoot",     "RightFoot",     "Spine1",    "LeftToeBase",    "RightToeBase",
               "Neck",        "LeftShoulder", "RightShoulder", "Head",      "LeftArm",        "RightArm",
               "LeftForeArm", "RightForeArm", "LeftHand",      "RightHand", "LeftFingerBase", "RightFingerBase"}},
      {"motionbuilder",
       {"Hips",
        "LeftHip",
        "RightHip",
        "Chest",
        "LeftKnee",
        "RightKnee",
        "",
        "LeftAnkle",
        "RightAnkle",
        "Chest2|CS_BVH",
        "LeftToe",
        "RightToe",
        "Neck",
        "LeftCollar",
        "RightCollar",
        "Head",
        "LeftShoulder",
        "RightShoulder",
        "LeftElbow",
        "RightElbow",
        "LeftWrist",
        "RightWrist",
        "",
        ""}},
      {"daz", {"hip",    "lThigh", "rThigh",   "abdomen",  "lShin", "rShin",   "",        "lFoot",
               "rFoot",  "chest",  "lToe",     "rToe",     "neck",  "lCollar", "rCollar", "head",
               "lShldr", "rShldr", "lForeArm", "rForeArm", "lHand", "rHand",   "lMid1",   "rMid1"}},
      {"makehuman", {"root",         "upperleg01.L", "upperleg01.R", "spine04", "lowerleg01.L", "lowerleg01.R",
                     "spine03",      "foot.L",       "foot.R",       "spine02", "toe3-1.L",     "toe3-1.R",
                     "neck01",       "clavicle.L",   "clavicle.R",   "head",    "upperarm01.L", "upperarm01.R",
                     "lowerarm01.L", "lowerarm01.R", "wrist.L",      "wrist.R", "finger3-1.L",  "finger3-1.R"}},
      {"makehuman_old",
       {"Root",    "UpLeg_L", "UpLeg_R", "Spine1",  "LoLeg_L", "LoLeg_R",    "Spine2",     "Foot_L",
        "Foot_R",  "Spine3",  "Toe_L",   "Toe_R",   "Neck",    "Clavicle_L", "Clavicle_R", "Head",
        "UpArm_L", "UpArm_R", "LoArm_L", "LoArm_R", "Hand_L",  "Hand_R",     "Middle1_L",  "Middle1_R"}},
  };
  return all;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// A BVH name compared without case and without a "prefix:" (mixamorig:Hips → hips).
std::string key(std::string_view name) {
  const std::size_t colon = name.rfind(':');
  return lower(colon == std::string_view::npos ? name : name.substr(colon + 1));
}

const std::array<J, 15> REQUIRED = {J::PELVIS,      J::LEFT_HIP,    J::RIGHT_HIP,     J::LEFT_KNEE,      J::RIGHT_KNEE,
                                    J::LEFT_ANKLE,  J::RIGHT_ANKLE, J::LEFT_SHOULDER, J::RIGHT_SHOULDER, J::LEFT_ELBOW,
                                    J::RIGHT_ELBOW, J::LEFT_WRIST,  J::RIGHT_WRIST,   J::NECK,           J::SPINE1};

// The canonical joint whose bone a joint's rotation turns (its child along the chain), or −1
// for the ends (head, hands, feet) and the pelvis and chest (framed by two directions).
int chain_child(int j) {
  switch (static_cast<J>(j)) {
  case J::LEFT_HIP: return idx(J::LEFT_KNEE);
  case J::RIGHT_HIP: return idx(J::RIGHT_KNEE);
  case J::LEFT_KNEE: return idx(J::LEFT_ANKLE);
  case J::RIGHT_KNEE: return idx(J::RIGHT_ANKLE);
  case J::LEFT_ANKLE: return idx(J::LEFT_FOOT);
  case J::RIGHT_ANKLE: return idx(J::RIGHT_FOOT);
  case J::SPINE1: return idx(J::SPINE2);
  case J::SPINE2: return idx(J::SPINE3);
  case J::NECK: return idx(J::HEAD);
  case J::LEFT_COLLAR: return idx(J::LEFT_SHOULDER);
  case J::RIGHT_COLLAR: return idx(J::RIGHT_SHOULDER);
  case J::LEFT_SHOULDER: return idx(J::LEFT_ELBOW);
  case J::RIGHT_SHOULDER: return idx(J::RIGHT_ELBOW);
  case J::LEFT_ELBOW: return idx(J::LEFT_WRIST);
  case J::RIGHT_ELBOW: return idx(J::RIGHT_WRIST);
  case J::LEFT_WRIST: return idx(J::LEFT_HAND);
  case J::RIGHT_WRIST: return idx(J::RIGHT_HAND);
  default: return -1;
  }
}

// The rotation of least angle taking direction a onto direction b (both non-zero).
Eigen::Matrix3d align(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
}

// An orthonormal frame (columns x, y, z) with y along `up` and x along `side` made normal to it.
Eigen::Matrix3d frame(const Eigen::Vector3d& up, const Eigen::Vector3d& side) {
  const Eigen::Vector3d y = up.normalized();
  const Eigen::Vector3d x = (side - side.dot(y) * y).normalized();
  Eigen::Matrix3d f;
  f.col(0) = x;
  f.col(1) = y;
  f.col(2) = x.cross(y);
  return f;
}

// The two-direction frames: the pelvis (up the spine, across the hips) and the chest (up the
// neck, across the shoulders).
struct Framing {
  int up_from, up_to, side_left, side_right;
};

} // namespace

bool motion_mapping_complete(const MotionMapping& mapping, std::string* missing) {
  std::string list;
  for (const J j : REQUIRED) {
    if (j == J::NECK &&
        (!mapping.joint[std::size_t(idx(J::NECK))].empty() || !mapping.joint[std::size_t(idx(J::HEAD))].empty()))
      continue;
    if (j == J::SPINE1 &&
        (!mapping.joint[std::size_t(idx(J::SPINE1))].empty() || !mapping.joint[std::size_t(idx(J::SPINE2))].empty() ||
         !mapping.joint[std::size_t(idx(J::SPINE3))].empty()))
      continue;
    if (!mapping.joint[std::size_t(idx(j))].empty()) continue;
    list += (list.empty() ? "" : ", ") + std::string(j == J::NECK     ? "neck or head"
                                                     : j == J::SPINE1 ? "a spine joint"
                                                                      : joint_name(idx(j)));
  }
  if (missing) *missing = list;
  return list.empty();
}

std::vector<std::string> builtin_motion_mappings() {
  std::vector<std::string> names = {"smpl", "mixamo"};
  for (const Convention& c : conventions())
    names.emplace_back(c.name);
  return names;
}

MotionMapping builtin_motion_mapping(std::string_view name) {
  MotionMapping m;
  m.name = std::string(name);
  if (name == "smpl" || name == "mixamo") {
    m.joint = builtin_rig_mapping(name).bone_for_joint;
    return m;
  }
  for (const Convention& c : conventions())
    if (name == c.name) {
      for (int j = 0; j < JOINT_COUNT; ++j) {
        const std::string_view all = c.joint[std::size_t(j)];
        m.joint[std::size_t(j)] = std::string(all.substr(0, all.find('|')));
      }
      return m;
    }
  std::string known;
  for (const std::string& n : builtin_motion_mappings())
    known += (known.empty() ? "" : ", ") + n;
  throw Error("motion mapping", 0, "unknown convention '" + std::string(name) + "' (known: " + known + ")");
}

MotionMapping detect_motion_mapping(const BvhMotion& motion) {
  std::map<std::string, std::string> by_key; // key → the file's spelling
  for (const BvhJoint& j : motion.joints)
    if (!j.end_site) by_key.emplace(key(j.name), j.name);
  struct Candidate {
    MotionMapping mapping;
    std::size_t found = 0;
    std::string missing;
  };
  std::optional<Candidate> best_complete, best_any;
  auto consider = [&](const std::string& name, const std::array<std::string, JOINT_COUNT>& names) {
    Candidate c;
    c.mapping.name = name;
    for (int j = 0; j < JOINT_COUNT; ++j) {
      std::string_view all = names[std::size_t(j)];
      while (!all.empty()) {
        const std::size_t bar = all.find('|');
        const auto it = by_key.find(key(all.substr(0, bar)));
        if (it != by_key.end()) {
          c.mapping.joint[std::size_t(j)] = it->second;
          ++c.found;
          break;
        }
        all = bar == std::string_view::npos ? std::string_view{} : all.substr(bar + 1);
      }
    }
    const bool complete = motion_mapping_complete(c.mapping, &c.missing);
    if (!best_any || c.found > best_any->found) best_any = c;
    if (complete && (!best_complete || c.found > best_complete->found)) best_complete = c;
  };
  for (const char* rig : {"smpl", "mixamo"})
    consider(rig, builtin_rig_mapping(rig).bone_for_joint);
  for (const Convention& c : conventions()) {
    std::array<std::string, JOINT_COUNT> names;
    for (int j = 0; j < JOINT_COUNT; ++j)
      names[std::size_t(j)] = c.joint[std::size_t(j)];
    consider(c.name, names);
  }
  if (best_complete) return best_complete->mapping;
  throw Error(motion.source, 0,
              "no built-in joint-name convention fits this rig: the closest, '" + best_any->mapping.name + "', finds " +
                  std::to_string(best_any->found) + " of 24 joints and misses " + best_any->missing +
                  "; give a mapping file ({\"pelvis\": \"<joint>\", \"left_hip\": ..., see docs/cli.md})");
}
MotionMapping parse_motion_mapping(std::string_view json_text, const std::string& path) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path, 0, std::string("invalid JSON: ") + e.what());
  }
  if (!doc.is_object()) throw Error(path, 0, "expected a JSON object from canonical joint names to BVH joint names");
  MotionMapping m;
  m.name = path;
  std::map<std::string, std::string> used;
  for (const auto& [k, v] : doc.items()) {
    const std::optional<int> j = joint_from_name(k);
    if (!j) throw Error(path, 0, "'" + k + "' is not a canonical joint name (pelvis, left_hip, ..., right_hand)");
    if (!v.is_string() || v.get<std::string>().empty())
      throw Error(path, 0, "'" + k + "': expected the name of a BVH joint");
    const std::string name = v.get<std::string>();
    if (const auto [it, fresh] = used.emplace(name, k); !fresh)
      throw Error(path, 0, "'" + k + "': BVH joint '" + name + "' is already mapped to '" + it->second + "'");
    m.joint[std::size_t(*j)] = name;
  }
  std::string missing;
  if (!motion_mapping_complete(m, &missing)) throw Error(path, 0, "the mapping misses " + missing);
  return m;
}

MotionMapping load_motion_mapping(const std::string& path) { return parse_motion_mapping(read_file_bytes(path), path); }

RetargetedMotion retarget_bvh(const BvhMotion& motion, const JointPositions& rest, const MotionMapping& mapping) {
  std::string missing;
  if (!motion_mapping_complete(mapping, &missing))
    throw Error(motion.source, 0, "the joint mapping '" + mapping.name + "' misses " + missing);
  // b[j]: the BVH joint driving canonical joint j, or −1.
  std::array<std::int32_t, JOINT_COUNT> b{};
  RetargetedMotion out;
  out.mapping = mapping.name;
  out.fps = motion.fps();
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const std::string& name = mapping.joint[std::size_t(j)];
    b[std::size_t(j)] = name.empty() ? -1 : motion.find(name);
    if (!name.empty() && b[std::size_t(j)] < 0)
      throw Error(motion.source, 0,
                  "the mapping '" + mapping.name + "' maps " + std::string(joint_name(j)) + " to '" + name +
                      "', which is not a joint of the file");
    if (b[std::size_t(j)] < 0) out.unmapped.push_back(j);
  }
  auto mapped = [&](J j) { return b[std::size_t(idx(j))] >= 0; };
  // The rig's axes into ours: its up axis to +Y, its left (left hip − right hip) to +X.
  const std::vector<Eigen::Vector3d> rest_bvh = bvh_rest_positions(motion);
  const std::array<double, 3> u = up_axis_vector(motion.up);
  const Eigen::Vector3d up(u[0], u[1], u[2]);
  const Eigen::Vector3d rig_left = rest_bvh[std::size_t(b[std::size_t(idx(J::LEFT_HIP))])] -
                                   rest_bvh[std::size_t(b[std::size_t(idx(J::RIGHT_HIP))])];
  if ((rig_left - rig_left.dot(up) * up).norm() <= 0)
    throw Error(motion.source, 0, "the rig's hips coincide across its up axis: cannot tell its left from its right");
  const Eigen::Matrix3d C = frame(up, rig_left).transpose(); // rows: the rig's left, up and forward
  const double s = motion.metres_per_unit;
  auto to_ours = [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(s * (C * p)); };
  auto ours = [&](int j) { return Eigen::Vector3d(rest.row(j).transpose()); };

  std::vector<Eigen::Vector3d> rest_rig(rest_bvh.size());
  for (std::size_t i = 0; i < rest_bvh.size(); ++i)
    rest_rig[i] = to_ours(rest_bvh[i]);
  auto rig_rest = [&](int j) { return rest_rig[std::size_t(b[std::size_t(j)])]; };

  // Each chain joint's bone: to its next mapped descendant along the chain.
  std::array<int, JOINT_COUNT> target{};
  std::array<Eigen::Matrix3d, JOINT_COUNT> alignment{};
  for (int j = 0; j < JOINT_COUNT; ++j) {
    target[std::size_t(j)] = -1;
    alignment[std::size_t(j)] = Eigen::Matrix3d::Identity();
    if (b[std::size_t(j)] < 0) continue;
    int c = chain_child(j);
    while (c >= 0 && b[std::size_t(c)] < 0)
      c = chain_child(c);
    if (c < 0) continue;
    const Eigen::Vector3d d_ours = ours(c) - ours(j), d_rig = rig_rest(c) - rig_rest(j);
    // A bone without length (CMU's hand joints sit on their wrists) has no direction: the joint
    // is driven as an end.
    if (d_ours.norm() <= 1e-9 || d_rig.norm() <= 1e-9) continue;
    target[std::size_t(j)] = c;
    alignment[std::size_t(j)] = align(d_ours, d_rig);
  }
  // Ends (head, hands, feet) take their parent's alignment.
  for (int j = 0; j < JOINT_COUNT; ++j)
    if (target[std::size_t(j)] < 0 && j != idx(J::PELVIS) && joint_parent(j) >= 0)
      alignment[std::size_t(j)] = alignment[std::size_t(joint_parent(j))];

  // Root motion: hips above the ankles at rest, on both skeletons; the clip's floor is the lowest
  // its ankles go.
  const double hips_ours =
      ours(idx(J::PELVIS)).y() - std::min(ours(idx(J::LEFT_ANKLE)).y(), ours(idx(J::RIGHT_ANKLE)).y());
  const double hips_rig =
      rig_rest(idx(J::PELVIS)).y() - std::min(rig_rest(idx(J::LEFT_ANKLE)).y(), rig_rest(idx(J::RIGHT_ANKLE)).y());
  if (!(hips_ours > 0) || !(hips_rig > 0))
    throw Error(motion.source, 0, "the hips are not above the ankles at rest: cannot scale the root's motion");
  out.leg_ratio = hips_ours / hips_rig;

  // The first of `list` that is mapped and stands apart from `from` at rest on both skeletons, by
  // 2 % of each one's hips-above-ankles height (a CMU rig's LowerBack sits on its Hips).
  auto first_apart = [&](J from, std::initializer_list<J> list) {
    for (const J j : list)
      if (mapped(j) && (ours(idx(j)) - ours(idx(from))).norm() > 0.02 * hips_ours &&
          (rig_rest(idx(j)) - rig_rest(idx(from))).norm() > 0.02 * hips_rig)
        return idx(j);
    return -1;
  };
  const int pelvis_up = first_apart(J::PELVIS, {J::SPINE1, J::SPINE2, J::SPINE3, J::NECK, J::HEAD});
  if (pelvis_up < 0) throw Error(motion.source, 0, "no spine or neck joint stands apart from the pelvis at rest");
  const Framing pelvis_framing{idx(J::PELVIS), pelvis_up, idx(J::LEFT_HIP), idx(J::RIGHT_HIP)};
  const int chest_up = mapped(J::SPINE3) ? first_apart(J::SPINE3, {J::NECK, J::HEAD}) : -1;
  std::optional<Framing> chest_framing;
  if (chest_up >= 0) chest_framing = Framing{idx(J::SPINE3), chest_up, idx(J::LEFT_SHOULDER), idx(J::RIGHT_SHOULDER)};
  auto rest_frame = [&](const Framing& f) {
    return frame(ours(f.up_to) - ours(f.up_from), ours(f.side_left) - ours(f.side_right));
  };
  const Eigen::Matrix3d pelvis_rest = rest_frame(pelvis_framing);
  const Eigen::Matrix3d chest_rest = chest_framing ? rest_frame(*chest_framing) : Eigen::Matrix3d::Identity();

  const std::size_t frames = motion.frame_count();
  std::vector<std::vector<Eigen::Vector3d>> positions(frames);
  std::vector<std::vector<Eigen::Matrix3d>> rotations(frames);
  double floor = INFINITY;
  for (std::size_t f = 0; f < frames; ++f) {
    const std::vector<Eigen::Isometry3d> world = bvh_world_transforms(motion, f);
    positions[f].resize(world.size());
    rotations[f].resize(world.size());
    for (std::size_t i = 0; i < world.size(); ++i) {
      positions[f][i] = to_ours(world[i].translation());
      rotations[f][i] = C * world[i].linear() * C.transpose();
    }
    for (const J ankle : {J::LEFT_ANKLE, J::RIGHT_ANKLE})
      floor = std::min(floor, positions[f][std::size_t(b[std::size_t(idx(ankle))])].y());
  }

  const Eigen::Vector3d start = frames > 0 ? positions[0][std::size_t(b[0])] : Eigen::Vector3d::Zero();
  out.frames.resize(frames);
  for (std::size_t f = 0; f < frames; ++f) {
    const std::vector<Eigen::Vector3d>& P = positions[f];
    auto posed = [&](int j) { return P[std::size_t(b[std::size_t(j)])]; };
    auto posed_frame = [&](const Framing& fr) {
      return frame(posed(fr.up_to) - posed(fr.up_from), posed(fr.side_left) - posed(fr.side_right));
    };
    std::array<Eigen::Matrix3d, JOINT_COUNT> G;
    Pose& pose = out.frames[f];
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const int parent = joint_parent(j);
      const Eigen::Matrix3d parent_world = parent >= 0 ? G[std::size_t(parent)] : Eigen::Matrix3d::Identity();
      if (j == idx(J::PELVIS)) {
        G[0] = posed_frame(pelvis_framing) * pelvis_rest.transpose();
      } else if (chest_framing && j == chest_framing->up_from) {
        G[std::size_t(j)] = posed_frame(*chest_framing) * chest_rest.transpose();
      } else if (b[std::size_t(j)] < 0) {
        G[std::size_t(j)] = parent_world;
      } else {
        Eigen::Matrix3d g = rotations[f][std::size_t(b[std::size_t(j)])] * alignment[std::size_t(j)];
        if (const int c = target[std::size_t(j)]; c >= 0) {
          // Turned on so that the bone points where the rig's posed bone points.
          const Eigen::Vector3d turned = g * (ours(c) - ours(j)), wanted = posed(c) - posed(j);
          if (wanted.norm() > 0) g = align(turned, wanted) * g;
        }
        G[std::size_t(j)] = g;
      }
      pose.axis_angle.row(j) = matrix_to_axis_angle(parent_world.transpose() * G[std::size_t(j)]).transpose();
    }
    const Eigen::Vector3d root = P[std::size_t(b[0])];
    pose.translation = out.leg_ratio * Eigen::Vector3d(root.x() - start.x(), root.y() - floor, root.z() - start.z());
    pose.translation.y() -= hips_ours;
    if (!pose.axis_angle.allFinite() || !pose.translation.allFinite())
      throw Error(motion.source, 0,
                  "frame " + std::to_string(f + 1) + ": the rig's joints are degenerate (coincident hips or spine)");
  }
  return out;
}

std::vector<Pose> resample_poses(const std::vector<Pose>& frames, double from_fps, double to_fps) {
  if (!(from_fps > 0) || !(to_fps > 0) || !std::isfinite(from_fps) || !std::isfinite(to_fps))
    throw Error("motion", 0,
                "frame rates must be positive, got " + std::to_string(from_fps) + " and " + std::to_string(to_fps));
  if (frames.size() < 2) return frames;
  const double duration = double(frames.size() - 1) / from_fps;
  const auto count = static_cast<std::size_t>(std::floor(duration * to_fps + 1e-9)) + 1;
  std::vector<Pose> out(count);
  for (std::size_t k = 0; k < count; ++k) {
    const double t = double(k) / to_fps * from_fps;
    const auto i = std::min(static_cast<std::size_t>(std::floor(t)), frames.size() - 2);
    const double w = std::clamp(t - double(i), 0.0, 1.0);
    const Pose& a = frames[i];
    const Pose& c = frames[i + 1];
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const Eigen::Quaterniond qa(axis_angle_to_matrix(a.axis_angle.row(j).transpose()));
      const Eigen::Quaterniond qc(axis_angle_to_matrix(c.axis_angle.row(j).transpose()));
      out[k].axis_angle.row(j) = matrix_to_axis_angle(qa.slerp(w, qc).toRotationMatrix()).transpose();
    }
    out[k].translation = (1 - w) * a.translation + w * c.translation;
  }
  return out;
}

BvhMotion poses_to_bvh(const JointPositions& rest, const std::vector<Pose>& frames, double fps) {
  if (!(fps > 0) || !std::isfinite(fps)) throw Error("motion", 0, "fps must be positive, got " + std::to_string(fps));
  constexpr double CM = 100.0;
  BvhMotion m;
  m.source = "poses";
  m.frame_time = 1.0 / fps;
  std::array<std::vector<int>, JOINT_COUNT> children;
  for (int j = 1; j < JOINT_COUNT; ++j)
    children[std::size_t(joint_parent(j))].push_back(j);
  std::array<std::int32_t, JOINT_COUNT> index{};
  std::array<std::size_t, JOINT_COUNT> column{};
  // Depth first from the pelvis, so that each joint's subtree follows it.
  auto add = [&](auto&& self, int j) -> void {
    BvhJoint joint;
    joint.name = std::string(joint_name(j));
    const int parent = joint_parent(j);
    joint.parent = parent < 0 ? -1 : index[std::size_t(parent)];
    joint.offset = CM * (parent < 0 ? Eigen::Vector3d(rest.row(j).transpose())
                                    : Eigen::Vector3d((rest.row(j) - rest.row(parent)).transpose()));
    if (parent < 0) joint.channels = {BvhChannel::X_POSITION, BvhChannel::Y_POSITION, BvhChannel::Z_POSITION};
    joint.channels.insert(joint.channels.end(),
                          {BvhChannel::Z_ROTATION, BvhChannel::Y_ROTATION, BvhChannel::X_ROTATION});
    joint.first_column = m.columns;
    joint.absolute_position = parent < 0;
    column[std::size_t(j)] = m.columns;
    m.columns += joint.channels.size();
    index[std::size_t(j)] = std::int32_t(m.joints.size());
    m.joints.push_back(std::move(joint));
    for (const int c : children[std::size_t(j)])
      self(self, c);
    if (children[std::size_t(j)].empty()) {
      // An end site continuing the last bone by a quarter of its length (a leaf has no bone of its own).
      BvhJoint end;
      end.name = std::string(joint_name(j)) + "/End Site";
      end.parent = index[std::size_t(j)];
      end.end_site = true;
      end.first_column = m.columns;
      end.offset = 0.25 * CM * Eigen::Vector3d((rest.row(j) - rest.row(parent)).transpose());
      m.joints.push_back(std::move(end));
    }
  };
  add(add, 0);
  m.values.assign(frames.size() * m.columns, 0.0);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    double* row = m.values.data() + f * m.columns;
    const Eigen::Vector3d root = CM * (Eigen::Vector3d(rest.row(0).transpose()) + frames[f].translation);
    for (int k = 0; k < 3; ++k)
      row[k] = root[k];
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const Eigen::Matrix3d R = axis_angle_to_matrix(frames[f].axis_angle.row(j).transpose());
      const Eigen::Vector3d zyx = R.eulerAngles(2, 1, 0) * (180.0 / std::numbers::pi);
      const std::size_t c = column[std::size_t(j)] + (j == 0 ? 3 : 0);
      for (int k = 0; k < 3; ++k)
        row[c + std::size_t(k)] = zyx[k];
    }
  }
  const std::vector<Eigen::Vector3d> rest_positions = bvh_rest_positions(m);
  m.up = bvh_infer_up(m, rest_positions);
  bvh_infer_unit(m, rest_positions, m.up);
  return m;
}

SkinAnimation poses_to_skin_animation(const JointPositions& rest, const std::vector<Pose>& frames, double fps,
                                      const std::string& name) {
  if (frames.empty()) throw Error(name, 0, "no frames to animate");
  if (!(fps > 0) || !std::isfinite(fps)) throw Error(name, 0, "fps must be positive, got " + std::to_string(fps));
  SkinAnimation a;
  a.name = name;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    a.times.push_back(float(double(k) / fps));
    for (int j = 0; j < JOINT_COUNT; ++j) {
      const Eigen::Quaterniond q(axis_angle_to_matrix(frames[k].axis_angle.row(j).transpose()));
      a.rotations.insert(a.rotations.end(), {float(q.x()), float(q.y()), float(q.z()), float(q.w())});
    }
    const Eigen::Vector3d root = rest.row(0).transpose() + frames[k].translation;
    a.root_positions.insert(a.root_positions.end(), {float(root.x()), float(root.y()), float(root.z())});
  }
  return a;
}

} // namespace vfit
