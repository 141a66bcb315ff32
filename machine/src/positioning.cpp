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
  last_move = PositioningMove{0, a, u, len, profile, move_limits, move_braking, c0};
  return {};
}

// A stop request `after_s` into the last GoTo: the move as it was until then (its sweep found the
// whole line free, so the part of it before the stop is free too), then the shortest jerk-limited
// stop at the move's own limits (braking law included). Nothing else changes while the machine
// only positions, so cutting the move afterwards gives what stopping it then would have.
std::optional<Response> Controller::stop_move(double after_s) {
  if (!stoppable_move || !(after_s >= 0) || !(after_s < stoppable_move->profile.duration_s())) return std::nullopt;
  const PositioningMove m = *stoppable_move;
  stoppable_move.reset();
  const MotionProfile stop = MotionProfile::stop(m.profile.at(after_s), m.limits, m.braking);
  const double s_end = std::min(stop.end_position_mm(), m.length_mm);
  position = m.start_mm + s_end * m.direction;
  cycle = m.start_cycle + cycles_for(after_s + stop.duration_s());
  sim.set_time(now());
  Response r;
  r.tag = m.tag;
  r.status = Response::Status::Fault;
  r.fault = Fault{FaultKind::Aborted,
                  fmt::format("move to {} stopped at {} on request, {:.3f} s after its start",
                              xyz(m.start_mm + m.length_mm * m.direction), xyz(position), after_s),
                  position, now()};
  r.start_time_s = static_cast<double>(m.start_cycle) * config.dt_s;
  r.end_time_s = now();
  return r;
}

}  // namespace metron::machine::detail
