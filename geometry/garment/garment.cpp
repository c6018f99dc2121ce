// SPDX-License-Identifier: Apache-2.0
#include "garment.h"

#include <algorithm>
#include <cctype>

#include "vfit/kernels/error.h"

namespace vfit {

std::string garment_type_name(GarmentType type) {
  switch (type) {
  case GarmentType::TEE: return "tee";
  case GarmentType::LONG_SLEEVE: return "long-sleeve";
  case GarmentType::TROUSERS: return "trousers";
  case GarmentType::SHORTS: return "shorts";
  case GarmentType::DRESS: return "dress";
  case GarmentType::SKIRT: return "skirt";
  }
  return "tee";
}

GarmentType parse_garment_type(std::string_view name) {
  std::string s(name);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  if (s == "tee" || s == "t-shirt" || s == "tshirt") return GarmentType::TEE;
  if (s == "long-sleeve" || s == "longsleeve" || s == "shirt") return GarmentType::LONG_SLEEVE;
  if (s == "trousers" || s == "pants" || s == "jeans") return GarmentType::TROUSERS;
  if (s == "shorts") return GarmentType::SHORTS;
  if (s == "dress") return GarmentType::DRESS;
  if (s == "skirt") return GarmentType::SKIRT;
  throw Error("garment", 0,
              "unknown garment type '" + std::string(name) +
                  "' (expected tee, long-sleeve, trousers, shorts, dress or skirt)");
}

std::string garment_part_name(GarmentPart part) {
  switch (part) {
  case GarmentPart::TORSO: return "torso";
  case GarmentPart::LEFT_SLEEVE: return "left_sleeve";
  case GarmentPart::RIGHT_SLEEVE: return "right_sleeve";
  case GarmentPart::LEFT_LEG: return "left_leg";
  case GarmentPart::RIGHT_LEG: return "right_leg";
  case GarmentPart::SKIRT: return "skirt";
  }
  return "torso";
}

Ease size_ease(std::string_view size) {
  std::string s(size);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  // Girth ease (m) over the body they are built around: XS hugs it, XXL hangs loose.
  if (s == "XS") return {0.02, 0.02, 0.02, 0.01};
  if (s == "S") return {0.05, 0.05, 0.05, 0.025};
  if (s == "M") return {0.09, 0.09, 0.08, 0.04};
  if (s == "L") return {0.14, 0.14, 0.12, 0.06};
  if (s == "XL") return {0.20, 0.20, 0.17, 0.08};
  if (s == "XXL") return {0.27, 0.27, 0.23, 0.10};
  // Seed 000 Fig. 13: trousers P1 < P2 < P3 < P4 on one body.
  if (s == "P1") return {0.02, 0.00, 0.02, 0.01};
  if (s == "P2") return {0.06, 0.03, 0.06, 0.04};
  if (s == "P3") return {0.14, 0.10, 0.14, 0.10};
  if (s == "P4") return {0.30, 0.30, 0.30, 0.16};
  throw Error("--size", 0,
              "unknown size '" + std::string(size) + "' (expected XS, S, M, L, XL, XXL, or P1-P4 for trousers)");
}

} // namespace vfit
