#pragma once
/// \file
/// A dressed character stepped frame by frame (seed 001 §7): a body and the garments fitted on
/// it, each garment layer skinned to the body's skeleton (garment_skin_weights(), §7.1), posed
/// per frame by linear blend skinning — eq. 8 with the physical term's weight w_p = 0. The
/// physical term (the cloth continuing from the previous frame against the moving body), its
/// blend (eq. 8–9) and the per-frame layering and clean-up are not part of this object yet: a
/// frame here is what LBS alone gives, measured (measure()) so that what it leaves is known:
/// vertices inside the body, edges through it, and layer offences.
///
/// For an app, per frame:
/// ```
///   vfit::DressedCharacter character(body, fitted.garments);   // fitted on `body` at rest
///   for (const vfit::Pose& pose : motion.frames) {
///     character.step(pose);                                    // no allocation after the first
///     upload(character.body_positions());                      // #V × 3 floats (m)
///     for (std::size_t g = 0; g < character.garment_count(); ++g)
///       upload(character.garment_positions(g));
///   }
/// ```
/// Shapes: positions are #V × 3 floats in metres, Y up, in the garments' and the body's vertex
/// order as given. Thread-safety: one thread steps a character; step() itself runs LBS in
/// parallel (TBB) over vertices.

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "engine/dress/dresser.h"
#include "engine/fit/fit_report.h"
#include "geometry/body/body.h"
#include "geometry/garment/garment_skinning.h"
#include "kernels/proximity.h"

namespace vfit {

/// What measure() finds on the current frame, summed over the garments.
struct FramePenetration {
  std::size_t inside = 0;               ///< garment vertices inside the body (signed distance < 0)
  double max_depth_mm = 0;              ///< the deepest of them (mm)
  std::size_t inside_1mm = 0;           ///< those more than 1 mm inside
  std::size_t crossing_edges = 0;       ///< garment edges through the body
  std::size_t layer_inside = 0;         ///< garment vertices inside a garment under it
  std::size_t layer_crossing_edges = 0; ///< edges of the garments under it through the garment
};

class DressedCharacter {
public:
  /// `body` in its rest pose (its weights bind that pose); `garments` fitted onto that body as
  /// it is (e.g. by fit_garments() on it), in dressing order or any. Skins each garment
  /// (garment_skin_weights() with `skinning`). Throws vfit::Error naming the garment when its
  /// skinning fails, or the body when its weights do not fit its mesh.
  DressedCharacter(const Body& body, const std::vector<FittedGarment>& garments,
                   const GarmentSkinningOptions& skinning = {});

  /// Poses the body and every garment by LBS for `pose` (its joints' rotations and the
  /// translation, as posed_joints() reads them). No allocation after the first call.
  void step(const Pose& pose);

  std::size_t garment_count() const { return m_garments.size(); }
  const std::string& garment_name(std::size_t g) const { return m_garments[g].name; }
  /// The body's and garment g's positions after the last step (before the first: at rest).
  std::span<const float> body_positions() const { return m_body_positions; }
  std::span<const float> garment_positions(std::size_t g) const { return m_garments[g].positions; }
  /// Garment g's skin weights, #V × 4.
  const SkinWeights& garment_weights(std::size_t g) const { return m_garments[g].weights; }
  const Body& body() const { return m_body; }
  const Mesh& garment_rest(std::size_t g) const { return m_garments[g].rest; }

  /// Where the garments stand after the last step, as the fit measures a garment
  /// (Dresser::measure()): the posed body indexed, then each garment, inner first, measured
  /// against the body and the garments under it (seed 001 eq. 7's layers, 3 mm apart) and added
  /// as a layer for the next. Allocates per call (the indices are built for the pose);
  /// O((#body faces + #garment vertices) · log #body faces).
  FramePenetration measure() const;

private:
  struct Layer {
    std::string name;
    Mesh rest;
    SkinWeights weights;
    std::vector<float> positions;
  };
  Body m_body;
  std::vector<Layer> m_garments;
  std::vector<float> m_body_positions;
};

} // namespace vfit
