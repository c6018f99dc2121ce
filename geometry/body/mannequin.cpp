// SPDX-License-Identifier: Apache-2.0
#include "mannequin.h"

#include <algorithm>
#include <cmath>

#include "cross_section.h"
#include "mannequin_shape.h"
#include "vfit/geometry/mesh/decimate.h"
#include "vfit/geometry/mesh/isosurface.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/parallel.h"

namespace vfit {
namespace {

constexpr std::size_t MIN_VERTICES = 1000, MAX_VERTICES = 2000000;
// Marching tetrahedra yields about this many vertices per m² of surface at 1 m cells
// (measured on the mannequin: 162k vertices at 6.8 mm cells over 1.69 m²); picks the grid.
constexpr double MT_VERTICES_PER_UNIT = 4.4;
constexpr double BODY_AREA_AT_170 = 1.75; // m², the default mannequin's surface area

// Moves each vertex onto the zero set with Newton steps along the numerical gradient.
void project_to_surface(const MannequinShape& shape, Mesh& mesh, int steps) {
  parallel_for_range(mesh.vertex_count(), 512, [&](std::size_t b, std::size_t e) {
    for (std::size_t v = b; v < e; ++v) {
      Eigen::Vector3d p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
      for (int k = 0; k < steps; ++k) {
        const double d = shape.distance(p.x(), p.y(), p.z());
        if (std::abs(d) < 1e-6) break;
        const double h = 1e-4;
        Eigen::Vector3d g((shape.distance(p.x() + h, p.y(), p.z()) - shape.distance(p.x() - h, p.y(), p.z())) / (2 * h),
                          (shape.distance(p.x(), p.y() + h, p.z()) - shape.distance(p.x(), p.y() - h, p.z())) / (2 * h),
                          (shape.distance(p.x(), p.y(), p.z() + h) - shape.distance(p.x(), p.y(), p.z() - h)) /
                              (2 * h));
        const double g2 = g.squaredNorm();
        if (g2 < 1e-8) break;
        p -= d * g / g2;
      }
      for (int k = 0; k < 3; ++k)
        mesh.positions[3 * v + k] = static_cast<float>(p[k]);
    }
  });
}

// Tangential relaxation: each vertex moves halfway to its one-ring centroid within its tangent
// plane, then back onto the surface. Evens out the edge lengths that decimation and projection
// leave (they can be 100× shorter than the mean).
void relax_on_surface(const MannequinShape& shape, Mesh& mesh, int iterations) {
  const std::size_t nv = mesh.vertex_count();
  std::vector<std::vector<std::int32_t>> nbr(nv);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      nbr[a].push_back(b);
      nbr[b].push_back(a);
    }
  std::vector<float> next(mesh.positions.size());
  for (int it = 0; it < iterations; ++it) {
    parallel_for_range(nv, 512, [&](std::size_t b, std::size_t e) {
      for (std::size_t v = b; v < e; ++v) {
        const Eigen::Vector3d p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (std::int32_t u : nbr[v])
          c += Eigen::Vector3d(mesh.positions[3 * u], mesh.positions[3 * u + 1], mesh.positions[3 * u + 2]);
        c /= double(std::max<std::size_t>(1, nbr[v].size()));
        const double h = 1e-4;
        Eigen::Vector3d n((shape.distance(p.x() + h, p.y(), p.z()) - shape.distance(p.x() - h, p.y(), p.z())),
                          (shape.distance(p.x(), p.y() + h, p.z()) - shape.distance(p.x(), p.y() - h, p.z())),
                          (shape.distance(p.x(), p.y(), p.z() + h) - shape.distance(p.x(), p.y(), p.z() - h)));
        if (n.squaredNorm() > 0) n.normalize();
        Eigen::Vector3d d = c - p;
        d -= d.dot(n) * n;
        const Eigen::Vector3d q = p + 0.5 * d;
        for (int k = 0; k < 3; ++k)
          next[3 * v + k] = static_cast<float>(q[k]);
      }
    });
    mesh.positions.swap(next);
    project_to_surface(shape, mesh, 2);
  }
}

// Skin weights: the shape's affinities, smoothed over the mesh's one-rings, top 4 kept.
SkinWeights compute_skin_weights(const MannequinShape& shape, const Mesh& mesh) {
  const std::size_t nv = mesh.vertex_count();
  std::vector<double> w(nv * JOINT_COUNT);
  parallel_for_range(nv, 256, [&](std::size_t b, std::size_t e) {
    for (std::size_t v = b; v < e; ++v) {
      const auto a = shape.skin_affinity({mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]});
      double sum = 0;
      for (double x : a)
        sum += x;
      for (int j = 0; j < JOINT_COUNT; ++j)
        w[v * JOINT_COUNT + j] = sum > 0 ? a[j] / sum : (j == 0 ? 1.0 : 0.0);
    }
  });
  // Vertex neighbours (CSR) for smoothing.
  std::vector<std::vector<std::int32_t>> nbr(nv);
  for (std::size_t f = 0; f < mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      nbr[a].push_back(b);
      nbr[b].push_back(a);
    }
  // Diffuse over a fixed physical width (~3 cm) whatever the resolution: the number of
  // averaging steps grows with (width / edge length)².
  double edge_sum = 0;
  std::size_t edges = 0;
  for (std::size_t v = 0; v < nv; ++v)
    for (std::int32_t u : nbr[v]) {
      const float* a = &mesh.positions[3 * v];
      const float* b = &mesh.positions[3 * u];
      edge_sum += std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                            double(a[2] - b[2]) * (a[2] - b[2]));
      ++edges;
    }
  const double mean_edge = edges ? edge_sum / double(edges) : 0.01;
  const int steps = std::clamp(static_cast<int>(std::lround(4.0 * std::pow(0.02 / mean_edge, 2))), 2, 60);
  std::vector<double> next(w.size());
  for (int iter = 0; iter < steps; ++iter) {
    parallel_for_range(nv, 512, [&](std::size_t b, std::size_t e) {
      for (std::size_t v = b; v < e; ++v)
        for (int j = 0; j < JOINT_COUNT; ++j) {
          double s = 0;
          for (std::int32_t u : nbr[v])
            s += w[u * JOINT_COUNT + j];
          const double avg = nbr[v].empty() ? w[v * JOINT_COUNT + j] : s / double(nbr[v].size());
          next[v * JOINT_COUNT + j] = 0.5 * w[v * JOINT_COUNT + j] + 0.5 * avg;
        }
    });
    w.swap(next);
  }
  return SkinWeights::from_dense(w, JOINT_COUNT, idx(Joint::PELVIS));
}

double joint_weight(const SkinWeights& w, std::size_t v, std::initializer_list<Joint> joints) {
  double s = 0;
  for (int k = 0; k < 4; ++k)
    for (Joint j : joints)
      if (w.joints[4 * v + k] == idx(j)) s += w.weights[4 * v + k];
  return s;
}

// Hat function: 0 at a, 1 at b, 0 at c (a < b < c); 0 outside.
double hat(double y, double a, double b, double c) {
  if (y <= a || y >= c) return 0;
  return y < b ? (y - a) / (b - a) : (c - y) / (c - b);
}

// Scales horizontal sections radially so measure_body() hits the requested girths: torso
// bands around the chest, waist and hip landmarks about the torso axis, and each leg's thigh
// and calf bands about the leg axis, blended by the skin weights of the parts they belong to.
void calibrate_girths(const MannequinShape& shape, Body& body) {
  const BodyMeasurements& want = shape.measurements();
  const JointPositions& jp = body.joints;
  auto J = [&](Joint j) -> Eigen::Vector3d { return jp.row(idx(j)).transpose(); };
  Mesh& mesh = body.mesh;
  for (int iter = 0; iter < 8; ++iter) {
    const MeasuredBody got = measure_body(mesh, jp);
    const BodyLandmarks& lm = got.landmarks;
    auto leg_point = [&](bool left, double y) -> Eigen::Vector3d {
      const Eigen::Vector3d hip = J(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP),
                            knee = J(left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE),
                            ankle = J(left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE);
      const auto& a = y > knee.y() ? hip : knee;
      const auto& b = y > knee.y() ? knee : ankle;
      const double t = std::clamp((y - a.y()) / (b.y() - a.y()), 0.0, 1.0);
      return a + t * (b - a);
    };
    const double s_chest = want.chest / got.values.chest, s_waist = want.waist / got.values.waist,
                 s_hip = want.hip / got.values.hip;
    // One factor for both legs: the shapes are symmetric, and the thigh's section just below the
    // crotch is where the two sides' tessellations differ most (a right leg calibrated on its
    // own sections at the left's heights came out 14 % wider there).
    const double s_thigh = want.thigh / got.values.thigh, s_calf = want.calf / got.values.calf;
    double worst = 0;
    for (double s : {s_chest, s_waist, s_hip, s_thigh, s_calf})
      worst = std::max(worst, std::abs(s - 1));
    // The crotch is a saddle that coarse meshes cut low: lift (or lower) the region around it
    // with a smooth bump so the measured crotch height meets the request too.
    const double crotch_error = want.crotch_height - (lm.crotch - lm.floor);
    if (worst < 5e-4 && std::abs(crotch_error) < 5e-4) return;
    if (std::abs(crotch_error) >= 5e-4) {
      const double rx = std::abs(J(Joint::LEFT_HIP).x()), ry = 0.08 * want.height / 1.70;
      for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
        float* p = &mesh.positions[3 * v];
        const double fx = 1 - (p[0] / rx) * (p[0] / rx), fy = 1 - ((p[1] - lm.crotch) / ry) * ((p[1] - lm.crotch) / ry);
        if (fx > 0 && fy > 0) p[1] = static_cast<float>(p[1] + crotch_error * fx * fy);
      }
    }
    const double shoulder_y = J(Joint::LEFT_SHOULDER).y(), knee_y = J(Joint::LEFT_KNEE).y(),
                 ankle_y = J(Joint::LEFT_ANKLE).y();
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      float* p = &mesh.positions[3 * v];
      const double y = p[1];
      const double torso_w = std::min(1.0, joint_weight(body.weights, v,
                                                        {Joint::PELVIS, Joint::SPINE1, Joint::SPINE2, Joint::SPINE3,
                                                         Joint::LEFT_HIP, Joint::RIGHT_HIP}) +
                                               (y > lm.crotch ? 0.0 : 0.0));
      const double torso_f = (s_hip - 1) * hat(y, lm.crotch - 0.02, lm.hip, lm.waist) +
                             (s_waist - 1) * hat(y, lm.hip, lm.waist, lm.chest) +
                             (s_chest - 1) * hat(y, lm.waist, lm.chest, shoulder_y);
      if (torso_f != 0 && torso_w > 0) {
        const double zc = shape.torso_centre_z(y), k = 1 + torso_f * torso_w;
        p[0] = static_cast<float>(p[0] * k);
        p[2] = static_cast<float>(zc + (p[2] - zc) * k);
      }
      for (int side = 0; side < 2; ++side) {
        const bool left = side == 1;
        const double leg_w =
            joint_weight(body.weights, v,
                         {left ? Joint::LEFT_HIP : Joint::RIGHT_HIP, left ? Joint::LEFT_KNEE : Joint::RIGHT_KNEE,
                          left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE});
        if (leg_w <= 0 || (left ? p[0] < 0 : p[0] > 0)) continue;
        const double leg_f = (s_thigh - 1) * hat(y, knee_y, lm.thigh, lm.crotch + 0.01) +
                             (s_calf - 1) * hat(y, ankle_y, lm.calf, knee_y);
        if (leg_f == 0) continue;
        const Eigen::Vector3d c = leg_point(left, y);
        const double k = 1 + leg_f * leg_w;
        p[0] = static_cast<float>(c.x() + (p[0] - c.x()) * k);
        p[2] = static_cast<float>(c.z() + (p[2] - c.z()) * k);
      }
    }
  }
}

} // namespace

Body make_mannequin(const MannequinOptions& options) {
  if (options.target_vertices < MIN_VERTICES || options.target_vertices > MAX_VERTICES)
    throw Error("mannequin", 0,
                "target vertex count " + std::to_string(options.target_vertices) + " is outside [" +
                    std::to_string(MIN_VERTICES) + ", " + std::to_string(MAX_VERTICES) + "]");
  const MannequinShape shape(options.measurements, options.pose);
  const double s = options.measurements.height / 1.70;
  // Grid: about 3× the target before decimation (fewer would leave the decimator little choice;
  // more costs time), never finer than 2.5 mm (large targets are reached by subdivision) and
  // never coarser than 0.7 × the hand's half-thickness (2 cm), or thin parts would break off.
  const double area = BODY_AREA_AT_170 * s * s;
  // Large targets need less slack: the fine grid already resolves every part.
  const double slack = options.target_vertices > 20000 ? 1.6 : 3.0;
  const double cell =
      std::clamp(std::sqrt(MT_VERTICES_PER_UNIT * area / (slack * double(options.target_vertices))), 0.0025, 0.014 * s);
  const auto [lo, hi] = shape.bounding_box(3 * cell);
  IsosurfaceOptions iso;
  iso.box_min = {lo.x(), lo.y(), lo.z()};
  iso.box_max = {hi.x(), hi.y(), hi.z()};
  iso.cell_size = cell;
  Mesh mesh = extract_isosurface([&](double x, double y, double z) { return shape.distance(x, y, z); }, iso);
  while (mesh.vertex_count() < options.target_vertices) {
    mesh = subdivide_midpoints(mesh);
    project_to_surface(shape, mesh, 3);
  }
  mesh = decimate_to_vertex_count(mesh, options.target_vertices);
  project_to_surface(shape, mesh, 3);
  relax_on_surface(shape, mesh, 3);

  Body body;
  body.joints = shape.joints();
  body.rest_pose = options.pose;
  body.source = "mannequin";
  body.weights = compute_skin_weights(shape, mesh);
  body.mesh = std::move(mesh);
  calibrate_girths(shape, body);
  return body;
}

} // namespace vfit
