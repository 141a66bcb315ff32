// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>

#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::machine::segmented {

/// The limits of the time-optimal bound: no jerk limit, so no jerk-limited motion can be faster.
struct BoundLimits {
  double speed_mm_s = 100;                 ///< tangential speed limit
  double acceleration_mm_s2 = 1000;        ///< tangential acceleration (and braking) limit
  double normal_acceleration_mm_s2 = 500;  ///< centripetal limit: v^2 * curvature <= this
};

/// The independent lower bound of a scan's duration (issue 11 item 5).
struct TimeOptimalBound {
  double time_s = 0;      ///< rest-to-rest minimum time under BoundLimits
  double length_mm = 0;   ///< arc length of the discretised path
  std::size_t nodes = 0;  ///< discretisation nodes
};

/// Time-optimal traversal of `path` from rest to rest with speed, tangential-acceleration and
/// centripetal limits and no jerk limit, by the forward/backward pass over a fine discretisation
/// (the phase-plane method of Bobrow et al. 1985 / Shin & McKay 1985, which TOPP-RA's
/// reachability analysis solves in general; with one path coordinate and box constraints the
/// two passes give the exact maximal velocity profile on the grid). Built only on the path's
/// geometry (points and derivatives), independently of metron's planner and interpolator.
/// Between nodes the acceleration is constant (v^2 linear in s), so each step takes
/// 2 ds / (v_i + v_i+1); the curvature is sampled at the nodes, so a curvature peak between
/// nodes can only make the result lower: a lower bound that tightens as `step_mm` shrinks.
TimeOptimalBound time_optimal_bound(const geometry::PccPath& path, const BoundLimits& limits, double step_mm = 0.01);

}  // namespace metron::machine::segmented
