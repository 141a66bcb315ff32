// SPDX-License-Identifier: GPL-3.0-or-later
// Positioning moves of the virtual CMM's controller: straight, rest to rest, jerk-limited, the
// ball checked against the world every cycle; axis travel limits.
#include <algorithm>
#include <cmath>

#include "controller.hpp"

namespace metron::machine::detail {

Controller::Controller(MachineConfig known, WorldTruth truth, std::uint64_t seed)
    : sim(std::move(truth), seed),
      config(std::move(known)),
      position(config.home_mm),
      positioning_feed(config.positioning_feed_mm_s),
      measuring_feed(config.measuring_feed_mm_s),
      acceleration(config.max_acceleration_mm_s2) {}

std::int64_t Controller::cycles_for(double t_s) const {
  return static_cast<std::int64_t>(std::ceil(t_s / config.dt_s - 1e-9));
}

MotionLimits Controller::limits(const Vec3& u, double feed) const {
  return sim.motion_limits(config, u, feed, acceleration, acceleration_cap);
}

// An axis with its own braking law (docs/world.md) slows every move down by it.
std::optional<BrakingLimits> Controller::braking(const Vec3& u, double feed) const {
  return sim.motion_braking(config, u, feed, acceleration_cap);
}

// Braking from `speed` along u: the axes decelerate as they accelerate (a constant-time axis
// stops from any speed in its time).
MotionLimits Controller::braking_limits(const Vec3& u, double speed) const {
  if (!sim.has_axis_dynamics()) return {config.max_speed_mm_s, config.max_acceleration_mm_s2, config.max_jerk_mm_s3};
  MotionLimits l = sim.motion_limits(config, u, speed, config.max_acceleration_mm_s2, std::nullopt);
  l.speed_mm_s = config.max_speed_mm_s;
  return l;
}

Tool* Controller::active_tool() {
  const auto it = tools.find(active);
  return it == tools.end() ? nullptr : &it->second;
}

tl::expected<void, Fault> Controller::check_travel(const Vec3& p, const char* what) const {
  static const char* axis = "xyz";
  for (int i = 0; i < 3; ++i) {
    const AxisTravel& t = config.travel[i];
    if (p[i] < t.min_mm - 1e-9 || p[i] > t.max_mm + 1e-9)
      return fault(FaultKind::AxisLimit,
                   fmt::format("{} {} outside the {} travel [{}, {}]", what, xyz(p), axis[i], t.min_mm, t.max_mm),
                   position, now());
  }
  return {};
}

// A positioning move: straight, rest to rest, the ball checked against the world every cycle.
tl::expected<void, Fault> Controller::move_to(const Vec3& target, double feed) {
  if (auto ok = check_travel(target, "target"); !ok) return ok;
  const Vec3 a = position;
  const double len = (target - a).norm();
  if (len < 1e-12) {
    position = target;
    return {};
  }
  const Vec3 u = (target - a) / len;
  const MotionLimits move_limits = limits(u, feed);
  const std::optional<BrakingLimits> move_braking = braking(u, feed);
  const MotionProfile profile = MotionProfile::rest_to_rest(len, move_limits, move_braking);
  const double t_end = profile.duration_s();
  const std::int64_t n = cycles_for(t_end), c0 = cycle;
  double s_prev = 0;
  for (std::int64_t k = 1; k <= n; ++k) {
    const double t = std::min(static_cast<double>(k) * config.dt_s, t_end);
    const MotionState st = profile.at(t);
    sim.set_time(static_cast<double>(c0) * config.dt_s + t);
    if (const auto f = sim.sweep(a + s_prev * u, a + st.position_mm * u)) {
      const double s_contact = s_prev + *f * (st.position_mm - s_prev);
      const double t_contact = profile.time_at(s_contact);
      position = a + s_contact * u;
      cycle = c0 + cycles_for(t_contact);
      const std::string feature = sim.feature_at(position);
      return fault(FaultKind::Collision,
                   fmt::format("collision{} at {} on a move to {}", feature.empty() ? "" : " with " + feature,
                               xyz(position), xyz(target)),
                   position, static_cast<double>(c0) * config.dt_s + t_contact);
    }
    s_prev = st.position_mm;
    emit(static_cast<double>(c0 + k) * config.dt_s, a + s_prev * u, st.speed_mm_s);
  }
  cycle = c0 + n;
  position = target;
  motion.moves.push_back(PositioningMove{a, u, len, profile, move_limits, move_braking, c0,
                                         std::numeric_limits<double>::infinity(), now(), target});
  return {};
}

// A stop request `after_s` into the last command. Its motion was kept as it ran (its sweeps
// found it free, so the part before the stop is free too); nothing else changes while the machine
// moves, so cutting the motion afterwards gives what stopping it then would have:
// - in a straight move (a GoTo, a point measurement's approach, probing move or retract), the
//   shortest jerk-limited stop at the move's own limits, braking law included;
// - in an active scan, the same stop from the head's speed, along its velocity at that cycle;
// - at rest between moves, or after a probing move's trigger (the move is stopping already),
//   where that move came to rest.
// The command's result is lost: a point measurement's hit, a scan's samples.
std::optional<Response> Controller::stop_move(double after_s) {
  if (!stoppable || !(after_s >= 0)) return std::nullopt;
  const double t_start = static_cast<double>(stoppable->start_cycle) * config.dt_s, t = t_start + after_s;
  if (!(t < stoppable->end_s)) return std::nullopt;
  const CommandMotion m = std::move(*stoppable);
  stoppable.reset();

  Vec3 rest = m.start_mm;
  double rest_s = t;
  if (!m.scan.empty() && m.scan.front().time_s - config.dt_s <= t) {
    // The cycle the request falls in (past the last one, the scan had ended: rest there).
    const auto found =
        std::find_if(m.scan.begin(), m.scan.end(), [&](const ScanHeadSample& c) { return c.time_s >= t; });
    const ScanHeadSample& at = found != m.scan.end() ? *found : m.scan.back();
    const double v = found != m.scan.end() ? at.velocity_mm_s.norm() : 0.0;
    rest = at.head_mm;
    rest_s = std::max(t, at.time_s);
    if (v > 1e-9) {
      const Vec3 u = at.velocity_mm_s / v;
      const MotionProfile stop = MotionProfile::stop(MotionState{0, v, 0}, braking_limits(u, v));
      rest += stop.end_position_mm() * u;
      rest_s += stop.duration_s();
    }
  } else {
    const auto started = [&](const PositioningMove& mv) {
      return static_cast<double>(mv.start_cycle) * config.dt_s <= t;
    };
    const auto last = std::find_if(m.moves.rbegin(), m.moves.rend(), started);
    if (last != m.moves.rend()) {
      const PositioningMove& mv = *last;
      const double into = t - static_cast<double>(mv.start_cycle) * config.dt_s;
      if (into < std::min(mv.cuttable_s, mv.profile.duration_s())) {
        const MotionProfile stop = MotionProfile::stop(mv.profile.at(into), mv.limits, mv.braking);
        rest = mv.start_mm + std::min(stop.end_position_mm(), mv.length_mm) * mv.direction;
        rest_s = t + stop.duration_s();
      } else {
        rest = mv.end_mm;
        rest_s = std::max(t, mv.end_s);
      }
    }
  }
  position = rest;
  cycle = m.start_cycle + cycles_for(rest_s - t_start);
  sim.set_time(now());
  last_hit = m.hit_before;
  Response r;
  r.tag = m.tag;
  r.status = Response::Status::Fault;
  r.fault = Fault{FaultKind::Aborted,
                  fmt::format("{} stopped at {} on request, {:.3f} s after its start", m.what, xyz(position), after_s),
                  position, now()};
  r.start_time_s = t_start;
  r.end_time_s = now();
  return r;
}

}  // namespace metron::machine::detail
