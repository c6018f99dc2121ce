#include "dressed_character.h"

#include <algorithm>
#include <cmath>

#include "kernels/error.h"

namespace vfit {

DressedCharacter::DressedCharacter(const Body& body, const std::vector<FittedGarment>& garments,
                                   const GarmentSkinningOptions& skinning)
    : m_body(body), m_body_positions(body.mesh.positions) {
  validate_skin_weights(m_body.weights, m_body.mesh.vertex_count(), "dressed character: the body's weights");
  for (const FittedGarment& g : garments) {
    Layer layer;
    layer.name = g.name;
    layer.rest = g.mesh;
    try {
      layer.weights = garment_skin_weights(m_body, g.mesh, g.segmentation.type, skinning);
    } catch (const Error& e) {
      throw Error(g.name, 0, std::string("skinning: ") + e.what());
    }
    layer.positions = g.mesh.positions;
    m_garments.push_back(std::move(layer));
  }
}

void DressedCharacter::step(const Pose& pose) {
  const auto transforms = skinning_transforms(m_body.joints, pose);
  linear_blend_skinning(m_body.mesh.positions, m_body.weights, transforms, m_body_positions);
  for (Layer& g : m_garments)
    linear_blend_skinning(g.rest.positions, g.weights, transforms, g.positions);
}

FramePenetration DressedCharacter::measure() {
  if (!m_index)
    m_index.emplace(m_body_positions, m_body.mesh.triangles);
  else
    m_index->refit(m_body_positions);
  FramePenetration out;
  for (Layer& g : m_garments) {
    if (g.queried)
      m_index->requery_closest_points(g.positions, INFINITY, g.hits);
    else
      m_index->closest_points(g.positions, INFINITY, g.hits);
    g.queried = true;
    for (std::size_t v = 0; v < g.hits.triangles.size(); ++v) {
      const double d = g.hits.signed_distances[v];
      if (g.hits.triangles[v] < 0 || d >= 0) continue;
      ++out.inside;
      if (d < -0.001) ++out.inside_1mm;
      out.max_depth_mm = std::max(out.max_depth_mm, -1000 * d);
    }
  }
  return out;
}

} // namespace vfit
