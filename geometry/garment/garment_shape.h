// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The implicit description of a catalogue garment: its surface as the zero set of a distance
/// function grown from the mannequin's, where it is cut open, which part each point belongs
/// to, and how it is unwrapped into UVs. Used by make_garment() (catalogue.h).

#include <Eigen/Core>

#include "garment.h"
#include "vfit/geometry/body/mannequin_shape.h"

namespace vfit {

class GarmentShape {
public:
  GarmentShape(GarmentType type, const BodyMeasurements& body, const Ease& ease, RestPose pose);

  /// Signed distance to the closed garment surface before cutting (m, negative inside).
  double distance(const Eigen::Vector3d& p) const;
  /// `p` moved out along the body's gradient until it is at least the clearance (3 mm) outside
  /// the body; unchanged when it already is. Tight sizes can graze the skin where the grown
  /// shapes blend differently from the body's own.
  Eigen::Vector3d clear_of_body(Eigen::Vector3d p) const;
  /// Central-difference gradient of distance().
  Eigen::Vector3d gradient(const Eigen::Vector3d& p) const;
  /// ≥ 0 where the garment has cloth (below the neckline, above the hem, before the cuffs).
  double keep(const Eigen::Vector3d& p) const;
  /// The ground-truth part of a point on the garment.
  GarmentPart part_of(const Eigen::Vector3d& p) const;
  /// Surface area (m²) of the closed surface, roughly, to size the meshing grid.
  double closed_area_estimate() const;
  /// Box around the closed surface with a margin (m).
  std::pair<Eigen::Vector3d, Eigen::Vector3d> bounding_box(double margin) const;
  /// Fills garment.mesh's UVs (one cylindrical chart per part, laid side by side) and face
  /// labels (the majority part of each face's corners; label_names = part names).
  void assign_uvs_and_face_labels(Garment& garment) const;

  const MannequinShape& body() const { return m_body; }

private:
  double skirt_distance(const Eigen::Vector3d& p) const;
  double sleeve_keep(const Eigen::Vector3d& p, bool left, double length) const;
  Eigen::Vector3d joint(Joint j) const { return m_body.joints().row(idx(j)).transpose(); }

  GarmentType m_type;
  Ease m_ease;
  MannequinShape m_body;
  ShapeInflation m_inflation;
  double m_scale = 1;
  // Landmark heights (m).
  double m_crotch = 0, m_hip = 0, m_waist = 0, m_chest = 0, m_shoulder = 0;
  // Cuts.
  double m_hem = 0, m_waistband = 0, m_sleeve_length = 0;
  bool m_has_skirt = false;
  // Skirt tube: semi-axes at the hip line, centre z, flare (m per m downwards).
  double m_skirt_a = 0, m_skirt_b = 0, m_skirt_c = 0, m_skirt_flare = 0, m_skirt_top = 0;
};

} // namespace vfit
