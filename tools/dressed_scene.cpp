// SPDX-License-Identifier: Apache-2.0
#include "dressed_scene.h"

#include <filesystem>

#include "vfit/geometry/garment/garment_skinning.h"
#include "vfit/geometry/mesh/gltf_format.h"

namespace vfit::cli {

std::array<float, 3> body_colour() { return {0.80f, 0.62f, 0.52f}; }

std::array<float, 3> garment_colour(std::size_t g) {
  static constexpr std::array<std::array<float, 3>, 4> PALETTE = {
      {{0.15f, 0.30f, 0.70f}, {0.70f, 0.20f, 0.20f}, {0.20f, 0.55f, 0.30f}, {0.60f, 0.50f, 0.15f}}};
  return PALETTE[g % PALETTE.size()];
}

std::string fitted_scene_glb(const Body& body, const std::vector<FittedGarment>& garments) {
  std::vector<MeshSkin> skins(1 + garments.size(), body_skin(body));
  std::vector<NamedMesh> named = {{"body", &body.mesh, &skins[0], body_colour()}};
  for (std::size_t g = 0; g < garments.size(); ++g) {
    const SkinWeights w = garment_skin_weights(body, garments[g].mesh, garments[g].segmentation.type);
    skins[g + 1].joints = w.joints;
    skins[g + 1].weights = w.weights;
    named.push_back(
        {std::filesystem::path(garments[g].name).stem().string(), &garments[g].mesh, &skins[g + 1], garment_colour(g)});
  }
  return write_glb(named);
}

} // namespace vfit::cli
