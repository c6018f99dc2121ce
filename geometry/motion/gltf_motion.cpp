// SPDX-License-Identifier: Apache-2.0
#include "gltf_motion.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "vfit/geometry/mesh/atomic_write.h"
#include "vfit/geometry/mesh/gltf_document.h"
#include "vfit/kernels/error.h"

namespace vfit {

namespace {

using gltf::Json;

enum class Path { TRANSLATION, ROTATION, SCALE };
enum class Interpolation { LINEAR, STEP, CUBICSPLINE };

// One animated property of one node.
struct Track {
  std::size_t node = 0;
  Path path = Path::TRANSLATION;
  Interpolation interpolation = Interpolation::LINEAR;
  std::vector<float> times;
  std::vector<float> values; // #keys × (components, ×3 for CUBICSPLINE: in-tangent, value, out-tangent)
  int components() const { return path == Path::ROTATION ? 4 : 3; }

  // The property at time t (clamped to the keyframes).
  Eigen::VectorXd at(double t) const {
    const int c = components();
    const std::size_t n = times.size();
    const std::size_t stride = interpolation == Interpolation::CUBICSPLINE ? 3 * std::size_t(c) : std::size_t(c);
    const std::size_t value_at = interpolation == Interpolation::CUBICSPLINE ? std::size_t(c) : 0;
    auto key = [&](std::size_t k, std::size_t offset) {
      Eigen::VectorXd v(c);
      for (int i = 0; i < c; ++i)
        v[i] = values[k * stride + offset + std::size_t(i)];
      return v;
    };
    if (t <= times.front() || n == 1) return key(0, value_at);
    if (t >= times.back()) return key(n - 1, value_at);
    // The last key at or before t (compared in double: t may round to a key's float), below the last.
    const auto after =
        std::upper_bound(times.begin(), times.end(), t, [](double value, float time) { return value < double(time); });
    const std::size_t k = std::min(std::size_t(after - times.begin()) - 1, n - 2);
    const double dt = double(times[k + 1]) - double(times[k]);
    const double u = std::clamp((t - double(times[k])) / dt, 0.0, 1.0);
    Eigen::VectorXd v;
    if (interpolation == Interpolation::STEP) {
      v = key(k, 0);
    } else if (interpolation == Interpolation::CUBICSPLINE) {
      const double u2 = u * u, u3 = u2 * u;
      v = (2 * u3 - 3 * u2 + 1) * key(k, value_at) + (u3 - 2 * u2 + u) * dt * key(k, 2 * std::size_t(c)) +
          (-2 * u3 + 3 * u2) * key(k + 1, value_at) + (u3 - u2) * dt * key(k + 1, 0);
    } else if (path == Path::ROTATION) {
      const Eigen::VectorXd a = key(k, 0), b = key(k + 1, 0);
      const Eigen::Quaterniond qa(a[3], a[0], a[1], a[2]), qb(b[3], b[0], b[1], b[2]);
      const Eigen::Quaterniond q = qa.normalized().slerp(u, qb.normalized());
      v.resize(4);
      v << q.x(), q.y(), q.z(), q.w();
    } else {
      v = (1 - u) * key(k, 0) + u * key(k + 1, 0);
    }
    if (path == Path::ROTATION && v.norm() > 0) v /= v.norm();
    return v;
  }
};

// A node's local TRS (from its matrix when it has one: decomposed with no shear assumed).
struct Trs {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Quaterniond r = Eigen::Quaterniond::Identity();
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  Eigen::Matrix4d matrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = r.toRotationMatrix() * s.asDiagonal();
    m.topRightCorner<3, 1>() = t;
    return m;
  }
};

// The rotation part of a world matrix with its scale divided out (a rig's armature scale).
Eigen::Matrix3d rotation_of(const Eigen::Matrix4d& m) {
  Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  for (int c = 0; c < 3; ++c) {
    const double n = r.col(c).norm();
    if (n > 0) r.col(c) /= n;
  }
  // Orthonormalise (round-off, non-uniform scale): the nearest rotation by SVD.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d q = svd.matrixU() * svd.matrixV().transpose();
  if (q.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    q = u * svd.matrixV().transpose();
  }
  return q;
}

} // namespace

BvhMotion parse_gltf_motion(std::string_view bytes, const std::string& path, double fps, std::size_t animation) {
  gltf::GltfDocument doc(bytes, path);
  doc.check_required_extensions();
  if (doc.array_size("skins") == 0) throw doc.fail("no skin: an animation needs a skeleton to drive");
  const Json& skin = doc.element("skins", 0, "skin 0");
  if (!skin.contains("joints") || !skin["joints"].is_array() || skin["joints"].empty())
    throw doc.fail("skin 0 has no joints");
  const std::size_t node_count = doc.array_size("nodes");
  std::vector<char> is_joint(node_count, 0);
  for (const Json& j : skin["joints"]) {
    const std::uint64_t n = doc.as_index(j, "skin 0's joints");
    if (n >= node_count) throw doc.fail("skin 0: joint node " + std::to_string(n) + " does not exist");
    is_joint[n] = 1;
  }
  if (doc.array_size("animations") == 0) throw doc.fail("no animation");
  if (animation >= doc.array_size("animations"))
    throw doc.fail("animation " + std::to_string(animation) + " does not exist (" +
                   std::to_string(doc.array_size("animations")) + " animations)");
  const std::string owner = "animation " + std::to_string(animation);
  const Json& anim = doc.element("animations", animation, owner);

  // Static TRS and children of every node.
  std::vector<Trs> rest(node_count);
  std::vector<std::vector<std::size_t>> children(node_count);
  std::vector<std::int64_t> parent(node_count, -1);
  for (std::size_t n = 0; n < node_count; ++n) {
    const Json& node = doc.element("nodes", n, "node " + std::to_string(n));
    const std::string node_owner = "node " + std::to_string(n);
    if (const auto m = doc.numbers(node, "matrix", 16, node_owner)) {
      const Eigen::Matrix4d mm = Eigen::Map<const Eigen::Matrix4d>(m->data());
      rest[n].t = mm.topRightCorner<3, 1>();
      for (int c = 0; c < 3; ++c)
        rest[n].s[c] = mm.topLeftCorner<3, 3>().col(c).norm();
      rest[n].r = Eigen::Quaterniond(rotation_of(mm));
    } else {
      if (const auto t = doc.numbers(node, "translation", 3, node_owner)) rest[n].t << (*t)[0], (*t)[1], (*t)[2];
      if (const auto r = doc.numbers(node, "rotation", 4, node_owner)) {
        rest[n].r = Eigen::Quaterniond((*r)[3], (*r)[0], (*r)[1], (*r)[2]);
        rest[n].r = rest[n].r.norm() > 0 ? rest[n].r.normalized() : Eigen::Quaterniond::Identity();
      }
      if (const auto s = doc.numbers(node, "scale", 3, node_owner)) rest[n].s << (*s)[0], (*s)[1], (*s)[2];
    }
    if (node.contains("children"))
      for (const Json& c : node["children"]) {
        const std::uint64_t child = doc.as_index(c, node_owner + "'s children");
        if (child >= node_count || parent[child] >= 0 || child == n)
          throw doc.fail(node_owner + ": child " + std::to_string(child) + " does not exist or has two parents");
        parent[child] = std::int64_t(n);
        children[n].push_back(child);
      }
  }

  // The animation's tracks.
  if (!anim.contains("channels") || !anim["channels"].is_array() || !anim.contains("samplers") ||
      !anim["samplers"].is_array())
    throw doc.fail(owner + ": expected channels and samplers");
  std::vector<Track> tracks;
  float end = 0;
  std::vector<float> first_input;
  bool shared_input = true;
  std::optional<std::uint64_t> input_accessor;
  for (std::size_t c = 0; c < anim["channels"].size(); ++c) {
    const std::string channel_owner = owner + ", channel " + std::to_string(c);
    const Json& ch = anim["channels"][c];
    if (!ch.is_object() || !ch.contains("target") || !ch["target"].is_object())
      throw doc.fail(channel_owner + ": expected a target");
    const Json& target = ch["target"];
    if (!target.contains("node")) continue; // a channel without a node targets an extension
    Track track;
    track.node = doc.index(target, "node", channel_owner);
    if (track.node >= node_count)
      throw doc.fail(channel_owner + ": node " + std::to_string(track.node) + " does not exist");
    const std::string p = target.value("path", std::string());
    if (p == "translation")
      track.path = Path::TRANSLATION;
    else if (p == "rotation")
      track.path = Path::ROTATION;
    else if (p == "scale")
      track.path = Path::SCALE;
    else if (p == "weights")
      continue; // morph weights do not move the skeleton
    else
      throw doc.fail(channel_owner + ": unknown path '" + p + "'");
    const std::uint64_t s = doc.index(ch, "sampler", channel_owner);
    if (s >= anim["samplers"].size())
      throw doc.fail(channel_owner + ": sampler " + std::to_string(s) + " does not exist");
    const Json& sampler = anim["samplers"][s];
    const std::string interpolation = sampler.value("interpolation", std::string("LINEAR"));
    if (interpolation == "LINEAR")
      track.interpolation = Interpolation::LINEAR;
    else if (interpolation == "STEP")
      track.interpolation = Interpolation::STEP;
    else if (interpolation == "CUBICSPLINE")
      track.interpolation = Interpolation::CUBICSPLINE;
    else
      throw doc.fail(owner + ", sampler " + std::to_string(s) + ": unknown interpolation '" + interpolation + "'");
    const std::uint64_t input = doc.index(sampler, "input", owner + ", sampler " + std::to_string(s));
    const std::uint64_t output = doc.index(sampler, "output", owner + ", sampler " + std::to_string(s));
    track.times = doc.read_floats(input, "animation input", 1, false);
    track.values = doc.read_floats(output, "animation output", track.components(), true);
    const std::size_t per_key =
        std::size_t(track.components()) * (track.interpolation == Interpolation::CUBICSPLINE ? 3 : 1);
    if (track.times.empty() || track.values.size() != track.times.size() * per_key)
      throw doc.fail(owner + ", sampler " + std::to_string(s) + ": " + std::to_string(track.times.size()) +
                     " times but " + std::to_string(track.values.size() / std::size_t(track.components())) + " values");
    for (std::size_t k = 0; k < track.times.size(); ++k)
      if (!std::isfinite(track.times[k]) || (k > 0 && !(track.times[k] > track.times[k - 1])))
        throw doc.fail(owner + ", sampler " + std::to_string(s) + ": time " + std::to_string(k + 1) +
                       " is not finite or not after the one before");
    for (const float v : track.values)
      if (!std::isfinite(v)) throw doc.fail(owner + ", sampler " + std::to_string(s) + ": a value is not finite");
    end = std::max(end, track.times.back());
    if (!input_accessor) {
      input_accessor = input;
      first_input = track.times;
    } else if (*input_accessor != input && track.times != first_input) {
      shared_input = false;
    }
    tracks.push_back(std::move(track));
  }
  if (tracks.empty()) throw doc.fail(owner + ": no channel moves a node");

  // The rate: given, or the keyframes' own when they are evenly spaced, else 30.
  if (fps == 0) {
    fps = 30;
    if (shared_input && first_input.size() > 1) {
      const double step = (double(first_input.back()) - double(first_input.front())) / double(first_input.size() - 1);
      bool even = step > 0;
      for (std::size_t k = 1; k < first_input.size() && even; ++k)
        even = std::abs(double(first_input[k]) - double(first_input[k - 1]) - step) < 1e-3 * step;
      if (even) fps = 1.0 / step;
      // Keyframe times are float32: a rate within 0.01 % of a whole number is that number.
      if (even && std::abs(fps - std::round(fps)) < 1e-4 * fps) fps = std::round(fps);
    }
  }
  if (!(fps > 0) || fps > 1000 || !std::isfinite(fps))
    throw doc.fail("the sampling rate must be in (0, 1000] frames per second, got " + std::to_string(fps));

  // Joints in depth-first order from the scene roots, each under its nearest joint ancestor.
  BvhMotion m;
  m.source = path;
  m.frame_time = 1.0 / fps;
  std::vector<std::int32_t> joint_index(node_count, -1);
  std::vector<std::size_t> joint_node;
  std::vector<char> visited(node_count, 0);
  auto walk = [&](auto&& self, std::size_t n, std::int32_t above) -> void {
    if (visited[n]) throw doc.fail("node " + std::to_string(n) + " is reached twice: the node hierarchy has a cycle");
    visited[n] = 1;
    std::int32_t here = above;
    if (is_joint[n]) {
      here = std::int32_t(m.joints.size());
      BvhJoint j;
      j.name = doc.node_name(n);
      j.parent = above;
      j.channels = {BvhChannel::X_POSITION, BvhChannel::Y_POSITION, BvhChannel::Z_POSITION,
                    BvhChannel::Z_ROTATION, BvhChannel::Y_ROTATION, BvhChannel::X_ROTATION};
      j.first_column = m.columns;
      j.absolute_position = true;
      m.columns += 6;
      joint_index[n] = here;
      joint_node.push_back(n);
      m.joints.push_back(std::move(j));
    }
    for (const std::size_t c : children[n])
      self(self, c, here);
  };
  for (std::size_t n = 0; n < node_count; ++n)
    if (parent[n] < 0) walk(walk, n, -1);
  std::size_t roots = 0;
  for (const BvhJoint& j : m.joints)
    roots += j.parent < 0 ? 1 : 0;
  if (roots != 1) throw doc.fail("skin 0's joints form " + std::to_string(roots) + " trees; one skeleton is needed");

  // World transforms of every node for a set of local TRS.
  auto world_of = [&](const std::vector<Trs>& local) {
    std::vector<Eigen::Matrix4d> world(node_count);
    std::vector<char> done(node_count, 0);
    auto go = [&](auto&& self, std::size_t n, const Eigen::Matrix4d& above) -> void {
      world[n] = above * local[n].matrix();
      done[n] = 1;
      for (const std::size_t c : children[n])
        self(self, c, world[n]);
    };
    for (std::size_t n = 0; n < node_count; ++n)
      if (parent[n] < 0) go(go, n, Eigen::Matrix4d::Identity());
    return world;
  };
  const std::vector<Eigen::Matrix4d> rest_world = world_of(rest);
  std::vector<Eigen::Matrix3d> rest_rotation(m.joints.size());
  for (std::size_t j = 0; j < m.joints.size(); ++j) {
    const Eigen::Matrix4d& w = rest_world[joint_node[j]];
    rest_rotation[j] = rotation_of(w);
    const Eigen::Vector3d p = w.topRightCorner<3, 1>();
    m.joints[j].offset =
        m.joints[j].parent < 0
            ? p
            : Eigen::Vector3d(p - rest_world[joint_node[std::size_t(m.joints[j].parent)]].topRightCorner<3, 1>());
  }

  const auto frames = static_cast<std::size_t>(std::floor(double(end) * fps + 1e-6)) + 1;
  m.values.resize(frames * m.columns);
  std::vector<Trs> local = rest;
  std::vector<Eigen::Matrix3d> W(m.joints.size());
  for (std::size_t f = 0; f < frames; ++f) {
    const double t = double(f) / fps;
    local = rest;
    for (const Track& track : tracks) {
      const Eigen::VectorXd v = track.at(t);
      Trs& trs = local[track.node];
      if (track.path == Path::TRANSLATION)
        trs.t = v.head<3>();
      else if (track.path == Path::SCALE)
        trs.s = v.head<3>();
      else
        trs.r = Eigen::Quaterniond(v[3], v[0], v[1], v[2]);
    }
    const std::vector<Eigen::Matrix4d> world = world_of(local);
    double* row = m.values.data() + f * m.columns;
    for (std::size_t j = 0; j < m.joints.size(); ++j) {
      const Eigen::Matrix4d& w = world[joint_node[j]];
      W[j] = rotation_of(w) * rest_rotation[j].transpose(); // relative to the rest
      const std::int32_t p = m.joints[j].parent;
      const Eigen::Vector3d position =
          p < 0
              ? Eigen::Vector3d(w.topRightCorner<3, 1>())
              : Eigen::Vector3d(W[std::size_t(p)].transpose() *
                                (w.topRightCorner<3, 1>() - world[joint_node[std::size_t(p)]].topRightCorner<3, 1>()));
      const Eigen::Matrix3d local_rotation = p < 0 ? W[j] : Eigen::Matrix3d(W[std::size_t(p)].transpose() * W[j]);
      const Eigen::Vector3d zyx = local_rotation.eulerAngles(2, 1, 0) * (180.0 / std::numbers::pi);
      for (int k = 0; k < 3; ++k) {
        row[m.joints[j].first_column + std::size_t(k)] = position[k];
        row[m.joints[j].first_column + 3 + std::size_t(k)] = zyx[k];
      }
    }
  }
  const std::vector<Eigen::Vector3d> rest_positions = bvh_rest_positions(m);
  m.up = bvh_infer_up(m, rest_positions);
  m.unit = "m";
  m.metres_per_unit = 1;
  return m;
}

BvhMotion read_gltf_motion(const std::filesystem::path& path, double fps, std::size_t animation) {
  return parse_gltf_motion(read_file_bytes(path), path.string(), fps, animation);
}

} // namespace vfit
