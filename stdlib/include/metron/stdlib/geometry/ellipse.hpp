// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <Eigen/Core>

/// The exact distance from a point to an ellipse in its own frame, shared by the ellipse fit and
/// the virtual CMM's elliptic cylinder.
namespace metron::geometry {

/// The nearest point of an ellipse and the distance to it.
struct EllipseFoot {
  Eigen::Vector2d foot = Eigen::Vector2d::Zero();     ///< on the ellipse, in its frame
  Eigen::Vector2d normal = Eigen::Vector2d::UnitX();  ///< unit, outward, at the foot
  double signed_distance = 0;                         ///< > 0 outside the ellipse, < 0 inside
};

/// The ellipse x^2/a^2 + y^2/b^2 = 1 (semi-axes a, b > 0, either the larger) and `p` in its
/// frame. The foot is the root of the one-variable equation of D. Eberly, "Distance from a Point
/// to an Ellipse, an Ellipsoid, or a Hyperellipsoid" (Geometric Tools, 2013), found by
/// bisection: exact to rounding for every point, inside or out, on an axis or at the centre.
EllipseFoot ellipse_foot(double a, double b, const Eigen::Vector2d& p);

}  // namespace metron::geometry
