// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/touch_cycle/axis_dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "metron/stdlib/jerk_limited_ramp.hpp"

namespace metron::machine {
namespace {

// Narrows the path limits (a, j) of a move at path feed `feed` to what one axis's law allows;
// `c` is the axis's share of the direction (0 < c <= 1).
void restrict_to(const RampLaw& law, double c, double feed, std::optional<double> cap, double& a, double& j) {
  if (law.mode == RampLaw::Mode::ConstantRate) {
    const double acc = cap ? std::min(law.acceleration_mm_s2, *cap) : law.acceleration_mm_s2;
    a = std::min(a, acc / c);
    j = std::min(j, law.jerk_mm_s3 / c);
    return;
  }
  // SEEDS.md 3: the feed is reached in a time T (fixed, or the table's at the axis's own feed):
  // a ramp of (1 - share) * T at constant acceleration plus share * T of jerk at each end.
  const double t = law_time_s(law, c * feed), share = constant_time_jerk_share;
  const double acc = std::max(feed, 1e-9) / ((1 - share) * t);
  a = std::min(a, acc);
  j = std::min(j, acc / (share * t));
}

}  // namespace

double law_time_s(const RampLaw& law, double axis_feed_mm_s) {
  if (law.mode != RampLaw::Mode::Tabulated || law.table.empty()) return law.time_s;
  const auto& t = law.table;
  if (axis_feed_mm_s <= t.front().feed_mm_s) return t.front().ramp_time_s;
  if (axis_feed_mm_s >= t.back().feed_mm_s) return t.back().ramp_time_s;
  const auto hi = std::upper_bound(t.begin(), t.end(), axis_feed_mm_s,
                                   [](double v, const RampTimePoint& p) { return v < p.feed_mm_s; });
  const auto lo = hi - 1;
  const double s = (axis_feed_mm_s - lo->feed_mm_s) / (hi->feed_mm_s - lo->feed_mm_s);
  return lo->ramp_time_s + s * (hi->ramp_time_s - lo->ramp_time_s);
}

MotionLimits path_limits(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s,
                         double acceleration_mm_s2, std::optional<double> acceleration_cap_mm_s2) {
  const double feed = std::min(feed_mm_s, spec.max_speed_mm_s);
  if (!axes) return {feed, acceleration_mm_s2, spec.max_jerk_mm_s3};
  double a = std::numeric_limits<double>::infinity(), j = a;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    restrict_to((*axes)[static_cast<std::size_t>(i)], c, feed, acceleration_cap_mm_s2, a, j);
  }
  if (!std::isfinite(a)) return {feed, acceleration_mm_s2, spec.max_jerk_mm_s3};
  return {feed, a, j};
}

std::optional<BrakingLimits> path_braking(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction,
                                          double feed_mm_s, std::optional<double> acceleration_cap_mm_s2) {
  if (!axes) return std::nullopt;
  const double feed = std::min(feed_mm_s, spec.max_speed_mm_s);
  double a = std::numeric_limits<double>::infinity(), j = a;
  bool own = false;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    const AxisDynamics& ax = (*axes)[static_cast<std::size_t>(i)];
    own = own || ax.braking.has_value();
    restrict_to(ax.braking ? *ax.braking : static_cast<const RampLaw&>(ax), c, feed, acceleration_cap_mm_s2, a, j);
  }
  if (!own || !std::isfinite(a)) return std::nullopt;
  return BrakingLimits{a, j};
}

double ramp_time_s(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s) {
  const MotionLimits l = path_limits(spec, axes, direction, feed_mm_s, spec.max_acceleration_mm_s2);
  return jerk_limited_ramp_time_s(l.speed_mm_s, l.acceleration_mm_s2, l.jerk_mm_s3);
}

double braking_time_s(const MachineConfig& spec, const AxesDynamics& axes, const Vec3& direction, double feed_mm_s) {
  const auto b = path_braking(spec, axes, direction, feed_mm_s);
  if (!b) return ramp_time_s(spec, axes, direction, feed_mm_s);
  return jerk_limited_ramp_time_s(std::min(feed_mm_s, spec.max_speed_mm_s), b->deceleration_mm_s2, b->jerk_mm_s3);
}

}  // namespace metron::machine
