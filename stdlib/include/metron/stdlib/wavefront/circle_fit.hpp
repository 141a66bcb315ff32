// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <span>

#include <tl/expected.hpp>

#include "metron/stdlib/geometry/vec.hpp"

namespace metron::wavefront {

/// A circle in a plane, with the fit's rms residual (radial distance for the geometric fits).
struct Circle2 {
  Vec2 centre{0, 0};
  double radius = 0;
  double residual_rms = 0;
};

/// Algebraic fit minimising sum (|p - c|^2 - r^2)^2 (I. Kasa, IEEE Trans. Instrum. Meas. 25,
/// 1976); biased toward small radii on short arcs. Needs 3 points not on a line.
tl::expected<Circle2, const char*> fit_circle_kasa(std::span<const Vec2> points);

/// Algebraic fit normalised by the gradient (V. Pratt, "Direct least-squares fitting of algebraic
/// surfaces", SIGGRAPH 1987; as solved in N. Chernov, "Circular and linear regression", 2010).
tl::expected<Circle2, const char*> fit_circle_pratt(std::span<const Vec2> points);

/// Geometric fit minimising sum (|p - c| - r)^2 by Levenberg-Marquardt from the Pratt fit.
tl::expected<Circle2, const char*> fit_circle_geometric(std::span<const Vec2> points);

/// A circle traced at known angles: p_k = c + Rot(sense * angle_k) r (linear least squares in
/// c and the radius vector r at angle 0). This is part-on-mount's fit when the spindle angles are
/// known; it works from 2 angles, and its covariance is sigma^2 (M^T M)^-1.
struct PhasedCircle {
  Vec2 centre{0, 0};         ///< circle centre
  Vec2 radius_vector{0, 0};  ///< the point's offset from the centre at angle 0
  double residual_rms = 0;   ///< rms distance of the points from the fitted positions
  double centre_sigma = 0;   ///< standard error of each centre coordinate from the residual (needs > 2 angles)
  int sense = 1;             ///< +1 counter-clockwise with the angle, -1 clockwise
};

/// Fits a phased circle; `sense` 0 tries both senses and keeps the better (needs 3 angles).
tl::expected<PhasedCircle, const char*> fit_circle_phased(std::span<const Vec2> points,
                                                          std::span<const double> angles_rad, int sense = 0);

/// Straight line y = intercept + slope x by ordinary least squares (x exact, y noisy).
struct Line2 {
  double intercept = 0;
  double slope = 0;
  double slope_sigma = 0;  ///< standard error of the slope from the residual (needs > 2 points)
  double residual_rms = 0;
};

/// Fits a line; needs 2 distinct x.
tl::expected<Line2, const char*> fit_line(std::span<const double> x, std::span<const double> y);

}  // namespace metron::wavefront
