// SPDX-License-Identifier: GPL-3.0-or-later
// The best-fit alignment (DMIS LOCATE): the part frame that lays features' nominals, as the
// program wrote them, closest to their actuals in the least-squares sense.
#pragma once
#include <array>
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::fitting {

/// One feature's share of a best fit: its nominal in part coordinates, its actual in machine
/// coordinates. What a feature can say about where the part is depends on its kind:
///   Point: its whole position (a sphere's or torus's centre);
///   Plane: its position along its normal only, and its normal (a plane; a surface point, whose
///          other two coordinates are only where the probe was sent);
///   Axis:  its position across its axis only, and its axis (a cylinder, cone, line; a circle,
///          whose height along its axis is where it was probed).
struct FrameMatch {
  enum class Kind { Point, Plane, Axis };
  Kind kind = Kind::Point;
  Vec3 nominal_position = Vec3::Zero();
  Vec3 nominal_direction = Vec3::UnitZ();  ///< unit; the normal (Plane) or the axis (Axis)
  Vec3 actual_position = Vec3::Zero();
  Vec3 actual_direction = Vec3::UnitZ();
  /// How far the feature's points spread (mm): a direction's mismatch counts as the displacement
  /// it makes at that distance; 0 when the direction says nothing (a surface point, a circle).
  double extent_mm = 0;
  std::string name;  ///< for messages
};

/// The motions a best fit may make, along and about the axes of the frame it starts from
/// (LOCATE's XDIR, YDIR, ZDIR and XAXIS, YAXIS, ZAXIS).
struct FrameFreedoms {
  std::array<bool, 3> along{true, true, true};
  std::array<bool, 3> about{true, true, true};
};

struct BestFitFrame {
  Frame part_to_machine = Frame::Identity();
  Vec3 translation_mm = Vec3::Zero();  ///< along the start frame's axes
  Vec3 rotation_deg = Vec3::Zero();    ///< about the start frame's axes (applied X, then Y, then Z)
  double rms_mm = 0;                   ///< root mean square of the residuals at the fit
  std::vector<double> residual_mm;     ///< each match's residual length at the fit (direction terms included)
  int iterations = 0;
};

/// The frame start * T(t) * Rz * Ry * Rx, with t and the angles limited to `freedoms`, minimising
/// the squared residuals of the matches (Levenberg-Marquardt). An error when there is nothing to
/// fit, or when the matches do not fix a freedom the fit was given (it names the freedom).
tl::expected<BestFitFrame, std::string> best_fit_frame(const std::vector<FrameMatch>& matches, const Frame& start,
                                                       const FrameFreedoms& freedoms);

/// Each match's residual length (mm) with the nominals placed by `part_to_machine`: how far each
/// feature is from its nominal in that frame (ITERAT's convergence test).
std::vector<double> frame_residuals_mm(const std::vector<FrameMatch>& matches, const Frame& part_to_machine);

}  // namespace metron::fitting
