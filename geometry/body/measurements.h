// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The 11 body measurements of seed 004 §1 (height, crotch height, knee height, arm length,
/// forearm length, shoulder width; chest, waist, hip, thigh and calf girths), presets, and
/// measuring them back from any rigged body.

#include <string>
#include <string_view>
#include <vector>

#include "skeleton.h"
#include "vfit/geometry/mesh/mesh.h"

namespace vfit {

/// Body measurements in metres. Lengths follow the canonical joints: arm length is shoulder →
/// elbow → wrist along the bones, forearm elbow → wrist, shoulder width between the shoulder
/// joints, knee height floor → knee joint. Girths are tape-measure (convex hull) perimeters of
/// horizontal sections (see measure_body()). Defaults: an average adult.
struct BodyMeasurements {
  double height = 1.70;
  double crotch_height = 0.78;
  double knee_height = 0.48;
  double arm_length = 0.55;
  double forearm_length = 0.25;
  double shoulder_width = 0.36;
  double chest = 0.96;
  double waist = 0.80;
  double hip = 0.98;
  double thigh = 0.56;
  double calf = 0.37;

  /// The values by name, in the order above ("height", ..., "calf").
  static const std::vector<std::string_view>& names();
  double& operator[](std::string_view name);
  double operator[](std::string_view name) const;
};

/// Named body types: "average", "banana" (straight), "pear" (hips wider than chest), "apple"
/// (full waist), "hourglass", "tall", "petite". Throws vfit::Error for an unknown name.
BodyMeasurements body_preset(std::string_view name);
std::vector<std::string> body_preset_names();

/// Throws vfit::Error naming the measurement when one is outside a plausible adult range
/// (height 1.2–2.3 m, each length and girth within proportions a body can have).
void check_measurements(const BodyMeasurements& m);

/// Heights (m) at which measure_body() took each girth, and the floor/top/crotch it found.
struct BodyLandmarks {
  double floor = 0, top = 0, crotch = 0, chest = 0, waist = 0, hip = 0, thigh = 0, calf = 0;
};

struct MeasuredBody {
  BodyMeasurements values;
  BodyLandmarks landmarks;
};

/// Measures an upright body in its rest pose (Y up, arms away from the torso as in A- or
/// T-pose) from its closed mesh (m) and canonical joints. Landmarks: floor and top are the
/// mesh's lowest and highest points; the crotch is the highest point below the pelvis where
/// the mid-line leaves the body; chest = the largest torso section between 55 % and 80 % of the
/// way from the hip joints up to the shoulder joints (below the armpits' fold), arms left out;
/// waist = the smallest torso
/// section between 20 % and 60 % of that way; hip = the
/// largest torso section between the crotch and the pelvis joint; thigh = the largest left-leg
/// section in the 8 cm below the crotch that holds that leg alone; calf = the largest left-leg section between 15 % and
/// 60 % of the way from knee to ankle. Each girth is the convex-hull perimeter of the section
/// loop around the torso (or leg) axis, so arms beside the torso are left out.
/// Throws vfit::Error when a landmark's section is missing (e.g. a mesh that is not a body).
MeasuredBody measure_body(const Mesh& mesh, const JointPositions& joints);

/// Depth of the torso, front to back (m): the Z extent of the vertices of an upright body (Y
/// up, facing +Z, metres) between the hip joints' height and the shoulder joints' height and
/// within the shoulder joints' span in X (so arms in A- or T-pose are left out): the chest,
/// belly and seat. What every garment the pipeline fits (garment.h's types) wraps, which makes
/// it the body's reference for a garment's unit (detect_garment_units()). 0 when no vertex is
/// in that box (joints that are not a body's).
double torso_depth(const Mesh& mesh, const JointPositions& joints);

} // namespace vfit
