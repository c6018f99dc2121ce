// SPDX-License-Identifier: Apache-2.0
#include "up_axis.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <vector>

#include "vfit/kernels/error.h"

namespace vfit {

std::string up_axis_name(UpAxis up) {
  switch (up) {
  case UpAxis::POS_Y: return "+y";
  case UpAxis::POS_Z: return "+z";
  case UpAxis::NEG_Z: return "-z";
  case UpAxis::NEG_Y: return "-y";
  case UpAxis::POS_X: return "+x";
  case UpAxis::NEG_X: return "-x";
  }
  return "+y";
}

std::array<double, 3> up_axis_vector(UpAxis up) {
  switch (up) {
  case UpAxis::POS_Y: return {0, 1, 0};
  case UpAxis::POS_Z: return {0, 0, 1};
  case UpAxis::NEG_Z: return {0, 0, -1};
  case UpAxis::NEG_Y: return {0, -1, 0};
  case UpAxis::POS_X: return {1, 0, 0};
  case UpAxis::NEG_X: return {-1, 0, 0};
  }
  return {0, 1, 0};
}

UpAxis parse_up_axis(std::string_view name) {
  std::string s(name);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (s.size() == 1) s = "+" + s;
  for (UpAxis up : UP_AXES)
    if (up_axis_name(up) == s) return up;
  throw Error(std::string(name), 0, "unknown up axis (expected +y, +z, -z, -y, +x or -x)");
}

std::array<double, 3> mirror_asymmetry(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  constexpr int N = 8;
  std::array<double, 3> result{0, 0, 0};
  const std::size_t nv = positions.size() / 3;
  if (nv == 0) return result;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], double(positions[3 * v + c]));
      hi[c] = std::max(hi[c], double(positions[3 * v + c]));
    }
  for (int c = 0; c < 3; ++c)
    if (!(hi[c] > lo[c])) return result;
  std::vector<double> area(std::size_t(N) * N * N, 0.0);
  double total = 0;
  for (std::size_t f = 0; f + 2 < triangles.size(); f += 3) {
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c)
        p[k][c] = positions[3 * std::size_t(triangles[f + k]) + c];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                 cz = e1[0] * e2[1] - e1[1] * e2[0];
    const double a = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
    if (!(a > 0)) continue;
    int cell[3];
    for (int c = 0; c < 3; ++c) {
      const double t = ((p[0][c] + p[1][c] + p[2][c]) / 3.0 - lo[c]) / (hi[c] - lo[c]);
      cell[c] = std::clamp(int(t * N), 0, N - 1);
    }
    area[(std::size_t(cell[0]) * N + std::size_t(cell[1])) * N + std::size_t(cell[2])] += a;
    total += a;
  }
  if (!(total > 0)) return result;
  for (int axis = 0; axis < 3; ++axis) {
    double diff = 0;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j)
        for (int k = 0; k < N; ++k) {
          int m[3] = {i, j, k};
          m[axis] = N - 1 - m[axis];
          diff += std::fabs(area[(std::size_t(i) * N + std::size_t(j)) * N + std::size_t(k)] -
                            area[(std::size_t(m[0]) * N + std::size_t(m[1])) * N + std::size_t(m[2])]);
        }
    result[std::size_t(axis)] = diff / (2.0 * total);
  }
  return result;
}

std::array<double, 3> normal_direction_shares(std::span<const float> positions,
                                              std::span<const std::int32_t> triangles) {
  std::array<double, 3> share{0, 0, 0};
  double total = 0;
  for (std::size_t f = 0; f + 2 < triangles.size(); f += 3) {
    double p[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c)
        p[k][c] = positions[3 * std::size_t(triangles[f + std::size_t(k)]) + std::size_t(c)];
    const double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (!(n2 > 0)) continue;
    const double twice_area = std::sqrt(n2);
    for (int c = 0; c < 3; ++c)
      share[std::size_t(c)] += n[c] * n[c] / twice_area; // area · n̂_c², times 2
    total += twice_area;
  }
  if (total > 0)
    for (double& x : share)
      x /= total;
  return share;
}

std::optional<UpAxis> detect_up_axis(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  // Margins: half the gaps measured on the corpus (see the header), so a garment that is less
  // symmetric or less tube-like than those still reads, and a shape that is neither is refused.
  constexpr double SYMMETRY_MARGIN = 0.05;
  constexpr double NORMAL_RATIO = 1.5;
  const auto share = normal_direction_shares(positions, triangles);
  std::optional<UpAxis> up;
  int axis = 0;
  if (share[1] * NORMAL_RATIO <= share[2])
    up = UpAxis::POS_Y, axis = 1;
  else if (share[2] * NORMAL_RATIO <= share[1])
    up = UpAxis::POS_Z, axis = 2;
  if (!up) return std::nullopt;
  const auto asym = mirror_asymmetry(positions, triangles);
  if (!(asym[0] + SYMMETRY_MARGIN <= asym[std::size_t(axis)])) return std::nullopt;
  return up;
}

namespace {
// The axis-aligned bounding box of #V × 3 positions: ±∞ bounds for no positions.
struct Box {
  std::array<float, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
};
Box bounding_box(std::span<const float> positions) {
  Box b;
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3)
    for (std::size_t c = 0; c < 3; ++c) {
      b.lo[c] = std::min(b.lo[c], positions[i + c]);
      b.hi[c] = std::max(b.hi[c], positions[i + c]);
    }
  return b;
}
} // namespace

std::optional<UpAxis> detect_body_up_axis(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  const auto [lo, hi] = bounding_box(positions);
  const double height_y = double(hi[1]) - double(lo[1]), height_z = double(hi[2]) - double(lo[2]);
  if (height_y >= 2 * height_z) return UpAxis::POS_Y;
  if (height_z >= 2 * height_y) return UpAxis::POS_Z;
  return detect_up_axis(positions, triangles);
}

namespace {
template <typename T> void rotate_coordinates(std::span<T> positions, UpAxis up) {
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
    const T x = positions[i], y = positions[i + 1], z = positions[i + 2];
    T nx = x, ny = y, nz = z;
    switch (up) {
    case UpAxis::POS_Y: break;
    case UpAxis::POS_Z: nx = x, ny = z, nz = -y; break;
    case UpAxis::NEG_Z: nx = x, ny = -z, nz = y; break;
    case UpAxis::NEG_Y: nx = -x, ny = -y, nz = z; break;
    case UpAxis::POS_X: nx = -y, ny = x, nz = z; break;
    case UpAxis::NEG_X: nx = y, ny = -x, nz = z; break;
    }
    positions[i] = nx;
    positions[i + 1] = ny;
    positions[i + 2] = nz;
  }
}

} // namespace

void rotate_to_y_up(std::span<float> positions, UpAxis up) { rotate_coordinates(positions, up); }
void rotate_to_y_up(std::span<double> positions, UpAxis up) { rotate_coordinates(positions, up); }

std::string facing_name(Facing facing) {
  switch (facing) {
  case Facing::POS_Z: return "+z";
  case Facing::NEG_Z: return "-z";
  case Facing::POS_X: return "+x";
  case Facing::NEG_X: return "-x";
  }
  return "+z";
}

Facing parse_facing(std::string_view name) {
  std::string s(name);
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (s.size() == 1) s = "+" + s;
  for (Facing f : {Facing::POS_Z, Facing::NEG_Z, Facing::POS_X, Facing::NEG_X})
    if (facing_name(f) == s) return f;
  throw Error(std::string(name), 0, "unknown facing (expected +z, -z, +x or -x)");
}

bool lateral_axis_is_z(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  // Margins: the extent ratio below the smallest measured on whole garments (1.28), the
  // symmetry gap below the smallest measured (a skirt: 0.034 against 0.041 is too close to use,
  // so such a garment must pass the extent cue, which a skirt as deep as wide does not).
  constexpr double EXTENT_RATIO = 1.2;
  constexpr double SYMMETRY_MARGIN = 0.02;
  if (positions.size() < 3) return false;
  const auto [lo, hi] = bounding_box(positions);
  const double ext_x = double(hi[0]) - double(lo[0]), ext_z = double(hi[2]) - double(lo[2]);
  if (!(ext_z >= EXTENT_RATIO * ext_x)) return false;
  const auto asym = mirror_asymmetry(positions, triangles);
  return asym[2] + SYMMETRY_MARGIN <= asym[0];
}

double top_edge_lean(std::span<const float> positions, int axis) {
  const auto a = static_cast<std::size_t>(axis);
  const Box box = bounding_box(positions);
  const float lo_y = box.lo[1], hi_y = box.hi[1], lo = box.lo[a], hi = box.hi[a];
  if (!(hi > lo) || !(hi_y > lo_y)) return 0;
  const double band = double(hi_y) - 0.05 * (double(hi_y) - double(lo_y));
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3)
    if (positions[i + 1] >= band) {
      sum += positions[i + a];
      ++n;
    }
  if (n == 0) return 0;
  return (sum / double(n) - 0.5 * (double(lo) + double(hi))) / (double(hi) - double(lo));
}

namespace {
template <typename T> void turn_about_y(std::span<T> positions, Facing facing) {
  for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
    const T x = positions[i], z = positions[i + 2];
    switch (facing) {
    case Facing::POS_Z: break;
    case Facing::NEG_Z: positions[i] = -x, positions[i + 2] = -z; break;
    case Facing::POS_X: positions[i] = -z, positions[i + 2] = x; break;
    case Facing::NEG_X: positions[i] = z, positions[i + 2] = -x; break;
    }
  }
}
} // namespace

void rotate_to_face_z(std::span<float> positions, Facing facing) { turn_about_y(positions, facing); }
void rotate_to_face_z(std::span<double> positions, Facing facing) { turn_about_y(positions, facing); }

Facing compose_facing(Facing first, Facing then) {
  // Quarter turns about +Y that take each facing to +Z: +Z 0, −X 1, −Z 2, +X 3 (counted the
  // way rotate_to_face_z() turns); two turns add.
  auto turns = [](Facing f) {
    switch (f) {
    case Facing::POS_Z: return 0;
    case Facing::NEG_X: return 1;
    case Facing::NEG_Z: return 2;
    case Facing::POS_X: return 3;
    }
    return 0;
  };
  constexpr std::array<Facing, 4> BY_TURNS = {Facing::POS_Z, Facing::NEG_X, Facing::NEG_Z, Facing::POS_X};
  return BY_TURNS[static_cast<std::size_t>((turns(first) + turns(then)) % 4)];
}

} // namespace vfit
