// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include <Eigen/Core>
#include <tl/expected.hpp>

#include "metron/stdlib/fitting/fit.hpp"

/// The 2-D outline of a closed slot (DMIS CPARLN, "closed-ended parallel lines") and its
/// least-squares fit from probe ball centres in the slot's plane.
namespace metron::fitting {

/// A slot outline in a plane: two parallel sides `width_mm` apart, closed by ROUND ends
/// (semicircles of diameter `width_mm`: a stadium) or FLAT ones (a rectangle); `length_mm` is
/// the overall length, end to end.
struct SlotOutline {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double angle_rad = 0;  ///< the long axis, from the plane's first axis toward its second
  double length_mm = 0;
  double width_mm = 0;
  bool round_ends = true;
};

/// Signed distance of `p` from the outline: > 0 outside the region it bounds, < 0 inside;
/// exact for both shapes, inside and out (stadium: distance from the centre segment minus the
/// half width; rectangle: the box distance; the closed forms of I. Quilez, "2D distance
/// functions", iquilezles.org).
double signed_distance(const SlotOutline& slot, const Eigen::Vector2d& p);

/// Which part of the outline a point lies nearest: the side toward +second axis of the slot's
/// own frame, the other side, the end toward +long axis, the other end.
enum class SlotPart { PlusSide, MinusSide, PlusEnd, MinusEnd };
SlotPart nearest_part(const SlotOutline& slot, const Eigen::Vector2d& p);

/// A fitted outline.
struct SlotFit {
  SlotOutline outline;
  /// One per point: its ball-compensated distance from the fitted outline, + outside the
  /// material (into the slot for an inner slot, away from the tab for an outer one).
  std::vector<double> residuals_mm;
  double rms_mm = 0;
  double form_mm = 0;  ///< max residual - min residual
  int iterations = 0;
};

/// Least-squares slot from ball centres in its plane: minimises
///   sum_i (s(c_i) - side * r)^2,   side = -1 for an inner slot (centres inside), +1 for a tab,
/// over the centre, the angle, the length and the width, by Levenberg-Marquardt from `start`
/// (the nominal). A ball of radius r touching the outline has its centre on the curve at signed
/// distance side * r (the offset curve), so the residual is the ball-compensated distance of the
/// touched surface point from the outline, whatever the approach direction.
/// Fails (TooFewPoints) with fewer than 5 points or when a side or an end has none (see
/// `nearest_part` about `start`); NoConvergence when the iteration does not settle or the
/// result is not a slot (width <= 0, length < width for round ends).
tl::expected<SlotFit, FitFailure> fit_slot(const std::vector<Eigen::Vector2d>& ball_centres, double ball_radius_mm,
                                           bool inner, const SlotOutline& start);

}  // namespace metron::fitting
