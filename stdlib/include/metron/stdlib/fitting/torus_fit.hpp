// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include <tl/expected.hpp>

#include "metron/stdlib/fitting/fit.hpp"
#include "metron/stdlib/geometry/vec.hpp"

/// A torus (DMIS TORUS): the surface swept by a circle of radius r (the tube) whose centre runs
/// round a circle of radius R (the centre circle) about an axis, and its least-squares fit from
/// probe ball centres.
namespace metron::fitting {

struct Torus {
  Vec3 centre = Vec3::Zero();    ///< the centre of the centre circle
  Vec3 axis = Vec3::UnitZ();     ///< unit, normal to the centre circle's plane
  double major_diameter_mm = 0;  ///< 2R: the centre circle's diameter
  double minor_diameter_mm = 0;  ///< 2r: the tube's diameter
};

/// Distance of `p` from the torus's tube centre circle (>= 0): the tube's surface lies at r.
double distance_from_centre_circle(const Torus& torus, const Vec3& p);

/// A fitted torus.
struct TorusFit {
  Torus torus;
  /// One per point: its ball-compensated distance from the fitted surface, + outside the
  /// material (an OUTER torus, a ring, has its material inside the tube; an INNER one, a
  /// toroidal groove or fillet, outside it).
  std::vector<double> residuals_mm;
  double rms_mm = 0;
  double form_mm = 0;  ///< max residual - min residual
  int iterations = 0;
};

/// Least-squares torus from ball centres: minimises sum_i (|c_i - C(c_i)| - (r + side * b))^2,
/// C(p) the point of the centre circle nearest p, b the ball radius, side +1 for an OUTER torus
/// (the ball rides outside the tube) and -1 for an INNER one, over the centre (3), the axis (2),
/// R and r, by Levenberg-Marquardt from `start` (the nominal). The distance from the centre
/// circle is the exact orthogonal distance to a torus (its normal lines all meet the centre
/// circle), so the residual is the ball-compensated distance of the touched surface point.
/// Fails TooFewPoints below 7 points, Degenerate on a non-finite coordinate or a point on the
/// axis, NoConvergence when the iteration does not settle or the result is not a torus
/// (R <= 0 or r <= 0).
tl::expected<TorusFit, FitFailure> fit_torus(const std::vector<Vec3>& ball_centres, double ball_radius_mm, bool inner,
                                             const Torus& start);

}  // namespace metron::fitting
