// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Garments: the mesh with per-vertex part labels, and the vocabulary of garment types, parts
/// and sizes shared by the catalogue, segmentation and fitting.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "vfit/geometry/body/body.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

enum class GarmentType { TEE, LONG_SLEEVE, TROUSERS, SHORTS, DRESS, SKIRT };

/// Part labels (seed 000 §4): what each vertex of a garment covers.
enum class GarmentPart : std::int8_t { TORSO, LEFT_SLEEVE, RIGHT_SLEEVE, LEFT_LEG, RIGHT_LEG, SKIRT };
inline constexpr int GARMENT_PART_COUNT = 6;

/// "tee" | "long-sleeve" | "trousers" | "shorts" | "dress" | "skirt".
std::string garment_type_name(GarmentType type);
/// Parses a type name (also "t-shirt", "shirt", "pants", "jeans"); throws vfit::Error otherwise.
GarmentType parse_garment_type(std::string_view name);
/// "torso" | "left_sleeve" | "right_sleeve" | "left_leg" | "right_leg" | "skirt".
std::string garment_part_name(GarmentPart part);

/// Ease: how much larger than the body the garment is, as girth (m) at chest, waist, hip and
/// thigh (a tape measure around garment minus around body).
struct Ease {
  double chest = 0.09, waist = 0.09, hip = 0.08, thigh = 0.04;
};

/// Ease of a named size: XS, S, M, L, XL, XXL for any garment, and the trousers sizes of seed
/// 000 Fig. 13: P1 (tight), P2 (good), P3 (loose), P4 (too large to stay up: its waist is
/// larger than the body's hips). Throws vfit::Error for an unknown size.
Ease size_ease(std::string_view size);

/// A garment mesh (metres, outward normals, UVs, face labels = parts) with its per-vertex
/// ground-truth part labels.
struct Garment {
  Mesh mesh;
  std::vector<GarmentPart> vertex_parts; ///< #V
  GarmentType type = GarmentType::TEE;
  std::string size;
  Ease ease;
  RestPose pose = RestPose::TPOSE;
};

} // namespace vfit
