// SPDX-License-Identifier: Apache-2.0
// A dressed character stepped frame by frame (engine/animate/): eq. 9's weights against a hand
// computation, the skirt's two parts, the per-frame clean-up against brute-force oracles, and
// the demo outfit walking: every frame clean by the fit's own measure and by brute force, the
// same frames for any thread count, cuts restarting the cloth, and the morph offsets replaying
// the frames through the skin.
#include "vfit/engine/animate/dressed_character.h"

#include <cmath>
#include <cstdio>
#include <cstring>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "demo_outfit.h"
#include "test_support.h"
#include "vfit/engine/animate/blend_weights.h"
#include "vfit/engine/animate/frame_cleanup.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/gltf_format.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/geometry/motion/retarget.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

TEST(BlendWeights, Eq9ByHand) {
  // min 0.01, max 0.06, mean 0.03: (0.03 − 0.01) / (0.06 − 0.01) = 0.4.
  const std::vector<double> d = {0.01, 0.02, 0.06, 0.03};
  EXPECT_NEAR(physical_weight(d), 0.4, 1e-12);
  EXPECT_NEAR(physical_weight(d, 0.25), 0.25, 1e-12); // capped
  // mean (0 + 0 + 0 + 0.1) / 4 = 0.025 → 0.25; mean 0.075 of (0, 0.1, 0.1, 0.1) → 0.75, capped at 0.5.
  EXPECT_NEAR(physical_weight(std::vector<double>{0, 0, 0, 0.1}), 0.25, 1e-12);
  EXPECT_NEAR(physical_weight(std::vector<double>{0, 0.1, 0.1, 0.1}), 0.5, 1e-12);
  EXPECT_EQ(physical_weight(std::vector<double>{0.02, 0.02}), 0.0); // max = min
  EXPECT_EQ(physical_weight({}), 0.0);
  EXPECT_THROW(physical_weight(std::vector<double>{0.01, -0.01}), Error);
  EXPECT_THROW(physical_weight(std::vector<double>{0.01, NAN}), Error);
}

// A skirt's top hugs the hips, its hem flares: two parts, two weights, the hem's larger, and the
// per-vertex weight ramps between them across the band.
TEST(BlendWeights, TheSkirtSplitGivesTwoWeights) {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  GarmentOptions o;
  o.type = GarmentType::SKIRT;
  o.pose = RestPose::APOSE;
  o.target_vertices = 2000;
  const Mesh skirt = make_garment(o).mesh;
  const ProximityIndex index(body.mesh.positions, body.mesh.triangles);
  const double hips = 0.5 * (body.joints(idx(Joint::LEFT_HIP), 1) + body.joints(idx(Joint::RIGHT_HIP), 1));
  const BlendWeights w = blend_weights(index, skirt, GarmentType::SKIRT, hips, 0.05);
  ASSERT_TRUE(w.split);
  EXPECT_GT(w.upper_vertices, 0u);
  EXPECT_GT(w.lower_vertices, 0u);
  EXPECT_NE(w.upper, w.lower);
  EXPECT_GE(w.upper, 0.0);
  EXPECT_LE(w.lower, 0.5);
  // Each part's weight is eq. 9 of its own distances (checked by hand here, brute force).
  ClosestHits hits;
  index.closest_points_brute_force(skirt.positions, INFINITY, hits);
  std::vector<double> upper, lower;
  for (std::size_t v = 0; v < skirt.vertex_count(); ++v)
    (skirt.positions[3 * v + 1] < hips ? lower : upper).push_back(std::max(0.0f, hits.signed_distances[v]));
  EXPECT_NEAR(w.upper, physical_weight(upper), 1e-6);
  EXPECT_NEAR(w.lower, physical_weight(lower), 1e-6);
  for (std::size_t v = 0; v < skirt.vertex_count(); ++v) {
    const double y = skirt.positions[3 * v + 1];
    if (y > hips + 0.05) {
      EXPECT_NEAR(w.per_vertex[v], w.upper, 1e-6);
    } else if (y < hips - 0.05) {
      EXPECT_NEAR(w.per_vertex[v], w.lower, 1e-6);
    }
    EXPECT_GE(w.per_vertex[v], std::min(w.upper, w.lower) - 1e-6);
    EXPECT_LE(w.per_vertex[v], std::max(w.upper, w.lower) + 1e-6);
  }
  // A tee is one part.
  o.type = GarmentType::TEE;
  const BlendWeights tee = blend_weights(index, make_garment(o).mesh, GarmentType::TEE, hips, 0.05);
  EXPECT_FALSE(tee.split);
  EXPECT_EQ(tee.upper, tee.lower);
}

// The clean-up on a ball: a wobbly shell half inside it ends outside by the gap (brute-force
// closest points), with no edge through the ball (brute-force segment test); an outer shell
// partly inside the first ends outside it by the clearance k (eq. 7).
TEST(FrameCleanup, PushesOutOfTheBodyAndOutOfTheLayerUnderIt) {
  const Mesh ball = make_uv_sphere(24, 48, 0.1f);
  auto shell = [&](float base, float wobble) {
    Mesh m = make_uv_sphere(16, 32, 1.0f);
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      const float* p = &m.positions[3 * v];
      const float r = base + wobble * std::sin(7.0f * p[0] + 5.0f * p[1]) * std::cos(3.0f * p[2]);
      for (std::size_t k = 0; k < 3; ++k)
        m.positions[3 * v + k] *= r;
    }
    return m;
  };
  const Mesh inner_rest = shell(0.104f, 0.0f), outer_rest = shell(0.112f, 0.0f);
  const std::vector<const Mesh*> rest = {&inner_rest, &outer_rest};
  FrameCleanupOptions o;
  FrameCleanup cleanup(ball, rest, o);
  cleanup.refit_body(ball.positions);
  Mesh inner = shell(0.1f, 0.012f), outer = shell(0.108f, 0.012f);
  const ProximityIndex body(ball.positions, ball.triangles);
  ClosestHits before;
  body.closest_points_brute_force(inner.positions, INFINITY, before);
  const FrameCleanupCounts a = cleanup.clean(0, inner.positions);
  const FrameCleanupCounts b = cleanup.clean(1, outer.positions);
  EXPECT_GT(a.body_pushed, 0u);
  EXPECT_GT(b.layer_pushed, 0u);
  EXPECT_EQ(a.left_inside_1mm + b.left_inside_1mm + a.left_crossing + b.left_crossing, 0u);
  for (const Mesh* m : {&inner, &outer}) {
    ClosestHits hits;
    body.closest_points_brute_force(m->positions, INFINITY, hits);
    for (std::size_t v = 0; v < hits.size(); ++v) {
      EXPECT_GE(hits.signed_distances[v], -1e-6f) << "vertex " << v; // float rounding of the push
      // A vertex that was inside ends the gap outside (a crossing push only moves it outwards).
      if (m == &inner && before.signed_distances[v] < 0) {
        EXPECT_GE(hits.signed_distances[v], o.body_gap - 1e-5) << "vertex " << v;
      }
    }
    std::vector<float> from, to;
    for (std::size_t f = 0; f < m->face_count(); ++f)
      for (std::size_t k = 0; k < 3; ++k) {
        const auto i = std::size_t(m->triangles[3 * f + k]), j = std::size_t(m->triangles[3 * f + (k + 1) % 3]);
        from.insert(from.end(), &m->positions[3 * i], &m->positions[3 * i] + 3);
        to.insert(to.end(), &m->positions[3 * j], &m->positions[3 * j] + 3);
      }
    SegmentHits crossing;
    body.first_hits_brute_force(from, to, crossing);
    for (std::size_t e = 0; e < crossing.size(); ++e)
      EXPECT_LT(crossing.triangles[e], 0) << "edge " << e;
  }
  const ProximityIndex layer(inner.positions, inner.triangles, OpenMeshSide::ONE_SIDED);
  ClosestHits hits;
  layer.closest_points_brute_force(outer.positions, INFINITY, hits);
  for (std::size_t v = 0; v < hits.size(); ++v)
    EXPECT_GE(hits.signed_distances[v], 0.0f) << "vertex " << v << " inside the layer under it";
}

// The demo outfit (trousers under a tee, 2,000 vertices each) on the A-pose mannequin.
struct Outfit {
  const Body& body = test::mannequin(RestPose::APOSE, 6000);
  std::vector<FittedGarment> garments = test::demo_outfit(2000);
  std::vector<Pose> walk = walk_cycle(RestPose::APOSE, 30, 12).frames;
};

bool all_finite(std::span<const float> a) {
  for (const float q : a)
    if (!std::isfinite(q)) return false;
  return true;
}

TEST(DressedCharacter, TheDemoOutfitWalksCleanEveryFrame) {
  const Outfit o;
  DressedCharacter c(o.body, o.garments);
  for (std::size_t f = 0; f < o.walk.size(); ++f) {
    const FrameReport& r = c.step(o.walk[f], 1.0 / 30);
    EXPECT_EQ(r.restarted, f == 0);
    EXPECT_EQ(r.diverged, 0u);
    EXPECT_EQ(r.non_finite, 0u);
    const FramePenetration p = c.measure();
    EXPECT_EQ(p.inside_1mm, 0u) << "frame " << f;
    EXPECT_EQ(p.crossing_edges, 0u) << "frame " << f;
    EXPECT_EQ(p.layer_inside + p.layer_crossing_edges, 0u) << "frame " << f;
    for (std::size_t g = 0; g < c.garment_count(); ++g)
      ASSERT_TRUE(all_finite(c.garment_positions(g)));
    if (f % 6 == 5) { // brute force: the posed body against every garment vertex
      const ProximityIndex posed(c.body_positions(), o.body.mesh.triangles);
      for (std::size_t g = 0; g < c.garment_count(); ++g) {
        ClosestHits hits;
        posed.closest_points_brute_force(c.garment_positions(g), INFINITY, hits);
        for (std::size_t v = 0; v < hits.size(); ++v)
          ASSERT_GE(hits.signed_distances[v], -0.001f) << "frame " << f << ", garment " << g << ", vertex " << v;
      }
    }
  }
}

TEST(DressedCharacter, TheThreadCountDoesNotChangeTheFrames) {
  const Outfit o;
  AnimationOptions one, two;
  one.threads = 1;
  two.threads = 2;
  DressedCharacter a(o.body, o.garments, one), b(o.body, o.garments, two);
  for (std::size_t f = 0; f < 5; ++f) {
    a.step(o.walk[f], 1.0 / 30);
    b.step(o.walk[f], 1.0 / 30);
  }
  for (std::size_t g = 0; g < a.garment_count(); ++g) {
    const auto x = a.garment_positions(g), y = b.garment_positions(g);
    ASSERT_EQ(x.size(), y.size());
    EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(float)), 0) << "garment " << g;
  }
}

TEST(DressedCharacter, CutsRestartTheClothAndPhysicsOffIsTheSkinning) {
  const Outfit o;
  DressedCharacter c(o.body, o.garments);
  EXPECT_TRUE(c.step(o.walk[0], 1.0 / 30).restarted);
  EXPECT_FALSE(c.step(o.walk[1], 1.0 / 30).restarted);
  // The physics moved the garments off their skinned positions.
  double moved = 0;
  for (std::size_t i = 0; i < c.garment_physical(1).size(); ++i)
    moved = std::max(moved, double(std::fabs(c.garment_physical(1)[i] - c.garment_skinned(1)[i])));
  EXPECT_GT(moved, 1e-4);
  // Arms up in one frame: the hands move metres per second past any human motion.
  EXPECT_TRUE(c.step(named_pose("arms_raised", RestPose::APOSE), 1.0 / 30).restarted);
  EXPECT_FALSE(c.step(named_pose("arms_raised", RestPose::APOSE), 1.0 / 30).restarted);
  EXPECT_TRUE(c.step(o.walk[2], 0.0).restarted);
  c.restart();
  EXPECT_TRUE(c.step(o.walk[3], 1.0 / 30).restarted);

  AnimationOptions off;
  off.physics = false;
  off.clean_up = false;
  DressedCharacter lbs(o.body, o.garments, off);
  lbs.step(o.walk[4], 1.0 / 30);
  for (std::size_t g = 0; g < lbs.garment_count(); ++g) {
    const auto x = lbs.garment_positions(g), y = lbs.garment_skinned(g);
    EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(float)), 0);
  }
  AnimationOptions bad;
  bad.inertia = 2;
  EXPECT_THROW(DressedCharacter(o.body, o.garments, bad), Error);
  bad = {};
  bad.max_physical_weight = -0.1;
  EXPECT_THROW(DressedCharacter(o.body, o.garments, bad), Error);
}

// Seed 001's reason for the blend: skinning alone distorts the cloth where a joint bends. A tee
// through a bending elbow and trousers through a bending knee (ramped over 8 frames, held for
// 6): the final garment, and the cloth itself, stretch and shrink their edges less than the
// skinned garment does (mean |l/L − 1| over the garment's edges, L at rest).
TEST(DressedCharacter, TheBlendStrainsLessThanSkinningOnABendingElbowAndKnee) {
  const Outfit o;
  for (const char* name : {"elbows_bent", "knee_bent"}) {
    DressedCharacter c(o.body, o.garments);
    const Pose target = named_pose(name, RestPose::APOSE);
    for (int f = 0; f <= 14; ++f) {
      Pose p;
      const double t = std::min(1.0, f / 8.0);
      p.axis_angle = t * target.axis_angle;
      p.translation = t * target.translation;
      c.step(p, 1.0 / 30);
    }
    const std::size_t g = std::string(name) == "elbows_bent" ? 1 : 0; // the tee, the trousers
    Mesh skinned = c.garment_rest(g), cloth = skinned, out = skinned;
    skinned.positions.assign(c.garment_skinned(g).begin(), c.garment_skinned(g).end());
    cloth.positions.assign(c.garment_physical(g).begin(), c.garment_physical(g).end());
    out.positions.assign(c.garment_positions(g).begin(), c.garment_positions(g).end());
    const double lbs = test::mean_edge_length_change(c.garment_rest(g), skinned),
                 physical = test::mean_edge_length_change(c.garment_rest(g), cloth),
                 blended = test::mean_edge_length_change(c.garment_rest(g), out);
    std::printf("%s: mean edge strain skinned %.4f, cloth %.4f, final %.4f\n", name, lbs, physical, blended);
    EXPECT_LT(physical, lbs) << name;
    EXPECT_LT(blended, lbs) << name;
  }
}

// The morph offsets replay each frame: skinning rest + offsets with the frame's pose gives the
// frame's garment back; the .glb carries one target per frame and a weights channel.
TEST(DressedCharacter, MorphOffsetsReplayTheFramesThroughTheSkin) {
  const Outfit o;
  DressedCharacter c(o.body, o.garments);
  std::vector<MorphFrames> morphs(c.garment_count());
  const std::vector<Pose> frames(o.walk.begin(), o.walk.begin() + 4);
  for (const Pose& pose : frames) {
    c.step(pose, 1.0 / 30);
    const auto transforms = skinning_transforms(o.body.joints, pose);
    for (std::size_t g = 0; g < c.garment_count(); ++g) {
      const Mesh& rest = c.garment_rest(g);
      std::vector<float> offsets(rest.positions.size()), replay(rest.positions.size());
      c.bind_space_offsets(g, offsets);
      std::vector<float> shaped = rest.positions;
      for (std::size_t i = 0; i < shaped.size(); ++i)
        shaped[i] += offsets[i];
      linear_blend_skinning(shaped, c.garment_weights(g), transforms, replay);
      double worst = 0;
      for (std::size_t i = 0; i < replay.size(); ++i)
        worst = std::max(worst, double(std::fabs(replay[i] - c.garment_positions(g)[i])));
      EXPECT_LT(worst, 1e-4) << "garment " << g; // float LBS of coordinates about 1 m
      morphs[g].offsets.insert(morphs[g].offsets.end(), offsets.begin(), offsets.end());
      ++morphs[g].count;
    }
  }
  MeshSkin skin = body_skin(o.body);
  std::vector<MeshSkin> skins(c.garment_count(), skin);
  std::vector<NamedMesh> named = {{"body", &o.body.mesh, &skin}};
  for (std::size_t g = 0; g < c.garment_count(); ++g) {
    skins[g].joints = c.garment_weights(g).joints;
    skins[g].weights = c.garment_weights(g).weights;
    named.push_back({c.garment_name(g), &c.garment_rest(g), &skins[g], std::nullopt, &morphs[g]});
  }
  const SkinAnimation animation = poses_to_skin_animation(o.body.joints, frames, 30, "walk");
  const std::string glb = write_glb(named, &animation);
  std::uint32_t length = 0;
  std::memcpy(&length, glb.data() + 12, 4);
  const nlohmann::json doc = nlohmann::json::parse(glb.substr(20, length));
  for (std::size_t m = 1; m <= c.garment_count(); ++m) {
    EXPECT_EQ(doc["meshes"][m]["primitives"][0]["targets"].size(), frames.size());
    EXPECT_EQ(doc["meshes"][m]["weights"].size(), frames.size());
  }
  std::size_t weight_channels = 0;
  for (const auto& ch : doc["animations"][0]["channels"])
    weight_channels += ch["target"]["path"] == "weights" ? 1 : 0;
  EXPECT_EQ(weight_channels, c.garment_count());
  test::TempDir tmp;
  const auto file = tmp / "walk.glb";
  test::write_file(file, glb);
  if (const auto report = test::gltf_validator_report(file)) {
    const auto v = nlohmann::json::parse(*report);
    EXPECT_EQ(v["errors"], 0) << *report;
    EXPECT_EQ(v["warnings"], 0) << *report;
  }
  // Morphs that do not match the clip are refused.
  morphs[0].count = 3;
  EXPECT_THROW(write_glb(named, &animation), Error);
  EXPECT_THROW(write_glb(named, nullptr), Error);
}

} // namespace
} // namespace vfit
