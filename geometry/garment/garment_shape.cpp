// SPDX-License-Identifier: Apache-2.0
#include "garment_shape.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

namespace vfit {
namespace {

constexpr double PI = std::numbers::pi;
constexpr double CLEARANCE = 0.003; // m between skin and cloth at zero ease

double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}
double smax(double a, double b, double k) { return -smin(-a, -b, k); }

double lerp_clamped(double y, double y0, double v0, double y1, double v1) {
  const double t = std::clamp((y - y0) / (y1 - y0), 0.0, 1.0);
  return v0 + t * (v1 - v0);
}

bool is_top(GarmentType t) { return t == GarmentType::TEE || t == GarmentType::LONG_SLEEVE || t == GarmentType::DRESS; }
bool is_bottom(GarmentType t) {
  return t == GarmentType::TROUSERS || t == GarmentType::SHORTS || t == GarmentType::SKIRT;
}

} // namespace

GarmentShape::GarmentShape(GarmentType type, const BodyMeasurements& body, const Ease& ease, RestPose pose)
    : m_type(type), m_ease(ease), m_body(body, pose) {
  const double H = body.height, s = H / 1.70;
  m_scale = s;
  m_crotch = body.crotch_height;
  m_hip = joint(Joint::LEFT_HIP).y() - 0.010 * H;
  m_waist = 0.620 * H;
  m_chest = joint(Joint::SPINE3).y();
  m_shoulder = joint(Joint::LEFT_SHOULDER).y();
  auto off = [](double girth_ease) { return std::max(0.0, girth_ease) / (2 * PI) + CLEARANCE; };
  const double oh = off(ease.hip), ow = off(ease.waist), oc = off(ease.chest), ot = off(ease.thigh);
  const double hip = m_hip, waist = m_waist, chest = m_chest;
  m_inflation.torso_offset = [=](double y) {
    return y < waist ? lerp_clamped(y, hip, oh, waist, ow) : lerp_clamped(y, waist, ow, chest, oc);
  };
  const double knee = joint(Joint::LEFT_KNEE).y(), ankle = joint(Joint::LEFT_ANKLE).y();
  m_inflation.leg_offset = [=](double y) { return y > knee ? ot : lerp_clamped(y, ankle, 0.85 * ot, knee, ot); };
  m_inflation.arm_offset = 0.5 * oc + 0.004;
  m_inflation.with_head = false;
  m_inflation.with_hands = false;
  m_inflation.with_feet = false;
  m_inflation.with_legs = type == GarmentType::TROUSERS || type == GarmentType::SHORTS;
  m_inflation.with_arms = is_top(type);

  const double upper_arm = body.arm_length - body.forearm_length;
  switch (type) {
  case GarmentType::TEE:
    m_hem = m_crotch + 0.11 * H;
    m_sleeve_length = 0.45 * upper_arm;
    break;
  case GarmentType::LONG_SLEEVE:
    m_hem = m_crotch + 0.09 * H;
    m_sleeve_length = body.arm_length - 0.045 * s; // ends before the hand (which starts ~1 cm above the wrist)
    break;
  case GarmentType::DRESS:
    m_hem = knee + 0.05 * H;
    m_sleeve_length = -0.015 * s; // sleeveless: the armhole opens just inside the shoulder joint
    m_has_skirt = true;
    break;
  case GarmentType::SKIRT:
    m_hem = knee + 0.07 * H;
    m_waistband = m_waist;
    m_has_skirt = true;
    break;
  case GarmentType::TROUSERS:
    m_hem = ankle + 0.035 * s;
    m_waistband = m_waist - 0.02 * H;
    break;
  case GarmentType::SHORTS:
    m_hem = m_crotch - 0.17 * s;
    m_waistband = m_waist - 0.02 * H;
    break;
  }
  if (m_inflation.with_legs) {
    // Leg ease wider than the gap between the thighs at the hem (shorts P4 on the average body:
    // 16 cm of thigh ease where the thighs are 2-3 cm apart) grows both legs into one tube with
    // one hem. Then the legs are cut flat at the mid-plane, 2 cm apart (the coarsest isosurface
    // cell is 1.6 cm). Grown legs whose hems keep the clearance between them at the mid-plane
    // (all the catalogue's sizes on the average body but shorts P4: 7 mm or more) are grown as
    // before.
    const double between = m_body.distance(0.0, m_hem, joint(Joint::LEFT_HIP).z(), &m_inflation);
    if (between < CLEARANCE) m_inflation.legs_gap = 0.01 * s;
  }
  if (m_has_skirt) {
    // An elliptic tube from the hip line down, large enough for the hips with their ease and
    // for both legs, flaring outwards (dress ~10°, skirt ~8°).
    const double girth = body.hip + std::max(0.0, ease.hip);
    const double ratio = 1.2, unit = PI * (3 * (ratio + 1) - std::sqrt((3 * ratio + 1) * (ratio + 3)));
    m_skirt_b = girth / unit;
    m_skirt_a = ratio * m_skirt_b;
    const double legs_half_width = joint(Joint::LEFT_HIP).x() + body.thigh / (2 * PI) + oh;
    m_skirt_a = std::max(m_skirt_a, legs_half_width) + 0.01 * s; // room for the buttocks' fillets
    m_skirt_b += 0.01 * s;
    m_skirt_c = m_body.torso_centre_z(m_hip);
    m_skirt_flare = type == GarmentType::DRESS ? 0.18 : 0.14;
    m_skirt_top = m_waist;
  }
}

double GarmentShape::skirt_distance(const Eigen::Vector3d& p) const {
  // Below the hip line the tube flares; above it narrows to the torso's waist (plus ease), so
  // the skirt grows out of the bodice without a shelf.
  double a, b;
  if (p.y() < m_hip) {
    const double drop = m_hip - p.y();
    a = m_skirt_a + m_skirt_flare * drop;
    b = m_skirt_b + m_skirt_flare * drop;
  } else {
    const TorsoSection w = m_body.torso_section(m_waist);
    const double ow = m_inflation.torso_offset(m_waist);
    const double t = std::clamp((p.y() - m_hip) / (m_waist - m_hip), 0.0, 1.0);
    a = m_skirt_a + t * (0.92 * (w.a + ow) - m_skirt_a);
    b = m_skirt_b + t * (0.92 * (w.b + ow) - m_skirt_b);
  }
  const double qx = p.x() / a, qz = (p.z() - m_skirt_c) / b, r = std::hypot(qx, qz);
  double d;
  if (r < 1e-9) {
    d = -std::min(a, b);
  } else {
    d = (r - 1.0) / (std::hypot(qx / a, qz / b) / r);
  }
  d = smax(d, p.y() - m_skirt_top, 0.03 * m_scale);
  return smax(d, (m_hem - 0.06 * m_scale) - p.y(), 0.02 * m_scale); // closed below the hem cut
}

double GarmentShape::distance(const Eigen::Vector3d& p) const {
  const double d = m_body.distance(p.x(), p.y(), p.z(), &m_inflation);
  if (!m_has_skirt) return d;
  return smin(d, skirt_distance(p), 0.04 * m_scale);
}

Eigen::Vector3d GarmentShape::clear_of_body(Eigen::Vector3d p) const {
  for (int it = 0; it < 4; ++it) {
    const double d = m_body.distance(p.x(), p.y(), p.z());
    if (d >= 0.5 * CLEARANCE) break;
    const double h = 1e-4;
    Eigen::Vector3d g;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d a = p, b = p;
      a[k] += h;
      b[k] -= h;
      g[k] = (m_body.distance(a.x(), a.y(), a.z()) - m_body.distance(b.x(), b.y(), b.z())) / (2 * h);
    }
    if (g.squaredNorm() < 1e-8) break;
    p += (CLEARANCE - d) * g / g.squaredNorm();
  }
  return p;
}

Eigen::Vector3d GarmentShape::gradient(const Eigen::Vector3d& p) const {
  const double h = 1e-4;
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d a = p, b = p;
    a[k] += h;
    b[k] -= h;
    g[k] = (distance(a) - distance(b)) / (2 * h);
  }
  return g;
}

double GarmentShape::sleeve_keep(const Eigen::Vector3d& p, bool left, double length) const {
  const Eigen::Vector3d sh = joint(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER);
  const Eigen::Vector3d d = (joint(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW) - sh).normalized();
  const double t = (p - sh).dot(d), r = ((p - sh) - t * d).norm();
  // Cut only within a cylinder around the arm: the torso beside it keeps its cloth.
  const double reach =
      0.047 * std::sqrt(m_body.measurements().chest / 0.96) * m_scale + m_inflation.arm_offset + 0.035 * m_scale;
  return std::max(length - t, r - reach);
}

double GarmentShape::keep(const Eigen::Vector3d& p) const {
  double k = p.y() - m_hem;
  if (is_bottom(m_type)) k = std::min(k, m_waistband - p.y());
  if (is_top(m_type)) {
    const double zc = m_body.torso_centre_z(m_shoulder);
    const double neckline = m_shoulder - 0.005 * m_body.measurements().height - 0.3 * std::max(0.0, p.z() - zc);
    const double hole = 0.080 * m_scale;
    k = std::min(k, std::max(neckline - p.y(), std::hypot(p.x(), p.z() - zc) - hole));
    k = std::min(k, sleeve_keep(p, true, m_sleeve_length));
    k = std::min(k, sleeve_keep(p, false, m_sleeve_length));
  }
  return k;
}

GarmentPart GarmentShape::part_of(const Eigen::Vector3d& p) const {
  switch (m_type) {
  case GarmentType::TEE:
  case GarmentType::LONG_SLEEVE:
    for (bool left : {true, false}) {
      const Eigen::Vector3d sh = joint(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER);
      const Eigen::Vector3d d = (joint(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW) - sh).normalized();
      if ((p - sh).dot(d) <= 0 || (left ? p.x() <= 0 : p.x() >= 0)) continue;
      // Past the shoulder's plane but well below the upper arm (more than 1.25 cloth radii under
      // its axis) is the torso's side seam, not the sleeve: in A-pose the plane through the
      // shoulder cuts into the torso below the armpit.
      const int shoulder = idx(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER);
      bool under_arm = false;
      for (const RoundCone& c : m_body.cones()) {
        if (c.joint != shoulder) continue;
        const Eigen::Vector3d axis = (c.q - c.p).normalized();
        const Eigen::Vector3d up = (Eigen::Vector3d::UnitY() - axis.y() * axis).normalized();
        under_arm = (p - c.p).dot(up) < -1.25 * (c.rp + m_inflation.arm_offset);
      }
      if (!under_arm) return left ? GarmentPart::LEFT_SLEEVE : GarmentPart::RIGHT_SLEEVE;
    }
    return GarmentPart::TORSO;
  case GarmentType::DRESS: return p.y() < m_waist ? GarmentPart::SKIRT : GarmentPart::TORSO;
  case GarmentType::SKIRT: return GarmentPart::SKIRT;
  case GarmentType::TROUSERS:
  case GarmentType::SHORTS:
    // Seed 000 eq. 3–4: the legs end at planes through the crotch rising outwards with slope 1.
    if (p.y() < m_crotch + std::abs(p.x())) return p.x() > 0 ? GarmentPart::LEFT_LEG : GarmentPart::RIGHT_LEG;
    return GarmentPart::TORSO;
  }
  return GarmentPart::TORSO;
}

double GarmentShape::closed_area_estimate() const {
  const double s2 = m_scale * m_scale;
  switch (m_type) {
  case GarmentType::TEE:
  case GarmentType::LONG_SLEEVE: return 1.05 * s2; // torso and arms
  case GarmentType::DRESS: return 1.50 * s2;       // torso, arms and the skirt tube
  case GarmentType::SKIRT: return 1.10 * s2;
  case GarmentType::TROUSERS:
  case GarmentType::SHORTS: return 1.45 * s2; // torso and legs
  }
  return 1.5 * s2;
}

std::pair<Eigen::Vector3d, Eigen::Vector3d> GarmentShape::bounding_box(double margin) const {
  auto [lo, hi] = m_body.bounding_box(margin);
  const double grow = 0.08 * m_scale + (m_has_skirt ? m_skirt_flare * m_hip : 0.0);
  lo -= Eigen::Vector3d(grow, 0, grow);
  hi += Eigen::Vector3d(grow, 0, grow);
  return {lo, hi};
}

void GarmentShape::assign_uvs_and_face_labels(Garment& g) const {
  Mesh& m = g.mesh;
  const std::size_t nf = m.face_count();
  // Charts present, in part order, side by side in u.
  std::vector<int> chart_of_part(GARMENT_PART_COUNT, -1);
  int charts = 0;
  for (GarmentPart part : g.vertex_parts)
    if (chart_of_part[int(part)] < 0) chart_of_part[int(part)] = 0;
  for (int p = 0; p < GARMENT_PART_COUNT; ++p)
    if (chart_of_part[p] == 0) chart_of_part[p] = charts++;
  m.face_labels.assign(nf, 0);
  m.label_names.clear();
  for (int p = 0; p < GARMENT_PART_COUNT; ++p)
    m.label_names.push_back(garment_part_name(static_cast<GarmentPart>(p)));
  // Height ranges per part, for v.
  std::vector<double> lo(GARMENT_PART_COUNT, INFINITY), hi(GARMENT_PART_COUNT, -INFINITY);
  auto axial = [&](GarmentPart part, const Eigen::Vector3d& p, double& around, double& along) {
    Eigen::Vector3d origin, axis, front;
    if (part == GarmentPart::LEFT_SLEEVE || part == GarmentPart::RIGHT_SLEEVE) {
      const bool left = part == GarmentPart::LEFT_SLEEVE;
      origin = joint(left ? Joint::LEFT_SHOULDER : Joint::RIGHT_SHOULDER);
      axis = (joint(left ? Joint::LEFT_ELBOW : Joint::RIGHT_ELBOW) - origin).normalized();
      front = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(axis) * axis; // seam under the arm
    } else if (part == GarmentPart::LEFT_LEG || part == GarmentPart::RIGHT_LEG) {
      const bool left = part == GarmentPart::LEFT_LEG;
      origin = joint(left ? Joint::LEFT_HIP : Joint::RIGHT_HIP);
      axis = (joint(left ? Joint::LEFT_ANKLE : Joint::RIGHT_ANKLE) - origin).normalized();
      front = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(axis) * axis; // seam at the back
    } else {
      origin = Eigen::Vector3d(0, 0, m_body.torso_centre_z(p.y()));
      axis = -Eigen::Vector3d::UnitY(); // v grows downwards from the top of the part
      front = Eigen::Vector3d::UnitZ();
    }
    front.normalize();
    const Eigen::Vector3d side = axis.cross(front);
    const Eigen::Vector3d q = p - origin;
    around = (std::atan2(q.dot(side), q.dot(front)) + PI) / (2 * PI); // [0, 1), 0/1 at the seam
    along = q.dot(axis);
  };
  const std::size_t nv = m.vertex_count();
  std::vector<double> around(nv), along(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3d p(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
    axial(g.vertex_parts[v], p, around[v], along[v]);
    const int part = int(g.vertex_parts[v]);
    lo[part] = std::min(lo[part], along[v]);
    hi[part] = std::max(hi[part], along[v]);
  }
  std::map<std::tuple<std::int32_t, int, bool>, std::int32_t> uv_index;
  m.uvs.clear();
  m.uv_triangles.assign(3 * nf, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    int votes[GARMENT_PART_COUNT] = {};
    for (int k = 0; k < 3; ++k)
      ++votes[int(g.vertex_parts[m.triangles[3 * f + k]])];
    const int part = int(std::max_element(votes, votes + GARMENT_PART_COUNT) - votes);
    m.face_labels[f] = part;
    // Each corner in the face's chart; corners across the seam get u + 1 so the face is whole.
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) {
      const std::int32_t vert = m.triangles[3 * f + k];
      const Eigen::Vector3d p(m.positions[3 * vert], m.positions[3 * vert + 1], m.positions[3 * vert + 2]);
      double a, b;
      axial(static_cast<GarmentPart>(part), p, a, b);
      u[k] = a;
      v[k] = (b - lo[part]) / std::max(1e-9, hi[part] - lo[part]);
    }
    const bool wraps = std::max({u[0], u[1], u[2]}) - std::min({u[0], u[1], u[2]}) > 0.5;
    for (int k = 0; k < 3; ++k) {
      const bool shifted = wraps && u[k] < 0.5;
      const auto key = std::make_tuple(m.triangles[3 * f + k], part, shifted);
      auto it = uv_index.find(key);
      if (it == uv_index.end()) {
        const double uu = (u[k] + (shifted ? 1.0 : 0.0)) / 1.1; // room for the wrapped corners
        const double width = 1.0 / charts;
        m.uvs.push_back(static_cast<float>((chart_of_part[part] + 0.05 + 0.9 * uu) * width));
        m.uvs.push_back(static_cast<float>(1.0 - std::clamp(v[k], 0.0, 1.0)));
        it = uv_index.emplace(key, static_cast<std::int32_t>(m.uvs.size() / 2 - 1)).first;
      }
      m.uv_triangles[3 * f + k] = it->second;
    }
  }
}

} // namespace vfit
