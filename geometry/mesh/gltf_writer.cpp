// SPDX-License-Identifier: Apache-2.0
// Writing binary glTF 2.0 (.glb); reading lives in gltf_format.cpp.
#include "gltf_format.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "vfit/kernels/error.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {
namespace {

using Json = nlohmann::json;

static_assert(std::endian::native == std::endian::little, "GLB is little-endian; we write with memcpy");

constexpr std::uint32_t GLB_MAGIC = 0x46546C67;  // "glTF"
constexpr std::uint32_t CHUNK_JSON = 0x4E4F534A; // "JSON"
constexpr std::uint32_t CHUNK_BIN = 0x004E4942;  // "BIN\0"
constexpr int UNSIGNED_SHORT = 5123;
constexpr int UNSIGNED_INT = 5125;
constexpr int FLOAT = 5126;
constexpr int ARRAY_BUFFER = 34962;
constexpr int ELEMENT_ARRAY_BUFFER = 34963;

void append_u32(std::string& out, std::uint32_t v) {
  char bytes[4];
  std::memcpy(bytes, &v, 4);
  out.append(bytes, 4);
}

// One glTF vertex per distinct (position, UV, normal) corner tuple.
struct SplitMesh {
  std::vector<float> positions; // #W × 3
  std::vector<float> normals;   // #W × 3
  std::vector<float> uvs;       // #W × 2, or empty
  std::vector<std::uint32_t> indices;
  std::vector<std::uint32_t> source_vertex; // #W: the input vertex each glTF vertex copies
};

void check_indices(std::span<const std::int32_t> tris, std::size_t faces, std::size_t count, const char* what,
                   const std::string& name) {
  if (tris.size() != 3 * faces)
    throw Error(name, 0,
                std::string(what) + " has " + std::to_string(tris.size()) + " indices, expected " +
                    std::to_string(3 * faces));
  for (std::size_t c = 0; c < tris.size(); ++c)
    if (tris[c] < 0 || static_cast<std::size_t>(tris[c]) >= count)
      throw Error(name, 0,
                  "face " + std::to_string(c / 3 + 1) + ": " + what + " index " + std::to_string(tris[c]) +
                      " out of range");
}

SplitMesh split_vertices(const Mesh& mesh, const std::string& name) {
  if (mesh.positions.size() % 3 != 0) throw Error(name, 0, "positions are not #V × 3");
  if (mesh.face_count() == 0) throw Error(name, 0, "no faces to write");
  for (std::size_t i = 0; i < mesh.positions.size(); ++i)
    if (!std::isfinite(mesh.positions[i]))
      throw Error(name, 0, "vertex " + std::to_string(i / 3 + 1) + " is not finite");
  check_indices(mesh.triangles, mesh.face_count(), mesh.vertex_count(), "vertex", name);
  if (mesh.has_uvs()) check_indices(mesh.uv_triangles, mesh.face_count(), mesh.uvs.size() / 2, "uv", name);
  if (mesh.has_normals())
    check_indices(mesh.normal_triangles, mesh.face_count(), mesh.normals.size() / 3, "normal", name);

  std::vector<float> vertex_normals;
  if (!mesh.has_normals()) vertex_normals_serial(mesh.positions, mesh.triangles, vertex_normals);
  const std::size_t corners = mesh.triangles.size();
  // Tuple t of corner c: its UV and normal (5 floats); a vertex lists the tuples seen at it.
  std::vector<std::array<float, 5>> tuples;
  std::vector<std::vector<std::uint32_t>> tuples_at(mesh.vertex_count());
  std::vector<std::uint32_t> tuple_of(corners);
  for (std::size_t c = 0; c < corners; ++c) {
    const auto v = static_cast<std::size_t>(mesh.triangles[c]);
    std::array<float, 5> t{0, 0, 0, 0, 0};
    if (mesh.has_uvs()) {
      const auto u = static_cast<std::size_t>(mesh.uv_triangles[c]);
      // glTF's UV origin is the image's top-left corner, vfit's (like OBJ's) its bottom-left.
      t[0] = mesh.uvs[2 * u];
      t[1] = 1.0f - mesh.uvs[2 * u + 1];
    }
    const float* n = mesh.has_normals() ? &mesh.normals[3 * static_cast<std::size_t>(mesh.normal_triangles[c])]
                                        : &vertex_normals[3 * v];
    std::copy(n, n + 3, t.begin() + 2);
    // glTF requires unit normals; an isolated or degenerate vertex has none, so give it +Z.
    if (!(t[2] * t[2] + t[3] * t[3] + t[4] * t[4] > 0.0f)) t[2] = t[3] = 0.0f, t[4] = 1.0f;
    // Tuples compare by value, so -0.0 and 0.0 don't split a vertex.
    auto same = [&](std::uint32_t k) { return tuples[k] == t; };
    auto& seen = tuples_at[v];
    const auto found = std::find_if(seen.begin(), seen.end(), same);
    if (found != seen.end()) {
      tuple_of[c] = *found;
    } else {
      tuple_of[c] = static_cast<std::uint32_t>(tuples.size());
      seen.push_back(tuple_of[c]);
      tuples.push_back(t);
    }
  }
  // Emit vertex by vertex, so a mesh without seams keeps its vertex order.
  SplitMesh out;
  std::vector<std::uint32_t> vertex_of_tuple(tuples.size());
  for (std::size_t v = 0; v < tuples_at.size(); ++v) {
    for (std::uint32_t k : tuples_at[v]) {
      vertex_of_tuple[k] = static_cast<std::uint32_t>(out.positions.size() / 3);
      out.source_vertex.push_back(static_cast<std::uint32_t>(v));
      out.positions.insert(out.positions.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
      out.normals.insert(out.normals.end(), tuples[k].begin() + 2, tuples[k].end());
      if (mesh.has_uvs()) out.uvs.insert(out.uvs.end(), tuples[k].begin(), tuples[k].begin() + 2);
    }
  }
  out.indices.resize(corners);
  for (std::size_t c = 0; c < corners; ++c)
    out.indices[c] = vertex_of_tuple[tuple_of[c]];
  return out;
}

// Accumulates the BIN chunk and the bufferViews and accessors that describe it.
class BinaryBuilder {
public:
  /// Appends `data` as a new bufferView (4-byte aligned) and returns an accessor for it.
  /// `target` < 0: no bufferView target (inverse bind matrices must have none).
  template <class T> std::size_t add(const std::vector<T>& data, int components, int component_type, int target) {
    while (m_bin.size() % 4 != 0)
      m_bin += '\0';
    const std::size_t offset = m_bin.size();
    m_bin.append(reinterpret_cast<const char*>(data.data()), data.size() * sizeof(T));
    Json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", data.size() * sizeof(T)}};
    if (target >= 0) view["target"] = target;
    m_views.push_back(std::move(view));
    const char* type = components == 1   ? "SCALAR"
                       : components == 2 ? "VEC2"
                       : components == 3 ? "VEC3"
                       : components == 4 ? "VEC4"
                                         : "MAT4";
    m_accessors.push_back({{"bufferView", m_views.size() - 1},
                           {"componentType", component_type},
                           {"count", data.size() / components},
                           {"type", type}});
    return m_accessors.size() - 1;
  }
  Json& accessor(std::size_t a) { return m_accessors[a]; }

  /// Moves the views and accessors into `doc` and returns the padded BIN chunk.
  std::string finish(Json& doc) {
    while (m_bin.size() % 4 != 0)
      m_bin += '\0';
    if (m_bin.empty()) return {};
    doc["buffers"] = Json::array({{{"byteLength", m_bin.size()}}});
    doc["bufferViews"] = std::move(m_views);
    doc["accessors"] = std::move(m_accessors);
    return std::move(m_bin);
  }

private:
  std::string m_bin;
  Json m_views = Json::array();
  Json m_accessors = Json::array();
};

// The per-component "min" and "max" of a VEC3 accessor over `values` (#N × 3, N ≥ 1), as the
// spec requires of POSITION and of morph targets' POSITION.
void set_bounds(Json& accessor, const std::vector<float>& values) {
  Json lo = Json::array(), hi = Json::array();
  for (std::size_t k = 0; k < 3; ++k) {
    float low = values[k], high = values[k];
    for (std::size_t v = k; v < values.size(); v += 3) {
      low = std::min(low, values[v]);
      high = std::max(high, values[v]);
    }
    lo.push_back(low);
    hi.push_back(high);
  }
  accessor["min"] = std::move(lo);
  accessor["max"] = std::move(hi);
}

// One animation of the skin whose joints are nodes first_node, first_node + 1, ...
Json animation_json(const SkinAnimation& a, const MeshSkin* skin, std::size_t first_node, BinaryBuilder& bin) {
  const std::string name = a.name.empty() ? "animation" : a.name;
  if (!skin) throw Error(name, 0, "an animation needs a skinned mesh to drive");
  const std::size_t nj = skin->joint_names.size(), nk = a.times.size();
  if (nk == 0 || a.rotations.size() != nk * nj * 4 || a.root_positions.size() != nk * 3)
    throw Error(name, 0,
                "sizes do not match: " + std::to_string(nk) + " times, " + std::to_string(a.rotations.size()) +
                    " rotation values (expected times × " + std::to_string(nj) + " joints × 4), " +
                    std::to_string(a.root_positions.size()) + " root position values (expected times × 3)");
  for (std::size_t k = 0; k < nk; ++k)
    if (!std::isfinite(a.times[k]) || (k > 0 && !(a.times[k] > a.times[k - 1])) || a.times[k] < 0)
      throw Error(name, 0, "time " + std::to_string(k + 1) + " is not finite, negative or not after the one before");
  for (const float v : a.rotations)
    if (!std::isfinite(v)) throw Error(name, 0, "a rotation is not finite");
  for (const float v : a.root_positions)
    if (!std::isfinite(v)) throw Error(name, 0, "a root position is not finite");
  std::size_t root = 0;
  while (root < nj && skin->joint_parents[root] >= 0)
    ++root;
  const std::size_t input = bin.add(a.times, 1, FLOAT, -1);
  bin.accessor(input)["min"] = Json::array({a.times.front()});
  bin.accessor(input)["max"] = Json::array({a.times.back()});
  Json samplers = Json::array(), channels = Json::array();
  std::vector<float> track(nk * 4);
  for (std::size_t j = 0; j < nj; ++j) {
    for (std::size_t k = 0; k < nk; ++k)
      for (std::size_t c = 0; c < 4; ++c)
        track[4 * k + c] = a.rotations[(k * nj + j) * 4 + c];
    channels.push_back({{"sampler", samplers.size()}, {"target", {{"node", first_node + j}, {"path", "rotation"}}}});
    samplers.push_back({{"input", input}, {"output", bin.add(track, 4, FLOAT, -1)}, {"interpolation", "LINEAR"}});
  }
  if (root < nj) {
    channels.push_back(
        {{"sampler", samplers.size()}, {"target", {{"node", first_node + root}, {"path", "translation"}}}});
    samplers.push_back(
        {{"input", input}, {"output", bin.add(a.root_positions, 3, FLOAT, -1)}, {"interpolation", "LINEAR"}});
  }
  return {{"name", name}, {"channels", std::move(channels)}, {"samplers", std::move(samplers)}};
}

} // namespace

std::string write_glb(std::span<const NamedMesh> meshes, const SkinAnimation* animation) {
  Json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", "vfit"}};
  Json nodes = Json::array();       // one per mesh, in order
  Json joint_nodes = Json::array(); // after the mesh nodes: node index = meshes.size() + position
  Json gltf_meshes = Json::array();
  Json skins = Json::array();
  std::vector<std::size_t> skin_roots; // root joint nodes, listed in the scene
  Json materials = Json::array();
  // Skins written so far: their skeleton, first joint node and skin index (shared when equal).
  struct WrittenSkin {
    const MeshSkin* skin;
    std::size_t first_node, index;
  };
  std::vector<WrittenSkin> written;
  auto same_skeleton = [](const MeshSkin& a, const MeshSkin& b) {
    return a.joint_names == b.joint_names && a.joint_parents == b.joint_parents &&
           a.joint_positions == b.joint_positions;
  };
  BinaryBuilder bin;
  std::vector<std::pair<std::size_t, std::size_t>> morphed; // (mesh node, target count)
  // Joint nodes come after the mesh nodes.
  std::size_t next_node = meshes.size();
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const std::string name = meshes[i].name.empty() ? "mesh " + std::to_string(i) : meshes[i].name;
    if (!meshes[i].mesh) throw Error(name, 0, "no mesh to write");
    const SplitMesh split = split_vertices(*meshes[i].mesh, name);

    Json attributes;
    const std::size_t position = bin.add(split.positions, 3, FLOAT, ARRAY_BUFFER);
    // The spec requires POSITION bounds; they are of the float values actually stored.
    set_bounds(bin.accessor(position), split.positions);
    attributes["POSITION"] = position;
    attributes["NORMAL"] = bin.add(split.normals, 3, FLOAT, ARRAY_BUFFER);
    if (!split.uvs.empty()) attributes["TEXCOORD_0"] = bin.add(split.uvs, 2, FLOAT, ARRAY_BUFFER);
    const std::size_t indices = bin.add(split.indices, 1, UNSIGNED_INT, ELEMENT_ARRAY_BUFFER);

    Json node = {{"mesh", i}};
    if (const MeshSkin* skin = meshes[i].skin) {
      const std::size_t nj = skin->joint_names.size(), nv = meshes[i].mesh->vertex_count();
      if (skin->joint_parents.size() != nj || skin->joint_positions.size() != 3 * nj || skin->joints.size() != 4 * nv ||
          skin->weights.size() != 4 * nv || nj == 0 || nj > 65535)
        throw Error(name, 0, "skin does not match the mesh (joints, parents, positions, weights)");
      std::vector<std::uint16_t> vj;
      std::vector<float> vw;
      for (std::uint32_t v : split.source_vertex)
        for (int k = 0; k < 4; ++k) {
          const std::int32_t j = skin->joints[4 * v + k];
          if (j < 0 || static_cast<std::size_t>(j) >= nj)
            throw Error(name, 0, "vertex " + std::to_string(v + 1) + ": joint index out of range");
          // An unused slot names joint 0, as the spec asks of a zero weight.
          const float w = skin->weights[4 * v + k];
          vj.push_back(w == 0 ? std::uint16_t{0} : static_cast<std::uint16_t>(j));
          vw.push_back(w);
        }
      attributes["JOINTS_0"] = bin.add(vj, 4, UNSIGNED_SHORT, ARRAY_BUFFER);
      attributes["WEIGHTS_0"] = bin.add(vw, 4, FLOAT, ARRAY_BUFFER);
      const auto shared = std::find_if(written.begin(), written.end(),
                                       [&](const WrittenSkin& w) { return same_skeleton(*w.skin, *skin); });
      if (shared != written.end()) node["skin"] = shared->index;
    }
    if (meshes[i].skin && !node.contains("skin")) {
      const MeshSkin* skin = meshes[i].skin;
      const std::size_t nj = skin->joint_names.size();
      // Joint nodes: translation relative to the parent's bind position; inverse bind matrices
      // undo the bind position (column-major 4×4, rotation-free bind pose).
      std::vector<float> ibm;
      Json skin_joints = Json::array();
      const std::size_t first = next_node;
      for (std::size_t j = 0; j < nj; ++j) {
        const std::int32_t p = skin->joint_parents[j];
        if (p >= static_cast<std::int32_t>(j)) throw Error(name, 0, "skin: a joint's parent must come before it");
        const float* pj = &skin->joint_positions[3 * j];
        Json jn = {{"name", skin->joint_names[j]}};
        jn["translation"] =
            p < 0 ? Json::array({pj[0], pj[1], pj[2]})
                  : Json::array({pj[0] - skin->joint_positions[3 * p], pj[1] - skin->joint_positions[3 * p + 1],
                                 pj[2] - skin->joint_positions[3 * p + 2]});
        joint_nodes.push_back(std::move(jn));
        skin_joints.push_back(first + j);
        if (p < 0)
          skin_roots.push_back(first + j);
        else
          joint_nodes[first + p - meshes.size()]["children"].push_back(first + j);
        const float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -pj[0], -pj[1], -pj[2], 1};
        ibm.insert(ibm.end(), m, m + 16);
      }
      next_node += nj;
      Json skin_json = {{"joints", std::move(skin_joints)}, {"inverseBindMatrices", bin.add(ibm, 16, FLOAT, -1)}};
      if (!skin_roots.empty()) skin_json["skeleton"] = skin_roots.back();
      node["skin"] = skins.size();
      written.push_back({skin, first, skins.size()});
      skins.push_back(std::move(skin_json));
    }
    Json primitive = {{"attributes", std::move(attributes)}, {"indices", indices}, {"mode", 4}};
    if (const MorphFrames* morphs = meshes[i].morphs) {
      const std::size_t nv = meshes[i].mesh->vertex_count();
      if (!animation) throw Error(name, 0, "morph frames need an animation to play them");
      if (morphs->count == 0 || morphs->count != animation->times.size() ||
          morphs->offsets.size() != morphs->count * nv * 3)
        throw Error(name, 0,
                    "morph frames do not match: " + std::to_string(morphs->count) + " frames of " +
                        std::to_string(morphs->offsets.size()) + " values for " + std::to_string(nv) +
                        " vertices and " + std::to_string(animation->times.size()) + " keyframes");
      Json targets = Json::array();
      std::vector<float> target(split.positions.size());
      for (std::size_t k = 0; k < morphs->count; ++k) {
        const float* frame = morphs->offsets.data() + k * nv * 3;
        for (std::size_t w = 0; w < split.source_vertex.size(); ++w)
          for (std::size_t c = 0; c < 3; ++c) {
            const float value = frame[3 * std::size_t(split.source_vertex[w]) + c];
            if (!std::isfinite(value))
              throw Error(name, 0,
                          "morph frame " + std::to_string(k + 1) + ", vertex " +
                              std::to_string(split.source_vertex[w] + 1) + " is not finite");
            target[3 * w + c] = value;
          }
        const std::size_t accessor = bin.add(target, 3, FLOAT, ARRAY_BUFFER);
        set_bounds(bin.accessor(accessor), target);
        targets.push_back({{"POSITION", accessor}});
      }
      primitive["targets"] = std::move(targets);
      morphed.push_back({i, morphs->count});
    }
    if (meshes[i].color) {
      const auto& c = *meshes[i].color;
      primitive["material"] = materials.size();
      materials.push_back({{"name", name},
                           {"doubleSided", true},
                           {"pbrMetallicRoughness",
                            {{"baseColorFactor", Json::array({c[0], c[1], c[2], 1.0f})},
                             {"metallicFactor", 0.0f},
                             {"roughnessFactor", 0.8f}}}});
    }
    Json mesh = {{"primitives", Json::array({std::move(primitive)})}};
    if (meshes[i].morphs) mesh["weights"] = std::vector<float>(meshes[i].morphs->count, 0.0f);
    if (!meshes[i].name.empty()) mesh["name"] = node["name"] = meshes[i].name;
    gltf_meshes.push_back(std::move(mesh));
    nodes.push_back(std::move(node));
  }
  Json scene = Json::object();
  // The spec forbids empty arrays, so a file of no meshes has a scene without nodes.
  if (!meshes.empty()) {
    for (std::size_t i = 0; i < meshes.size(); ++i)
      scene["nodes"].push_back(i);
    for (std::size_t r : skin_roots)
      scene["nodes"].push_back(r);
    for (auto& jn : joint_nodes)
      nodes.push_back(std::move(jn));
    doc["nodes"] = std::move(nodes);
    doc["meshes"] = std::move(gltf_meshes);
    if (!skins.empty()) doc["skins"] = std::move(skins);
    if (!materials.empty()) doc["materials"] = std::move(materials);
  }
  if (animation) {
    Json clip = animation_json(*animation, written.empty() ? nullptr : written.front().skin,
                               written.empty() ? 0 : written.front().first_node, bin);
    // Morph weights: one-hot at each keyframe (target k at keyframe k), linear between them.
    // The keyframe times are the input accessor of the clip's first sampler.
    for (const auto& [node, count] : morphed) {
      std::vector<float> weights(count * count, 0.0f);
      for (std::size_t k = 0; k < count; ++k)
        weights[k * count + k] = 1.0f;
      const std::size_t input = clip["samplers"][0]["input"].get<std::size_t>();
      clip["channels"].push_back(
          {{"sampler", clip["samplers"].size()}, {"target", {{"node", node}, {"path", "weights"}}}});
      clip["samplers"].push_back(
          {{"input", input}, {"output", bin.add(weights, 1, FLOAT, -1)}, {"interpolation", "LINEAR"}});
    }
    doc["animations"] = Json::array({std::move(clip)});
  }
  doc["scene"] = 0;
  doc["scenes"] = Json::array({std::move(scene)});
  const std::string binary = bin.finish(doc);

  std::string json = doc.dump();
  while (json.size() % 4 != 0)
    json += ' '; // the spec pads the JSON chunk with spaces
  std::string out;
  const std::size_t total = 12 + 8 + json.size() + (binary.empty() ? 0 : 8 + binary.size());
  if (total > std::numeric_limits<std::uint32_t>::max())
    throw Error("glb", 0, "the meshes need " + std::to_string(total) + " bytes, more than a .glb can hold");
  out.reserve(total);
  append_u32(out, GLB_MAGIC);
  append_u32(out, 2);
  append_u32(out, static_cast<std::uint32_t>(total));
  append_u32(out, static_cast<std::uint32_t>(json.size()));
  append_u32(out, CHUNK_JSON);
  out += json;
  if (!binary.empty()) {
    append_u32(out, static_cast<std::uint32_t>(binary.size()));
    append_u32(out, CHUNK_BIN);
    out += binary;
  }
  return out;
}

} // namespace vfit
