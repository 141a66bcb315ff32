// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/runtime/characterisation.hpp"
#include "metron/runtime/outputs.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "metron/stdlib/fitting/fit.hpp"
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

// Tangents of the monotone cubic through the samples (Td over feed): the weighted harmonic mean
// of the neighbouring secants, zero where the data turn (Fritsch and Butland 1984, as PCHIP),
// one-sided secants at the ends; then every interval's pair is limited to the region where its
// Hermite cubic stays monotone (Fritsch and Carlson, SIAM J. Numer. Anal. 17 (1980), alpha^2 +
// beta^2 <= 9), so the curve never overshoots the measurements.
std::vector<double> monotone_tangents(const std::vector<RampSample>& p) {
  const std::size_t n = p.size();
  std::vector<double> h(n - 1), d(n - 1), m(n);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    h[k] = p[k + 1].feed_mm_s - p[k].feed_mm_s;
    d[k] = (p[k + 1].ramp_time_s - p[k].ramp_time_s) / h[k];
  }
  m.front() = d.front();
  m.back() = d.back();
  for (std::size_t k = 1; k + 1 < n; ++k)
    m[k] = d[k - 1] * d[k] <= 0
               ? 0
               : 3 * (h[k - 1] + h[k]) / ((2 * h[k] + h[k - 1]) / d[k - 1] + (h[k] + 2 * h[k - 1]) / d[k]);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    if (d[k] == 0) {
      m[k] = m[k + 1] = 0;
      continue;
    }
    double alpha = m[k] / d[k], beta = m[k + 1] / d[k];
    if (alpha < 0) m[k] = alpha = 0;
    if (beta < 0) m[k + 1] = beta = 0;
    if (alpha * alpha + beta * beta > 9) {
      const double tau = 3 / std::hypot(alpha, beta);
      m[k] = tau * alpha * d[k];
      m[k + 1] = tau * beta * d[k];
    }
  }
  return m;
}

// The model-free Td(V): the monotone cubic between the first and last timed feed. Beyond them
// the rule never shortens the acceleration distance of a machine whose ramp time does not grow
// as the feed falls and whose mean acceleration V / Td does not fall as the feed grows (both
// families and the tabulated ramps of docs/world.md): Td held below the slowest feed, Td growing
// in proportion to the feed above the fastest (D1 with its square).
double interpolated_ramp_s(const std::vector<RampSample>& p, double feed) {
  if (p.empty()) return 0;
  if (feed <= p.front().feed_mm_s || p.size() == 1) return p.front().ramp_time_s;
  if (feed >= p.back().feed_mm_s) return p.back().ramp_time_s * feed / p.back().feed_mm_s;
  const std::vector<double> m = monotone_tangents(p);
  const auto hi =
      std::upper_bound(p.begin(), p.end(), feed, [](double v, const RampSample& s) { return v < s.feed_mm_s; });
  const std::size_t k = static_cast<std::size_t>(hi - p.begin()) - 1;
  const double h = p[k + 1].feed_mm_s - p[k].feed_mm_s, t = (feed - p[k].feed_mm_s) / h;
  // Cubic Hermite basis on [0, 1].
  const double h00 = (1 + 2 * t) * (1 - t) * (1 - t), h10 = t * (1 - t) * (1 - t), h01 = t * t * (3 - 2 * t),
               h11 = t * t * (t - 1);
  return h00 * p[k].ramp_time_s + h10 * h * m[k] + h01 * p[k + 1].ramp_time_s + h11 * h * m[k + 1];
}

// How well the interpolation predicts what it did not see: each inner sample from the others
// (an interpolant passes through every sample, so its own residual says nothing). Noise or
// inconsistent timings, and shapes the feeds sample too coarsely, make it large.
double leave_one_out_rms(const std::vector<RampSample>& s) {
  if (s.size() < 3) return inf;
  double sum = 0;
  for (std::size_t k = 1; k + 1 < s.size(); ++k) {
    std::vector<RampSample> rest = s;
    rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(k));
    const double r = (interpolated_ramp_s(rest, s[k].feed_mm_s) - s[k].ramp_time_s) / s[k].ramp_time_s;
    sum += r * r;
  }
  return std::sqrt(sum / static_cast<double>(s.size() - 2));
}

// Tb / Td at `feed` from the timed stops: linear between them, held beyond them.
double braking_share(const AxisAcceleration& a, double feed) {
  const auto share = [&](const RampSample& s) { return s.ramp_time_s / a.ramp_time_s(s.feed_mm_s); };
  const auto& st = a.stops;
  if (feed <= st.front().feed_mm_s) return share(st.front());
  if (feed >= st.back().feed_mm_s) return share(st.back());
  const auto hi =
      std::upper_bound(st.begin(), st.end(), feed, [](double v, const RampSample& s) { return v < s.feed_mm_s; });
  const auto lo = hi - 1;
  const double t = (feed - lo->feed_mm_s) / (hi->feed_mm_s - lo->feed_mm_s);
  return share(*lo) + t * (share(*hi) - share(*lo));
}

const char* mode_name(AxisAcceleration::Mode m) {
  return m == AxisAcceleration::Mode::ConstantTime   ? "constant_time"
         : m == AxisAcceleration::Mode::ConstantRate ? "constant_rate"
                                                     : "interpolated";
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

double mean_of(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

const char* axis_name(int i) { return i == 0 ? "x" : i == 1 ? "y" : "z"; }

}  // namespace

tl::expected<AxisAcceleration, std::string> fit_acceleration(std::vector<RampSample> samples,
                                                             const RampFitSettings& settings) {
  std::sort(samples.begin(), samples.end(),
            [](const RampSample& a, const RampSample& b) { return a.feed_mm_s < b.feed_mm_s; });
  if (samples.size() < 3) return tl::unexpected(fmt::format("{} timed feeds, at least 3 needed", samples.size()));
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const RampSample& x = samples[k];
    if (!(x.feed_mm_s > 0 && std::isfinite(x.feed_mm_s) && x.ramp_time_s > 0 && std::isfinite(x.ramp_time_s)))
      return tl::unexpected(fmt::format("sample {}: expected a positive feed and ramp time, got {:g} mm/s, {:g} s", k,
                                        x.feed_mm_s, x.ramp_time_s));
    if (k > 0 && !(x.feed_mm_s > samples[k - 1].feed_mm_s))
      return tl::unexpected(fmt::format("two samples at {:g} mm/s", x.feed_mm_s));
  }
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
  const double loo = leave_one_out_rms(a.samples);
  const auto use = [&](AxisAcceleration::Mode m) {
    a.mode = m;
    a.fit_rms_relative = m == AxisAcceleration::Mode::ConstantTime   ? rms_time
                         : m == AxisAcceleration::Mode::ConstantRate ? best
                                                                     : loo;
    return a;
  };
  if (settings.only) return use(*settings.only);
  // The simplest model within its threshold. Constant time yields to constant rate when that fits
  // markedly better (a constant-rate fit can imitate constant time only with an unbounded
  // acceleration, so near-flat data stay constant time).
  const double family = settings.family_rms_relative;
  if (rms_time <= family && rms_time <= best * 1.5 + 0.002) return use(AxisAcceleration::Mode::ConstantTime);
  if (best <= family) return use(AxisAcceleration::Mode::ConstantRate);
  if (loo <= settings.interpolation_rms_relative) return use(AxisAcceleration::Mode::Interpolated);
  return tl::unexpected(fmt::format(
      "the timed moves fit no acceleration model: constant time {:.2f} %, constant rate {:.2f} % (threshold {:.2f} %), "
      "interpolation {:.2f} % leave-one-out (threshold {:.2f} %): noisy or inconsistent timings",
      100 * rms_time, 100 * best, 100 * family, 100 * loo, 100 * settings.interpolation_rms_relative));
}

double AxisAcceleration::ramp_time_s(double feed_mm_s) const {
  if (mode == Mode::ConstantTime) return time_s;
  if (mode == Mode::Interpolated) return interpolated_ramp_s(samples, feed_mm_s);
  return constant_rate_ramp_s(std::max(feed_mm_s, 1e-9), acceleration_mm_s2, jerk_mm_s3);
}

double AxisAcceleration::acceleration_time_s(double feed_mm_s) const {
  // A rest-to-rest move's Td is the mean of accelerating and braking: Ta = 2 Td - Tb.
  if (!asymmetric || stops.empty()) return ramp_time_s(feed_mm_s);
  return (2 - braking_share(*this, feed_mm_s)) * ramp_time_s(feed_mm_s);
}

double AxisAcceleration::braking_time_s(double feed_mm_s) const {
  if (!asymmetric || stops.empty()) return ramp_time_s(feed_mm_s);
  return braking_share(*this, feed_mm_s) * ramp_time_s(feed_mm_s);
}

namespace {

// A path time along `direction` at path feed `feed`: the slowest axis involved dominates. Axes
// of the two families with symmetric braking combine as the controller plans them: per axis the
// path acceleration and jerk limits a_i/|u_i|, j_i/|u_i| (constant rate) or the axis's ramp time
// (constant time). Any other axis contributes its own time at its own feed |u_i| V (`time`: its
// acceleration or braking time).
double path_time_s(const std::array<AxisAcceleration, 3>& axes, const Vec3& direction, double feed,
                   double (AxisAcceleration::*time)(double) const) {
  double a = inf, j = inf, t = 0;
  for (int i = 0; i < 3; ++i) {
    const double c = std::abs(direction[i]);
    if (c < 1e-9) continue;
    const AxisAcceleration& ax = axes[static_cast<std::size_t>(i)];
    if (ax.asymmetric || ax.mode == AxisAcceleration::Mode::Interpolated)
      t = std::max(t, (ax.*time)(c * feed));
    else if (ax.mode == AxisAcceleration::Mode::ConstantTime)
      t = std::max(t, ax.time_s);
    else
      a = std::min(a, ax.acceleration_mm_s2 / c), j = std::min(j, ax.jerk_mm_s3 / c);
  }
  const double rate = std::isfinite(a) ? constant_rate_ramp_s(std::max(feed, 1e-9), a, j) : 0;
  return std::max(rate, t);
}

bool any_asymmetric(const std::array<AxisAcceleration, 3>& axes, const Vec3& direction) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(direction[i]) >= 1e-9 && axes[static_cast<std::size_t>(i)].asymmetric) return true;
  return false;
}

}  // namespace

double MachineCharacterisation::ramp_time_s(const Vec3& direction, double feed_mm_s) const {
  return path_time_s(axes, direction, feed_mm_s, &AxisAcceleration::acceleration_time_s);
}

double MachineCharacterisation::braking_time_s(const Vec3& direction, double feed_mm_s) const {
  return path_time_s(axes, direction, feed_mm_s, &AxisAcceleration::braking_time_s);
}

double MachineCharacterisation::acceleration_distance_mm(const Vec3& direction, double feed_mm_s) const {
  return feed_mm_s * ramp_time_s(direction, feed_mm_s) / 2;  // SEEDS.md 3: D1 = V * Td / 2 (Ta when asymmetric)
}

double MachineCharacterisation::stop_distance_mm(const Vec3& direction, double feed_mm_s) const {
  // SEEDS.md 3: pre-travel + feed x (interface + controller delays, worst-case latency and the
  // interpolator's next cycle) + the braking distance. The speed never exceeds the feed on the
  // way to it, so the delay term holds for a contact anywhere on the ramp. Braking from the feed
  // covers V * Tb / 2; a contact while still accelerating must first ramp the acceleration down
  // (at the ramp's own jerk, docs/world.md), which takes at most half the ramp's time Ta at a
  // speed still at most V: at most V * Ta / 2 more. Hence V (Ta + Tb) / 2 in all, whatever the
  // ramp's family; it is V * Td, what timed rest-to-rest moves measure, so it stays an upper
  // bound when braking was not timed (docs/touch-trigger.md).
  const double delays = pre_travel_mm + feed_mm_s * (response.delay_s + response.jitter_s + dt_s);
  if (!any_asymmetric(axes, direction)) return delays + 2 * acceleration_distance_mm(direction, feed_mm_s);
  return delays + feed_mm_s * (ramp_time_s(direction, feed_mm_s) + braking_time_s(direction, feed_mm_s)) / 2;
}

double MachineCharacterisation::move_time_s(const Vec3& direction, double length_mm, double feed_mm_s) const {
  if (!(length_mm > 0)) return 0;
  // The mean ramp Td = (Ta + Tb) / 2: accelerating to v and braking from it covers v * Td(v).
  const auto td = [&](double v) {
    return any_asymmetric(axes, direction) ? (ramp_time_s(direction, v) + braking_time_s(direction, v)) / 2
                                           : ramp_time_s(direction, v);
  };
  const auto ramps_mm = [&](double v) { return v * td(v); };
  if (ramps_mm(feed_mm_s) <= length_mm) return length_mm / feed_mm_s + td(feed_mm_s);
  double lo = 0, hi = feed_mm_s;
  for (int i = 0; i < 60; ++i) (ramps_mm((lo + hi) / 2) < length_mm ? lo : hi) = (lo + hi) / 2;
  return 2 * td(hi);
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
  const double d1 = acceleration_distance_mm(direction, slow_mm_s);      // SEEDS.md 3: D1, slow feed's ramp
  const double d2 = fast_mm_s * response.jitter_s;                       // D2: first touch's uncertainty
  const double d3 = slow_mm_s * (response.delay_s + response.jitter_s);  // D3: dynamic zone
  return d1 + d2 + d3 + tolerance_mm;
}

double MachineCharacterisation::qualified_offset_mm() const {
  return pre_travel_mm + response.qualification_feed_mm_s * (response.delay_s + response.jitter_s / 2);
}

double MachineCharacterisation::dynamic_correction_mm(double feed_mm_s, double qualification_feed_mm_s) const {
  return (feed_mm_s - qualification_feed_mm_s) * (response.delay_s + response.jitter_s / 2);
}

std::optional<double> MachineCharacterisation::early_contact_mm(const machine::PtMeas& p,
                                                                const machine::Hit& hit) const {
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
    p.approach_mm = approach_mm.value_or(
        from_rest(standoff_mm(u, p.feed_mm_s, 0, nominal_tolerance_mm) + qualified_offset_mm(), p.feed_mm_s));
    return p;
  }
  p.first_feed_mm_s = std::min(first_feed_mm_s, max_feed_mm_s(u));
  // The first touch finds the surface: at its feed before the earliest possible contact (a
  // touch at constant feed; the stop distance bound holds on the ramp as well).
  p.approach_mm = approach_mm.value_or(
      from_rest(acceleration_distance_mm(u, p.first_feed_mm_s) + nominal_tolerance_mm + qualified_offset_mm(),
                p.first_feed_mm_s));
  p.standoff_mm = standoff_mm(u, p.feed_mm_s, p.first_feed_mm_s, 0);
  // From the first latched centre back to the surface: pre-travel and the constant-delay part
  // of the first touch's dynamic zone (its jitter part is D2), then the standoff.
  p.backoff_mm = p.standoff_mm + pre_travel_mm + p.first_feed_mm_s * response.delay_s;
  return p;
}

tl::expected<AxisAcceleration, std::string> measure_axis_acceleration(machine::Machine& machine, int axis,
                                                                      const std::vector<double>& feeds, int dither,
                                                                      double* clock_resolution_s,
                                                                      const RampFitSettings& fit) {
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

  // One feed: Td from dithered out-and-back moves; none when the machine clamps the feed.
  const auto time_feed = [&](double feed) -> tl::expected<std::optional<RampSample>, std::string> {
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
    // grows with the length (Dc (1/Vmax - 1/V)). One move of twice the length tells.
    auto check = timed(2 * base, feed);
    if (!check) return tl::unexpected(check.error());
    const double ramp2 = mean_of({(*check)[0] - 2 * base / feed, (*check)[1] - 2 * base / feed});
    if (std::abs(ramp2 - ramp) > 0.01 * ramp + 1.5 * dt) return std::optional<RampSample>{};
    return std::optional<RampSample>{RampSample{feed, ramp}};
  };

  std::vector<RampSample> samples;
  for (double feed : feeds) {
    auto s = time_feed(feed);
    if (!s) return tl::unexpected(s.error());
    if (!*s) break;  // clamped: this feed and faster ones are dropped
    samples.push_back(**s);
  }
  if (samples.size() < 3)
    return tl::unexpected(fmt::format("too few usable timing feeds on the {} axis", axis_name(axis)));
  auto fitted = fit_acceleration(samples, fit);
  // No family fits: the model-free interpolation is only as good as the feeds sample the shape,
  // so feeds halfway (geometrically) between the timed ones are timed too, at most twice.
  for (int round = 0; round < 2 && !fit.only; ++round) {
    const bool family = fitted && fitted->mode != AxisAcceleration::Mode::Interpolated;
    if (family || (fitted && fitted->fit_rms_relative <= fit.family_rms_relative)) break;
    std::sort(samples.begin(), samples.end(),
              [](const RampSample& a, const RampSample& b) { return a.feed_mm_s < b.feed_mm_s; });
    std::vector<RampSample> more;
    for (std::size_t k = 0; k + 1 < samples.size(); ++k) {
      auto s = time_feed(std::sqrt(samples[k].feed_mm_s * samples[k + 1].feed_mm_s));
      if (!s) return tl::unexpected(s.error());
      if (*s) more.push_back(**s);
    }
    samples.insert(samples.end(), more.begin(), more.end());
    fitted = fit_acceleration(samples, fit);
  }
  if (!fitted) return tl::unexpected(fmt::format("{} axis: {}", axis_name(axis), fitted.error()));
  return fitted;
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
    auto a =
        measure_axis_acceleration(machine, i, settings.timing_feeds_mm_s, settings.dither, &c.dt_s, settings.ramp_fit);
    if (!a) return tl::unexpected(a.error());
    c.axes[static_cast<std::size_t>(i)] = *a;
  }
  return {};
}

// 2. A qualified tool: its last qualification point is a surface point with a known normal.
tl::expected<TouchTarget, std::string> qualify_touch_point(Bench& bench, double ball_diameter_mm,
                                                           MachineCharacterisation& c) {
  const std::string tool = "METRON_CHAR";
  for (machine::Command cmd :
       {machine::Command{bench.tag++, machine::DefineTool{tool, ball_diameter_mm, -Vec3::UnitZ(), 50}},
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

// One timed stop from constant feed `v` (docs/touch-trigger.md, "braking"): a touch along -n on
// `surface` whose contact comes after its ramp, the controller clock from the latch to the end of
// the retract, and a reference move along n timed like the retract. The controller brakes at its
// next cycle after the latch (a lag delta the clock's cycle gives), covers V delta + V Tb / 2
// (a stop's speed falls point-symmetrically) and retracts L = that + retract:
//   tau = delta + Tb + T(L),  T(L) - T(Lref) = (L - Lref) / Vp  (both cruise at Vp),
// the stop, the retract and the reference each rounded up to whole cycles (dt / 2 net on average).
tl::expected<double, std::string> timed_stop(Bench& bench, const MachineCharacterisation& c, const AxisAcceleration& ax,
                                             const Vec3& surface, const Vec3& n, double v, double retract_mm,
                                             double positioning_mm_s, double dither) {
  machine::PtMeas p;
  p.nominal_mm = surface;
  p.normal = n;
  // Ta <= 2 Td whatever the braking: the contact comes at the feed.
  p.approach_mm = 1.5 * v * ax.ramp_time_s(v) + 0.3;
  p.search_mm = v * ax.ramp_time_s(v) + c.over_travel_mm + 0.5;
  p.retract_mm = retract_mm;
  p.speed_mm_s = v;
  const auto r = run1(bench.machine, {bench.tag++, p});
  if (r.status == machine::Response::Status::Fault || !r.hit)
    return tl::unexpected(fmt::format("timed stop at {:.1f} mm/s: {}", v, fault_text(r)));
  const double dt = c.dt_s, latch = r.hit->time_s;
  const double delta = std::ceil(latch / dt - 1e-9) * dt - latch;
  const double tau = r.end_time_s - latch;
  const Vec3 at = bench.machine.state().position_mm;
  const double lref = retract_mm + v * (delta + ax.ramp_time_s(v) / 2) + positioning_mm_s * dt * dither;
  double t_ref = 0;
  for (const Vec3& to : {Vec3(at + lref * n), at}) {
    const auto m = run1(bench.machine, {bench.tag++, machine::GoTo{to, std::nullopt}});
    if (m.status == machine::Response::Status::Fault) return tl::unexpected("timed stop reference: " + fault_text(m));
    t_ref += (m.end_time_s - m.start_time_s) / 2;
  }
  const double vp = positioning_mm_s;
  return (tau - delta - t_ref - (v * delta + retract_mm - lref) / vp - dt / 2) / (1 + v / (2 * vp));
}

// 3b. Braking per axis (docs/touch-trigger.md, "braking"): stops timed after touches along each
// axis on the reference sphere (its qualification points give the sphere), at feeds up to the
// preliminary maximum. An axis whose stops differ from the timed moves' mean ramp Td by more
// than their timing uncertainty brakes by its own law: Tb measured, Ta = 2 Td - Tb.
tl::expected<void, std::string> time_stops(Bench& bench, MachineCharacterisation& c) {
  const machine::MachineState st = bench.machine.state();
  if (!st.tool || st.tool->qualification_centres_mm.size() < 4) {
    bench.say("no qualification points: braking not timed (taken to mirror the acceleration)");
    return {};
  }
  fitting::FitOptions options;
  options.inner = false;
  const auto sphere = fitting::fit(fitting::Shape::Sphere, st.tool->qualification_centres_mm, options);
  if (!sphere) {
    bench.say("no sphere through the qualification points: braking not timed");
    return {};
  }
  const Vec3 centre = sphere->position, home = st.position_mm;
  const double centres_mm = sphere->diameter_mm / 2, r = st.tool->effective_radius_mm;
  const double vp = st.positioning_feed_mm_s, safe_z = centre.z() + centres_mm + 10;
  const auto go = [&](const Vec3& to) -> tl::expected<void, std::string> {
    const auto m = run1(bench.machine, {bench.tag++, machine::GoTo{to, std::nullopt}});
    if (m.status == machine::Response::Status::Fault) return tl::unexpected("timed stops: " + fault_text(m));
    return {};
  };
  // Over the sphere, across, and down: every point here lies on or above its equator.
  const auto route = [&](const Vec3& to) -> tl::expected<void, std::string> {
    const Vec3 at = bench.machine.state().position_mm;
    if (auto ok = go({at.x(), at.y(), std::max(safe_z, at.z())}); !ok) return ok;
    if (auto ok = go({to.x(), to.y(), std::max(safe_z, at.z())}); !ok) return ok;
    return go(to);
  };
  constexpr int bins = 4, per_bin = 6;
  for (int i = 0; i < 3; ++i) {
    const Vec3 n = Vec3::Unit(i);
    AxisAcceleration& ax = c.axes[static_cast<std::size_t>(i)];
    // A qualification point within 5 degrees of the axis tells that the sphere was probed there.
    const bool probed = std::any_of(
        st.tool->qualification_centres_mm.begin(), st.tool->qualification_centres_mm.end(),
        [&](const Vec3& q) { return (q - centre).normalized().dot(n) > std::cos(5 * std::numbers::pi / 180); });
    const double top = 0.95 * c.max_feed_mm_s(-n);
    if (!probed || !(top > 0)) continue;
    bench.say(fmt::format("timing stops on the {} axis ...", axis_name(i)));
    const Vec3 surface = centre + (centres_mm - r) * n;
    // Long enough that the retract cruises at the positioning feed (its ramps cover Vp Td).
    const double retract = vp * ax.ramp_time_s(vp) + 2;
    // Within the timed moves' feeds where the protected ones allow: the comparison with Td holds
    // only where Td was measured (below it Td is an upper bound).
    const double lowest = std::min(std::max(ax.samples.front().feed_mm_s, 0.1 * top), top / 2);
    if (auto ok = route(surface + (r + 1.5 * lowest * ax.ramp_time_s(lowest) + 0.3) * n); !ok) return ok;
    ax.stops.clear();
    for (int b = 0; b < bins; ++b) {
      const double mid = lowest * std::pow(top / lowest, static_cast<double>(b) / (bins - 1));
      // Feeds spread by +-5 % (and reference lengths over a cycle) spread the roundings.
      double sum_v = 0, sum_t = 0;
      for (int k = 0; k < per_bin; ++k) {
        const double v = mid * (0.95 + 0.1 * k / (per_bin - 1));
        auto tb = timed_stop(bench, c, ax, surface, n, v, retract, vp, static_cast<double>(k) / per_bin);
        if (!tb) return tl::unexpected(tb.error());
        sum_v += v, sum_t += *tb;
      }
      ax.stops.push_back({sum_v / per_bin, sum_t / per_bin});
    }
    if (auto ok = go({bench.machine.state().position_mm.x(), bench.machine.state().position_mm.y(),
                      std::max(safe_z, bench.machine.state().position_mm.z())});
        !ok)
      return ok;
    // The stops' uncertainty: the roundings (a cycle and a half at worst) and 3 % of Td.
    ax.asymmetric = false;
    for (const RampSample& sp : ax.stops) {
      const double td = ax.ramp_time_s(sp.feed_mm_s);
      if (sp.feed_mm_s >= ax.samples.front().feed_mm_s && std::abs(sp.ramp_time_s - td) > 1.5 * c.dt_s + 0.03 * td)
        ax.asymmetric = true;
    }
    if (!ax.asymmetric) continue;
    for (const RampSample& sp : ax.stops) {
      // Ta = 2 Td - Tb must stay positive (and Tb too): else the stops contradict the moves.
      const double share = sp.ramp_time_s / ax.ramp_time_s(sp.feed_mm_s);
      if (!(share > 0.05 && share < 1.95))
        return tl::unexpected(
            fmt::format("{} axis: a stop from {:.1f} mm/s took {:.1f} ms against a mean ramp of {:.1f} ms: "
                        "inconsistent timings",
                        axis_name(i), sp.feed_mm_s, 1e3 * sp.ramp_time_s, 1e3 * ax.ramp_time_s(sp.feed_mm_s)));
    }
  }
  return route(home);
}

// 4. Limits and strategy.
tl::expected<void, std::string> choose_limits_and_strategy(MachineCharacterisation& c) {
  c.max_probe_feed_mm_s = inf;
  for (int i = 0; i < 3; ++i) c.max_probe_feed_mm_s = std::min(c.max_probe_feed_mm_s, c.max_feed_mm_s(Vec3::Unit(i)));
  // The accurate feed: the spread of repeated touches within the threshold (SEEDS.md 3).
  const double accurate = c.response.jitter_s > 0
                              ? std::sqrt(std::max(std::pow(c.threshold_mm, 2) - std::pow(6 * c.response.noise_mm, 2),
                                                   std::pow(c.threshold_mm / 2, 2))) /
                                    c.response.jitter_s
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
      bench.say(fmt::format("trial {} cycles: {:.4f} s",
                            cc->blend       ? "blended one-touch"
                            : cc->one_touch ? "one-touch"
                                            : "two-touch",
                            *t));
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
  if (settings.time_stops)
    if (auto ok = time_stops(bench, c); !ok) return tl::unexpected(ok.error());
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
    json ax = {{"mode", mode_name(a.mode)},
               {"time_s", a.time_s},
               {"acceleration_mm_s2", a.acceleration_mm_s2},
               {"jerk_mm_s3", a.jerk_mm_s3},
               {"fit_rms_relative", a.fit_rms_relative},
               {"samples", samples}};
    if (!a.stops.empty()) {
      json stops = json::array();
      for (const auto& s : a.stops) stops.push_back({{"feed_mm_s", s.feed_mm_s}, {"stop_time_s", s.ramp_time_s}});
      ax["braking"] = {{"asymmetric", a.asymmetric}, {"stops", stops}};
    }
    axes[axis_name(i)] = ax;
  }
  json touches = json::array();
  for (const auto& s : c.response.samples)
    touches.push_back({{"feed_mm_s", s.feed_mm_s},
                       {"count", s.count},
                       {"mean_mm", s.mean_mm},
                       {"range_mm", s.range_mm},
                       {"midrange_mm", s.midrange_mm},
                       {"stddev_mm", s.stddev_mm}});
  return {
      {"format", "metron-touch-characterisation"},
      {"version", 2},
      {"world", c.world},
      {"dt_s", c.dt_s},
      {"axes", axes},
      {"response",
       {{"skip", c.response.scanned ? "scanned" : "latched"},
        {"jitter_s", c.response.jitter_s},
        {"delay_s", c.response.delay_s},
        {"noise_mm", c.response.noise_mm},
        {"qualification_feed_mm_s", c.response.qualification_feed_mm_s},
        {"touches", touches}}},
      {"over_travel_mm", c.over_travel_mm},
      {"over_travel_margin", c.over_travel_margin},
      {"pre_travel_mm", c.pre_travel_mm},
      {"max_probe_feed_mm_s", c.max_probe_feed_mm_s},
      {"strategy",
       {{"threshold_mm", c.threshold_mm},
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
    sj::fail(
        "/max_probe_feed_mm_s",
        fmt::format("{:g} mm/s exceeds {:.4g} mm/s, the fastest feed this file's own ramps, delays, pre-travel and "
                    "over-travel protect (docs/touch-trigger.md, \"maximum protected feed\")",
                    c.max_probe_feed_mm_s, protected_mm_s));
  for (const auto& [key, feed] :
       {std::pair{"measuring_feed_mm_s", c.measuring_feed_mm_s}, std::pair{"first_feed_mm_s", c.first_feed_mm_s}})
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
    o.get("format",
          [](const json& v, const std::string& p) { return sj::one_of(v, p, {"metron-touch-characterisation"}); });
    // Version 1 files (before the interpolated model and timed stops) read as they are.
    o.read("version", [](const json& v, const std::string& p) { sj::integer(v, p, 1, 2); });
    o.read("world", [&](const json& v, const std::string& p) { c.world = sj::string(v, p); });
    c.dt_s = o.get("dt_s", sj::positive);
    sj::Object axes(o.required("axes"), o.at("axes"));
    for (int i = 0; i < 3; ++i) {
      sj::Object ax(axes.required(axis_name(i)), axes.at(axis_name(i)));
      auto& a = c.axes[static_cast<std::size_t>(i)];
      const std::string mode = ax.get("mode", [](const json& v, const std::string& p) {
        return sj::one_of(v, p, {"constant_time", "constant_rate", "interpolated"});
      });
      a.mode = mode == "constant_time"   ? AxisAcceleration::Mode::ConstantTime
               : mode == "constant_rate" ? AxisAcceleration::Mode::ConstantRate
                                         : AxisAcceleration::Mode::Interpolated;
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
      // The interpolation is its samples: increasing feeds, positive times.
      if (a.mode == AxisAcceleration::Mode::Interpolated) {
        const std::string p = ax.at("samples");
        if (a.samples.size() < 2) sj::fail(p, "an interpolated axis needs at least two samples");
        for (std::size_t k = 0; k < a.samples.size(); ++k) {
          if (!(a.samples[k].ramp_time_s > 0))
            sj::fail(p + "/" + std::to_string(k) + "/ramp_time_s", "expected a positive number");
          if (k > 0 && !(a.samples[k].feed_mm_s > a.samples[k - 1].feed_mm_s))
            sj::fail(p + "/" + std::to_string(k) + "/feed_mm_s", "expected feeds in increasing order");
        }
      }
      ax.read("braking", [&](const json& v, const std::string& p) {
        sj::Object b(v, p);
        b.read("asymmetric", [&](const json& x, const std::string& q) { a.asymmetric = sj::boolean(x, q); });
        const json& stops = b.required("stops");
        if (!stops.is_array()) sj::fail(b.at("stops"), "expected an array");
        for (std::size_t k = 0; k < stops.size(); ++k) {
          const std::string q = b.at("stops") + "/" + std::to_string(k);
          sj::Object st(stops[k], q);
          a.stops.push_back({st.get("feed_mm_s", sj::positive), st.get("stop_time_s", sj::positive)});
          st.finish();
          if (k > 0 && !(a.stops[k].feed_mm_s > a.stops[k - 1].feed_mm_s))
            sj::fail(q + "/feed_mm_s", "expected feeds in increasing order");
          // Ta = 2 Td - Tb must stay positive, and Tb too.
          const double share = a.stops[k].ramp_time_s / a.ramp_time_s(a.stops[k].feed_mm_s);
          if (a.asymmetric && !(share > 0.05 && share < 1.95))
            sj::fail(q + "/stop_time_s", fmt::format("a stop of {:g} s against a mean ramp of {:g} s: inconsistent",
                                                     a.stops[k].ramp_time_s, a.ramp_time_s(a.stops[k].feed_mm_s)));
        }
        if (a.asymmetric && a.stops.empty()) sj::fail(b.at("stops"), "an asymmetric axis needs its timed stops");
        b.finish();
      });
      ax.finish();
    }
    axes.finish();
    sj::Object r(o.required("response"), o.at("response"));
    c.response.scanned = r.get("skip", [](const json& v, const std::string& p) {
      return sj::one_of(v, p, {"latched", "scanned"});
    }) == "scanned";
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
        t.count =
            static_cast<int>(s.get("count", [](const json& n, const std::string& q) { return sj::integer(n, q, 0); }));
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
      if (c.over_travel_margin > 1)
        sj::fail(p, "the stop distance may use at most the whole over-travel (a margin <= 1)");
    });
    c.pre_travel_mm = o.get("pre_travel_mm", sj::non_negative);
    c.max_probe_feed_mm_s = o.get("max_probe_feed_mm_s", sj::positive);
    sj::Object s(o.required("strategy"), o.at("strategy"));
    c.threshold_mm = s.get("threshold_mm", sj::non_negative);
    c.one_touch = s.get("cycle", [](const json& v, const std::string& p) {
      return sj::one_of(v, p, {"one_touch", "two_touch"});
    }) == "one_touch";
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
      o << fmt::format("  {}: constant time, Td = {:.4f} s (fit rms {:.2f} %)\n", axis_name(i), a.time_s,
                       100 * a.fit_rms_relative);
    else if (a.mode == AxisAcceleration::Mode::ConstantRate)
      o << fmt::format("  {}: constant rate, a = {:.0f} mm/s^2, j = {:.0f} mm/s^3 (fit rms {:.2f} %)\n", axis_name(i),
                       a.acceleration_mm_s2, a.jerk_mm_s3, 100 * a.fit_rms_relative);
    else
      o << fmt::format(
          "  {}: interpolated (no family fits), monotone cubic through {} feeds (leave-one-out rms {:.2f} %)\n",
          axis_name(i), a.samples.size(), 100 * a.fit_rms_relative);
    if (a.asymmetric) {
      o << "     braking differs (timed stops): feed mm/s  Tb ms  Td ms  Ta ms\n";
      for (const auto& s : a.stops)
        o << fmt::format("     {:28.1f} {:6.2f} {:6.2f} {:6.2f}\n", s.feed_mm_s, 1e3 * s.ramp_time_s,
                         1e3 * a.ramp_time_s(s.feed_mm_s), 1e3 * a.acceleration_time_s(s.feed_mm_s));
    }
    o << "     feed mm/s  Td ms   D1 mm\n";
    for (const auto& s : a.samples)
      o << fmt::format("     {:9.1f} {:6.2f} {:7.4f}\n", s.feed_mm_s, 1e3 * s.ramp_time_s,
                       s.feed_mm_s * s.ramp_time_s / 2);
  }
  o << fmt::format("controller cycle: {:.4f} s\n", c.dt_s);
  o << "trigger response (repeated touches on one point)\n";
  for (const auto& s : c.response.samples)
    o << fmt::format("  {:7.1f} mm/s: {} touches, range {:.4f} mm, sigma {:.4f} mm\n", s.feed_mm_s, s.count, s.range_mm,
                     s.stddev_mm);
  o << fmt::format("  skip input: {} (jitter {:.2f} ms), constant delay {:.2f} ms, probe noise {:.2f} um (1 sigma)\n",
                   c.response.scanned ? "scanned" : "latched", 1e3 * c.response.jitter_s, 1e3 * c.response.delay_s,
                   1e3 * c.response.noise_mm);
  o << fmt::format("pre-travel (upper estimate): {:.4f} mm; rated over-travel {:.3f} mm, margin {:.0f} %\n",
                   c.pre_travel_mm, c.over_travel_mm, 100 * c.over_travel_margin);
  o << fmt::format("maximum protected probing feed: {:.1f} mm/s (stop distance {:.3f} mm along z)\n",
                   c.max_probe_feed_mm_s, c.stop_distance_mm(-Vec3::UnitZ(), c.max_probe_feed_mm_s));
  o << fmt::format("strategy: {}{} (threshold {:.1f} um; spread at {:.1f} mm/s: {:.1f} um)\n",
                   c.blend       ? "blended one-touch"
                   : c.one_touch ? "one-touch"
                                 : "two-touch",
                   c.blend ? " (beyond the seed)" : "", 1e3 * c.threshold_mm, c.first_feed_mm_s,
                   1e3 * c.response.spread_mm(c.first_feed_mm_s));
  const Vec3 down = -Vec3::UnitZ();
  if (c.one_touch)
    o << fmt::format("  measuring feed {:.1f} mm/s, approach {:.3f} mm (D1 + D3 + tolerance {:.3f})\n",
                     c.measuring_feed_mm_s, c.standoff_mm(down, c.measuring_feed_mm_s, 0, c.nominal_tolerance_mm),
                     c.nominal_tolerance_mm);
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

tl::expected<TouchBaseline, std::string> parse_touch_baseline(const std::string& text) {
  const auto number = [](const std::string& field, const char* what) -> tl::expected<double, std::string> {
    double v = 0;
    std::size_t used = 0;
    try {
      v = std::stod(field, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != field.size() || !std::isfinite(v) || !(v > 0))
      return tl::unexpected(fmt::format("the {} '{}' is not a positive number", what, field));
    return v;
  };
  if (text == "one-touch") return TouchBaseline{};
  const std::string prefix = "two-touch:";
  if (text.rfind(prefix, 0) != 0)
    return tl::unexpected(fmt::format("'{}': expected one-touch or two-touch:BACKOFF_MM[:FIRST_FEED_MM_S]", text));
  const std::string rest = text.substr(prefix.size());
  const std::size_t colon = rest.find(':');
  TouchBaseline b;
  b.two_touch = true;
  auto backoff = number(rest.substr(0, colon), "back-off");
  if (!backoff) return tl::unexpected(backoff.error());
  b.backoff_mm = *backoff;
  if (colon != std::string::npos) {
    auto feed = number(rest.substr(colon + 1), "first-touch feed");
    if (!feed) return tl::unexpected(feed.error());
    b.first_feed_mm_s = *feed;
  }
  return b;
}

std::string describe(const TouchBaseline& b, const MachineCharacterisation* c) {
  if (!b.two_touch) return "one-touch from the approach distance at the measuring feed";
  const std::optional<double> first = b.first_feed_mm_s ? b.first_feed_mm_s
                                      : c               ? std::optional(c->first_feed_mm_s)
                                                        : std::nullopt;
  return fmt::format("two-touch, {:.3f} mm back-off, first touch at {}", b.backoff_mm,
                     first ? fmt::format("{:.3f} mm/s", *first) : std::string("(no feed: needs a characterisation)"));
}

}  // namespace metron::runtime
