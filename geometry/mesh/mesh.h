// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The mesh type every preprocessing stage reads and writes: flat arrays that kernels/ can take
/// as spans without a copy, with per-corner UV and normal indices so seams survive a round trip.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace vfit {

/// A triangle mesh with optional UVs, normals and per-face labels (OBJ groups).
/// Positions are in the file's units until a caller converts them (see units.h); vfit's
/// convention is metres, Y up, the body facing +Z. Triangles are counter-clockwise seen from
/// outside (outward normals by the right-hand rule).
struct Mesh {
  std::vector<float> positions;               ///< #V × 3
  std::vector<std::int32_t> triangles;        ///< #F × 3 vertex indices
  std::vector<float> uvs;                     ///< #T × 2 texture coordinates
  std::vector<std::int32_t> uv_triangles;     ///< #F × 3 indices into uvs; empty: no UVs
  std::vector<float> normals;                 ///< #N × 3 unit normals as stored in the file
  std::vector<std::int32_t> normal_triangles; ///< #F × 3 indices into normals; empty: none
  std::vector<std::int32_t> face_labels;      ///< #F indices into label_names; empty: no labels
  std::vector<std::string> label_names;       ///< names of the labels (OBJ `g`/`o` names)

  std::size_t vertex_count() const { return positions.size() / 3; }
  std::size_t face_count() const { return triangles.size() / 3; }
  bool has_uvs() const { return !uv_triangles.empty(); }
  bool has_normals() const { return !normal_triangles.empty(); }
  bool has_labels() const { return !face_labels.empty(); }

  /// Flat views for kernels/: #V × 3 floats and #F × 3 ints.
  std::span<const float> position_view() const { return positions; }
  std::span<const std::int32_t> triangle_view() const { return triangles; }
};

/// Where a mesh's elements came from, so that validation can name them in errors.
struct MeshSource {
  std::string path;                      ///< the file (or a name such as "garment")
  bool text = true;                      ///< true: face_origin holds 1-based line numbers;
                                         ///< false: 1-based face element indices (binary files)
  std::vector<std::int64_t> face_origin; ///< #F (may be empty: origins unknown)

  /// "<path>:<line>" or "<path>: face <n>" style location of triangle f, for messages.
  std::int64_t line_of(std::size_t f) const { return text && f < face_origin.size() ? face_origin[f] : 0; }
  std::string element_of(std::size_t f) const {
    if (text && f < face_origin.size()) return "";
    return "face " + std::to_string(f < face_origin.size() ? face_origin[f] : static_cast<std::int64_t>(f) + 1) + ": ";
  }
};

/// A parsed file: the mesh, where its faces came from, and warnings worth showing the user
/// (ignored statements, unit detection, repairs).
struct ParsedMesh {
  Mesh mesh;
  MeshSource source;
  std::vector<std::string> warnings;
};

/// A skeleton and per-vertex skin weights attached to a mesh, for writers of rigged files
/// (glTF skins). Joint positions are the bind (rest) pose, world space (m).
struct MeshSkin {
  std::vector<std::string> joint_names;    ///< #J
  std::vector<std::int32_t> joint_parents; ///< #J, −1 for a root; parents precede children
  std::vector<float> joint_positions;      ///< #J × 3
  std::vector<std::int32_t> joints;        ///< #V × 4 joint indices
  std::vector<float> weights;              ///< #V × 4, rows sum to 1
};

/// A mesh's shape per keyframe of an animation, beyond what its skin gives: offset k (m, in the
/// mesh's bind space, added to the rest positions before skinning) is the shape at keyframe k
/// (e.g. the cloth's physics and clean-up over the skinned garment). Written as one morph target
/// per keyframe, weight 1 at its keyframe and 0 at the others, ramping linearly between them.
struct MorphFrames {
  std::size_t count = 0;      ///< #K targets, one per keyframe of the animation
  std::vector<float> offsets; ///< #K × #V × 3 (m)
};

/// A mesh with a name, for writers of multi-mesh files (glTF scenes: body and garments), and
/// optionally its skin, colour and per-keyframe shapes.
struct NamedMesh {
  std::string name;
  const Mesh* mesh = nullptr;
  const MeshSkin* skin = nullptr;
  /// Base colour (linear RGB in [0, 1]) of a material of its own; none: the viewer's default.
  std::optional<std::array<float, 3>> color = std::nullopt;
  const MorphFrames* morphs = nullptr; ///< with an animation of as many keyframes; null: none
};

/// Keyframes of a skeleton (a MeshSkin's joints, in its order), for writers of animated files:
/// at each time, every joint's rotation relative to its parent (the rest pose has none: the
/// bind pose is rotation-free) and the root joint's position.
struct SkinAnimation {
  std::string name;
  std::vector<float> times;          ///< #K seconds, strictly increasing, from 0
  std::vector<float> rotations;      ///< #K × #J × 4: unit quaternions (x, y, z, w), local to the parent
  std::vector<float> root_positions; ///< #K × 3: the (first) root joint's position (m)
};

} // namespace vfit
