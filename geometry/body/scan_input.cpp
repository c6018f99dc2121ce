// SPDX-License-Identifier: Apache-2.0
#include "scan_input.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "joint_estimation.h"
#include "vfit/geometry/mesh/orient.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/hole_caps.h"
#include "vfit/kernels/proximity.h"

namespace vfit {
namespace {

bool estimator_accepts(const Mesh& m) {
  try {
    (void)estimate_joints(m);
    return true;
  } catch (const Error&) {
    return false;
  }
}

} // namespace

PreparedScan prepare_scan(Mesh scan, const std::string& source, std::optional<Facing> facing) {
  PreparedScan p;
  p.vertex_count = scan.vertex_count();
  p.face_count = scan.face_count();
  if (scan.face_count() > 0) {
    if (const OrientReport o = orient_consistently(scan); o.changed())
      p.warnings.push_back(source + ": turned over " + std::to_string(o.flipped) + " of " +
                           std::to_string(scan.face_count()) +
                           " triangles wound against their neighbours (inconsistent orientation)");
    if (orient_outward(scan))
      p.warnings.push_back(source + ": wound inside out (negative enclosed volume): every triangle turned over");
  }
  // UVs, normals and labels wait outside while caps are added.
  std::swap(p.attributes.uvs, scan.uvs);
  std::swap(p.attributes.uv_triangles, scan.uv_triangles);
  std::swap(p.attributes.normals, scan.normals);
  std::swap(p.attributes.normal_triangles, scan.normal_triangles);
  std::swap(p.attributes.face_labels, scan.face_labels);
  std::swap(p.attributes.label_names, scan.label_names);
  if (scan.face_count() > 0) {
    const HoleCaps caps = build_hole_caps(scan.triangles, scan.vertex_count());
    if (caps.loop_count() > 0) {
      std::vector<float> capped;
      capped_positions(scan.positions, caps, capped);
      scan.positions = std::move(capped);
      scan.triangles.insert(scan.triangles.end(), caps.triangles.begin(), caps.triangles.end());
      p.warnings.push_back(source + ": " + std::to_string(caps.loop_count()) +
                           " holes capped for the fit (the rigged scan keeps its own surface)");
    }
  }
  if (facing) {
    p.facing = *facing;
  } else if (scan.face_count() > 0 && !estimator_accepts(scan)) {
    for (Facing f : {Facing::NEG_Z, Facing::POS_X, Facing::NEG_X}) {
      Mesh turned = scan;
      rotate_to_face_z(turned.positions, f);
      if (estimator_accepts(turned)) {
        p.facing = f;
        p.warnings.push_back(source + ": faced " + facing_name(f) +
                             " (detected: its feet), turned to face +z (force with --facing)");
        break;
      }
    }
  }
  rotate_to_face_z(scan.positions, p.facing);
  p.mesh = std::move(scan);
  return p;
}

ScanCoverage scan_fit_coverage(const ScanFit& fit, const Mesh& scan) {
  if (scan.face_count() == 0) return {};
  const Body& tmpl = scan_fit_template();
  // The template's rest vertices follow their joints' shape displacement (rest joints of the
  // fitted shape over its scale, less the template's), then scale and pose (eq. 3).
  const double s = fit.scale;
  const JointPositions dJ = fit.rest_joints / s - tmpl.joints;
  std::vector<float> shaped(tmpl.mesh.positions.size());
  for (std::size_t v = 0; v < tmpl.mesh.vertex_count(); ++v) {
    Eigen::Vector3d p(tmpl.mesh.positions[3 * v], tmpl.mesh.positions[3 * v + 1], tmpl.mesh.positions[3 * v + 2]);
    for (int k = 0; k < 4; ++k)
      p += double(tmpl.weights.weights[4 * v + std::size_t(k)]) *
           dJ.row(tmpl.weights.joints[4 * v + std::size_t(k)]).transpose();
    for (int a = 0; a < 3; ++a)
      shaped[3 * v + std::size_t(a)] = static_cast<float>(s * p[a]);
  }
  std::vector<float> posed;
  linear_blend_skinning(shaped, tmpl.weights, skinning_transforms(fit.rest_joints, fit.pose), posed);
  const ProximityIndex index(scan.positions, scan.triangles);
  ClosestHits hits;
  index.closest_points(posed, INFINITY, hits);
  std::vector<double> d;
  for (std::size_t i = 0; i < hits.size(); ++i)
    if (hits.triangles[i] >= 0) d.push_back(std::abs(hits.signed_distances[i]));
  if (d.empty()) return {};
  ScanCoverage c;
  for (double x : d)
    c.mean += x / double(d.size());
  const auto k = static_cast<std::size_t>(0.95 * double(d.size() - 1));
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(k), d.end());
  c.p95 = d[k];
  return c;
}

void restore_scan_surface(Body& rigged, const PreparedScan& prepared) {
  Mesh& m = rigged.mesh;
  m.positions.resize(3 * prepared.vertex_count);
  m.triangles.resize(3 * prepared.face_count);
  rigged.weights.joints.resize(4 * prepared.vertex_count);
  rigged.weights.weights.resize(4 * prepared.vertex_count);
  m.uvs = prepared.attributes.uvs;
  m.uv_triangles = prepared.attributes.uv_triangles;
  m.normals = prepared.attributes.normals;
  m.normal_triangles = prepared.attributes.normal_triangles;
  m.face_labels = prepared.attributes.face_labels;
  m.label_names = prepared.attributes.label_names;
  // Normals as stored describe the scan in its file's frame: turned with it.
  rotate_to_face_z(m.normals, prepared.facing);
}

} // namespace vfit
