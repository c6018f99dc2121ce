// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// glTF 2.0: binary `.glb` and JSON `.gltf` (buffers embedded as base64 data URIs or in files
/// beside it). Triangle primitives of every mesh in the default scene are read with their node
/// transforms applied; POSITION, NORMAL and TEXCOORD_0 are kept. Skins, morph targets,
/// materials and animations are ignored here.

#include <span>
#include <string>
#include <string_view>

#include "mesh.h"

namespace vfit {

/// Parses a `.glb` (magic "glTF") or `.gltf` (JSON, recognised by its leading `{`). `path` is
/// used in messages and to resolve a `.gltf`'s buffer URIs, which must be relative paths that
/// stay in its folder.
///
/// The scene is `scene`, else scene 0, else every root node; node transforms (matrix or TRS)
/// compose down the hierarchy, except that a skinned mesh's node transform is ignored, as the
/// spec says (its bind-pose positions are kept). Normals go through the inverse transpose and
/// are renormalised; a mirroring transform has its triangles' corners swapped so they stay
/// counter-clockwise. Triangle strips and fans become triangles (minus the zero-area joins of
/// strips); points and lines are skipped with a warning.
///
/// Corners with bit-identical positions (−0.0 = 0.0) are welded into one vertex, in accessor
/// order, across all primitives (glTF splits vertices at UV seams, so this restores the
/// topology); vertices no triangle uses are dropped. UVs and normals stay per corner
/// (`uv_triangles`, `normal_triangles`); corners of primitives without them get UV (0, 0) or
/// their face's normal when others have them. V is flipped (v' = 1 − v): glTF puts the UV origin
/// at the image's top-left corner, vfit (like OBJ) at its bottom-left. Each glTF mesh becomes a
/// face label named after it ("mesh<N>" when unnamed). `source.face_origin[f]` = f + 1.
///
/// Throws vfit::Error "<path>: <what>" naming the chunk, buffer, bufferView, accessor, node or
/// primitive for malformed input: bad magic, version or length; truncated chunks or buffers;
/// invalid JSON; accessors reading past their bufferView or buffer; sparse accessors; indices
/// out of range; non-finite positions; unreadable buffer files; unsupported required
/// extensions (Draco, meshopt, quantization); and "no faces" when nothing is a triangle.
ParsedMesh read_gltf(std::string_view bytes, const std::string& path);

/// A binary glTF (`.glb`) holding each named mesh as a separate mesh and node (its name kept),
/// with POSITION (with min/max), NORMAL (the mesh's per-corner normals, or area-weighted vertex
/// normals computed here; +Z where a vertex has none), TEXCOORD_0 (when it has UVs, v flipped
/// as read_gltf describes) and UNSIGNED_INT indices. A vertex is split once per distinct (UV,
/// normal) pair among its corners, so a mesh without seams keeps its vertices and their order.
/// A mesh with a skin gets JOINTS_0/WEIGHTS_0 and a skin whose joints are nodes (translation
/// relative to the parent's bind position, inverse bind matrices undoing the bind position);
/// meshes whose skins have the same joints (names, parents, bind positions) share one skin and
/// one set of joint nodes, so one skeleton moves a body and its garments. A mesh with a colour
/// gets a material of its own (metallic 0, roughness 0.8, double-sided). With `animation`, an
/// animation drives the first skin's joint nodes: a LINEAR rotation channel per joint and a
/// translation channel on its root. A mesh with morphs gets one morph target (POSITION offsets,
/// with min/max) per keyframe and a LINEAR weights channel on its node, one-hot at each
/// keyframe. Throws vfit::Error naming the mesh for a null mesh, a mesh
/// without faces, non-finite positions or out-of-range indices, a skin that does not match its
/// mesh, morphs without an animation or whose sizes do not match the mesh and #times, a non-finite
/// offset, and naming the animation when there is no skin, its sizes do not match the skeleton
/// and #times, its times do not increase, or a value is not finite.
std::string write_glb(std::span<const NamedMesh> meshes, const SkinAnimation* animation = nullptr);

} // namespace vfit
