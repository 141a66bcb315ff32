// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include <Eigen/Core>
#include <tl/expected.hpp>

#include "metron/stdlib/fitting/fit.hpp"

/// An ellipse in a plane (DMIS ELLIPS) and its least-squares fit from probe ball centres in that
/// plane.
namespace metron::fitting {

struct EllipseOutline {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double angle_rad = 0;          ///< the major axis, from the plane's first axis toward its second
  double major_diameter_mm = 0;  ///< 2a, along the major axis
  double minor_diameter_mm = 0;  ///< 2b <= 2a
};

/// Signed orthogonal distance of `p` from the ellipse: > 0 outside the region it bounds, < 0
/// inside (geometry/ellipse.hpp, exact).
double signed_distance(const EllipseOutline& ellipse, const Eigen::Vector2d& p);

/// A fitted ellipse.
struct EllipseFit {
  EllipseOutline outline;
  /// One per point: its ball-compensated distance from the fitted ellipse, + outside the
  /// material (into the hole for an inner ellipse, away from the boss for an outer one).
  std::vector<double> residuals_mm;
  double rms_mm = 0;
  double form_mm = 0;  ///< max residual - min residual
  int iterations = 0;
};

/// Least-squares ellipse from ball centres in its plane: minimises sum_i (s(c_i) - side * r)^2
/// (s the exact signed distance, side -1 for an inner ellipse, +1 for a boss; the ball centre
/// runs on the offset curve, so the residual is the touched point's distance whatever the
/// approach) over the centre, the angle and the two diameters, by Levenberg-Marquardt from
/// `start` (the nominal). The derivatives are those of the orthogonal distance with the foot's
/// parameter held (its tangential change is second order): for a parameter q,
/// ds/dq = -n . dX/dq at the foot X, n the outward normal (Forbes, NPL DITC 140/89; Ahn,
/// "Least Squares Orthogonal Distance Fitting of Curves and Surfaces in Space", LNCS 3151, 2004).
/// The result has major >= minor (the axes swap, and the angle turns 90 degrees, when the fit
/// finds them the other way) and its angle nearest the start's, modulo 180 degrees.
/// Fails TooFewPoints below 5 points, Degenerate on a non-finite coordinate, NoConvergence when
/// the iteration does not settle or a diameter is not positive.
tl::expected<EllipseFit, FitFailure> fit_ellipse(const std::vector<Eigen::Vector2d>& ball_centres,
                                                 double ball_radius_mm, bool inner, const EllipseOutline& start);

}  // namespace metron::fitting
