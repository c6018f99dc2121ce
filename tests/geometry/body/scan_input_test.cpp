// SPDX-License-Identifier: Apache-2.0
#include "vfit/geometry/body/scan_input.h"

#include <algorithm>
#include <random>
#include <utility>

#include <gtest/gtest.h>

#include "test_support.h"

namespace vfit {
namespace {

bool has_warning(const PreparedScan& p, const std::string& needle) {
  return std::any_of(p.warnings.begin(), p.warnings.end(),
                     [&](const std::string& w) { return w.find(needle) != std::string::npos; });
}

// The mannequin's closed A-pose mesh as a scan: as given, nothing changes; stored facing -Z, +X
// or -X, it is turned back exactly (quarter turns only permute and negate coordinates).
TEST(ScanInput, TurnsAScanFacingAnotherWayByItsFeet) {
  const Mesh& body = test::mannequin(RestPose::APOSE, 4000).mesh;
  const PreparedScan same = prepare_scan(body, "scan");
  EXPECT_TRUE(same.warnings.empty());
  EXPECT_EQ(same.mesh.positions, body.positions);
  EXPECT_EQ(same.mesh.triangles, body.triangles);
  for (Facing f : {Facing::NEG_Z, Facing::POS_X, Facing::NEG_X}) {
    SCOPED_TRACE(facing_name(f));
    Mesh stored = body;
    for (int k = 0; k < (f == Facing::NEG_Z ? 1 : 3); ++k)
      rotate_to_face_z(stored.positions, f);
    const PreparedScan p = prepare_scan(stored, "scan");
    EXPECT_EQ(facing_name(p.facing), facing_name(f));
    EXPECT_EQ(p.mesh.positions, body.positions);
    EXPECT_TRUE(has_warning(p, "faced " + facing_name(f)));
    const PreparedScan stated = prepare_scan(stored, "scan", f); // stated: no search, no warning
    EXPECT_EQ(stated.mesh.positions, body.positions);
    EXPECT_TRUE(stated.warnings.empty());
  }
}

// Holes are capped for the fit (caps after the scan's own vertices and triangles) and dropped
// again from the rigged scan; a scan wound inside out is wound outward.
TEST(ScanInput, CapsHolesForTheFitAndRewindsAnInsideOutScan) {
  const Body& mannequin = test::mannequin(RestPose::APOSE, 4000);
  Mesh holed = mannequin.mesh;
  holed.triangles.clear();
  std::mt19937 rng(5);
  for (std::size_t f = 0; f < mannequin.mesh.face_count(); ++f)
    if (std::uniform_real_distribution<double>(0, 1)(rng) >= 0.02)
      for (int k = 0; k < 3; ++k)
        holed.triangles.push_back(mannequin.mesh.triangles[3 * f + std::size_t(k)]);
  holed.uv_triangles.clear();
  holed.normal_triangles.clear();
  holed.face_labels.clear();
  const PreparedScan p = prepare_scan(holed, "scan");
  EXPECT_TRUE(has_warning(p, "holes capped"));
  EXPECT_EQ(p.vertex_count, holed.vertex_count());
  EXPECT_EQ(p.face_count, holed.face_count());
  EXPECT_GT(p.mesh.vertex_count(), holed.vertex_count());
  EXPECT_GT(p.mesh.face_count(), holed.face_count());
  EXPECT_TRUE(std::equal(holed.positions.begin(), holed.positions.end(), p.mesh.positions.begin()));
  // As fit_scan() would return it: the prepared mesh with weights for every vertex.
  Body rigged;
  rigged.mesh = p.mesh;
  rigged.weights.joints.assign(4 * p.mesh.vertex_count(), 0);
  rigged.weights.weights.assign(4 * p.mesh.vertex_count(), 0.25f);
  restore_scan_surface(rigged, p);
  EXPECT_EQ(rigged.mesh.positions, holed.positions);
  EXPECT_EQ(rigged.mesh.triangles, holed.triangles);
  EXPECT_EQ(rigged.weights.vertex_count(), holed.vertex_count());

  Mesh inside_out = mannequin.mesh;
  for (std::size_t f = 0; f < inside_out.face_count(); ++f) {
    std::swap(inside_out.triangles[3 * f + 1], inside_out.triangles[3 * f + 2]);
    if (inside_out.has_uvs()) std::swap(inside_out.uv_triangles[3 * f + 1], inside_out.uv_triangles[3 * f + 2]);
  }
  const PreparedScan q = prepare_scan(inside_out, "scan");
  EXPECT_TRUE(has_warning(q, "inside out"));
  EXPECT_EQ(q.mesh.triangles, mannequin.mesh.triangles);
}

// A point cloud has no sides or holes: it is only turned by a stated facing.
TEST(ScanInput, LeavesAPointCloudAsGivenUnlessTold) {
  Mesh cloud;
  cloud.positions = test::mannequin(RestPose::APOSE, 4000).mesh.positions;
  const PreparedScan p = prepare_scan(cloud, "cloud");
  EXPECT_TRUE(p.warnings.empty());
  EXPECT_EQ(p.mesh.positions, cloud.positions);
  const PreparedScan q = prepare_scan(cloud, "cloud", Facing::NEG_Z);
  EXPECT_EQ(q.mesh.positions[2], -cloud.positions[2]);
}

} // namespace
} // namespace vfit
