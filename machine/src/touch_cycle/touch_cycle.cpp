// SPDX-License-Identifier: GPL-3.0-or-later
// The touch-trigger measurement cycle of the virtual CMM's controller (SEEDS.md 3): one probing
// move until the trigger, latched by the skip input, braking and the over-travel check; one- and
// two-touch point measurements.
#include <algorithm>
#include <cmath>

#include "controller.hpp"

namespace metron::machine::detail {

// One probing move from rest at `start` along unit u over `len` at `feed` until the trigger:
// the controller latches the axes when it acts on the trigger (SEEDS.md 3, C->D), brakes, and
// the probe's over-travel switch is checked.
tl::expected<Controller::Touch, Fault> Controller::touch(const Vec3& start, const Vec3& u, double len, double feed,
                                                         double search_mm, std::optional<double> reach_mm) {
  const double move_feed = reach_mm ? positioning_feed : feed;
  const MotionLimits move_limits = limits(u, move_feed);
  const MotionProfile profile = reach_mm
                                    ? MotionProfile::reach_feed(*reach_mm, len, std::min(feed, config.max_speed_mm_s),
                                                                move_limits, braking(u, move_feed))
                                    : MotionProfile::rest_to_rest(len, move_limits, braking(u, move_feed));
  const double t_end = profile.duration_s();
  const std::int64_t n_cycles = cycles_for(t_end), c0 = cycle;
  const double t0_abs = now();
  sim.begin_probe(&profile, start, u, t0_abs);
  std::optional<double> signal;
  for (std::int64_t k = 1; k <= n_cycles && !signal; ++k) {
    const double t0 = static_cast<double>(k - 1) * config.dt_s,
                 t1 = std::min(static_cast<double>(k) * config.dt_s, t_end);
    signal = sim.probe_step(t0, t1);
    const MotionState st = profile.at(t1);
    if (!signal) emit(t0_abs + t1, start + st.position_mm * u, st.speed_mm_s);
  }
  if (!signal) {
    cycle = c0 + n_cycles;
    position = start + len * u;
    return fault(FaultKind::NoContact,
                 fmt::format("no {} within {:.3f} mm past the nominal point (probed {:.3f} mm from the approach point)",
                             sim.touched() ? "trigger" : "contact", search_mm, len),
                 position, now());
  }

  // SEEDS.md 3, C->D: the controller's response. Latched: fixed latency; scanned: the next
  // tick of a scan clock whose phase is random relative to the motion (the jitter).
  double latch = *signal + config.skip.latency_s;
  if (config.skip.kind == SkipInput::Kind::Scanned) {
    const double period = config.skip.period_s;
    const double phase = sim.scan_phase() * period;
    latch = phase + std::ceil((*signal - phase) / period) * period;
  }
  const Vec3 latched = start + profile.at(latch).position_mm * u;

  // The interpolator acts at its next cycle: a jerk-limited stop from the current state.
  const double brake = static_cast<double>(cycles_for(latch)) * config.dt_s;
  double stop_s = len, stop_t = t_end;
  if (brake < t_end) {
    const MotionState at_brake = profile.at(brake);
    // An axis with its own braking law stops by it (at the machine's limits, as braking_limits),
    // after ending a rising speed at the move's jerk.
    const auto own = sim.motion_braking(config, u, at_brake.speed_mm_s, std::nullopt);
    const MotionProfile stop = own ? MotionProfile::stop(at_brake, move_limits, own)
                                   : MotionProfile::stop(at_brake, braking_limits(u, at_brake.speed_mm_s));
    stop_s = std::min(stop.end_position_mm(), len);
    stop_t = brake + stop.duration_s();
    for (std::int64_t k = cycles_for(*signal); static_cast<double>(k) * config.dt_s < stop_t; ++k) {
      const double t = static_cast<double>(k) * config.dt_s;
      const MotionState st = t < brake ? profile.at(t) : stop.at(t - brake);
      emit(t0_abs + t, start + st.position_mm * u, st.speed_mm_s);
    }
  }
  cycle = c0 + cycles_for(stop_t);
  position = start + stop_s * u;
  motion.moves.push_back(
      PositioningMove{start, u, len, profile, move_limits, braking(u, move_feed), c0, brake, now(), position});
  if (const auto past = sim.over_travel(stop_s))
    return fault(FaultKind::OverTravel,
                 fmt::format("probe over-travel: stopped {:.3f} mm past contact, limit {:.3f} mm, touching at "
                             "{:.1f} mm/s: probe slower",
                             *past, config.data_sheet.rated_over_travel_mm, profile.at(*signal).speed_mm_s),
                 position, now());
  return Touch{latched, t0_abs + latch};
}

// One touch-trigger point (SEEDS.md 3): approach, probe until the trigger, latch, brake,
// check over-travel, retract.
tl::expected<Hit, Fault> Controller::measure_point(const PtMeas& m) {
  Tool* tool = active_tool();
  if (!tool) return fault(FaultKind::NoTool, "no tool selected", position, now());
  const bool finite = m.nominal_mm.allFinite() && m.normal.allFinite() && std::isfinite(m.approach_mm) &&
                      std::isfinite(m.search_mm) && std::isfinite(m.retract_mm);
  if (!finite || m.normal.norm() < 1e-9)
    return fault(FaultKind::BadCommand, "ptmeas needs a finite point and a non-zero normal", position, now());
  if (m.approach_mm < 0 || m.search_mm < 0 || m.retract_mm < 0 || m.approach_mm + m.search_mm <= 0)
    return fault(FaultKind::BadCommand, "ptmeas approach, search and retract must be >= 0 and approach + search > 0",
                 position, now());
  const double feed = m.speed_mm_s.value_or(measuring_feed);
  if (!(feed > 0)) return fault(FaultKind::BadCommand, "ptmeas speed must be positive", position, now());

  const Vec3 n = m.normal.normalized();
  const double r = tool->info.effective_radius_mm;
  const Vec3 start = m.nominal_mm + (r + m.approach_mm) * n;
  const Vec3 end = m.nominal_mm + (r - m.search_mm) * n;
  if (auto ok = check_travel(start, "approach point"); !ok) return tl::unexpected(ok.error());
  if (auto ok = check_travel(end, "search end"); !ok) return tl::unexpected(ok.error());
  if (auto ok = move_to(start, positioning_feed); !ok) return tl::unexpected(ok.error());

  const Vec3 u = -n;
  const double len = m.approach_mm + m.search_mm;
  Vec3 latched;
  double latch_abs = 0;
  if (m.blend_mm && (m.two_touch || !(*m.blend_mm >= 0) || *m.blend_mm > m.approach_mm))
    return fault(FaultKind::BadCommand, "a blended ptmeas needs 0 <= blend <= approach and one touch", position, now());
  if (!m.two_touch) {
    auto t = touch(start, u, len, feed, m.search_mm,
                   m.blend_mm ? std::optional<double>(m.approach_mm - *m.blend_mm) : std::nullopt);
    if (!t) return tl::unexpected(t.error());
    latched = t->latched_mm;
    latch_abs = t->latch_time_s;
  } else {
    // SEEDS.md 3, two-touch cycle: (1) fast first touch, (2) back off, (3) slow second touch
    // from rest, which gives the measurement; (4) retract below.
    const auto& tt = *m.two_touch;
    if (!(tt.first_speed_mm_s > 0) || !(tt.backoff_mm > 0) || !std::isfinite(tt.backoff_mm))
      return fault(FaultKind::BadCommand, "two-touch first speed and back-off must be positive", position, now());
    auto first = touch(start, u, len, tt.first_speed_mm_s, m.search_mm);
    if (!first) return tl::unexpected(first.error());
    const Vec3 standoff = first->latched_mm + tt.backoff_mm * n;
    if (auto ok = check_travel(standoff, "two-touch standoff point"); !ok) return tl::unexpected(ok.error());
    if (auto ok = move_to(standoff, positioning_feed); !ok) return tl::unexpected(ok.error());
    auto second = touch(standoff, u, tt.backoff_mm + m.search_mm, feed, m.search_mm);
    if (!second) return tl::unexpected(second.error());
    latched = second->latched_mm;
    latch_abs = second->latch_time_s;
  }

  Hit hit;
  hit.centre_mm = latched;
  hit.normal = n;
  hit.ball_radius_mm = r;
  hit.time_s = latch_abs;
  if (auto ok = move_to(latched + m.retract_mm * n, positioning_feed); !ok) return tl::unexpected(ok.error());
  last_hit = hit;
  return hit;
}

}  // namespace metron::machine::detail
