// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/touch_cycle/axis_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "metron/stdlib/jerk_limited_ramp.hpp"

namespace metron::machine {

MotionLimits path_limits(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s,
                         double acceleration_mm_s2, std::optional<double> acceleration_cap_mm_s2) {
  const double feed = std::min(feed_mm_s, spec.max_speed_mm_s);
  if (!axes) return {feed, acceleration_mm_s2, spec.max_jerk_mm_s3};
  double a = std::numeric_limits<double>::infinity(), j = a;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    const AxisDynamics& ax = (*axes)[static_cast<std::size_t>(i)];
    if (ax.mode == AxisDynamics::Mode::ConstantRate) {
      const double acc = acceleration_cap_mm_s2 ? std::min(ax.acceleration_mm_s2, *acceleration_cap_mm_s2) : ax.acceleration_mm_s2;
      a = std::min(a, acc / c);
      j = std::min(j, ax.jerk_mm_s3 / c);
    } else {
      // SEEDS.md 3: the feed is reached in a fixed time T whatever the feed: a ramp of
      // (1 - share) * T at constant acceleration plus share * T of jerk at each end.
      const double t = ax.time_s, share = constant_time_jerk_share;
      const double acc = std::max(feed, 1e-9) / ((1 - share) * t);
      a = std::min(a, acc);
      j = std::min(j, acc / (share * t));
    }
  }
  if (!std::isfinite(a)) return {feed, acceleration_mm_s2, spec.max_jerk_mm_s3};
  return {feed, a, j};
}

double ramp_time_s(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s) {
  const MotionLimits l = path_limits(spec, axes, direction, feed_mm_s, spec.max_acceleration_mm_s2);
  return jerk_limited_ramp_time_s(l.speed_mm_s, l.acceleration_mm_s2, l.jerk_mm_s3);
}

}  // namespace metron::machine
