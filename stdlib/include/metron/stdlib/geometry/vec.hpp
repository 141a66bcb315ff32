// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace metron {

using Vec3 = Eigen::Vector3d;  ///< a point or direction in mm
using Vec2 = Eigen::Vector2d;
using Mat3 = Eigen::Matrix3d;
/// A rigid transform; by convention `Frame` maps part (or local) coordinates to machine coordinates.
using Frame = Eigen::Isometry3d;

/// A unit vector perpendicular to `n` (any one; stable for a given n).
inline Vec3 any_perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return n.cross(a).normalized();
}

}  // namespace metron
