// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Pictures of a body and its garments for judging a fit: views from the front, the side and
/// the back, ray-cast on our Embree BVH (kernels/ray_caster.h) with no GPU and no display,
/// smooth Lambert shading from a light beside the camera, per-mesh colours, outlines where one
/// mesh passes in front of another, and optionally one mesh in false colour by a per-vertex
/// scalar (strain, ease) with a legend. The views are composited side by side into one image
/// (compose_views) or kept apart (compose_view), and written as PNG (image.h).

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "vfit/engine/view/colour_map.h"
#include "vfit/engine/view/image.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Where a view looks from (vfit's convention: Y up, the body faces +Z, +X is its left).
enum class RenderView {
  FRONT, ///< from +Z looking toward −Z: the body's front, its left (+X) on the picture's right
  SIDE,  ///< from +X looking toward −X: the body's left side, its front (+Z) on the left
  BACK,  ///< from −Z looking toward +Z: the body's back
};

/// "front" | "side" | "back".
std::string render_view_name(RenderView view);
/// Parses "front" | "side" | "back" (case-sensitive); throws vfit::Error naming the word.
RenderView parse_render_view(std::string_view name);
/// Parses a comma-separated list such as "front,side,back"; throws vfit::Error for an empty
/// list or an unknown name.
std::vector<RenderView> parse_render_views(std::string_view list);

/// The camera model of a view.
enum class Projection {
  ORTHOGRAPHIC, ///< parallel rays: sizes compare across the picture (default)
  PERSPECTIVE,  ///< a pinhole camera with a 30° field of view
};

/// How one view maps the world to its size × size pixels. Pixel coordinates are continuous:
/// x to the right, y down, pixel (i, j) covers [i, i+1) × [j, j+1).
struct ViewCamera {
  Projection projection = Projection::ORTHOGRAPHIC;
  int size = 0;                   ///< pixels along each side
  std::array<float, 3> centre{};  ///< the point at the middle of the picture (m)
  std::array<float, 3> forward{}; ///< unit viewing direction
  std::array<float, 3> right{};   ///< unit, the picture's +x
  std::array<float, 3> up{};      ///< unit, the picture's −y (world +Y)
  float half_extent = 1.0f;       ///< half the picture's side at the centre's depth (m)
  float eye_distance = 1.0f;      ///< distance from the eye (or the ray origins) to centre's plane (m)

  /// Pixel coordinates (x, y) of world point p (m). For PERSPECTIVE, p must lie in front of
  /// the eye.
  std::array<float, 2> project(const std::array<float, 3>& p) const;
  /// The ray through pixel coordinates (x, y): origin (on a plane behind the scene for
  /// ORTHOGRAPHIC, the eye for PERSPECTIVE) and unit direction.
  void ray(float x, float y, std::array<float, 3>& origin, std::array<float, 3>& direction) const;
};

/// A per-vertex scalar shown in false colour on one mesh.
struct RenderScalar {
  std::size_t mesh = 0;          ///< index of the mesh it belongs to
  std::vector<float> values;     ///< #V of that mesh; NaN = no value (drawn grey)
  std::string name;              ///< legend title, e.g. "strain" (may be empty)
  std::optional<float> min, max; ///< colour range; default: the finite values' range
  std::optional<ColourMap> map;  ///< default: DIVERGING when min < 0 < max, else SEQUENTIAL
};

/// What render_views() draws and how.
struct RenderOptions {
  int size = 512; ///< pixels along each side of a view, in [16, 8192]
  /// The views, in the order they are rendered and composed (duplicates allowed).
  std::vector<RenderView> views = {RenderView::FRONT, RenderView::SIDE, RenderView::BACK};
  Projection projection = Projection::ORTHOGRAPHIC; ///< the camera model of every view
  int supersampling = 2;              ///< samples per pixel along each axis (1 = none, 2 = 2×2), in [1, 4]
  bool outlines = true;               ///< dark lines at silhouettes and where one surface passes another
  std::vector<Rgb> colours;           ///< base colour per mesh; missing entries use default_mesh_colour()
  std::optional<RenderScalar> scalar; ///< false colour for one mesh, with a legend
};

/// Default base colour of mesh `index`: 0 (the body) skin-grey, 1, 2, … (garments) a blue,
/// an orange, a green, a purple, a yellow, then repeating.
Rgb default_mesh_colour(std::size_t index);

/// One rendered view.
struct ViewImage {
  RenderView view = RenderView::FRONT; ///< where it looks from
  ViewCamera camera;                   ///< maps world points to its pixels
  Image image;                         ///< size × size
  /// size × size, row-major from the top: the mesh index seen in each pixel (the one most of its
  /// samples hit; ties to the first sample), or −1 for background.
  std::vector<std::int32_t> mesh_ids;

  /// The mesh seen at pixel (x, y), or −1 (assert-checked range).
  std::int32_t mesh_id(int x, int y) const;
};

/// The legend of a false-colour rendering: the colour range actually used.
struct ScalarLegend {
  std::string name;                      ///< RenderScalar::name
  float min = 0, max = 1;                ///< values drawn at the bottom and the top of the colour map
  ColourMap map = ColourMap::SEQUENTIAL; ///< the map used
};

/// What render_views() returns: the views and what the legend shows.
struct Rendering {
  std::vector<ViewImage> views;       ///< in the order of RenderOptions::views
  std::optional<ScalarLegend> legend; ///< set when a scalar was rendered
  std::size_t ray_count = 0;          ///< rays cast over all views
};

/// Renders `meshes` (mesh 0 conventionally the body, the rest garments; all in the same units,
/// positions #V × 3) from each of `options.views`. Every view frames the union bounding box
/// of all meshes at the same scale (orthographic: the same metres per pixel in every view), with
/// a 6 % margin. Shading: base colour × (ambient 0.3 + 0.7 · max(0, n·l)) with n the smooth
/// normal (area-weighted vertex normals interpolated by barycentrics) turned toward the viewer
/// (two-sided, so open garments show their inside, darkened to 60 %) and l a light above and left
/// of the camera. Supersampled samples are averaged per pixel.
/// Throws vfit::Error for an empty mesh list, a null mesh, no triangles in any mesh, triangle
/// indices out of range, non-finite positions, a size or supersampling outside its range, no
/// views, or a scalar whose mesh index or value count does not match.
Rendering render_views(std::span<const Mesh* const> meshes, const RenderOptions& options);

/// All views side by side, left to right in rendering order, each titled with its name
/// (top-left), followed by the legend panel when the rendering has one: a vertical colour bar
/// with the maximum at the top, the minimum at the bottom and the middle value, labelled with
/// the built-in bitmap font, under the scalar's name.
Image compose_views(const Rendering& rendering);

/// View `index` alone (titled), with the legend panel when the rendering has one. Throws
/// vfit::Error when `index` is out of range.
Image compose_view(const Rendering& rendering, std::size_t index);

} // namespace vfit
