// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// Biovision hierarchy (BVH) motion capture: reading, writing and forward kinematics.
///
/// A BVH file is a joint hierarchy (each joint an OFFSET from its parent and a list of
/// CHANNELS) followed by one line of channel values per frame. A joint's local transform at a
/// frame is a translation — its OFFSET, with its position channels — then its rotation
/// channels applied in file order: "CHANNELS 3 Zrotation Xrotation Yrotation" is
/// R = Rz(z)·Rx(x)·Ry(y) acting on column vectors, angles in degrees. The world transform of a
/// joint is its parent's times its local one (the root's parent is the identity).
///
/// BVH states neither its length unit nor its up axis: both are inferred from the skeleton at
/// rest (every channel zero), see BvhMotion::unit and BvhMotion::up.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vfit/geometry/mesh/up_axis.h"

namespace vfit {

enum class BvhChannel : std::uint8_t { X_POSITION, Y_POSITION, Z_POSITION, X_ROTATION, Y_ROTATION, Z_ROTATION };

/// "Xposition", ..., "Zrotation", as BVH spells them.
std::string_view bvh_channel_name(BvhChannel channel);

/// One joint of the hierarchy, or an end site (a leaf with an offset and no channels).
struct BvhJoint {
  std::string name;         ///< as in the file; an end site is named "<parent name>/End Site"
  std::int32_t parent = -1; ///< index of the parent joint (parents come first); −1 for the root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero(); ///< from the parent's origin, file units
  std::vector<BvhChannel> channels;                 ///< in file order; empty for an end site
  std::size_t first_column = 0;                     ///< the column of its first channel in a frame's values
  bool end_site = false;
  /// Position channels replace the OFFSET (the root's, as BVH defines them) rather than add to
  /// it. For another joint with position channels, decided from the data when read: replace
  /// when the channels' mean over the frames lies nearer the OFFSET than zero (exporters that
  /// write every joint's local position each frame), add otherwise (exporters that write
  /// displacements from the rest, MakeHuman's).
  bool absolute_position = false;
};

/// A whole BVH file.
struct BvhMotion {
  std::string source;           ///< the file it came from (for messages)
  std::vector<BvhJoint> joints; ///< depth-first, in file order; joints[0] is the root
  std::size_t columns = 0;      ///< channel values per frame
  double frame_time = 0;        ///< seconds per frame (> 0)
  std::vector<double> values;   ///< #frames × columns, frame-major: file units and degrees
  /// Metres per file unit, inferred from the skeleton's height at rest (see bvh_infer_unit()).
  double metres_per_unit = 1;
  /// "m", "dm", "cm", "mm", "inch" or "foot" when one of them makes the skeleton an adult's
  /// height (1.4–2.1 m); otherwise "scaled": metres_per_unit makes it 1.7 m.
  std::string unit;
  /// The axis pointing from the feet to the head at rest (BVH's own convention is +Y; old
  /// MakeHuman rigs are +Z).
  UpAxis up = UpAxis::POS_Y;

  std::size_t frame_count() const { return columns == 0 ? 0 : values.size() / columns; }
  double fps() const { return 1.0 / frame_time; }
  /// Channel values of frame `f` (columns of them).
  const double* frame(std::size_t f) const { return values.data() + f * columns; }
  /// Index of the joint named `name` (end sites included), or −1.
  std::int32_t find(std::string_view name) const;
};

/// Parses BVH text. `source` names it in errors. Accepts any order of rotation channels,
/// joints with 0–6 channels (each channel at most once), end sites, CRLF or LF lines, tabs.
/// Throws vfit::Error "<source>:<line>: <what>" for a missing or misplaced keyword, an
/// unbalanced brace, an OFFSET that is not 3 finite numbers, an unknown or repeated channel,
/// two joints of one name, a "Frames:" count that is not a whole number in [1, 10^7], a
/// "Frame Time:" that is not a finite number in (0, 10] s, a frame line with the wrong number
/// of values or a value that is not a finite number, fewer or more frame lines than "Frames:"
/// states, and for more than 10^5 joints, nesting deeper than 1,000 or 10^9 values in all.
/// Linear in the text's size.
BvhMotion parse_bvh(std::string_view text, const std::string& source);

/// Reads and parses the BVH file at `path` (a regular file); throws vfit::Error naming it.
BvhMotion read_bvh(const std::filesystem::path& path);

/// BVH text of `motion` (its hierarchy and frames as they are, in file units; numbers written
/// with 17 significant digits, so parse_bvh() gives them back exactly). Its joints' position
/// channels are written as they are: a non-root joint whose absolute_position differs from
/// what parse_bvh() would decide from the values reads back differently.
std::string bvh_text(const BvhMotion& motion);

/// The local transform of joint `j` at frame `f` (file units): translation by its OFFSET and
/// position channels, then its rotation channels in file order.
Eigen::Isometry3d bvh_local_transform(const BvhMotion& motion, std::size_t j, std::size_t f);

/// World transforms of every joint (end sites included) at frame `f`, in file units and axes.
/// O(#joints).
std::vector<Eigen::Isometry3d> bvh_world_transforms(const BvhMotion& motion, std::size_t f);

/// World positions of every joint at rest: all channels zero, positions from the OFFSETs alone
/// (the root at its OFFSET). File units.
std::vector<Eigen::Vector3d> bvh_rest_positions(const BvhMotion& motion);

/// The up axis of a skeleton at rest (`rest`: bvh_rest_positions()): from the root towards a
/// joint named like a head ("head", "Head", "HEAD", ...), else opposite to the mean of the two
/// end sites farthest from the root in the two largest subtrees of the first joint with three
/// or more children (the feet, below the hips), snapped to the nearest axis.
UpAxis bvh_infer_up(const BvhMotion& motion, const std::vector<Eigen::Vector3d>& rest);

/// Sets motion.metres_per_unit and motion.unit from the skeleton's extent along `up` at rest,
/// its height: the first of m, dm, cm, mm, inch, foot that puts it within 1.4–2.1 m, else
/// "scaled" to 1.7 m. Throws vfit::Error naming the source when the skeleton has no height.
void bvh_infer_unit(BvhMotion& motion, const std::vector<Eigen::Vector3d>& rest, UpAxis up);

} // namespace vfit
