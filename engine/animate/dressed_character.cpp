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

namespace {

// The fit's layering constants: the gap kept outside an inner garment (seed 001 eq. 7's k) and
// how far a layer point may be from a garment vertex and still count.
constexpr double LAYER_CLEARANCE = 0.003, LAYER_REACH = 0.05;

} // namespace

FramePenetration DressedCharacter::measure() const {
  Mesh posed;
  posed.positions = m_body_positions;
  posed.triangles = m_body.mesh.triangles;
  DressingBody body(posed, LAYER_CLEARANCE, LAYER_REACH);
  FramePenetration out;
  ClosestHits hits;
  for (const Layer& g : m_garments) {
    Mesh garment;
    garment.positions = g.positions;
    garment.triangles = g.rest.triangles;
    const PenetrationStats s = Dresser(body, garment, DressOptions{}).measure(garment);
    out.inside += s.inside_count;
    out.max_depth_mm = std::max(out.max_depth_mm, 1000 * s.max_depth);
    out.crossing_edges += s.crossing_edges;
    out.layer_inside += s.layer_inside_count;
    out.layer_crossing_edges += s.layer_crossing_edges;
    body.index().closest_points(garment.positions, INFINITY, hits);
    for (std::size_t v = 0; v < hits.size(); ++v)
      if (hits.triangles[v] >= 0 && hits.signed_distances[v] < -0.001f) ++out.inside_1mm;
    body.add_layer(garment);
  }
  return out;
}

} // namespace vfit
