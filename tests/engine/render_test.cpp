// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/view/render.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "test_support.h"
#include "vfit/engine/view/bitmap_font.h"
#include "vfit/engine/view/image.h"
#include "vfit/geometry/body/mannequin.h"
#include "vfit/geometry/body/skeleton.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/primitives.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/ray_caster.h"

namespace vfit {
namespace {

using Vec3 = std::array<double, 3>;

Vec3 vertex(const Mesh& m, std::int32_t index) {
  const std::size_t v = static_cast<std::size_t>(index);
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Möller–Trumbore in double precision, both sides: the ray parameter t of the hit and the
// barycentrics (u, v), or nullopt. `margin` gets min(u, v, 1 − u − v) (negative outside).
struct OracleHit {
  double t, u, v;
};
std::optional<OracleHit> moller_trumbore(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c,
                                         double& margin) {
  const Vec3 e1 = sub(b, a), e2 = sub(c, a);
  const Vec3 p = cross(d, e2);
  const double det = dot(e1, p);
  margin = -1.0;
  if (std::abs(det) < 1e-18) return std::nullopt;
  const Vec3 s = sub(o, a);
  const double u = dot(s, p) / det;
  const Vec3 q = cross(s, e1);
  const double v = dot(d, q) / det;
  const double t = dot(e2, q) / det;
  margin = std::min({u, v, 1.0 - u - v});
  if (margin < 0.0 || t < 0.0) return std::nullopt;
  return OracleHit{t, u, v};
}

// The nearest hit over every triangle of every mesh; `ambiguous` is set when some triangle at
// (almost) that distance or closer is grazed within EDGE_EPS of its edges, where float and
// double arithmetic may legitimately disagree about hit or miss.
struct Oracle {
  std::int32_t mesh = -1, triangle = -1;
  double t = std::numeric_limits<double>::infinity();
  bool ambiguous = false;
};
Oracle brute_force(const std::vector<const Mesh*>& meshes, const Vec3& o, const Vec3& d) {
  constexpr double EDGE_EPS = 1e-5;
  Oracle best;
  std::vector<double> grazing; // t of near-edge candidates
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const Mesh& m = *meshes[k];
    for (std::size_t f = 0; f < m.face_count(); ++f) {
      const Vec3 a = vertex(m, m.triangles[3 * f]), b = vertex(m, m.triangles[3 * f + 1]),
                 c = vertex(m, m.triangles[3 * f + 2]);
      double margin = 0;
      const auto h = moller_trumbore(o, d, a, b, c, margin);
      if (std::abs(margin) < EDGE_EPS) {
        // Where the plane is hit, even if just outside the triangle.
        const Vec3 n = cross(sub(b, a), sub(c, a));
        const double den = dot(n, d);
        if (std::abs(den) > 1e-18) grazing.push_back(dot(n, sub(a, o)) / den);
      }
      if (h && h->t < best.t) best = {static_cast<std::int32_t>(k), static_cast<std::int32_t>(f), h->t, false};
    }
  }
  for (double t : grazing)
    if (t >= 0.0 && t <= best.t + 1e-4) best.ambiguous = true;
  return best;
}

TEST(RayCaster, FirstHitsEqualABruteForceOracleOnRandomRays) {
  // Two meshes: a closed sphere and an open tube crossing it, so rays meet both, from outside
  // and from inside, front and back faces.
  const Mesh sphere = make_uv_sphere(16, 32, 0.4f);
  Mesh tube = make_tube(6, 24, 0.15f, 1.2f);
  for (std::size_t v = 0; v < tube.vertex_count(); ++v)
    tube.positions[3 * v + 1] -= 0.6f;
  const std::vector<const Mesh*> meshes = {&sphere, &tube};
  const RayCastMesh cast[] = {{sphere.positions, sphere.triangles}, {tube.positions, tube.triangles}};
  const RayCaster caster(cast);
  EXPECT_EQ(caster.mesh_count(), 2u);

  std::mt19937 rng(7);
  std::uniform_real_distribution<float> box(-1.0f, 1.0f), target(-0.5f, 0.5f);
  const std::size_t count = 3000;
  std::vector<float> origins(3 * count), directions(3 * count);
  for (std::size_t i = 0; i < count; ++i)
    for (int c = 0; c < 3; ++c) {
      origins[3 * i + c] = i % 5 == 0 ? 0.1f * box(rng) : box(rng); // every fifth ray starts inside
      directions[3 * i + c] = target(rng) - origins[3 * i + c];
    }
  RayHits hits, serial;
  caster.intersect(origins, directions, 0.0f, std::numeric_limits<float>::infinity(), hits);
  caster.intersect_serial(origins, directions, 0.0f, std::numeric_limits<float>::infinity(), serial);
  ASSERT_EQ(hits.size(), count);
  EXPECT_EQ(hits.meshes, serial.meshes);
  EXPECT_EQ(hits.triangles, serial.triangles);
  EXPECT_EQ(hits.distances, serial.distances);

  std::size_t compared = 0, hit_count = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Vec3 o{origins[3 * i], origins[3 * i + 1], origins[3 * i + 2]};
    const Vec3 d{directions[3 * i], directions[3 * i + 1], directions[3 * i + 2]};
    const Oracle ref = brute_force(meshes, o, d);
    if (ref.ambiguous) continue;
    ++compared;
    ASSERT_EQ(hits.meshes[i], ref.mesh) << "ray " << i;
    if (ref.mesh < 0) {
      EXPECT_EQ(hits.triangles[i], -1);
      EXPECT_TRUE(std::isinf(hits.distances[i]));
      continue;
    }
    ++hit_count;
    // Float traversal against double arithmetic on coordinates of ~1 m and |d| ~ 1: the hit
    // parameter agrees to ~1e-6; 1e-4 leaves room without letting a wrong triangle pass (the
    // triangles are ≥ 2 cm wide).
    EXPECT_EQ(hits.triangles[i], ref.triangle) << "ray " << i;
    EXPECT_NEAR(hits.distances[i], ref.t, 1e-4) << "ray " << i;
    // The barycentrics reconstruct the hit point on the reported triangle.
    const Mesh& m = *meshes[static_cast<std::size_t>(hits.meshes[i])];
    const std::size_t f = static_cast<std::size_t>(hits.triangles[i]);
    const double u = hits.barycentrics[2 * i], v = hits.barycentrics[2 * i + 1];
    const Vec3 a = vertex(m, m.triangles[3 * f]), b = vertex(m, m.triangles[3 * f + 1]),
               c = vertex(m, m.triangles[3 * f + 2]);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR((1 - u - v) * a[k] + u * b[k] + v * c[k], o[k] + hits.distances[i] * d[k], 1e-4) << "ray " << i;
  }
  EXPECT_GT(compared, count * 99 / 100) << "too many rays graze an edge to be compared";
  EXPECT_GT(hit_count, count / 2);
  EXPECT_LT(hit_count, compared); // some rays miss everything
}

TEST(RayCaster, TFarLimitsTheHitsAndEmptyMeshesAreNeverHit) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.5f);
  const Mesh empty;
  const RayCastMesh cast[] = {{empty.positions, empty.triangles}, {sphere.positions, sphere.triangles}};
  const RayCaster caster(cast);
  const std::vector<float> origins = {0, 0, 2, 0, 0, 2};
  const std::vector<float> directions = {0, 0, -1, 0, 1, 0};
  RayHits hits;
  caster.intersect(origins, directions, 0.0f, 10.0f, hits);
  EXPECT_EQ(hits.meshes[0], 1);
  // 2 − 0.5, less the chord sag of the polygonal sphere (r(1 − cos(π/16)) < 1 cm) at most.
  EXPECT_NEAR(hits.distances[0], 1.5f, 0.01f);
  EXPECT_EQ(hits.meshes[1], -1);
  caster.intersect(origins, directions, 0.0f, 1.0f, hits);
  EXPECT_EQ(hits.meshes[0], -1) << "the sphere lies beyond t_far";
}

RenderOptions single_view(int size) {
  RenderOptions o;
  o.size = size;
  o.views = {RenderView::FRONT};
  o.supersampling = 1;
  o.outlines = false;
  return o;
}

double luminance(Rgb8 c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

TEST(Render, AnOrthographicSphereIsADiscOfTheExpectedRadiusBrighterAtItsCentre) {
  const Mesh sphere = make_uv_sphere(48, 96, 0.5f);
  const Mesh* meshes[] = {&sphere};
  const Rendering r = render_views(meshes, single_view(128));
  ASSERT_EQ(r.views.size(), 1u);
  const ViewImage& v = r.views[0];
  ASSERT_EQ(v.image.width, 128);
  const auto c = v.camera.project({0, 0, 0});
  const auto edge = v.camera.project({0.5f, 0, 0});
  const double radius = edge[0] - c[0];
  EXPECT_NEAR(c[0], 64.0, 1e-3);
  EXPECT_NEAR(c[1], 64.0, 1e-3);
  // The sphere's extent, plus the 6 % framing margin, fills the picture: r = 64 / 1.06 px.
  EXPECT_NEAR(radius, 64.0 / 1.06, 0.01);
  // Pixel centres clearly inside the disc see the sphere, those clearly outside see nothing;
  // the band of ±1 px covers the polygonal silhouette (inscribed: r·cos(π/96) = r − 0.03 px).
  std::size_t inside = 0;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x) {
      const double rho = std::hypot(x + 0.5 - c[0], y + 0.5 - c[1]);
      if (rho < radius - 1.0) {
        EXPECT_EQ(v.mesh_id(x, y), 0) << x << "," << y;
      }
      if (rho > radius + 1.0) {
        EXPECT_EQ(v.mesh_id(x, y), -1) << x << "," << y;
      }
      inside += v.mesh_id(x, y) == 0;
    }
  EXPECT_NEAR(std::sqrt(inside / M_PI), radius, 0.5);
  // Lambert shading: the centre faces the light (28° off the view axis) better than the rim.
  double ring = 0;
  const int samples = 64;
  for (int k = 0; k < samples; ++k) {
    const double a = 2 * M_PI * k / samples;
    ring += luminance(v.image.at(int(c[0] + 0.9 * radius * std::cos(a)), int(c[1] + 0.9 * radius * std::sin(a))));
  }
  EXPECT_GT(luminance(v.image.at(64, 64)), ring / samples + 30.0);
  EXPECT_EQ(v.image.at(1, 1), (Rgb8{246, 246, 246})); // background
}

TEST(Render, CameraRaysProjectBackToTheirPixel) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.3f);
  const Mesh* meshes[] = {&sphere};
  for (Projection p : {Projection::ORTHOGRAPHIC, Projection::PERSPECTIVE}) {
    RenderOptions o = single_view(32);
    o.projection = p;
    o.views = {RenderView::FRONT, RenderView::SIDE, RenderView::BACK};
    const Rendering r = render_views(meshes, o);
    for (const ViewImage& v : r.views)
      for (float t : {0.5f, 1.0f, 2.0f}) {
        std::array<float, 3> origin, direction;
        v.camera.ray(7.25f, 20.5f, origin, direction);
        const std::array<float, 3> q = {origin[0] + t * direction[0], origin[1] + t * direction[1],
                                        origin[2] + t * direction[2]};
        const auto px = v.camera.project(q);
        EXPECT_NEAR(px[0], 7.25f, 1e-3f);
        EXPECT_NEAR(px[1], 20.5f, 1e-3f);
      }
  }
}

TEST(Render, ViewsLookFromTheirSides) {
  // A small box sphere to the body's left (+X) and in front (+Z) of a big one: from the front
  // it is on the right of the picture, from the back on the left, from the side (+X) in front.
  const Mesh big = make_uv_sphere(16, 32, 0.5f);
  Mesh small = make_uv_sphere(8, 16, 0.1f);
  for (std::size_t v = 0; v < small.vertex_count(); ++v) {
    small.positions[3 * v] += 0.45f;
    small.positions[3 * v + 2] += 0.45f;
  }
  const Mesh* meshes[] = {&big, &small};
  RenderOptions o = single_view(64);
  o.views = {RenderView::FRONT, RenderView::SIDE, RenderView::BACK};
  const Rendering r = render_views(meshes, o);
  auto mean_x = [](const ViewImage& v) {
    double sum = 0, n = 0;
    for (int y = 0; y < v.image.height; ++y)
      for (int x = 0; x < v.image.width; ++x)
        if (v.mesh_id(x, y) == 1) sum += x, n += 1;
    return n > 0 ? sum / n : -1.0;
  };
  EXPECT_GT(mean_x(r.views[0]), 40.0); // front: +X on the right
  EXPECT_GT(mean_x(r.views[2]), 0.0);
  EXPECT_LT(mean_x(r.views[2]), 24.0); // back: +X on the left
  EXPECT_GT(mean_x(r.views[1]), 0.0);
  EXPECT_LT(mean_x(r.views[1]), 24.0); // side from +X: the front (+Z) on the left
}

// The check: in the front view, garment pixels cover the torso.
TEST(Render, AGarmentOnTheMannequinCoversTheTorsoInTheFrontView) {
  MannequinOptions mo;
  mo.target_vertices = 1500;
  const Body body = make_mannequin(mo);
  GarmentOptions go;
  go.type = GarmentType::TEE;
  go.body = mo.measurements;
  go.pose = mo.pose;
  go.target_vertices = 1000;
  const Garment tee = make_garment(go);
  const Mesh* meshes[] = {&body.mesh, &tee.mesh};
  const Rendering r = render_views(meshes, single_view(160));
  const ViewImage& v = r.views[0];
  auto pixel_of = [&](Joint j) {
    const auto row = body.joints.row(static_cast<int>(j));
    return v.camera.project({float(row[0]), float(row[1]), float(row[2])});
  };
  // The torso: between the shoulder joints (inner 60 %), from the chest (spine3) down to the
  // lower back (spine1).
  const auto left = pixel_of(Joint::LEFT_SHOULDER), right = pixel_of(Joint::RIGHT_SHOULDER);
  const auto chest = pixel_of(Joint::SPINE3), waist = pixel_of(Joint::SPINE1);
  const float mid = 0.5f * (left[0] + right[0]), half = 0.3f * std::abs(left[0] - right[0]);
  ASSERT_GT(half, 5.0f);
  ASSERT_GT(waist[1], chest[1] + 5.0f); // image y grows downward
  std::size_t torso = 0, garment = 0;
  for (int y = int(chest[1]); y <= int(waist[1]); ++y)
    for (int x = int(mid - half); x <= int(mid + half); ++x) {
      ++torso;
      garment += v.mesh_id(x, y) == 1;
    }
  EXPECT_GT(garment, torso * 98 / 100) << garment << " of " << torso << " torso pixels show the tee";
  // And not everywhere: the head and the knees show the body.
  const auto head = pixel_of(Joint::HEAD), knee = pixel_of(Joint::LEFT_KNEE);
  EXPECT_EQ(v.mesh_id(int(head[0]), int(head[1])), 0);
  EXPECT_EQ(v.mesh_id(int(knee[0]), int(knee[1])), 0);
  // The front view shows the body's left (+X) on the picture's right.
  EXPECT_GT(left[0], right[0]);
}

TEST(Render, FalseColourFollowsTheScalarAndAddsALegend) {
  const Mesh sphere = make_uv_sphere(24, 48, 0.5f);
  RenderOptions o = single_view(96);
  RenderScalar s;
  s.name = "height";
  for (std::size_t v = 0; v < sphere.vertex_count(); ++v)
    s.values.push_back(sphere.positions[3 * v + 1]);
  o.scalar = s;
  const Mesh* meshes[] = {&sphere};
  const Rendering r = render_views(meshes, o);
  ASSERT_TRUE(r.legend.has_value());
  EXPECT_NEAR(r.legend->min, -0.5f, 1e-6f);
  EXPECT_NEAR(r.legend->max, 0.5f, 1e-6f);
  EXPECT_EQ(r.legend->map, ColourMap::DIVERGING); // the range spans 0
  const ViewImage& v = r.views[0];
  // The diverging map is red at the top (max) and blue at the bottom (min).
  const Rgb8 top = v.image.at(48, 20), bottom = v.image.at(48, 76);
  EXPECT_GT(top[0], top[2]);
  EXPECT_GT(bottom[2], bottom[0]);
  const Image composite = compose_views(r);
  EXPECT_GT(composite.width, 96 + 20);
  EXPECT_EQ(composite.height, 96);
}

TEST(Render, ComposedViewsSitSideBySideWithTitles) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.5f);
  const Mesh* meshes[] = {&sphere};
  RenderOptions o = single_view(64);
  o.views = {RenderView::FRONT, RenderView::BACK};
  const Rendering r = render_views(meshes, o);
  const Image all = compose_views(r);
  EXPECT_EQ(all.width, 128);
  EXPECT_EQ(all.height, 64);
  const Image back = compose_view(r, 1);
  EXPECT_EQ(back.width, 64);
  EXPECT_THROW(compose_view(r, 2), Error);
  // The title "BACK" is drawn in the top-left corner: some dark pixels where the view had none.
  std::size_t ink = 0;
  for (int y = 0; y < 6 + GLYPH_HEIGHT; ++y)
    for (int x = 0; x < 6 + text_width("BACK", 1); ++x)
      ink += luminance(back.at(x, y)) < 128.0;
  EXPECT_GT(ink, 20u);
}

TEST(BitmapFont, GlyphsAreOurOwnAndUnknownCharactersDrawAsAQuestionMark) {
  std::size_t eight = 0;
  for (int row = 0; row < GLYPH_HEIGHT; ++row)
    for (int column = 0; column < GLYPH_WIDTH; ++column) {
      eight += glyph_ink('8', column, row);
      EXPECT_EQ(glyph_ink('a', column, row), glyph_ink('A', column, row));
      EXPECT_EQ(glyph_ink('#', column, row), glyph_ink('?', column, row));
    }
  EXPECT_EQ(eight, 17u);
  EXPECT_FALSE(glyph_ink('8', 5, 0));
  EXPECT_EQ(text_width("", 2), 0);
  EXPECT_EQ(text_width("12", 2), 22);
}

TEST(Render, PngIsWrittenAtomicallyAndDecodesBack) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.5f);
  const Mesh* meshes[] = {&sphere};
  RenderOptions o = single_view(40);
  o.views = {RenderView::FRONT, RenderView::SIDE, RenderView::BACK};
  o.supersampling = 2;
  o.outlines = true;
  const Image composite = compose_views(render_views(meshes, o));
  test::TempDir dir;
  const auto path = dir / "views.png";
  write_png(path, composite);
  const Image back = read_png(path);
  EXPECT_EQ(back.width, 120);
  EXPECT_EQ(back.height, 40);
  EXPECT_EQ(back.rgb, composite.rgb); // PNG is lossless
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path()))
    ++files;
  EXPECT_EQ(files, 1u) << "no temporary file is left beside the PNG";
  EXPECT_THROW(decode_png("not a png", "x.png"), Error);
  EXPECT_THROW(decode_png(std::string("\x89PNG\r\n\x1a\n", 8) + "truncated", "x.png"), Error);
  EXPECT_THROW(encode_png(Image()), Error);
}

TEST(Render, BadArgumentsThrow) {
  const Mesh sphere = make_uv_sphere(8, 16, 0.5f);
  const Mesh* one[] = {&sphere};
  EXPECT_THROW(render_views(std::span<const Mesh* const>(), RenderOptions{}), Error);
  RenderOptions o;
  o.size = 0;
  EXPECT_THROW(render_views(one, o), Error);
  o = RenderOptions{};
  o.views.clear();
  EXPECT_THROW(render_views(one, o), Error);
  o = RenderOptions{};
  o.supersampling = 0;
  EXPECT_THROW(render_views(one, o), Error);
  o = RenderOptions{};
  o.scalar = RenderScalar{0, {1.0f, 2.0f}, "too few", {}, {}, {}};
  EXPECT_THROW(render_views(one, o), Error);
  o.scalar->mesh = 3;
  EXPECT_THROW(render_views(one, o), Error);
  const Mesh* null_mesh[] = {nullptr};
  EXPECT_THROW(render_views(null_mesh, RenderOptions{}), Error);
  const Mesh empty;
  const Mesh* no_faces[] = {&empty};
  EXPECT_THROW(render_views(no_faces, RenderOptions{}), Error);
  Mesh bad_index = sphere;
  bad_index.triangles[4] = 100000;
  const Mesh* bad[] = {&bad_index};
  EXPECT_THROW(render_views(bad, RenderOptions{}), Error);
  EXPECT_THROW(parse_render_view("top"), Error);
  EXPECT_THROW(parse_render_views("front,,back"), Error);
  EXPECT_EQ(parse_render_views("back,front").size(), 2u);
}

} // namespace
} // namespace vfit
