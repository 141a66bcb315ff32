// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/characterisation.hpp"
#include "metron/runtime/outputs.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/stdlib/jerk_limited_ramp.hpp"
#include "metron/stdlib/json_reader.hpp"

namespace metron::runtime {
namespace {

using nlohmann::json;
constexpr double inf = std::numeric_limits<double>::infinity();

// The constant-rate model of the ramp time: a jerk-limited ramp to v from rest.
double constant_rate_ramp_s(double v, double a, double j) { return jerk_limited_ramp_time_s(v, a, j); }

double rms_relative(const std::vector<RampSample>& s, const std::function<double(double)>& model) {
  double sum = 0;
  for (const auto& x : s) {
    const double r = (model(x.feed_mm_s) - x.ramp_time_s) / x.ramp_time_s;
    sum += r * r;
  }
  return std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, s.size())));
}

// Fits both acceleration models to the timed moves; the constant-time model is chosen when it
// explains the data within 0.5 % (a constant-rate fit can imitate it only with an unbounded
// acceleration).
AxisAcceleration fit_axis(std::vector<RampSample> samples) {
  AxisAcceleration a;
  a.samples = std::move(samples);
  double mean = 0;
  for (const auto& s : a.samples) mean += s.ramp_time_s;
  mean /= static_cast<double>(a.samples.size());
  const double rms_time = rms_relative(a.samples, [&](double) { return mean; });

  // Constant rate: a coarse log grid over (a, j), then zoom in around the best cell.
  double best = inf, la_best = 3, lj_best = 4;
  double la_lo = 0.5, la_hi = 6.5, lj_lo = 1, lj_hi = 8.5;
  for (int round = 0; round < 8; ++round) {
    const int n = round == 0 ? 120 : 24;
    for (int i = 0; i <= n; ++i)
      for (int k = 0; k <= n; ++k) {
        const double la = la_lo + (la_hi - la_lo) * i / n, lj = lj_lo + (lj_hi - lj_lo) * k / n;
        const double acc = std::pow(10, la), jerk = std::pow(10, lj);
        const double r = rms_relative(a.samples, [&](double v) { return constant_rate_ramp_s(v, acc, jerk); });
        if (r < best) best = r, la_best = la, lj_best = lj;
      }
    const double wa = (la_hi - la_lo) / (round == 0 ? 20 : 6), wj = (lj_hi - lj_lo) / (round == 0 ? 20 : 6);
    la_lo = la_best - wa, la_hi = la_best + wa, lj_lo = lj_best - wj, lj_hi = lj_best + wj;
  }
  a.acceleration_mm_s2 = std::pow(10, la_best);
  a.jerk_mm_s3 = std::pow(10, lj_best);
  a.time_s = mean;
  if (rms_time < 0.005 && rms_time <= best * 1.5 + 0.002) {
    a.mode = AxisAcceleration::Mode::ConstantTime;
    a.fit_rms_relative = rms_time;
  } else {
    a.mode = AxisAcceleration::Mode::ConstantRate;
    a.fit_rms_relative = best;
  }
  return a;
}

std::string fault_text(const machine::Response& r) {
  return r.fault ? fmt::format("{}: {}", machine::to_string(r.fault->kind), r.fault->message) : "fault";
}

// Executes one command and returns its response (a fault is returned as a response too).
machine::Response run1(machine::Machine& m, machine::Command c) {
  m.submit(std::move(c));
  auto rs = m.execute();
  return rs.empty() ? machine::Response{} : rs.front();
}

double mean_of(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size()); }

const char* axis_name(int i) { return i == 0 ? "x" : i == 1 ? "y" : "z"; }

}  // namespace

double AxisAcceleration::ramp_time_s(double feed_mm_s) const {
  if (mode == Mode::ConstantTime) return time_s;
  return constant_rate_ramp_s(std::max(feed_mm_s, 1e-9), acceleration_mm_s2, jerk_mm_s3);
}

double MachineCharacterisation::ramp_time_s(const Vec3& direction, double feed_mm_s) const {
  // The path's ramp is set by its most restrictive axis, as the controller plans it: per axis
  // the path acceleration and jerk limits a_i/|u_i|, j_i/|u_i| (constant rate) or the axis's
  // ramp time (constant time).
  double a = inf, j = inf, t = 0;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    const AxisAcceleration& ax = axes[static_cast<std::size_t>(i)];
    if (ax.mode == AxisAcceleration::Mode::ConstantTime) t = std::max(t, ax.time_s);
    else a = std::min(a, ax.acceleration_mm_s2 / c), j = std::min(j, ax.jerk_mm_s3 / c);
  }
  const double rate = std::isfinite(a) ? constant_rate_ramp_s(std::max(feed_mm_s, 1e-9), a, j) : 0;
  return std::max(rate, t);
}

double MachineCharacterisation::acceleration_distance_mm(const Vec3& direction, double feed_mm_s) const {
  return feed_mm_s * ramp_time_s(direction, feed_mm_s) / 2;  // SEEDS.md 3: D1 = V * Td / 2
}

double MachineCharacterisation::stop_distance_mm(const Vec3& direction, double feed_mm_s) const {
  // SEEDS.md 3: pre-travel + feed x (interface + controller delays, worst-case latency and the
  // interpolator's next cycle) + the braking distance. The speed never exceeds the feed on the
  // way to it, so the delay term holds for a contact anywhere on the ramp. Braking mirrors the
  // ramp (V * Td / 2 from the feed); a contact while still accelerating must first ramp the
  // acceleration down, which a jerk-limited ramp does in at most half its time (the ramp's
  // acceleration rises and falls), at a speed still at most V: at most V * Td / 2 more.
  // Hence V * Td in all, whatever the ramp's family (docs/touch-trigger.md).
  return pre_travel_mm + feed_mm_s * (response.delay_s + response.jitter_s + dt_s) +
         2 * acceleration_distance_mm(direction, feed_mm_s);
}

double MachineCharacterisation::move_time_s(const Vec3& direction, double length_mm, double feed_mm_s) const {
  if (!(length_mm > 0)) return 0;
  // Accelerating to v and braking from it covers v * Td(v) (two ramps of D1 = v Td / 2 each).
  const auto ramps_mm = [&](double v) { return v * ramp_time_s(direction, v); };
  if (ramps_mm(feed_mm_s) <= length_mm) return length_mm / feed_mm_s + ramp_time_s(direction, feed_mm_s);
  double lo = 0, hi = feed_mm_s;
  for (int i = 0; i < 60; ++i) (ramps_mm((lo + hi) / 2) < length_mm ? lo : hi) = (lo + hi) / 2;
  return 2 * ramp_time_s(direction, hi);
}

double MachineCharacterisation::max_feed_mm_s(const Vec3& direction) const {
  const double limit = over_travel_margin * over_travel_mm;
  if (stop_distance_mm(direction, 1e-6) >= limit) return 0;
  double lo = 0, hi = 1;
  while (stop_distance_mm(direction, hi) < limit && hi < 1e5) lo = hi, hi *= 2;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (stop_distance_mm(direction, mid) < limit ? lo : hi) = mid;
  }
  return lo;
}

double MachineCharacterisation::standoff_mm(const Vec3& direction, double slow_mm_s, double fast_mm_s,
                                            double tolerance_mm) const {
  const double d1 = acceleration_distance_mm(direction, slow_mm_s);  // SEEDS.md 3: D1, slow feed's ramp
  const double d2 = fast_mm_s * response.jitter_s;                  // D2: first touch's uncertainty
  const double d3 = slow_mm_s * (response.delay_s + response.jitter_s);  // D3: dynamic zone
  return d1 + d2 + d3 + tolerance_mm;
}

double MachineCharacterisation::qualified_offset_mm() const {
  return pre_travel_mm + response.qualification_feed_mm_s * (response.delay_s + response.jitter_s / 2);
}

double MachineCharacterisation::dynamic_correction_mm(double feed_mm_s, double qualification_feed_mm_s) const {
  return (feed_mm_s - qualification_feed_mm_s) * (response.delay_s + response.jitter_s / 2);
}

std::optional<double> MachineCharacterisation::early_contact_mm(const machine::PtMeas& p, const machine::Hit& hit) const {
  if (p.two_touch || !p.speed_mm_s) return std::nullopt;
  const Vec3 n = p.normal.normalized();
  const double feed = *p.speed_mm_s;
  // From the start (nominal + effective radius + approach) to the latched centre, less the
  // pre-travel and the mean trigger chain at the feed: where the contact came.
  const double travelled = (p.nominal_mm + (hit.ball_radius_mm + p.approach_mm) * n - hit.centre_mm).dot(n);
  const double contact = travelled - pre_travel_mm - feed * (response.delay_s + response.jitter_s / 2);
  // Where the feed is reached: the ramp's D1 from rest, or the blend point.
  const double reach = p.blend_mm ? p.approach_mm - *p.blend_mm : acceleration_distance_mm(-n, feed);
  // Half the latency's spread and a micrometre of noise are not evidence.
  if (contact >= reach - feed * response.jitter_s / 2 - 1e-3) return std::nullopt;
  // On its nominal the surface is touched q (the qualified offset) after the start's approach.
  return p.approach_mm - qualified_offset_mm() - contact;
}

TouchPlan MachineCharacterisation::plan(const Vec3& normal, std::optional<double> feed_mm_s,
                                        std::optional<double> approach_mm, std::optional<RestingHead> resting) const {
  const Vec3 u = -normal.normalized();
  TouchPlan p;
  p.two_touch = !one_touch && !blend;
  p.feed_mm_s = feed_mm_s.value_or(measuring_feed_mm_s);
  // A touch that starts at `planned` from rest at `feed`: where the head already rests farther
  // out on the same line, probing the extra distance at the feed beats a rest-to-rest move
  // closer and a new start from rest when it takes less time (issue 11: a plain one-touch from
  // the clearance is quicker than positioning to a short standoff first).
  const auto from_rest = [&](double planned, double feed) {
    if (approach_mm || !resting || !(resting->distance_mm > planned)) return planned;
    const double extra = resting->distance_mm - planned;
    return extra / feed <= move_time_s(u, extra, resting->positioning_feed_mm_s) ? resting->distance_mm : planned;
  };
  if (blend) {
    // No stop at a standoff: the approach move itself slows to the feed before the band in
    // which the surface may be (the nominal tolerance), plus the dynamic zone D3.
    p.blend_mm = nominal_tolerance_mm + p.feed_mm_s * (response.delay_s + response.jitter_s) + qualified_offset_mm();
    p.approach_mm = std::max(approach_mm.value_or(resting ? resting->distance_mm : 2.0), *p.blend_mm);
    return p;
  }
  if (!p.two_touch) {
    // One touch from rest: at constant speed before the earliest possible contact.
    p.approach_mm = approach_mm.value_or(from_rest(standoff_mm(u, p.feed_mm_s, 0, nominal_tolerance_mm) + qualified_offset_mm(),
                                                   p.feed_mm_s));
    return p;
  }
  p.first_feed_mm_s = std::min(first_feed_mm_s, max_feed_mm_s(u));
  // The first touch finds the surface: at its feed before the earliest possible contact (a
  // touch at constant feed; the stop distance bound holds on the ramp as well).
  p.approach_mm = approach_mm.value_or(
      from_rest(acceleration_distance_mm(u, p.first_feed_mm_s) + nominal_tolerance_mm + qualified_offset_mm(), p.first_feed_mm_s));
  p.standoff_mm = standoff_mm(u, p.feed_mm_s, p.first_feed_mm_s, 0);
  // From the first latched centre back to the surface: pre-travel and the constant-delay part
  // of the first touch's dynamic zone (its jitter part is D2), then the standoff.
  p.backoff_mm = p.standoff_mm + pre_travel_mm + p.first_feed_mm_s * response.delay_s;
  return p;
}

tl::expected<AxisAcceleration, std::string> measure_axis_acceleration(machine::Machine& machine, int axis,
                                                                     const std::vector<double>& feeds, int dither,
                                                                     double* clock_resolution_s) {
  const Vec3 e = Vec3::Unit(axis);
  std::uint64_t tag = 1u << 20;
  double sign = 1;
  // A timed out-and-back move; the first one that would leave the travel flips the direction.
  const auto timed = [&](double length, double feed) -> tl::expected<std::array<double, 2>, std::string> {
    const Vec3 p0 = machine.state().position_mm;
    for (int attempt = 0; attempt < 2; ++attempt) {
      auto out = run1(machine, {tag++, machine::GoTo{p0 + sign * length * e, feed}});
      if (out.status == machine::Response::Status::Fault) {
        if (attempt == 0 && out.fault && out.fault->kind == machine::FaultKind::AxisLimit) {
          sign = -sign;
          continue;
        }
        return tl::unexpected(fmt::format("timed move on {}: {}", axis_name(axis), fault_text(out)));
      }
      auto back = run1(machine, {tag++, machine::GoTo{p0, feed}});
      if (back.status == machine::Response::Status::Fault)
        return tl::unexpected(fmt::format("timed move on {}: {}", axis_name(axis), fault_text(back)));
      return std::array<double, 2>{out.end_time_s - out.start_time_s, back.end_time_s - back.start_time_s};
    }
    return tl::unexpected(fmt::format("no room for a timed move of {:.1f} mm on {}", length, axis_name(axis)));
  };

  // The clock ticks once per controller cycle: find its resolution from moves whose lengths
  // differ by a fifth of a millisecond of travel.
  std::vector<double> durations;
  for (int k = 0; k < 40; ++k) {
    auto t = timed(20 + k * 20 * 0.0002, 20);
    if (!t) return tl::unexpected(t.error());
    durations.push_back((*t)[0]);
  }
  std::sort(durations.begin(), durations.end());
  double dt = inf;
  for (std::size_t i = 1; i < durations.size(); ++i)
    if (durations[i] - durations[i - 1] > 1e-7) dt = std::min(dt, durations[i] - durations[i - 1]);
  if (!std::isfinite(dt)) dt = 0;
  if (clock_resolution_s) *clock_resolution_s = dt;

  std::vector<RampSample> samples;
  for (double feed : feeds) {
    // Long enough to cruise (the ramp is well under half a second at any feed of interest).
    const double base = feed * 0.6 + 5;
    std::vector<double> td;
    for (int k = 0; k < dither; ++k) {
      // Lengths spread over one clock cycle of travel so the rounding to whole cycles averages
      // to half a cycle.
      const double len = base + feed * dt * k / dither;
      auto t = timed(len, feed);
      if (!t) return tl::unexpected(t.error());
      // SEEDS.md 3: Td = Ta - Dc / V.
      for (double ta : *t) td.push_back(ta - len / feed);
    }
    const double ramp = mean_of(td) - dt / 2;
    // A feed above the machine's speed limit is clamped by the controller: the apparent Td then
    // grows with the length (Dc (1/Vmax - 1/V)). One move of twice the length tells; such feeds
    // (and faster ones) are dropped.
    auto check = timed(2 * base, feed);
    if (!check) return tl::unexpected(check.error());
    const double ramp2 = mean_of({(*check)[0] - 2 * base / feed, (*check)[1] - 2 * base / feed});
    if (std::abs(ramp2 - ramp) > 0.01 * ramp + 1.5 * dt) break;
    samples.push_back({feed, ramp});
  }
  if (samples.size() < 3) return tl::unexpected(fmt::format("too few usable timing feeds on the {} axis", axis_name(axis)));
  return fit_axis(std::move(samples));
}

namespace {

using Say = std::function<void(const std::string&)>;

// The point the touch steps probe: the last qualification point, a surface point with a known
// normal, and the tool that took it.
struct TouchTarget {
  Vec3 surface = Vec3::Zero();  // MCS; with the effective radius the latched centre lies on it
  Vec3 normal = Vec3::UnitZ();  // unit, on the probe's side
  machine::ToolInfo tool;       // as qualified
};

// The machine and the command tags the steps after the timed moves share, in order.
struct Bench {
  machine::Machine& machine;
  std::uint64_t tag;
  const Say& say;
};

// 1. Acceleration characteristic per axis from timed moves (SEEDS.md 3).
tl::expected<void, std::string> measure_axes(machine::Machine& machine, const CharacterisationSettings& settings,
                                             const Say& say, MachineCharacterisation& c) {
  for (int i = 0; i < 3; ++i) {
    say(fmt::format("timing moves on the {} axis ...", axis_name(i)));
    auto a = measure_axis_acceleration(machine, i, settings.timing_feeds_mm_s, settings.dither, &c.dt_s);
    if (!a) return tl::unexpected(a.error());
    c.axes[static_cast<std::size_t>(i)] = *a;
  }
  return {};
}

// 2. A qualified tool: its last qualification point is a surface point with a known normal.
tl::expected<TouchTarget, std::string> qualify_touch_point(Bench& bench, double ball_diameter_mm,
                                                           MachineCharacterisation& c) {
  const std::string tool = "METRON_CHAR";
  for (machine::Command cmd : {machine::Command{bench.tag++, machine::DefineTool{tool, ball_diameter_mm, -Vec3::UnitZ(), 50}},
                               machine::Command{bench.tag++, machine::SelectTool{tool}},
                               machine::Command{bench.tag++, machine::QualifyTool{}}}) {
    auto r = run1(bench.machine, cmd);
    if (r.status == machine::Response::Status::Fault) return tl::unexpected("tool qualification: " + fault_text(r));
  }
  const machine::MachineState st = bench.machine.state();
  if (!st.last_hit || !st.tool) return tl::unexpected(std::string("qualification gave no point"));
  TouchTarget target;
  target.normal = st.last_hit->normal.normalized();
  // With the qualified (effective) radius the latched centre gives the surface itself.
  target.surface = st.last_hit->centre_mm - st.tool->effective_radius_mm * target.normal;
  target.tool = *st.tool;
  c.over_travel_mm = st.tool->rated_over_travel_mm;
  c.response.qualification_feed_mm_s = st.measuring_feed_mm_s;
  if (!(c.over_travel_mm > 0)) return tl::unexpected(std::string("the probe's rated over-travel is unknown"));
  return target;
}

// Repeated touches on the target at one feed, from the same standoff (SEEDS.md 3).
tl::expected<TouchSample, std::string> touch_sample(Bench& bench, const TouchTarget& target,
                                                    const MachineCharacterisation& c, int touches, double feed) {
  const Vec3& n = target.normal;
  machine::PtMeas p;
  p.nominal_mm = target.surface;
  p.normal = n;
  // Contact comes q (the qualified offset, ~0.03 mm) after nominal + effective radius; slow
  // feeds start closer so that their touches stay short.
  p.approach_mm = 1.5 * c.acceleration_distance_mm(-n, feed) + (feed < 1 ? 0.1 : 0.3);
  // The probing move ends at rest at the search end: the latch must come before it slows
  // down, i.e. within search - D1 of the surface (the stop distance is below the over-travel).
  p.search_mm = 1.5 * c.acceleration_distance_mm(-n, feed) + c.over_travel_mm + 0.5;
  p.retract_mm = 0.5;
  p.speed_mm_s = feed;
  std::vector<double> x;
  for (int k = 0; k < touches; ++k) {
    auto r = run1(bench.machine, {bench.tag++, p});
    if (r.status == machine::Response::Status::Fault || !r.hit)
      return tl::unexpected(fmt::format("touch at {:.1f} mm/s: {}", feed, fault_text(r)));
    x.push_back((r.hit->centre_mm - target.surface).dot(n));
  }
  TouchSample s;
  s.feed_mm_s = feed;
  s.count = static_cast<int>(x.size());
  s.mean_mm = mean_of(x);
  const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
  s.range_mm = *hi - *lo;
  s.midrange_mm = (*hi + *lo) / 2;
  double var = 0;
  for (double v : x) var += (v - s.mean_mm) * (v - s.mean_mm);
  s.stddev_mm = std::sqrt(var / std::max(1.0, static_cast<double>(x.size() - 1)));
  return s;
}

// The trigger response (delay, jitter, noise) and the pre-travel from the touch samples so far.
void estimate_response(const TouchTarget& target, MachineCharacterisation& c) {
  auto& r = c.response;
  const auto& s = r.samples;
  // Midranges: x(F) = A - F * (delay + jitter / 2), a straight line in F. (The midrange of a
  // uniform latency scatters ~3x less than the mean at 60 touches.)
  double sf = 0, sx = 0, sff = 0, sfx = 0;
  for (const auto& t : s)
    sf += t.feed_mm_s, sx += t.midrange_mm, sff += t.feed_mm_s * t.feed_mm_s, sfx += t.feed_mm_s * t.midrange_mm;
  const double m = static_cast<double>(s.size());
  const double slope = (m * sfx - sf * sx) / (m * sff - sf * sf);
  // Spread: uniform latency over one scan period spreads the points by F * period; the
  // slowest feed's scatter is the probe's own noise.
  const auto lowest = std::min_element(s.begin(), s.end(), [](auto& a, auto& b) { return a.feed_mm_s < b.feed_mm_s; });
  const auto highest = std::max_element(s.begin(), s.end(), [](auto& a, auto& b) { return a.feed_mm_s < b.feed_mm_s; });
  // The range of N uniform draws over a width W is W (N - 1) / (N + 1) on average; at the
  // highest feed the jitter's width F * period dominates the probe's own scatter.
  // Averaged over the faster feeds (each range scatters by about 3 % at 60 touches).
  double period = 0;
  int used = 0;
  for (const auto& t : s)
    if (t.feed_mm_s >= 0.25 * highest->feed_mm_s) {
      const double k = static_cast<double>(t.count);
      period += t.range_mm / t.feed_mm_s * (k + 1) / (k - 1);
      ++used;
    }
  period /= std::max(1, used);
  // Jitter class: a scanned input spreads the points in proportion to the feed (the range
  // grows with feed) by a period of a millisecond or more; a latched one by microseconds
  // (the range stays the probe's own scatter at every feed).
  const bool grows = highest->range_mm > 1.5 * lowest->range_mm;
  r.scanned = grows && period > 2e-4;
  r.jitter_s = r.scanned ? period : 0;
  // The probe's own scatter: the slowest feed's, less the jitter's share there.
  const double v = lowest->stddev_mm * lowest->stddev_mm - std::pow(lowest->feed_mm_s * r.jitter_s, 2) / 12;
  r.noise_mm = std::sqrt(std::max(0.0, v));
  r.delay_s = std::max(0.0, -slope - r.jitter_s / 2);
  // Nominal - effective radius = pre-travel + F_q * (delay + jitter / 2) (+ the ball's radius error).
  c.pre_travel_mm = std::max(0.0, target.tool.nominal_radius_mm - target.tool.effective_radius_mm -
                                      r.qualification_feed_mm_s * (r.delay_s + r.jitter_s / 2));
}

// 3. Repeated touches on the target at several feeds, same standoff (SEEDS.md 3).
tl::expected<void, std::string> measure_touch_response(Bench& bench, const CharacterisationSettings& settings,
                                                       const TouchTarget& target, MachineCharacterisation& c) {
  const auto sample = [&](double feed) -> tl::expected<void, std::string> {
    bench.say(fmt::format("repeated touches at {:.1f} mm/s ...", feed));
    auto s = touch_sample(bench, target, c, settings.touches_per_feed, feed);
    if (!s) return tl::unexpected(s.error());
    c.response.samples.push_back(*s);
    return {};
  };
  for (double feed : {2.0, 5.0})
    if (auto ok = sample(feed); !ok) return ok;
  estimate_response(target, c);
  // Faster feeds, safely inside the preliminary limit, sharpen the delay and jitter estimates.
  const double prelim = c.max_feed_mm_s(-target.normal);
  for (double share : {0.3, 0.6, 0.9}) {
    const double feed = share * prelim;
    if (feed <= 5.5) continue;
    if (auto ok = sample(feed); !ok) return ok;
  }
  estimate_response(target, c);
  if (c.response.scanned) {
    // The probe's own scatter (issue 11): at the slowest feed so far the jitter's share of the
    // variance, (F x period)^2 / 12, dwarfs the probe's (2 mm/s x 4 ms: 2.3 um against 0.2 um),
    // and the difference of the two is ill-conditioned. A feed slow enough that the jitter's
    // standard deviation is 0.05 um makes the subtraction a small correction.
    const double slow = std::clamp(0.05e-3 * std::sqrt(12.0) / c.response.jitter_s, 0.01, 2.0);
    if (auto ok = sample(slow); !ok) return ok;
    estimate_response(target, c);
  }
  return {};
}

// 4. Limits and strategy.
tl::expected<void, std::string> choose_limits_and_strategy(MachineCharacterisation& c) {
  c.max_probe_feed_mm_s = inf;
  for (int i = 0; i < 3; ++i) c.max_probe_feed_mm_s = std::min(c.max_probe_feed_mm_s, c.max_feed_mm_s(Vec3::Unit(i)));
  // The accurate feed: the spread of repeated touches within the threshold (SEEDS.md 3).
  const double accurate = c.response.jitter_s > 0
                              ? std::sqrt(std::max(std::pow(c.threshold_mm, 2) - std::pow(6 * c.response.noise_mm, 2),
                                                   std::pow(c.threshold_mm / 2, 2))) / c.response.jitter_s
                              : c.max_probe_feed_mm_s;
  c.first_feed_mm_s = c.max_probe_feed_mm_s;
  // SEEDS.md 3: one-touch cycles when the spread at the fast feed is below the threshold.
  c.one_touch = c.response.spread_mm(c.first_feed_mm_s) <= c.threshold_mm;
  c.measuring_feed_mm_s = std::min(accurate, c.max_probe_feed_mm_s);
  if (!(c.measuring_feed_mm_s > 0)) return tl::unexpected(std::string("no probing feed meets the threshold"));
  return {};
}

// Mean time of timed trial cycles with characterisation `cc` on the target (the controller clock
// is a sensor). A cycle starts at rest 2 mm above the nominal and ends retracted; the nominal is
// off the surface by -tol, 0, +tol in turn, as the standoff's tolerance term assumes.
tl::expected<double, std::string> time_trial_cycles(Bench& bench, const TouchTarget& target,
                                                    const MachineCharacterisation& cc) {
  const Vec3& n = target.normal;
  double total = 0;
  int count = 0;
  for (double offset : {-1.0, 0.0, 1.0, 0.5, -0.5}) {
    const Vec3 nominal = target.surface + offset * cc.nominal_tolerance_mm * n;
    const TouchPlan plan = cc.plan(n, std::nullopt, std::nullopt);
    auto go = run1(bench.machine,
                   {bench.tag++, machine::GoTo{nominal + (target.tool.effective_radius_mm + 2.0) * n, std::nullopt}});
    if (go.status == machine::Response::Status::Fault) return tl::unexpected("trial cycle: " + fault_text(go));
    machine::PtMeas p;
    p.nominal_mm = nominal;
    p.normal = n;
    p.approach_mm = std::min(plan.approach_mm, 2.0);
    p.search_mm = 2 * cc.nominal_tolerance_mm + cc.over_travel_mm + 1;
    p.retract_mm = 2.0;
    p.speed_mm_s = plan.feed_mm_s;
    if (plan.two_touch) p.two_touch = machine::PtMeas::TwoTouch{plan.first_feed_mm_s, plan.backoff_mm};
    if (plan.blend_mm) p.blend_mm = std::min(*plan.blend_mm, p.approach_mm);
    auto r = run1(bench.machine, {bench.tag++, p});
    if (r.status == machine::Response::Status::Fault) return tl::unexpected("trial cycle: " + fault_text(r));
    total += r.end_time_s - r.start_time_s;
    ++count;
  }
  return total / count;
}

// 5. Beyond the seed: the first-touch feed and the cycle chosen by timed trial cycles.
tl::expected<void, std::string> choose_cycle_by_timing(Bench& bench, const CharacterisationSettings& settings,
                                                       const TouchTarget& target, MachineCharacterisation& c) {
  if (settings.optimise_first_feed && !c.one_touch) {
    // The first touch's feed trades its own time against D2 = feed * jitter in the standoff
    // (and its ramp D1 in the approach): pick the fastest of a few candidates by timing.
    double best = inf, best_feed = c.first_feed_mm_s;
    for (int k = 1; k <= 6; ++k) {
      MachineCharacterisation cc = c;
      cc.first_feed_mm_s = c.measuring_feed_mm_s + (c.max_probe_feed_mm_s - c.measuring_feed_mm_s) * k / 6;
      auto t = time_trial_cycles(bench, target, cc);
      if (!t) return tl::unexpected(t.error());
      bench.say(fmt::format("trial two-touch cycles, first touch {:.1f} mm/s: {:.4f} s", cc.first_feed_mm_s, *t));
      if (*t < best) best = *t, best_feed = cc.first_feed_mm_s;
    }
    c.first_feed_mm_s = best_feed;
  }
  if (settings.fastest) {
    // Controller-aware: every cycle that meets the threshold, the fastest by timing.
    MachineCharacterisation one = c, two = c, blend = c;
    one.one_touch = true, one.blend = false;
    two.one_touch = false, two.blend = false;
    blend.blend = true;
    double best = inf;
    for (const MachineCharacterisation* cc : {&one, &two, &blend}) {
      auto t = time_trial_cycles(bench, target, *cc);
      if (!t) return tl::unexpected(t.error());
      bench.say(fmt::format("trial {} cycles: {:.4f} s", cc->blend ? "blended one-touch" : cc->one_touch ? "one-touch" : "two-touch", *t));
      if (*t < best) best = *t, c.one_touch = cc->one_touch, c.blend = cc->blend;
    }
  }
  return {};
}

}  // namespace

tl::expected<MachineCharacterisation, std::string> characterise(machine::Machine& machine,
                                                                const CharacterisationSettings& settings,
                                                                const std::function<void(const std::string&)>& log,
                                                                double ball_diameter_mm) {
  const Say say = [&](const std::string& s) {
    if (log) log(s);
  };
  MachineCharacterisation c;
  c.threshold_mm = settings.repeatability_threshold_mm;
  c.nominal_tolerance_mm = settings.nominal_tolerance_mm;
  c.over_travel_margin = settings.over_travel_margin;
  c.blend = settings.blend;

  if (auto ok = measure_axes(machine, settings, say, c); !ok) return tl::unexpected(ok.error());
  Bench bench{machine, std::uint64_t{1} << 24, say};
  auto target = qualify_touch_point(bench, ball_diameter_mm, c);
  if (!target) return tl::unexpected(target.error());
  if (auto ok = measure_touch_response(bench, settings, *target, c); !ok) return tl::unexpected(ok.error());
  if (auto ok = choose_limits_and_strategy(c); !ok) return tl::unexpected(ok.error());
  if (auto ok = choose_cycle_by_timing(bench, settings, *target, c); !ok) return tl::unexpected(ok.error());
  return c;
}

// ---- the file ----

json to_json(const MachineCharacterisation& c) {
  json axes = json::object();
  for (int i = 0; i < 3; ++i) {
    const auto& a = c.axes[static_cast<std::size_t>(i)];
    json samples = json::array();
    for (const auto& s : a.samples) samples.push_back({{"feed_mm_s", s.feed_mm_s}, {"ramp_time_s", s.ramp_time_s}});
    json ax = {{"mode", a.mode == AxisAcceleration::Mode::ConstantTime ? "constant_time" : "constant_rate"},
               {"time_s", a.time_s},
               {"acceleration_mm_s2", a.acceleration_mm_s2},
               {"jerk_mm_s3", a.jerk_mm_s3},
               {"fit_rms_relative", a.fit_rms_relative},
               {"samples", samples}};
    axes[axis_name(i)] = ax;
  }
  json touches = json::array();
  for (const auto& s : c.response.samples)
    touches.push_back({{"feed_mm_s", s.feed_mm_s}, {"count", s.count}, {"mean_mm", s.mean_mm},
                       {"range_mm", s.range_mm}, {"midrange_mm", s.midrange_mm}, {"stddev_mm", s.stddev_mm}});
  return {
      {"format", "metron-touch-characterisation"},
      {"version", 1},
      {"world", c.world},
      {"dt_s", c.dt_s},
      {"axes", axes},
      {"response", {{"skip", c.response.scanned ? "scanned" : "latched"},
                    {"jitter_s", c.response.jitter_s},
                    {"delay_s", c.response.delay_s},
                    {"noise_mm", c.response.noise_mm},
                    {"qualification_feed_mm_s", c.response.qualification_feed_mm_s},
                    {"touches", touches}}},
      {"over_travel_mm", c.over_travel_mm},
      {"over_travel_margin", c.over_travel_margin},
      {"pre_travel_mm", c.pre_travel_mm},
      {"max_probe_feed_mm_s", c.max_probe_feed_mm_s},
      {"strategy", {{"threshold_mm", c.threshold_mm},
                    {"cycle", c.one_touch ? "one_touch" : "two_touch"},
                    {"blend", c.blend},
                    {"measuring_feed_mm_s", c.measuring_feed_mm_s},
                    {"first_feed_mm_s", c.first_feed_mm_s},
                    {"nominal_tolerance_mm", c.nominal_tolerance_mm}}},
  };
}

namespace {

// The feeds a file states must be the ones its own measurements protect (issue 15): a file whose
// maximum feed was raised by hand would let a probing feed through into an over-travel.
void check_protected_feeds(const MachineCharacterisation& c) {
  namespace sj = strict_json;
  double protected_mm_s = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) protected_mm_s = std::min(protected_mm_s, c.max_feed_mm_s(Vec3::Unit(i)));
  const double allowed = protected_mm_s * (1 + 1e-9);
  if (c.max_probe_feed_mm_s > allowed)
    sj::fail("/max_probe_feed_mm_s",
             fmt::format("{:g} mm/s exceeds {:.4g} mm/s, the fastest feed this file's own ramps, delays, pre-travel and "
                         "over-travel protect (docs/touch-trigger.md, \"maximum protected feed\")",
                         c.max_probe_feed_mm_s, protected_mm_s));
  for (const auto& [key, feed] : {std::pair{"measuring_feed_mm_s", c.measuring_feed_mm_s},
                                  std::pair{"first_feed_mm_s", c.first_feed_mm_s}})
    if (feed > c.max_probe_feed_mm_s * (1 + 1e-9))
      sj::fail(std::string("/strategy/") + key,
               fmt::format("{:g} mm/s exceeds the maximum protected feed {:g} mm/s", feed, c.max_probe_feed_mm_s));
}

}  // namespace

tl::expected<MachineCharacterisation, std::string> characterisation_from_json(const json& j) {
  namespace sj = strict_json;
  auto read = sj::read([&] {
    MachineCharacterisation c;
    sj::Object o(j, "");
    o.get("format", [](const json& v, const std::string& p) { return sj::one_of(v, p, {"metron-touch-characterisation"}); });
    o.read("version", [](const json& v, const std::string& p) { sj::integer(v, p, 1, 1); });
    o.read("world", [&](const json& v, const std::string& p) { c.world = sj::string(v, p); });
    c.dt_s = o.get("dt_s", sj::positive);
    sj::Object axes(o.required("axes"), o.at("axes"));
    for (int i = 0; i < 3; ++i) {
      sj::Object ax(axes.required(axis_name(i)), axes.at(axis_name(i)));
      auto& a = c.axes[static_cast<std::size_t>(i)];
      const std::string mode =
          ax.get("mode", [](const json& v, const std::string& p) { return sj::one_of(v, p, {"constant_time", "constant_rate"}); });
      a.mode = mode == "constant_time" ? AxisAcceleration::Mode::ConstantTime : AxisAcceleration::Mode::ConstantRate;
      a.time_s = ax.get("time_s", sj::positive);
      a.acceleration_mm_s2 = ax.get("acceleration_mm_s2", sj::positive);
      a.jerk_mm_s3 = ax.get("jerk_mm_s3", sj::positive);
      ax.non_negative("fit_rms_relative", a.fit_rms_relative);
      ax.read("samples", [&](const json& v, const std::string& p) {
        if (!v.is_array()) sj::fail(p, "expected an array");
        for (std::size_t k = 0; k < v.size(); ++k) {
          sj::Object s(v[k], p + "/" + std::to_string(k));
          a.samples.push_back({s.get("feed_mm_s", sj::positive), s.get("ramp_time_s", sj::number)});
          s.finish();
        }
      });
      ax.finish();
    }
    axes.finish();
    sj::Object r(o.required("response"), o.at("response"));
    c.response.scanned = r.get("skip", [](const json& v, const std::string& p) { return sj::one_of(v, p, {"latched", "scanned"}); }) ==
                         "scanned";
    c.response.jitter_s = r.get("jitter_s", sj::non_negative);
    c.response.delay_s = r.get("delay_s", sj::non_negative);
    c.response.noise_mm = r.get("noise_mm", sj::non_negative);
    c.response.qualification_feed_mm_s = r.get("qualification_feed_mm_s", sj::positive);
    r.read("touches", [&](const json& v, const std::string& p) {
      if (!v.is_array()) sj::fail(p, "expected an array");
      for (std::size_t k = 0; k < v.size(); ++k) {
        sj::Object s(v[k], p + "/" + std::to_string(k));
        TouchSample t;
        t.feed_mm_s = s.get("feed_mm_s", sj::positive);
        t.count = static_cast<int>(s.get("count", [](const json& n, const std::string& q) { return sj::integer(n, q, 0); }));
        t.mean_mm = s.get("mean_mm", sj::number);
        t.range_mm = s.get("range_mm", sj::non_negative);
        s.number("midrange_mm", t.midrange_mm);
        t.stddev_mm = s.get("stddev_mm", sj::non_negative);
        s.finish();
        c.response.samples.push_back(t);
      }
    });
    r.finish();
    c.over_travel_mm = o.get("over_travel_mm", sj::non_negative);
    o.read("over_travel_margin", [&](const json& v, const std::string& p) {
      c.over_travel_margin = sj::positive(v, p);
      if (c.over_travel_margin > 1) sj::fail(p, "the stop distance may use at most the whole over-travel (a margin <= 1)");
    });
    c.pre_travel_mm = o.get("pre_travel_mm", sj::non_negative);
    c.max_probe_feed_mm_s = o.get("max_probe_feed_mm_s", sj::positive);
    sj::Object s(o.required("strategy"), o.at("strategy"));
    c.threshold_mm = s.get("threshold_mm", sj::non_negative);
    c.one_touch =
        s.get("cycle", [](const json& v, const std::string& p) { return sj::one_of(v, p, {"one_touch", "two_touch"}); }) == "one_touch";
    s.read("blend", [&](const json& v, const std::string& p) { c.blend = sj::boolean(v, p); });
    c.measuring_feed_mm_s = s.get("measuring_feed_mm_s", sj::positive);
    c.first_feed_mm_s = s.get("first_feed_mm_s", sj::positive);
    s.non_negative("nominal_tolerance_mm", c.nominal_tolerance_mm);
    s.finish();
    o.finish();
    check_protected_feeds(c);
    return c;
  });
  if (!read) return tl::unexpected(fmt::format("{}: {}", read.error().pointer, read.error().message));
  return std::move(*read);
}

tl::expected<void, std::string> save_characterisation(const MachineCharacterisation& c, const std::string& path) {
  // Atomically, like every output (docs/security.md): a failed write keeps an earlier file.
  const std::string text = to_json(c).dump(2, ' ', false, json::error_handler_t::replace) + "\n";
  if (auto failed = write_file_atomically(path, text)) return tl::unexpected(*failed);
  return {};
}

tl::expected<MachineCharacterisation, std::string> load_characterisation(const std::string& path) {
  auto j = strict_json::read_document(path);
  if (!j) return tl::unexpected(j.error());
  auto c = characterisation_from_json(*j);
  if (!c) return tl::unexpected(fmt::format("{}: {}", path, c.error()));
  return c;
}

std::string format_characterisation(const MachineCharacterisation& c) {
  std::ostringstream o;
  o << "acceleration characteristic (timed moves, SEEDS.md 3: Td = Ta - Dc/V, D1 = V*Td/2)\n";
  for (int i = 0; i < 3; ++i) {
    const auto& a = c.axes[static_cast<std::size_t>(i)];
    if (a.mode == AxisAcceleration::Mode::ConstantTime)
      o << fmt::format("  {}: constant time, Td = {:.4f} s (fit rms {:.2f} %)\n", axis_name(i), a.time_s, 100 * a.fit_rms_relative);
    else
      o << fmt::format("  {}: constant rate, a = {:.0f} mm/s^2, j = {:.0f} mm/s^3 (fit rms {:.2f} %)\n", axis_name(i),
                       a.acceleration_mm_s2, a.jerk_mm_s3, 100 * a.fit_rms_relative);
    o << "     feed mm/s  Td ms   D1 mm\n";
    for (const auto& s : a.samples)
      o << fmt::format("     {:9.1f} {:6.2f} {:7.4f}\n", s.feed_mm_s, 1e3 * s.ramp_time_s, s.feed_mm_s * s.ramp_time_s / 2);
  }
  o << fmt::format("controller cycle: {:.4f} s\n", c.dt_s);
  o << "trigger response (repeated touches on one point)\n";
  for (const auto& s : c.response.samples)
    o << fmt::format("  {:7.1f} mm/s: {} touches, range {:.4f} mm, sigma {:.4f} mm\n", s.feed_mm_s, s.count, s.range_mm,
                     s.stddev_mm);
  o << fmt::format("  skip input: {} (jitter {:.2f} ms), constant delay {:.2f} ms, probe noise {:.2f} um (1 sigma)\n",
                   c.response.scanned ? "scanned" : "latched", 1e3 * c.response.jitter_s, 1e3 * c.response.delay_s,
                   1e3 * c.response.noise_mm);
  o << fmt::format("pre-travel (upper estimate): {:.4f} mm; rated over-travel {:.3f} mm, margin {:.0f} %\n", c.pre_travel_mm,
                   c.over_travel_mm, 100 * c.over_travel_margin);
  o << fmt::format("maximum protected probing feed: {:.1f} mm/s (stop distance {:.3f} mm along z)\n", c.max_probe_feed_mm_s,
                   c.stop_distance_mm(-Vec3::UnitZ(), c.max_probe_feed_mm_s));
  o << fmt::format("strategy: {}{} (threshold {:.1f} um; spread at {:.1f} mm/s: {:.1f} um)\n",
                   c.blend ? "blended one-touch" : c.one_touch ? "one-touch" : "two-touch",
                   c.blend ? " (beyond the seed)" : "", 1e3 * c.threshold_mm, c.first_feed_mm_s,
                   1e3 * c.response.spread_mm(c.first_feed_mm_s));
  const Vec3 down = -Vec3::UnitZ();
  if (c.one_touch)
    o << fmt::format("  measuring feed {:.1f} mm/s, approach {:.3f} mm (D1 + D3 + tolerance {:.3f})\n", c.measuring_feed_mm_s,
                     c.standoff_mm(down, c.measuring_feed_mm_s, 0, c.nominal_tolerance_mm), c.nominal_tolerance_mm);
  else
    o << fmt::format("  first touch {:.1f} mm/s, second touch {:.2f} mm/s, standoff D1+D2+D3 = {:.4f} mm along z\n",
                     c.first_feed_mm_s, c.measuring_feed_mm_s,
                     c.standoff_mm(down, c.measuring_feed_mm_s, c.first_feed_mm_s, 0));
  o << "standoff per feed along z (second touch after a first touch at the first-touch feed)\n";
  o << "  feed mm/s   D1 mm    D2 mm    D3 mm   standoff mm\n";
  for (double f : {1.0, 2.0, 5.0, 10.0, 20.0}) {
    if (f > c.max_probe_feed_mm_s) break;
    const double d1 = c.acceleration_distance_mm(down, f), d2 = c.first_feed_mm_s * c.response.jitter_s,
                 d3 = f * (c.response.delay_s + c.response.jitter_s);
    o << fmt::format("  {:8.1f} {:8.4f} {:8.4f} {:8.4f} {:9.4f}\n", f, d1, d2, d3, d1 + d2 + d3);
  }
  return o.str();
}

}  // namespace metron::runtime
