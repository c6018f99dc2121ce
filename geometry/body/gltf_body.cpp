// SPDX-License-Identifier: Apache-2.0
// A glTF skinned mesh as a vfit::Body: skin, bind pose, rig mapping and weight transfer.
#include "gltf_body.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <unordered_map>

#include <Eigen/LU>

#include "vfit/geometry/mesh/gltf_document.h"
#include "vfit/geometry/mesh/units.h"
#include "vfit/kernels/error.h"

namespace vfit {
namespace {

using gltf::GltfDocument;
using gltf::Json;

// Every node's parent (−1 for roots) and world transform from the hierarchy as stored.
struct NodeTree {
  std::vector<std::int64_t> parent;
  std::vector<Eigen::Matrix4d> world;
};

NodeTree node_tree(const GltfDocument& doc) {
  const std::size_t n = doc.array_size("nodes");
  NodeTree tree;
  tree.parent.assign(n, -1);
  std::vector<std::vector<std::size_t>> children(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Json& node = doc.element("nodes", i, "node");
    const auto c = node.find("children");
    if (c == node.end()) continue;
    if (!c->is_array()) throw doc.fail("node " + std::to_string(i) + ": 'children' is not an array");
    for (const Json& v : *c) {
      const std::uint64_t child = doc.as_index(v, "node " + std::to_string(i) + " child");
      if (child >= n)
        throw doc.fail("node " + std::to_string(i) + ": child " + std::to_string(child) + " does not exist");
      if (tree.parent[child] >= 0 || child == i)
        throw doc.fail("node " + std::to_string(child) + " has two parents (the hierarchy is not a tree)");
      tree.parent[child] = static_cast<std::int64_t>(i);
      children[i].push_back(child);
    }
  }
  // Top-down from the roots; a node never reached sits on a cycle.
  tree.world.assign(n, Eigen::Matrix4d::Identity());
  std::vector<char> reached(n, 0);
  std::vector<std::size_t> stack;
  for (std::size_t i = 0; i < n; ++i)
    if (tree.parent[i] < 0) stack.push_back(i);
  while (!stack.empty()) {
    const std::size_t i = stack.back();
    stack.pop_back();
    reached[i] = 1;
    const Eigen::Matrix4d local = doc.local_transform(doc.element("nodes", i, "node"), i);
    tree.world[i] = tree.parent[i] < 0 ? local : Eigen::Matrix4d(tree.world[tree.parent[i]] * local);
    stack.insert(stack.end(), children[i].begin(), children[i].end());
  }
  if (const auto it = std::find(reached.begin(), reached.end(), 0); it != reached.end())
    throw doc.fail("node " + std::to_string(it - reached.begin()) + " lies on a cycle of the node hierarchy");
  return tree;
}

// The first node, depth-first in scene order, with both a mesh and a skin.
std::size_t find_skinned_node(const GltfDocument& doc, const NodeTree& tree) {
  std::vector<std::size_t> stack = doc.scene_roots();
  std::reverse(stack.begin(), stack.end());
  std::vector<std::vector<std::size_t>> children(tree.parent.size());
  for (std::size_t i = 0; i < tree.parent.size(); ++i)
    if (tree.parent[i] >= 0) children[tree.parent[i]].push_back(i);
  while (!stack.empty()) {
    const std::size_t n = stack.back();
    stack.pop_back();
    const Json& node = doc.element("nodes", n, "node");
    if (node.contains("mesh") && node.contains("skin")) return n;
    stack.insert(stack.end(), children[n].rbegin(), children[n].rend());
  }
  throw doc.fail("no skinned mesh (no node of the scene has both a 'mesh' and a 'skin')");
}

// The skin's joints: node indices and bind-pose world matrices (inverse of the inverse bind matrices).
struct Skin {
  std::vector<std::size_t> nodes;
  std::vector<Eigen::Matrix4d> bind_world;
};

Skin read_skin(GltfDocument& doc, std::size_t s, const NodeTree& tree) {
  const std::string owner = "skin " + std::to_string(s);
  const Json& skin = doc.element("skins", s, "skin");
  const auto joints = skin.find("joints");
  if (joints == skin.end() || !joints->is_array() || joints->empty()) throw doc.fail(owner + " has no joints");
  Skin out;
  for (const Json& j : *joints) {
    const std::uint64_t node = doc.as_index(j, owner + " joint");
    if (node >= tree.parent.size()) throw doc.fail(owner + ": joint node " + std::to_string(node) + " does not exist");
    out.nodes.push_back(node);
  }
  if (!skin.contains("inverseBindMatrices")) {
    // The spec's default is identity matrices: the joints' current world transforms are the bind pose.
    for (std::size_t node : out.nodes)
      out.bind_world.push_back(tree.world[node]);
    return out;
  }
  const std::uint64_t a = doc.index(skin, "inverseBindMatrices", owner);
  const std::vector<float> ibm = doc.read_floats(a, "inverseBindMatrices", 16, false);
  if (ibm.size() < 16 * out.nodes.size())
    throw doc.fail("accessor " + std::to_string(a) + ": " + std::to_string(ibm.size() / 16) +
                   " inverseBindMatrices for the " + std::to_string(out.nodes.size()) + " joints of " + owner);
  for (std::size_t k = 0; k < out.nodes.size(); ++k) {
    const Eigen::Matrix4d m = Eigen::Map<const Eigen::Matrix4f>(ibm.data() + 16 * k).cast<double>();
    const double det = m.topLeftCorner<3, 3>().determinant();
    if (!std::isfinite(det) || std::abs(det) < 1e-12)
      throw doc.fail("accessor " + std::to_string(a) + ": inverse bind matrix " + std::to_string(k) + " of " + owner +
                     " is singular");
    out.bind_world.push_back(m.inverse());
  }
  return out;
}

// Canonical joint of each skin joint's weight: that of its nearest mapped ancestor-or-self.
std::vector<int> weight_targets(const GltfDocument& doc, const Skin& skin, const NodeTree& tree,
                                const RigMapping& mapping, JointPositions& joints) {
  std::unordered_map<std::string, std::size_t> slot_of_bone;
  std::vector<std::string> names(skin.nodes.size());
  for (std::size_t k = 0; k < skin.nodes.size(); ++k) {
    names[k] = doc.node_name(skin.nodes[k]);
    slot_of_bone.try_emplace(names[k], k);
  }
  std::vector<int> joint_of_node(tree.parent.size(), -1);
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const std::string& bone = mapping.bone_for_joint[j];
    const std::string what =
        "rig mapping " + mapping.name + ": bone \"" + bone + "\" of joint " + std::string(joint_name(j));
    const auto it = slot_of_bone.find(bone);
    if (it == slot_of_bone.end()) throw doc.fail(what + " is not a joint of the skin");
    if (std::count(names.begin(), names.end(), bone) > 1) throw doc.fail(what + " names two skin joints");
    const std::size_t node = skin.nodes[it->second];
    if (joint_of_node[node] >= 0)
      throw doc.fail(what + " is already the bone of " + std::string(joint_name(joint_of_node[node])));
    joint_of_node[node] = j;
    joints.row(j) = skin.bind_world[it->second].topRightCorner<3, 1>().transpose();
  }
  for (int j = 0; j < JOINT_COUNT; ++j) {
    const JointAnchor& anchor = mapping.anchors[j];
    if (anchor.toward.empty()) continue;
    const auto it = slot_of_bone.find(anchor.toward);
    if (it == slot_of_bone.end())
      throw doc.fail("rig mapping " + mapping.name + ": bone \"" + anchor.toward + "\" that anchors joint " +
                     std::string(joint_name(j)) + " is not a joint of the skin");
    const Eigen::RowVector3d toward = skin.bind_world[it->second].topRightCorner<3, 1>().transpose();
    joints.row(j) += anchor.fraction * (toward - joints.row(j));
  }
  std::vector<int> target(skin.nodes.size(), idx(Joint::PELVIS));
  for (std::size_t k = 0; k < skin.nodes.size(); ++k)
    for (std::int64_t n = static_cast<std::int64_t>(skin.nodes[k]); n >= 0; n = tree.parent[n])
      if (joint_of_node[n] >= 0) {
        target[k] = joint_of_node[n];
        break;
      }
  return target;
}

// Adds the primitive's JOINTS_n/WEIGHTS_n to `dense` (#V × 24) for the welded vertices not yet `done`.
void add_primitive_weights(GltfDocument& doc, const gltf::PrimitiveVertices& prim, const std::vector<int>& target,
                           std::vector<double>& dense, std::vector<char>& done) {
  const std::string owner = "primitive " + std::to_string(prim.primitive) + " of mesh " + std::to_string(prim.mesh);
  const Json& attributes =
      doc.element("meshes", prim.mesh, "mesh").at("primitives").at(prim.primitive).at("attributes");
  std::vector<std::vector<std::uint32_t>> joint_sets;
  std::vector<std::vector<float>> weight_sets;
  std::vector<std::uint64_t> joint_accessors;
  for (int set = 0;; ++set) {
    const std::string joints_key = "JOINTS_" + std::to_string(set), weights_key = "WEIGHTS_" + std::to_string(set);
    const bool has_joints = attributes.contains(joints_key), has_weights = attributes.contains(weights_key);
    if (!has_joints && !has_weights && set > 0) break;
    if (!has_joints || !has_weights)
      throw doc.fail(owner + " has " +
                     (has_joints ? joints_key + " but no " + weights_key
                                 : (has_weights ? weights_key + " but no " : "no ") + joints_key));
    const std::uint64_t ja = doc.index(attributes, joints_key.c_str(), owner);
    const std::uint64_t wa = doc.index(attributes, weights_key.c_str(), owner);
    joint_sets.push_back(doc.read_unsigned(ja, joints_key.c_str(), 4));
    weight_sets.push_back(doc.read_floats(wa, weights_key.c_str(), 4, true));
    joint_accessors.push_back(ja);
    if (joint_sets.back().size() != 4 * prim.welded.size() || weight_sets.back().size() != 4 * prim.welded.size())
      throw doc.fail(owner + ": " + joints_key + " or " + weights_key + " count differs from POSITION's (" +
                     std::to_string(prim.welded.size()) + ")");
  }
  for (std::size_t i = 0; i < prim.welded.size(); ++i) {
    const std::int32_t v = prim.welded[i];
    for (std::size_t set = 0; set < joint_sets.size(); ++set)
      for (std::size_t k = 4 * i; k < 4 * i + 4; ++k) {
        const std::uint32_t j = joint_sets[set][k];
        const float w = weight_sets[set][k];
        if (j >= target.size())
          throw doc.fail("accessor " + std::to_string(joint_accessors[set]) + ": JOINTS_" + std::to_string(set) +
                         " element " + std::to_string(i) + " names joint " + std::to_string(j) + ", the skin has " +
                         std::to_string(target.size()));
        if (!std::isfinite(w) || w < 0.0f)
          throw doc.fail(owner + ": WEIGHTS_" + std::to_string(set) + " element " + std::to_string(i) +
                         " holds a negative or non-finite weight");
        if (v >= 0 && !done[v]) dense[std::size_t(v) * JOINT_COUNT + target[j]] += w;
      }
    if (v < 0 || done[v]) continue;
    const double* row = dense.data() + std::size_t(v) * JOINT_COUNT;
    if (std::all_of(row, row + JOINT_COUNT, [](double w) { return w <= 0.0; }))
      throw doc.fail(owner + ": vertex " + std::to_string(i) + " has all its weights zero");
    done[v] = 1;
  }
}

// Scales a body stored in dm, cm, mm or inches to metres.
void convert_to_metres(Body& body, const std::string& path, std::vector<std::string>& warnings) {
  const auto p = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      body.mesh.positions.data(), static_cast<Eigen::Index>(body.mesh.vertex_count()), 3);
  const double extent = (p.colwise().maxCoeff() - p.colwise().minCoeff()).maxCoeff();
  const double reach = p.cwiseAbs().maxCoeff();
  const std::optional<Units> units = detect_body_units(extent, reach);
  if (!units) throw Error(path, 0, "cannot infer the units of a body " + std::to_string(extent) + " units tall");
  if (*units == Units::M) return;
  const double factor = metres_per_unit(*units);
  scale_positions(body.mesh.positions, factor);
  body.joints *= factor;
  warnings.push_back(path + ": the body's largest extent is " + std::to_string(extent) + ", read as " +
                     units_name(*units) + " and scaled to metres");
  if (const std::string w = body_units_warning(extent, reach, *units); w.find(" it would be ") != std::string::npos)
    warnings.push_back(path + ": " + w);
}

} // namespace

RestPose classify_rest_pose(const JointPositions& joints) {
  double sum = 0.0;
  for (auto [shoulder, elbow] :
       {std::pair{Joint::LEFT_SHOULDER, Joint::LEFT_ELBOW}, std::pair{Joint::RIGHT_SHOULDER, Joint::RIGHT_ELBOW}}) {
    const Eigen::Vector3d d = (joints.row(idx(elbow)) - joints.row(idx(shoulder))).transpose();
    if (!(d.norm() > 0.0)) return RestPose::OTHER;
    sum += std::asin(std::clamp(-d.y() / d.norm(), -1.0, 1.0)) * 180.0 / std::numbers::pi;
  }
  const double below_horizontal = sum / 2.0;
  if (std::abs(below_horizontal) < 20.0) return RestPose::TPOSE;
  if (below_horizontal <= 70.0) return RestPose::APOSE;
  return RestPose::OTHER;
}

Body parse_gltf_body(std::string_view bytes, const std::string& path, const std::optional<RigMapping>& mapping,
                     std::vector<std::string>* warnings) {
  std::vector<std::string> notes;
  Body body;
  try {
    GltfDocument doc(bytes, path);
    doc.check_required_extensions();
    const NodeTree tree = node_tree(doc);
    const std::size_t node_index = find_skinned_node(doc, tree);
    const Json& node = doc.element("nodes", node_index, "node");
    const std::string owner = "node " + std::to_string(node_index);
    const Skin skin = read_skin(doc, doc.index(node, "skin", owner), tree);

    std::vector<std::string> bones;
    for (std::size_t n : skin.nodes)
      bones.push_back(doc.node_name(n));
    const RigMapping rig = mapping ? *mapping : detect_rig_mapping(bones, path);
    notes.push_back(path + ": rig mapping " + rig.name + " (" + std::to_string(bones.size()) + " bones)");
    const std::vector<int> target = weight_targets(doc, skin, tree, rig, body.joints);

    gltf::GltfMeshBuilder builder(doc);
    builder.add_mesh(doc.index(node, "mesh", owner), Eigen::Matrix4d::Identity());
    ParsedMesh parsed = builder.finish();
    const std::size_t nv = parsed.mesh.vertex_count();
    std::vector<double> dense(nv * JOINT_COUNT, 0.0);
    std::vector<char> done(nv, 0);
    for (const gltf::PrimitiveVertices& prim : builder.primitive_vertices())
      add_primitive_weights(doc, prim, target, dense, done);
    body.mesh = std::move(parsed.mesh);
    body.weights = SkinWeights::from_dense(dense, JOINT_COUNT);
    notes.insert(notes.begin(), parsed.warnings.begin(), parsed.warnings.end());
  } catch (const Json::exception& e) {
    throw Error(path, 0, std::string("invalid glTF: ") + e.what());
  }
  convert_to_metres(body, path, notes);
  body.rest_pose = classify_rest_pose(body.joints);
  body.source = path;
  validate_skin_weights(body.weights, body.mesh.vertex_count(), path);
  if (warnings) warnings->insert(warnings->end(), notes.begin(), notes.end());
  return body;
}

Body read_gltf_body(const std::string& path, const std::optional<RigMapping>& mapping,
                    std::vector<std::string>* warnings) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, 0, "cannot read the file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_gltf_body(bytes, path, mapping, warnings);
}

} // namespace vfit
