// SPDX-License-Identifier: Apache-2.0
// One row of ClosestHits from a finished closest-point search, shared by ProximityIndex
// (kernels/proximity.cpp) and SpatialHash (kernels/spatial_hash.cpp) so that both decide the
// side the same way. Not a public header: it is included textually, like closest_point_math.h,
// inside those files' anonymous namespace after closest_point_math.h (whose types it uses).

constexpr std::uint32_t NO_TRIANGLE = std::numeric_limits<std::uint32_t>::max();

/// Writes row i of `hits`: the closest point `best` on triangle `best_triangle` (NO_TRIANGLE:
/// nothing within reach — the query point itself, triangle −1, +∞ distance), its barycentrics
/// and feature, and the signed distance. seed 000 eq. 18: f = (g − h)·n_h < 0 ⇒ inside, n_h the
/// angle-weighted pseudo-normal of the closest feature on the capped mesh; a hole cap strictly
/// closer than the mesh (`best_cap` on cap triangle `best_cap_triangle`, a query near an open
/// hole) decides the side instead. feature_normal(triangle, feature) → const float[3].
template <typename FeatureNormal>
void write_closest_hit(vfit_vec3 query, const vfit_closest_point& best, std::uint32_t best_triangle,
                       const vfit_closest_point& best_cap, std::uint32_t best_cap_triangle,
                       const FeatureNormal& feature_normal, std::size_t i, ClosestHits& hits) {
  if (best_triangle == NO_TRIANGLE) {
    hits.points[3 * i] = query.x;
    hits.points[3 * i + 1] = query.y;
    hits.points[3 * i + 2] = query.z;
    hits.triangles[i] = -1;
    hits.barycentrics[2 * i] = 0.0f;
    hits.barycentrics[2 * i + 1] = 0.0f;
    hits.signed_distances[i] = std::numeric_limits<float>::infinity();
    hits.features[i] = static_cast<std::int8_t>(TriangleFeature::NONE);
    return;
  }
  hits.points[3 * i] = best.point.x;
  hits.points[3 * i + 1] = best.point.y;
  hits.points[3 * i + 2] = best.point.z;
  hits.triangles[i] = static_cast<std::int32_t>(best_triangle);
  hits.barycentrics[2 * i] = best.u;
  hits.barycentrics[2 * i + 1] = best.v;
  hits.features[i] = static_cast<std::int8_t>(best.feature);
  const bool cap_decides = best_cap_triangle != NO_TRIANGLE && best_cap.distance2 < best.distance2;
  const vfit_closest_point& side_point = cap_decides ? best_cap : best;
  const float* n = feature_normal(cap_decides ? best_cap_triangle : best_triangle, side_point.feature);
  const vfit_vec3 d = vfit_v3_sub(query, side_point.point);
  const float side = d.x * n[0] + d.y * n[1] + d.z * n[2];
  const float distance = std::sqrt(best.distance2);
  hits.signed_distances[i] = side < 0.0f ? -distance : distance;
}
