// SPDX-License-Identifier: Apache-2.0
#include "vfit/engine/view/render.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"
#include "vfit/kernels/ray_caster.h"
#include "vfit/kernels/vertex_normals.h"

namespace vfit {
namespace {

using Vec3 = std::array<float, 3>;

Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 operator*(float s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 normalised(const Vec3& a) {
  const float n = std::sqrt(dot(a, a));
  return n > 0.0f ? (1.0f / n) * a : a;
}

// Rows of samples per TBB task when generating rays and shading.
constexpr std::size_t SAMPLE_ROW_GRAIN = 8;
// Ambient and diffuse weights of the Lambert shading; false colour gets more ambient so that
// its hue reads in shadow too.
constexpr float AMBIENT = 0.3f, DIFFUSE = 0.7f;
constexpr float SCALAR_AMBIENT = 0.45f, SCALAR_DIFFUSE = 0.55f;
constexpr float INSIDE_DARKENING = 0.6f; // the inside of an open garment, seen through an opening
constexpr float OUTLINE_DARKENING = 0.3f;
// A depth step larger than this fraction of the scene's diagonal between neighbouring samples
// of the same mesh is drawn as an outline (an arm in front of the torso in the side view).
constexpr float OUTLINE_DEPTH_STEP = 0.04f;
constexpr float FRAME_MARGIN = 1.06f;
constexpr float PERSPECTIVE_TAN_HALF_FOV = 0.2679492f; // tan 15°: a 30° field of view
constexpr Rgb BACKGROUND = {246 / 255.0f, 246 / 255.0f, 246 / 255.0f};

struct Bounds {
  Vec3 lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  Vec3 hi{-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
};

struct ViewAxes {
  Vec3 forward, right, up;
};

ViewAxes axes_of(RenderView view) {
  const Vec3 up{0, 1, 0};
  Vec3 forward{0, 0, -1};
  if (view == RenderView::SIDE) forward = {-1, 0, 0};
  if (view == RenderView::BACK) forward = {0, 0, 1};
  return {forward, cross(forward, up), up};
}

// Half the extent of the box along a unit axis.
float half_extent_along(const Bounds& b, const Vec3& axis) {
  float h = 0.0f;
  for (int i = 0; i < 3; ++i)
    h += 0.5f * std::abs(axis[i]) * (b.hi[i] - b.lo[i]);
  return h;
}

ViewCamera frame_view(RenderView view, const Bounds& b, float half_extent, const RenderOptions& o) {
  const ViewAxes a = axes_of(view);
  ViewCamera c;
  c.projection = o.projection;
  c.size = o.size;
  c.centre = 0.5f * (b.lo + b.hi);
  c.forward = a.forward;
  c.right = a.right;
  c.up = a.up;
  const float depth_half = half_extent_along(b, a.forward);
  if (o.projection == Projection::ORTHOGRAPHIC) {
    c.half_extent = half_extent;
    c.eye_distance = depth_half * 1.01f + 1e-3f * half_extent; // ray origins just behind the box
  } else {
    // The box's near face, at depth_half in front of the centre, fills the frame.
    c.eye_distance = half_extent / PERSPECTIVE_TAN_HALF_FOV + depth_half;
    c.half_extent = PERSPECTIVE_TAN_HALF_FOV * c.eye_distance;
  }
  return c;
}

struct MeshData {
  const Mesh* mesh;
  std::vector<float> normals; // #V × 3 area-weighted vertex normals
  Rgb colour;
};

struct ScalarData {
  std::size_t mesh;
  std::span<const float> values;
  float min, max;
  ColourMap map;
};

// The shaded samples of one view: colour, mesh id and depth along the view direction (+∞ for
// background), with the rays and hits that made them; reused from view to view.
struct Samples {
  int n = 0; // n × n samples
  std::vector<Rgb> colours;
  std::vector<std::int32_t> ids;
  std::vector<float> depths;
  std::vector<float> origins, directions; // n² × 3
  RayHits hits;
};

Vec3 corner(const Mesh& m, std::size_t v) {
  return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}

Vec3 vertex_normal(const MeshData& m, std::size_t v) {
  return {m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]};
}

Rgb shade(const std::vector<MeshData>& meshes, const std::optional<ScalarData>& scalar, const RayHits& hits,
          std::size_t k, const Vec3& direction, const Vec3& light) {
  const MeshData& md = meshes[static_cast<std::size_t>(hits.meshes[k])];
  const Mesh& m = *md.mesh;
  const std::size_t f = static_cast<std::size_t>(hits.triangles[k]);
  const std::size_t ia = static_cast<std::size_t>(m.triangles[3 * f]);
  const std::size_t ib = static_cast<std::size_t>(m.triangles[3 * f + 1]);
  const std::size_t ic = static_cast<std::size_t>(m.triangles[3 * f + 2]);
  const float u = hits.barycentrics[2 * k], v = hits.barycentrics[2 * k + 1], w = 1.0f - u - v;
  const Vec3 a = corner(m, ia);
  const Vec3 geometric = cross(corner(m, ib) - a, corner(m, ic) - a);
  Vec3 n = w * vertex_normal(md, ia) + u * vertex_normal(md, ib) + v * vertex_normal(md, ic);
  // Two-sided: seen from behind (the inside of an open garment), the surface faces the viewer.
  const bool inside = dot(geometric, direction) > 0.0f;
  if (inside) n = -1.0f * n;
  const float lambert = std::max(0.0f, dot(normalised(n), light));
  Rgb base = md.colour;
  float intensity = AMBIENT + DIFFUSE * lambert;
  if (scalar && scalar->mesh == static_cast<std::size_t>(hits.meshes[k])) {
    const float s = w * scalar->values[ia] + u * scalar->values[ib] + v * scalar->values[ic];
    const float t = scalar->max > scalar->min ? (s - scalar->min) / (scalar->max - scalar->min) : 0.5f;
    base = colour_map(scalar->map, t);
    intensity = SCALAR_AMBIENT + SCALAR_DIFFUSE * lambert;
  }
  if (inside) intensity *= INSIDE_DARKENING;
  return {base[0] * intensity, base[1] * intensity, base[2] * intensity};
}

void cast_and_shade(const RayCaster& caster, const std::vector<MeshData>& meshes,
                    const std::optional<ScalarData>& scalar, const ViewCamera& camera, int supersampling, Samples& s) {
  s.n = camera.size * supersampling;
  const std::size_t n = static_cast<std::size_t>(s.n);
  const std::size_t count = n * n;
  std::vector<float>& origins = s.origins;
  std::vector<float>& directions = s.directions;
  origins.resize(3 * count);
  directions.resize(3 * count);
  parallel_for_range(n, SAMPLE_ROW_GRAIN, [&](std::size_t row_begin, std::size_t row_end) {
    for (std::size_t j = row_begin; j < row_end; ++j)
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t k = j * n + i;
        std::array<float, 3> o, d;
        camera.ray((static_cast<float>(i) + 0.5f) / supersampling, (static_cast<float>(j) + 0.5f) / supersampling, o,
                   d);
        std::copy(o.begin(), o.end(), origins.begin() + 3 * k);
        std::copy(d.begin(), d.end(), directions.begin() + 3 * k);
      }
  });
  RayHits& hits = s.hits;
  caster.intersect(origins, directions, 0.0f, std::numeric_limits<float>::infinity(), hits);

  // A light above and to the left of the camera, so that folds and the body's curvature read.
  const Vec3 light = normalised(-1.0f * camera.forward + 0.45f * camera.up - 0.3f * camera.right);
  s.colours.resize(count);
  s.ids.resize(count);
  s.depths.resize(count);
  parallel_for_range(n, SAMPLE_ROW_GRAIN, [&](std::size_t row_begin, std::size_t row_end) {
    for (std::size_t k = row_begin * n; k < row_end * n; ++k) {
      s.ids[k] = hits.meshes[k];
      if (hits.meshes[k] < 0) {
        s.colours[k] = BACKGROUND;
        s.depths[k] = std::numeric_limits<float>::infinity();
        continue;
      }
      const Vec3 d{directions[3 * k], directions[3 * k + 1], directions[3 * k + 2]};
      s.depths[k] = hits.distances[k] * dot(d, camera.forward);
      s.colours[k] = shade(meshes, scalar, hits, k, d, light);
    }
  });
}

// Darkens the nearer sample of every neighbouring pair (`reach` samples apart, so that the line
// is about one pixel wide whatever the supersampling) that shows different meshes, or the same
// mesh across a depth step: silhouettes, hems and openings, limbs in front of the torso.
void draw_outlines(Samples& s, int reach, float depth_step) {
  const int n = s.n;
  std::vector<std::uint8_t> edge(s.ids.size(), 0);
  parallel_for_range(static_cast<std::size_t>(n), SAMPLE_ROW_GRAIN, [&](std::size_t row_begin, std::size_t row_end) {
    for (int j = static_cast<int>(row_begin); j < static_cast<int>(row_end); ++j)
      for (int i = 0; i < n; ++i) {
        const std::size_t k = static_cast<std::size_t>(j) * n + i;
        if (s.ids[k] < 0) continue;
        const int neighbours[4][2] = {{i - reach, j}, {i + reach, j}, {i, j - reach}, {i, j + reach}};
        for (const auto& q : neighbours) {
          if (q[0] < 0 || q[0] >= n || q[1] < 0 || q[1] >= n) continue;
          const std::size_t l = static_cast<std::size_t>(q[1]) * n + q[0];
          const bool differs = s.ids[l] != s.ids[k] || std::abs(s.depths[l] - s.depths[k]) > depth_step;
          if (differs && s.depths[k] < s.depths[l]) edge[k] = 1;
        }
      }
  });
  for (std::size_t k = 0; k < edge.size(); ++k)
    if (edge[k])
      for (float& c : s.colours[k])
        c *= OUTLINE_DARKENING;
}

std::uint8_t to_byte(float c) { return static_cast<std::uint8_t>(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f)); }

// Averages each pixel's supersampling² samples; its mesh id is the one most samples hit.
void resolve(const Samples& s, int supersampling, ViewImage& out) {
  const int size = s.n / supersampling;
  out.image = Image(size, size);
  out.mesh_ids.assign(static_cast<std::size_t>(size) * size, -1);
  const float weight = 1.0f / static_cast<float>(supersampling * supersampling);
  parallel_for_range(static_cast<std::size_t>(size), SAMPLE_ROW_GRAIN, [&](std::size_t row_begin, std::size_t row_end) {
    std::vector<std::int32_t> ids;
    for (int y = static_cast<int>(row_begin); y < static_cast<int>(row_end); ++y)
      for (int x = 0; x < size; ++x) {
        Rgb sum{0, 0, 0};
        ids.clear();
        for (int sy = 0; sy < supersampling; ++sy)
          for (int sx = 0; sx < supersampling; ++sx) {
            const std::size_t k = static_cast<std::size_t>(y * supersampling + sy) * s.n + (x * supersampling + sx);
            for (int c = 0; c < 3; ++c)
              sum[c] += weight * s.colours[k][c];
            ids.push_back(s.ids[k]);
          }
        std::int32_t best = ids[0];
        std::ptrdiff_t best_count = 0;
        for (std::int32_t id : ids) {
          const std::ptrdiff_t c = std::count(ids.begin(), ids.end(), id);
          if (c > best_count) best = id, best_count = c;
        }
        out.mesh_ids[static_cast<std::size_t>(y) * size + x] = best;
        out.image.set(x, y, {to_byte(sum[0]), to_byte(sum[1]), to_byte(sum[2])});
      }
  });
}

void check_inputs(std::span<const Mesh* const> meshes, const RenderOptions& o) {
  if (meshes.empty()) throw Error("render", 0, "no meshes to render");
  if (o.size < 16 || o.size > 8192)
    throw Error("render", 0, "view size " + std::to_string(o.size) + " is outside [16, 8192] pixels");
  if (o.supersampling < 1 || o.supersampling > 4)
    throw Error("render", 0, "supersampling " + std::to_string(o.supersampling) + " is outside [1, 4]");
  if (o.views.empty()) throw Error("render", 0, "no views requested");
  std::size_t faces = 0;
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const Mesh* m = meshes[k];
    const std::string name = "render mesh " + std::to_string(k);
    if (!m) throw Error(name, 0, "is null");
    if (m->positions.size() % 3 != 0 || m->triangles.size() % 3 != 0)
      throw Error(name, 0, "positions and triangles must be rows of 3");
    for (std::size_t i = 0; i < m->positions.size(); ++i)
      if (!std::isfinite(m->positions[i]))
        throw Error(name, 0, "vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
    for (std::size_t i = 0; i < m->triangles.size(); ++i)
      if (m->triangles[i] < 0 || static_cast<std::size_t>(m->triangles[i]) >= m->vertex_count())
        throw Error(name, 0,
                    "triangle " + std::to_string(i / 3) + " has vertex index " + std::to_string(m->triangles[i]) +
                        " out of range");
    faces += m->face_count();
  }
  if (faces == 0) throw Error("render", 0, "no triangles in any mesh");
  if (o.scalar) {
    if (o.scalar->mesh >= meshes.size())
      throw Error("render scalar", 0,
                  "mesh index " + std::to_string(o.scalar->mesh) + " out of range (" + std::to_string(meshes.size()) +
                      " meshes)");
    const std::size_t v = meshes[o.scalar->mesh]->vertex_count();
    if (o.scalar->values.size() != v)
      throw Error("render scalar", 0,
                  std::to_string(o.scalar->values.size()) + " values for mesh " + std::to_string(o.scalar->mesh) +
                      " of " + std::to_string(v) + " vertices");
  }
}

ScalarLegend legend_of(const RenderScalar& s) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : s.values)
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  if (lo > hi) lo = hi = 0.0f; // no finite value: everything is drawn grey anyway
  ScalarLegend l;
  l.name = s.name;
  l.min = s.min.value_or(lo);
  l.max = s.max.value_or(hi);
  l.map = s.map.value_or(l.min < 0.0f && l.max > 0.0f ? ColourMap::DIVERGING : ColourMap::SEQUENTIAL);
  return l;
}

} // namespace

std::string render_view_name(RenderView view) {
  switch (view) {
  case RenderView::FRONT: return "front";
  case RenderView::SIDE: return "side";
  case RenderView::BACK: return "back";
  }
  return "?";
}

RenderView parse_render_view(std::string_view name) {
  for (RenderView v : {RenderView::FRONT, RenderView::SIDE, RenderView::BACK})
    if (name == render_view_name(v)) return v;
  throw Error("views", 0, "unknown view '" + std::string(name) + "' (expected front, side or back)");
}

std::vector<RenderView> parse_render_views(std::string_view list) {
  std::vector<RenderView> views;
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t comma = std::min(list.find(',', start), list.size());
    views.push_back(parse_render_view(list.substr(start, comma - start)));
    start = comma + 1;
  }
  return views;
}

std::array<float, 2> ViewCamera::project(const std::array<float, 3>& p) const {
  const Vec3 q = p - centre;
  float x = dot(q, right), y = dot(q, up);
  if (projection == Projection::PERSPECTIVE) {
    const float depth = eye_distance + dot(q, forward);
    x *= eye_distance / depth;
    y *= eye_distance / depth;
  }
  const float pixels_per_metre = 0.5f * static_cast<float>(size) / half_extent;
  return {0.5f * size + x * pixels_per_metre, 0.5f * size - y * pixels_per_metre};
}

void ViewCamera::ray(float x, float y, std::array<float, 3>& origin, std::array<float, 3>& direction) const {
  const float metres_per_pixel = 2.0f * half_extent / static_cast<float>(size);
  const float dx = (x - 0.5f * size) * metres_per_pixel, dy = (0.5f * size - y) * metres_per_pixel;
  const Vec3 eye = centre - eye_distance * forward;
  if (projection == Projection::ORTHOGRAPHIC) {
    origin = eye + dx * right + dy * up;
    direction = forward;
  } else {
    origin = eye;
    direction = normalised(eye_distance * forward + dx * right + dy * up);
  }
}

Rgb default_mesh_colour(std::size_t index) {
  static constexpr Rgb BODY = {0.80f, 0.76f, 0.72f};
  static constexpr Rgb GARMENTS[] = {{0.22f, 0.45f, 0.78f},
                                     {0.90f, 0.52f, 0.20f},
                                     {0.30f, 0.66f, 0.36f},
                                     {0.58f, 0.36f, 0.70f},
                                     {0.90f, 0.78f, 0.25f}};
  if (index == 0) return BODY;
  return GARMENTS[(index - 1) % std::size(GARMENTS)];
}

std::int32_t ViewImage::mesh_id(int x, int y) const {
  assert(x >= 0 && x < image.width && y >= 0 && y < image.height && "pixel outside the view");
  return mesh_ids[static_cast<std::size_t>(y) * image.width + x];
}

Rendering render_views(std::span<const Mesh* const> meshes, const RenderOptions& options) {
  check_inputs(meshes, options);
  Bounds bounds;
  std::vector<MeshData> data(meshes.size());
  std::vector<RayCastMesh> cast_meshes(meshes.size());
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const Mesh& m = *meshes[k];
    for (std::size_t v = 0; v < m.vertex_count(); ++v)
      for (int i = 0; i < 3; ++i) {
        bounds.lo[i] = std::min(bounds.lo[i], m.positions[3 * v + i]);
        bounds.hi[i] = std::max(bounds.hi[i], m.positions[3 * v + i]);
      }
    data[k].mesh = &m;
    vertex_normals_tbb(m.positions, m.triangles, data[k].normals);
    data[k].colour = k < options.colours.size() ? options.colours[k] : default_mesh_colour(k);
    cast_meshes[k] = {m.positions, m.triangles};
  }
  const RayCaster caster(cast_meshes);

  Rendering r;
  std::optional<ScalarData> scalar;
  if (options.scalar) {
    r.legend = legend_of(*options.scalar);
    scalar = ScalarData{options.scalar->mesh, options.scalar->values, r.legend->min, r.legend->max, r.legend->map};
  }
  // One scale for every view: the largest half-extent any of them needs.
  float half_extent = 0.0f;
  for (RenderView v : options.views) {
    const ViewAxes a = axes_of(v);
    half_extent = std::max({half_extent, half_extent_along(bounds, a.right), half_extent_along(bounds, a.up)});
  }
  half_extent = std::max(half_extent, 1e-6f) * FRAME_MARGIN;
  const float diagonal = std::sqrt(dot(bounds.hi - bounds.lo, bounds.hi - bounds.lo));

  Samples s;
  for (RenderView v : options.views) {
    ViewImage view;
    view.view = v;
    view.camera = frame_view(v, bounds, half_extent, options);
    cast_and_shade(caster, data, scalar, view.camera, options.supersampling, s);
    r.ray_count += s.ids.size();
    if (options.outlines) draw_outlines(s, options.supersampling, OUTLINE_DEPTH_STEP * diagonal);
    resolve(s, options.supersampling, view);
    r.views.push_back(std::move(view));
  }
  return r;
}

} // namespace vfit
