// SPDX-License-Identifier: Apache-2.0
#include "table1.h"

namespace vfit {

const std::vector<Table1Row>& table1_rows() {
  // Images stand for the paper's photographed bodies: I_1 arms down, I_2 elbows bent,
  // I_4 walking, I_5 legs apart (the paper's poses differ per image; these give the same
  // variety of reposing work).
  static const std::vector<Table1Row> rows = {
      {"Dress", "I_1", GarmentType::DRESS, "M", 5875, 11593, "arms_down", 788, 3552, 5071, 9422},
      {"Shirt 1", "I_2", GarmentType::TEE, "L", 3106, 9312, "elbows_bent", 223, 1568, 3984, 5781},
      {"Shirt 2", "I_2", GarmentType::TEE, "M", 3550, 7096, "elbows_bent", 355, 1957, 3754, 6070},
      {"Shirt 2", "I_4", GarmentType::TEE, "M", 3550, 7096, "walking", 349, 1924, 4075, 6355},
      {"Pant 1 (P1)", "I_4", GarmentType::TROUSERS, "P1", 4200, 8396, "walking", 271, 3619, 7011, 10904},
      {"Pant 1 (P2)", "I_4", GarmentType::TROUSERS, "P2", 4200, 8396, "walking", 266, 3630, 4534, 8439},
      {"Pant 1 (P3)", "I_4", GarmentType::TROUSERS, "P3", 4200, 8396, "walking", 279, 3637, 2929, 6861},
      {"Pant 2", "I_5", GarmentType::TROUSERS, "M", 3062, 6120, "legs_apart", 159, 2859, 3575, 5599},
      {"Shorts 1", "I_5", GarmentType::SHORTS, "M", 8196, 16388, "legs_apart", 987, 4584, 7821, 13399},
  };
  return rows;
}

GarmentOptions table1_garment_options(const Table1Row& row) {
  GarmentOptions o;
  o.type = row.type;
  o.size = row.size;
  o.pose = RestPose::TPOSE;
  o.target_vertices = row.vertices;
  return o;
}

} // namespace vfit
