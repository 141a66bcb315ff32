// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/motion_profile.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "metron/stdlib/jerk_limited_ramp.hpp"

namespace metron::machine {
namespace {

MotionState advance(const MotionState& s, double jerk, double t) {
  return {s.position_mm + s.speed_mm_s * t + s.acceleration_mm_s2 * t * t / 2 + jerk * t * t * t / 6,
          s.speed_mm_s + s.acceleration_mm_s2 * t + jerk * t * t / 2, s.acceleration_mm_s2 + jerk * t};
}

struct Ramp {
  double jerk_time_s;   // each of the two jerk phases
  double const_time_s;  // constant-acceleration phase
  [[nodiscard]] double duration_s() const { return 2 * jerk_time_s + const_time_s; }
};

// Acceleration from rest to `speed` (and, mirrored, the deceleration back to rest).
Ramp ramp_to(double speed, const MotionLimits& l) {
  const double a = l.acceleration_mm_s2, j = l.jerk_mm_s3;
  if (speed * j >= a * a) return {a / j, speed / a - a / j};
  return {std::sqrt(speed / j), 0.0};
}

// The peak speed of a rest-to-rest move: the limit, or lower for short moves.
double peak_speed(double distance, const MotionLimits& l) {
  const double v = l.speed_mm_s, a = l.acceleration_mm_s2, j = l.jerk_mm_s3;
  // The ramp is symmetric in time, so its distance is speed * duration / 2.
  if (v * ramp_to(v, l).duration_s() <= distance) return v;
  // Without a constant-acceleration phase: distance/2 = v^1.5 / sqrt(j).
  const double v_jerk = std::cbrt(distance / 2 * std::sqrt(j) * distance / 2 * std::sqrt(j));
  if (v_jerk * j < a * a) return v_jerk;
  // With one: v^2/a + v*a/j = distance.
  return a / 2 * (-a / j + std::sqrt(a * a / (j * j) + 4 * distance / a));
}

void check_limits(const MotionLimits& l) {
  if (!(l.speed_mm_s > 0 && l.acceleration_mm_s2 > 0 && l.jerk_mm_s3 > 0))
    throw std::invalid_argument("motion limits must be positive");
}

// The limits every slow-down uses: the braking ones where given, else the acceleration's.
MotionLimits slowing(const MotionLimits& l, const std::optional<BrakingLimits>& b) {
  if (!b) return l;
  MotionLimits d = l;
  d.acceleration_mm_s2 = b->deceleration_mm_s2;
  d.jerk_mm_s3 = b->jerk_mm_s3;
  check_limits(d);
  return d;
}

// The peak speed of a rest-to-rest move that brakes by other limits than it accelerates: each
// ramp is symmetric in time, so the two cover v (T_up + T_down) / 2; that grows with v.
double peak_speed(double distance, const MotionLimits& up, const MotionLimits& down) {
  const auto ramps = [&](double v) { return v * (ramp_to(v, up).duration_s() + ramp_to(v, down).duration_s()) / 2; };
  if (ramps(up.speed_mm_s) <= distance) return up.speed_mm_s;
  double lo = 0, hi = up.speed_mm_s;
  for (int i = 0; i < 200 && hi - lo > 1e-15 * up.speed_mm_s; ++i)
    (ramps((lo + hi) / 2) <= distance ? lo : hi) = (lo + hi) / 2;
  return lo;
}

}  // namespace

MotionProfile::MotionProfile(MotionState start, std::vector<JerkPhase> phases) : m_start(start), m_end(start) {
  for (const JerkPhase& p : phases) {
    if (p.duration_s <= 0) continue;
    m_phase_start_s.push_back(m_duration_s);
    m_phase_state.push_back(m_end);
    m_phases.push_back(p);
    m_end = advance(m_end, p.jerk_mm_s3, p.duration_s);
    m_duration_s += p.duration_s;
  }
}

MotionProfile MotionProfile::rest_to_rest(double distance_mm, const MotionLimits& limits,
                                          const std::optional<BrakingLimits>& braking) {
  check_limits(limits);
  if (!(distance_mm > 0)) return {};
  if (braking) {
    const MotionLimits down = slowing(limits, braking);
    const double v = peak_speed(distance_mm, limits, down);
    const Ramp up = ramp_to(v, limits), dn = ramp_to(v, down);
    const double cruise_s = std::max(0.0, (distance_mm - v * (up.duration_s() + dn.duration_s()) / 2) / v);
    const double j = limits.jerk_mm_s3, jb = down.jerk_mm_s3;
    MotionProfile p({}, {{up.jerk_time_s, j},
                         {up.const_time_s, 0},
                         {up.jerk_time_s, -j},
                         {cruise_s, 0},
                         {dn.jerk_time_s, -jb},
                         {dn.const_time_s, 0},
                         {dn.jerk_time_s, jb}});
    p.m_end = {distance_mm, 0, 0};
    return p;
  }
  const double v = peak_speed(distance_mm, limits);
  const Ramp r = ramp_to(v, limits);
  const double cruise_s = std::max(0.0, (distance_mm - v * r.duration_s()) / v);
  const double j = limits.jerk_mm_s3;
  MotionProfile p({}, {{r.jerk_time_s, j},
                       {r.const_time_s, 0},
                       {r.jerk_time_s, -j},
                       {cruise_s, 0},
                       {r.jerk_time_s, -j},
                       {r.const_time_s, 0},
                       {r.jerk_time_s, j}});
  // The polynomials land on the target only to rounding; the controller ends exactly on it.
  p.m_end = {distance_mm, 0, 0};
  return p;
}

namespace {

// A jerk-limited speed change by dv (>= 0 up, < 0 down) with zero acceleration at both ends:
// its phases, duration and distance (the mean of both speeds times the duration, since the
// speed curve is point-symmetric).
struct SpeedChange {
  std::vector<JerkPhase> phases;
  double duration_s = 0;
};
SpeedChange speed_change(double dv, const MotionLimits& limits, const std::optional<BrakingLimits>& braking) {
  SpeedChange c;
  const double sign = dv < 0 ? -1 : 1, m = std::abs(dv);
  if (m <= 0) return c;
  const MotionLimits l = dv < 0 ? slowing(limits, braking) : limits;
  const double a = l.acceleration_mm_s2, j = l.jerk_mm_s3;
  if (m * j >= a * a) {
    c.phases = {{a / j, sign * j}, {m / a - a / j, 0}, {a / j, -sign * j}};
  } else {
    const double t = std::sqrt(m / j);
    c.phases = {{t, sign * j}, {t, -sign * j}};
  }
  c.duration_s = jerk_limited_ramp_time_s(m, a, j);
  return c;
}
double change_distance(double v0, double v1, const MotionLimits& l, const std::optional<BrakingLimits>& b) {
  return (v0 + v1) / 2 * speed_change(v1 - v0, l, b).duration_s;
}

}  // namespace

MotionProfile MotionProfile::reach_feed(double reach_mm, double distance_mm, double feed_mm_s,
                                        const MotionLimits& limits, const std::optional<BrakingLimits>& braking) {
  const double feed = std::min(feed_mm_s, limits.speed_mm_s);
  const auto two_ramps = [&](double v) {
    return change_distance(0, v, limits, braking) + change_distance(v, feed, limits, braking);
  };
  std::vector<JerkPhase> phases;
  const auto append = [&](const std::vector<JerkPhase>& p) { phases.insert(phases.end(), p.begin(), p.end()); };
  double covered = 0;
  if (change_distance(0, feed, limits, braking) >= reach_mm) {
    append(speed_change(feed, limits, braking).phases);  // too close: ramp straight to the feed
    covered = change_distance(0, feed, limits, braking);
  } else {
    double peak = limits.speed_mm_s;
    if (two_ramps(peak) > reach_mm) {
      double lo = feed, hi = peak;
      for (int i = 0; i < 100; ++i) (two_ramps((lo + hi) / 2) < reach_mm ? lo : hi) = (lo + hi) / 2;
      peak = lo;
    }
    append(speed_change(peak, limits, braking).phases);
    phases.push_back({(reach_mm - two_ramps(peak)) / peak, 0});  // cruise at the peak (0 when bisected)
    append(speed_change(feed - peak, limits, braking).phases);
    covered = reach_mm;
  }
  const double stop = change_distance(feed, 0, limits, braking);
  phases.push_back({std::max(0.0, distance_mm - covered - stop) / feed, 0});
  append(speed_change(-feed, limits, braking).phases);
  return MotionProfile({}, std::move(phases));
}

MotionProfile MotionProfile::stop(const MotionState& from, const MotionLimits& limits,
                                  const std::optional<BrakingLimits>& braking) {
  check_limits(limits);
  if (braking && from.speed_mm_s > 0) {
    // The controller ends a rising speed as its ramp would (at the ramp's jerk), then brakes by
    // the braking limits from zero acceleration: so the speed never exceeds the ramp's target.
    const MotionLimits down = slowing(limits, braking);
    if (!(from.acceleration_mm_s2 > 0)) return stop(from, down);
    const double t = from.acceleration_mm_s2 / limits.jerk_mm_s3;
    MotionState flat = advance(from, -limits.jerk_mm_s3, t);
    flat.acceleration_mm_s2 = 0;
    std::vector<JerkPhase> phases{{t, -limits.jerk_mm_s3}};
    const MotionProfile rest = stop(flat, down);
    phases.insert(phases.end(), rest.phases().begin(), rest.phases().end());
    MotionProfile p(from, phases);
    p.m_end.speed_mm_s = 0;
    p.m_end.acceleration_mm_s2 = 0;
    return p;
  }
  const double v0 = from.speed_mm_s, a0 = from.acceleration_mm_s2;
  const double a = limits.acceleration_mm_s2, j = limits.jerk_mm_s3;
  if (v0 <= 0) {
    MotionProfile p(from, {});
    p.m_end = {from.position_mm, 0, 0};
    return p;
  }
  std::vector<JerkPhase> phases;
  if (a0 < 0 && v0 < a0 * a0 / (2 * j)) {
    // Already braking harder than needed: releasing the brake at the jerk limit reaches zero
    // speed before zero acceleration; stop when the speed is zero.
    const double t = (-a0 - std::sqrt(a0 * a0 - 2 * j * v0)) / j;
    phases = {{t, j}};
  } else {
    // Jerk down to -peak, hold, jerk back to 0: v0 + (a0^2 - 2 peak^2)/(2j) - peak*hold = 0.
    double peak = std::sqrt(j * v0 + a0 * a0 / 2);
    double hold_s = 0;
    if (peak > a) {
      peak = a;
      hold_s = (v0 + a0 * a0 / (2 * j) - a * a / j) / a;
    }
    phases = {{(a0 + peak) / j, -j}, {hold_s, 0}, {peak / j, j}};
  }
  MotionProfile p(from, phases);
  p.m_end.speed_mm_s = 0;
  p.m_end.acceleration_mm_s2 = 0;
  return p;
}

MotionState MotionProfile::at(double t_s) const {
  if (t_s >= m_duration_s) return m_end;
  if (t_s <= 0 || m_phases.empty()) return m_start;
  const auto it = std::upper_bound(m_phase_start_s.begin(), m_phase_start_s.end(), t_s);
  const std::size_t i = static_cast<std::size_t>(it - m_phase_start_s.begin()) - 1;
  return advance(m_phase_state[i], m_phases[i].jerk_mm_s3, t_s - m_phase_start_s[i]);
}

double MotionProfile::time_at(double position_mm) const {
  if (position_mm <= m_start.position_mm) return 0;
  if (position_mm >= m_end.position_mm) return m_duration_s;
  double lo = 0, hi = m_duration_s;
  // Position is non-decreasing in time, so bisection converges to the first crossing.
  for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
    const double mid = (lo + hi) / 2;
    (at(mid).position_mm < position_mm ? lo : hi) = mid;
  }
  return hi;
}

double rest_to_rest_time_s(double distance_mm, const MotionLimits& limits,
                           const std::optional<BrakingLimits>& braking) {
  check_limits(limits);
  if (!(distance_mm > 0)) return 0;
  if (braking) {
    const MotionLimits down = slowing(limits, braking);
    const double v = peak_speed(distance_mm, limits, down);
    const double ramps_s = ramp_to(v, limits).duration_s() + ramp_to(v, down).duration_s();
    return ramps_s + std::max(0.0, (distance_mm - v * ramps_s / 2) / v);
  }
  const double v = peak_speed(distance_mm, limits);
  const Ramp r = ramp_to(v, limits);
  return 2 * r.duration_s() + std::max(0.0, (distance_mm - v * r.duration_s()) / v);
}

}  // namespace metron::machine
