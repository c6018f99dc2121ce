// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// A dressed character stepped frame by frame (seed 001 §7): a body and the garments fitted on
/// it, each frame
/// 1. linear blend skinning (LBS) of the body and of every garment layer, each skinned to the
///    body's skeleton (garment_skin_weights(), §7.1);
/// 2. physics: each garment's cloth (ClothSim, implicit Euler, continuous contacts) continues
///    from the previous frame, carried by the skinning: each particle moves as its skinned
///    position did and keeps its velocity relative to the skin, less `inertia` times the skin's
///    change of velocity (what a world-space simulation would feel); then it is stepped by dt
///    against the posed body, at rest in that carried frame, leashed by tethers to the skinned
///    garment (`tether` plus the vertex's rest distance to the body). Stepped in world space
///    instead, the body moved a frame's motion into the cloth at once and the contacts flung
///    it (docs/benchmarks.md). Bottoms (trousers, shorts, skirts) have their waistband attached
///    to the body. The first frame, a cut in the motion (a body vertex faster than cut_speed)
///    and a diverged cloth restart the cloth from the frame's LBS, at rest;
/// 3. the blend of eq. 8, x = w_p·physical + (1 − w_p)·LBS, with w_p per vertex from eq. 9
///    (blend_weights.h: per garment, and per upper and lower part for skirts and dresses),
///    computed once from the fitted garment on the body at rest;
/// 4. the clean-up (frame_cleanup.h): out of the body, edges through it, and each layer outside
///    the ones under it (eq. 7).
/// A non-finite blended vertex (which a restored divergence should never leave) takes its LBS
/// position and is counted; nothing non-finite is ever published.
///
/// For an app, per frame:
/// ```
///   vfit::AnimationOptions options;
///   options.threads = 2;                                        // or 0: TBB's default
///   vfit::DressedCharacter character(body, fitted.garments, options);
///   for (const vfit::Pose& pose : motion.frames) {
///     const vfit::FrameReport& r = character.step(pose, 1.0 / 30);  // dt: the frame's time (s)
///     if (r.left_inside_1mm || r.left_crossing) log(r);           // what the clean-up left
///     upload(character.body_positions());                         // #V × 3 floats (m)
///     for (std::size_t g = 0; g < character.garment_count(); ++g)
///       upload(character.garment_positions(g));
///   }
/// ```
/// Shapes: positions are #V × 3 floats in metres, Y up, in the garments' and the body's vertex
/// order as given. Thread-safety: one thread steps a character; step() runs its stages in
/// parallel (TBB) inside the character's own arena of `threads` threads; the frames do not
/// depend on the thread count. After the first step the skinning, blend and the clean-up's
/// body and layer pushes reuse their buffers; the cloth simulator (its contact sets grow and
/// shrink with the contacts) and the layer-piercing test (a small index over the candidate
/// triangles, per garment over another) still allocate per frame.

#include <array>
#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vfit/engine/animate/blend_weights.h"
#include "vfit/engine/animate/frame_cleanup.h"
#include "vfit/engine/cloth/cloth_sim.h"
#include "vfit/engine/fit/fit_report.h"
#include "vfit/geometry/body/body.h"
#include "vfit/geometry/garment/garment_skinning.h"

namespace vfit {

/// How a DressedCharacter animates.
struct AnimationOptions {
  bool physics = true; ///< off: LBS only (w_p = 0), with the clean-up still on
  /// The cloth of every garment (fabrics, contacts, step). Defaults: ClothOptions' with
  /// implicit_step = 1/60 s, so a 30 fps frame takes two implicit steps.
  ClothOptions cloth = default_cloth();
  double max_physical_weight = 0.5; ///< eq. 9's cap on w_p
  double split_band = 0.05;         ///< m: skirts' and dresses' w_p ramps over hip height ± this
  bool clean_up = true;             ///< the per-frame clean-up (frame_cleanup.h)
  FrameCleanupOptions cleanup;
  /// m/s: a body vertex moving faster than this between two frames is a cut in the motion, and
  /// the cloth restarts from the frame's LBS (the fastest human motions, a throw or a kick, stay
  /// under about 15 m/s at the hand or foot).
  double cut_speed = 25;
  /// How much of the skin's acceleration the cloth feels (0: none, the cloth is carried by the
  /// skinning and only sags and collides; 1: all of it, as in a world-space simulation).
  double inertia = 1.0;
  /// m: how far the cloth may leave the skinned garment, beyond each vertex's distance to the
  /// body at rest (ClothSim::set_tethers()).
  double tether = 0.03;
  int threads = 0; ///< step()'s threads; 0: TBB's default (every core)
  GarmentSkinningOptions skinning;

  static ClothOptions default_cloth();
};

/// What one step() did, timed per stage (ms), and what its clean-up left.
struct FrameReport {
  /// cleanup_ms: out of the body and edges through it; layering_ms: eq. 7 against the inner
  /// garments; total_ms: the whole step.
  double lbs_ms = 0, physics_ms = 0, blend_ms = 0, cleanup_ms = 0, layering_ms = 0, total_ms = 0;
  bool restarted = false;           ///< the cloth restarted from LBS (first frame, a cut, or a divergence)
  std::size_t diverged = 0;         ///< garments whose cloth diverged this frame (their LBS is used)
  long long solver_iterations = 0;  ///< the cloths' CG iterations, summed
  std::size_t contacts = 0;         ///< the cloths' body contacts resolved, summed
  std::size_t non_finite = 0;       ///< blended vertices replaced by their LBS position
  std::size_t body_pushed = 0;      ///< clean-up: vertices pushed out of the body
  std::size_t crossings_pushed = 0; ///< clean-up: edges through the body moved out
  std::size_t layer_pushed = 0;     ///< clean-up: vertices pushed out of an inner garment (eq. 7)
  std::size_t left_inside_1mm = 0;  ///< vertices the clean-up left more than 1 mm inside
  std::size_t left_crossing = 0;    ///< edges the clean-up left through the body

  /// Adds `frame`'s times and counts to these, for totals over frames (divide by the frame
  /// count for means); `restarted` becomes whether any frame restarted.
  void add(const FrameReport& frame);
  /// Adds one garment's clean-up (its counts, and its body_ms and layering_ms to cleanup_ms
  /// and layering_ms).
  void add(const FrameCleanupCounts& garment);
};

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
  /// it is (e.g. by fit_garments() on it), inner first (the fit's dressing order). Skins each
  /// garment, builds its cloth and its blend weights, indexes the body and the garments for the
  /// clean-up. Throws vfit::Error naming the garment when its skinning or cloth fails, or the
  /// body when its weights do not fit its mesh.
  DressedCharacter(const Body& body, const std::vector<FittedGarment>& garments, const AnimationOptions& options = {});
  ~DressedCharacter();
  DressedCharacter(DressedCharacter&&) noexcept;
  DressedCharacter& operator=(DressedCharacter&&) noexcept;

  /// Poses the body and the garments for `pose` (its joints' rotations and the translation, as
  /// posed_joints() reads them), `dt` seconds (> 0) after the previous step; dt ≤ 0 or not
  /// finite restarts the cloth (as a cut does). The report stays valid until the next step.
  const FrameReport& step(const Pose& pose, double dt);
  /// The next step() restarts the cloth from its LBS (e.g. when the app jumps in the clip).
  void restart() { m_restart = true; }

  std::size_t garment_count() const { return m_garments.size(); }
  const std::string& garment_name(std::size_t g) const { return m_garments[g].name; }
  /// The body's and garment g's positions after the last step (before the first: at rest).
  std::span<const float> body_positions() const { return m_body_positions; }
  std::span<const float> garment_positions(std::size_t g) const { return m_garments[g].positions; }
  /// Garment g's LBS positions of the last step (the skinned animation alone).
  std::span<const float> garment_skinned(std::size_t g) const { return m_garments[g].lbs; }
  /// Garment g's cloth after the last step (the physical term of eq. 8), or its LBS positions
  /// when physics is off.
  std::span<const float> garment_physical(std::size_t g) const {
    return m_garments[g].cloth ? m_garments[g].cloth->positions() : std::span<const float>(m_garments[g].lbs);
  }
  /// Garment g's positions of the last step as offsets from its rest shape before skinning
  /// (#V × 3, m): the skin of vertex v, M_v = Σ_j w_vj·R_j (its joints' rotations blended),
  /// carries offset δ_v to M_v·δ_v, so δ_v = M_v⁻¹·(x_v − LBS_v), and skinning rest + δ with the
  /// frame's pose gives the frame back (a glTF morph target, MorphFrames). Where M_v is nearly
  /// singular (|det| < 1e-3: weights split between opposed rotations) the heaviest joint's
  /// rotation stands for it. `out` must hold #V × 3 floats. O(#V).
  void bind_space_offsets(std::size_t g, std::span<float> out) const;
  /// Garment g's skin weights, #V × 4.
  const SkinWeights& garment_weights(std::size_t g) const { return m_garments[g].weights; }
  /// Garment g's eq. 9 weights.
  const BlendWeights& garment_blend(std::size_t g) const { return m_garments[g].blend; }
  const Body& body() const { return m_body; }
  const Mesh& garment_rest(std::size_t g) const { return m_garments[g].rest; }
  const AnimationOptions& options() const { return m_options; }

  /// Where the garments stand after the last step, as the fit measures a garment
  /// (Dresser::measure()): the posed body indexed, then each garment, inner first, measured
  /// against the body and the garments under it (seed 001 eq. 7's layers, 3 mm apart) and added
  /// as a layer for the next. Independent of the clean-up's own queries (it casts rays for
  /// vertices far inside), so it checks them. Allocates per call; O((#body faces + #garment
  /// vertices) · log #body faces).
  FramePenetration measure() const;

private:
  struct Layer {
    std::string name;
    GarmentType type = GarmentType::TEE;
    Mesh rest;
    SkinWeights weights;
    BlendWeights blend;
    std::vector<float> lbs, lbs_previous, positions;
    std::vector<float> skin_velocity, start_x, start_v; // #V × 3: the carried cloth's state
    bool skin_velocity_known = false;
    std::vector<float> tether_radii; // #V (m)
    std::unique_ptr<ClothSim> cloth;
    ClothStepReport last; // of the last step
  };
  void step_stages(const Pose& pose, double dt);

  AnimationOptions m_options;
  Body m_body;
  std::vector<Layer> m_garments;
  std::vector<float> m_body_positions, m_previous_body;
  std::unique_ptr<FrameCleanup> m_cleanup;
  struct Arena;
  std::unique_ptr<Arena> m_arena;
  FrameReport m_report;
  bool m_restart = true;
  std::array<Eigen::Isometry3d, JOINT_COUNT> m_transforms; // of the last step
};

} // namespace vfit
