// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/axis_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace metron::machine {

MotionLimits path_limits(const MachineSpec& spec, const Vec3& direction, double feed_mm_s, double acceleration_mm_s2,
                         std::optional<double> acceleration_cap_mm_s2) {
  const double feed = std::min(feed_mm_s, spec.max_speed_mm_s);
  if (!spec.axes) return {feed, acceleration_mm_s2, spec.max_jerk_mm_s3};
  double a = std::numeric_limits<double>::infinity(), j = a;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    const AxisDynamics& ax = (*spec.axes)[static_cast<std::size_t>(i)];
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

double ramp_time_s(const MachineSpec& spec, const Vec3& direction, double feed_mm_s) {
  const MotionLimits l = path_limits(spec, direction, feed_mm_s, spec.max_acceleration_mm_s2);
  const double v = l.speed_mm_s;
  // Jerk-limited ramp from rest to v: triangular acceleration when v < a^2/j, else trapezoidal.
  if (v * l.jerk_mm_s3 < l.acceleration_mm_s2 * l.acceleration_mm_s2) return 2 * std::sqrt(v / l.jerk_mm_s3);
  return v / l.acceleration_mm_s2 + l.acceleration_mm_s2 / l.jerk_mm_s3;
}

}  // namespace metron::machine
