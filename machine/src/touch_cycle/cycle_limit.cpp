// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/touch_cycle/cycle_limit.hpp"

#include <algorithm>
#include <cmath>

#include "metron/machine/motion_profile.hpp"
#include "metron/machine/touch_cycle/axis_dynamics.hpp"

namespace metron::machine {
namespace {

// Minimum time of a speed change by dv with zero acceleration at both ends: jerk-limited
// (trapezoidal acceleration, or triangular when the acceleration limit is not reached), or
// with the acceleration limit alone when `jerk` is false.
double change_s(double dv, const MotionLimits& l, bool jerk) {
  dv = std::abs(dv);
  const double a = l.acceleration_mm_s2, j = l.jerk_mm_s3;
  if (!jerk) return dv / a;
  return dv * j >= a * a ? dv / a + a / j : 2 * std::sqrt(dv / j);
}

// Minimum time from rest to speed v (zero acceleration) within `length`: up to a peak p and
// down to v (by the braking limits `down`), each change covering its mean speed times its time;
// no better than the plain ramp.
double reach_s(double length, double v, const MotionLimits& l, const MotionLimits& down, bool jerk) {
  const auto dist = [&](double p) { return p / 2 * change_s(p, l, jerk) + (p + v) / 2 * change_s(p - v, down, jerk); };
  if (v / 2 * change_s(v, l, jerk) >= length) return change_s(v, l, jerk);
  double peak = l.speed_mm_s;
  if (dist(peak) > length) {
    double lo = v, hi = peak;
    for (int i = 0; i < 100; ++i) (dist((lo + hi) / 2) < length ? lo : hi) = (lo + hi) / 2;
    peak = lo;
  }
  return change_s(peak, l, jerk) + change_s(peak - v, down, jerk) + (length - dist(peak)) / peak;
}

// Minimum rest-to-rest time over `length`, braking by `down`: the ramps cover v (T_up + T_down) / 2.
double rest_to_rest_s(double length, const MotionLimits& l, const MotionLimits& down, bool jerk) {
  if (length <= 0) return 0;
  const auto both = [&](double v) { return (change_s(v, l, jerk) + change_s(v, down, jerk)) / 2; };
  const auto ramps = [&](double v) { return v * both(v); };
  if (ramps(l.speed_mm_s) <= length) return length / l.speed_mm_s + both(l.speed_mm_s);
  double lo = 0, hi = l.speed_mm_s;
  for (int i = 0; i < 100; ++i) (ramps((lo + hi) / 2) < length ? lo : hi) = (lo + hi) / 2;
  return 2 * both(hi);
}

// The limits a slow-down uses: an axis's own braking law where it has one.
MotionLimits slowing(const MotionLimits& l, const std::optional<BrakingLimits>& b) {
  if (!b) return l;
  return {l.speed_mm_s, b->deceleration_mm_s2, b->jerk_mm_s3};
}

}  // namespace

TouchCycleLimit touch_cycle_limit(const MachineConfig& config, const WorldTruth& truth, const Vec3& direction,
                                  double feed_mm_s, double clearance_mm, double tolerance_mm,
                                  double positioning_feed_mm_s, double qualification_feed_mm_s) {
  const Vec3 u = direction.normalized();
  const MotionLimits fast = path_limits(config, truth.axes, u, positioning_feed_mm_s, config.max_acceleration_mm_s2);
  const MotionLimits fast_down = slowing(fast, path_braking(config, truth.axes, u, positioning_feed_mm_s));
  const MotionLimits slow_down = slowing(path_limits(config, truth.axes, u, feed_mm_s, config.max_acceleration_mm_s2),
                                         path_braking(config, truth.axes, u, feed_mm_s));
  const double jitter = config.skip.kind == SkipInput::Kind::Scanned ? config.skip.period_s : 0;
  const double latency = config.skip.kind == SkipInput::Kind::Latched ? config.skip.latency_s : 0;
  // Mean time from the threshold to the latch: filter, transmission, skip latency, half a scan.
  const double delay = truth.probe.filter_delay_s + truth.probe.transmission_delay_s + latency + jitter / 2;
  const double pt = truth.probe.pre_travel.at(u);
  TouchCycleLimit lim;
  // The latched centre at the qualification feed is nominal + effective radius on a surface at
  // its nominal: contact came pt + F_q * delay before, i.e. that much closer to the start.
  lim.q_mm = pt + qualification_feed_mm_s * delay;
  lim.reach_mm = clearance_mm - lim.q_mm - tolerance_mm;
  for (bool jerk : {true, false}) {
    // Rest to the feed by the earliest contact; across the band (tolerance on average) at the
    // feed; pre-travel at the feed; the trigger chain; the stop (braking from the feed takes the
    // braking ramp's time Tb); back to the clearance above the latched point (clearance + the
    // braking distance V Tb / 2).
    const double tb = change_s(feed_mm_s, slow_down, jerk);
    const double t = reach_s(std::max(lim.reach_mm, 0.0), feed_mm_s, fast, fast_down, jerk) + tolerance_mm / feed_mm_s +
                     pt / feed_mm_s + delay + tb +
                     rest_to_rest_s(clearance_mm + feed_mm_s * tb / 2, fast, fast_down, jerk);
    (jerk ? lim.time_s : lim.no_jerk_time_s) = t;
  }
  return lim;
}

}  // namespace metron::machine
