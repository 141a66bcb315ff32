// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <array>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/machine/machine.hpp"
#include "metron/stdlib/geometry/vec.hpp"

/// Touch-trigger machine characterisation (SEEDS.md 3, docs/touch-trigger.md): what the host
/// learns about the controller and axes from its own sensors (the controller clock, latched
/// positions), and the touch strategy it derives from that. Nothing here reads the world.
namespace metron::runtime {

/// One timed move: the ramp time Td = Ta - Dc/V at feed V (SEEDS.md 3); or one timed stop: the
/// time from feed V to rest.
struct RampSample {
  double feed_mm_s = 0;    ///< commanded feed
  double ramp_time_s = 0;  ///< Td, averaged over dithered lengths (a stop: its time Tb)
};

/// The acceleration characteristic of one axis, fitted over feed for lookup. Timed rest-to-rest
/// moves give the mean ramp time Td = (Ta + Tb) / 2 of accelerating (Ta) and braking (Tb);
/// timed stops give Tb, so Ta = 2 Td - Tb (docs/touch-trigger.md, "braking").
struct AxisAcceleration {
  enum class Mode {
    ConstantRate,  ///< jerk-limited ramp to a fixed acceleration: Td = V/a + a/j (SEEDS.md 3)
    ConstantTime,  ///< any feed in a fixed time: Td = T (SEEDS.md 3)
    Interpolated,  ///< no family: monotone cubic through the samples (Fritsch-Carlson)
  };
  Mode mode = Mode::ConstantRate;  ///< the simplest model that fits the timed moves within its threshold
  double time_s = 0;               ///< ConstantTime: the ramp time (informative for the others: best constant)
  double acceleration_mm_s2 = 0;   ///< ConstantRate: fitted acceleration limit (informative for the others)
  double jerk_mm_s3 = 0;           ///< ConstantRate: fitted jerk limit (informative for the others)
  /// RMS relative residual of Td of the chosen model; Interpolated: its leave-one-out residual
  /// (each inner sample predicted from the others), since it passes through every sample.
  double fit_rms_relative = 0;
  std::vector<RampSample> samples;  ///< the timed moves, by increasing feed (Interpolated: its knots)
  /// Timed stops from constant speed (feed, stop time Tb), by increasing feed; empty: braking
  /// not measured (it is then taken to mirror the acceleration).
  std::vector<RampSample> stops;
  /// The stops differ from Td beyond their timing uncertainty: braking is the measured share
  /// Tb / Td (interpolated over feed, held beyond the timed stops), accelerating the rest.
  bool asymmetric = false;

  /// Mean ramp time Td at `feed_mm_s` from the fitted model: what a timed rest-to-rest move sees.
  [[nodiscard]] double ramp_time_s(double feed_mm_s) const;
  /// Time of the acceleration from rest to `feed_mm_s`: Td, or 2 Td - Tb when asymmetric.
  [[nodiscard]] double acceleration_time_s(double feed_mm_s) const;
  /// Time of a stop from `feed_mm_s` at constant speed: Td, or the measured Tb when asymmetric.
  [[nodiscard]] double braking_time_s(double feed_mm_s) const;
  /// SEEDS.md 3: acceleration distance D1 = V * Ta / 2 (V * Td / 2 for a symmetric ramp).
  [[nodiscard]] double distance_mm(double feed_mm_s) const { return feed_mm_s * acceleration_time_s(feed_mm_s) / 2; }
};

/// How the model of an axis's ramp time over feed is chosen (docs/touch-trigger.md): the
/// simplest that fits the samples within its threshold, else the characterisation is refused.
struct RampFitSettings {
  /// A family (constant time, else constant rate) is used when its RMS relative residual is
  /// within this; constant time yields to constant rate when that fits markedly better.
  double family_rms_relative = 0.01;
  /// Else the interpolation, when its leave-one-out RMS relative residual is within this; else
  /// the samples fit no model (noisy or inconsistent timings) and are refused.
  double interpolation_rms_relative = 0.03;
  /// Fit only this model and accept it whatever its residual (comparisons and tests).
  std::optional<AxisAcceleration::Mode> only;
};

/// Fits the ramp-time samples of one axis (at least three distinct positive feeds, positive
/// times) by RampFitSettings; the error says which models were tried and their residuals.
tl::expected<AxisAcceleration, std::string> fit_acceleration(std::vector<RampSample> samples,
                                                             const RampFitSettings& settings = {});

/// Repeated touches on one point at one feed (same standoff).
struct TouchSample {
  double feed_mm_s = 0;    ///< probing feed
  int count = 0;           ///< touches
  double mean_mm = 0;      ///< mean latched position along the probing direction
  double range_mm = 0;     ///< max - min of the latched positions
  double midrange_mm = 0;  ///< (max + min) / 2: for a uniform latency far steadier than the mean
  double stddev_mm = 0;    ///< sample standard deviation
};

/// The controller's response to the trigger as seen from the latched positions.
struct ResponseTime {
  bool scanned = false;                ///< jitter class: scanned skip input (else latched)
  double jitter_s = 0;                 ///< estimated scan period (latency uniform in [0, jitter))
  double delay_s = 0;                  ///< constant delay trigger -> latch (filter + transmission + latency)
  double noise_mm = 0;                 ///< 1-sigma trigger noise (the probe's repeatability)
  double qualification_feed_mm_s = 0;  ///< feed at which the tool's effective radius was qualified
  std::vector<TouchSample> samples;    ///< the measurements
  /// Expected spread (range) of repeated touches at a feed: feed * jitter and 6 sigma of the
  /// probe's own scatter, independent, added in quadrature.
  [[nodiscard]] double spread_mm(double feed_mm_s) const { return std::hypot(feed_mm_s * jitter_s, 6 * noise_mm); }
};

/// The documented default of CharacterisationSettings::nominal_tolerance_mm (mm).
inline constexpr double default_nominal_tolerance_mm = 0.2;

/// Settings of a characterisation run.
struct CharacterisationSettings {
  double repeatability_threshold_mm = 0.010;  ///< one-touch below this spread (SEEDS.md 3: 10 um)
  /// Uncertainty of nominal surface positions (the standoff's tolerance term): the same
  /// documented default for `metron characterise` and CHARACTERISE in a program
  /// (docs/touch-trigger.md); a surface farther off its nominal is touched while accelerating.
  double nominal_tolerance_mm = default_nominal_tolerance_mm;
  double over_travel_margin = 0.8;  ///< the stop distance may use this share of the over-travel
  int touches_per_feed = 60;        ///< repeated touches per feed
  int dither = 10;                  ///< timed moves per feed, lengths spread over one cycle
  std::vector<double> timing_feeds_mm_s{2, 5, 10, 20, 50, 100, 150};  ///< feeds of the timed moves
  RampFitSettings ramp_fit;          ///< model choice and rejection of the acceleration characteristic
  bool time_stops = true;            ///< time stops after touches on the reference sphere (braking per axis)
  bool blend = false;                ///< beyond the seed: blended one-touch cycles (TouchPlan::blend_mm)
  bool optimise_first_feed = false;  ///< beyond the seed: first-touch feed from timed trial cycles
  bool fastest = false;              ///< beyond the seed: the fastest cycle meeting the threshold, by timed trials
};

/// A touch cycle chosen for one probing direction.
struct TouchPlan {
  bool two_touch = false;          ///< else one touch
  double feed_mm_s = 0;            ///< the measuring feed (second touch or the single touch)
  double first_feed_mm_s = 0;      ///< two-touch: first-touch feed
  double approach_mm = 0;          ///< start distance before the nominal surface
  double backoff_mm = 0;           ///< two-touch: from the first latched centre to the second start
  double standoff_mm = 0;          ///< two-touch: D1 + D2 + D3 from the surface found
  std::optional<double> blend_mm;  ///< blended one touch: the feed is reached this far before the nominal
};

/// Puts a plan's cycle (approach, feeds, two-touch, blend) into a touch command; its point, normal,
/// search and retract stay the caller's.
inline void apply_touch_plan(const TouchPlan& plan, machine::PtMeas& p) {
  p.approach_mm = plan.approach_mm;
  p.speed_mm_s = plan.feed_mm_s;
  if (plan.two_touch) p.two_touch = machine::PtMeas::TwoTouch{plan.first_feed_mm_s, plan.backoff_mm};
  p.blend_mm = plan.blend_mm;
}

/// Where the head rests before a touch: on the touch's approach line, `distance_mm` from the
/// nominal point (measured as TouchPlan::approach_mm), with the positioning feed a move closer
/// would use.
struct RestingHead {
  double distance_mm = 0;             ///< from the nominal point (+ effective radius) along the normal
  double positioning_feed_mm_s = 50;  ///< feed of a move to a closer standoff
};

/// A conventional touch cycle, set the way an installer sets one without measuring the machine
/// (issue 11, `metron run --touch-baseline`): PTMEAS uses it instead of the characterised plan,
/// at the same measuring feed, so that a program's time can be compared under both.
struct TouchBaseline {
  bool two_touch = false;                 ///< else one touch from SNSET/APPRCH at the measuring feed
  double backoff_mm = 0;                  ///< two-touch: from the first latched centre to the second start
  std::optional<double> first_feed_mm_s;  ///< two-touch: none = the characterisation's first-touch feed
};

/// Reads `one-touch` or `two-touch:BACKOFF_MM[:FIRST_FEED_MM_S]`; the error says what is wrong.
tl::expected<TouchBaseline, std::string> parse_touch_baseline(const std::string& text);

/// Everything a characterisation found, and the strategy derived from it.
struct MachineCharacterisation {
  std::string world;                     ///< informative: the machine it was measured on
  std::array<AxisAcceleration, 3> axes;  ///< x, y, z
  ResponseTime response;                 ///< trigger response
  double dt_s = 0.001;                   ///< controller cycle (from the clock's resolution)
  double over_travel_mm = 0;             ///< the probe's rated over-travel
  double pre_travel_mm = 0;              ///< upper estimate of pre-travel (nominal - effective radius - delay term)
  double max_probe_feed_mm_s = 0;        ///< fastest feed whose stop distance stays within margin * over-travel
  double over_travel_margin = 0.8;       ///< share of the over-travel the stop distance may use
  double threshold_mm = 0.010;           ///< strategy threshold on the spread
  double nominal_tolerance_mm = 0;       ///< the standoff's tolerance term
  bool one_touch = false;                ///< strategy (SEEDS.md 3)
  double measuring_feed_mm_s = 0;        ///< one-touch feed, or the second touch's
  double first_feed_mm_s = 0;            ///< two-touch: first-touch feed
  /// Beyond the seed: one touch at the measuring feed whose approach blends into it, reaching it
  /// (with zero acceleration) the nominal tolerance + D3 before the nominal surface.
  bool blend = false;

  /// Acceleration ramp time Ta along unit `direction` from rest to `feed_mm_s` (the slowest axis
  /// involved dominates).
  [[nodiscard]] double ramp_time_s(const Vec3& direction, double feed_mm_s) const;
  /// Braking time Tb along `direction` from `feed_mm_s` at constant speed to rest.
  [[nodiscard]] double braking_time_s(const Vec3& direction, double feed_mm_s) const;
  /// D1 along `direction` (SEEDS.md 3: V * Ta / 2).
  [[nodiscard]] double acceleration_distance_mm(const Vec3& direction, double feed_mm_s) const;
  /// Upper bound of the distance from contact to standstill for a contact anywhere on the ramp
  /// to `feed_mm_s` or at that feed: pre-travel + feed * (delay + jitter + dt) + feed * (Ta + Tb) / 2
  /// (docs/touch-trigger.md, "maximum protected feed"; Ta = Tb = Td for a symmetric ramp).
  [[nodiscard]] double stop_distance_mm(const Vec3& direction, double feed_mm_s) const;
  /// Time of a rest-to-rest move of `length_mm` along `direction` at `feed_mm_s`, from the
  /// acceleration characteristic: L / V + Td(V), or 2 Td(v) where the move never reaches V
  /// (v Td(v) = L), with Td = (Ta + Tb) / 2.
  [[nodiscard]] double move_time_s(const Vec3& direction, double length_mm, double feed_mm_s) const;
  /// Fastest feed along `direction` whose stop distance stays within margin * over-travel.
  [[nodiscard]] double max_feed_mm_s(const Vec3& direction) const;
  /// SEEDS.md 3: optimal standoff D1 + D2 + D3 (+ the nominal tolerance when `with_tolerance`).
  [[nodiscard]] double standoff_mm(const Vec3& direction, double slow_mm_s, double fast_mm_s,
                                   double tolerance_mm) const;
  /// Nominal minus effective radius of a tool qualified at the qualification feed: the ball
  /// centre is at nominal + effective radius when latched, this much before it at contact.
  /// Approach distances (from nominal + effective radius) include it.
  [[nodiscard]] double qualified_offset_mm() const;
  /// How much farther past the surface a hit at `feed_mm_s` is latched than one at the feed the
  /// tool was qualified at: (feed - qualification feed) * (delay + jitter / 2); hits are moved
  /// back by it along the normal (SEEDS.md 3: the delay-distance correction at constant feed).
  [[nodiscard]] double dynamic_correction_mm(double feed_mm_s, double qualification_feed_mm_s) const;
  /// Issue 11: a one-touch `hit` of `p` whose contact came before the probing feed was reached
  /// (a surface farther above its nominal than the approach allows for: the point is taken while
  /// still accelerating and may be off). Returns how far above its nominal the surface lies,
  /// estimated from the latched centre; none when the contact was at the feed, or for two-touch
  /// cycles (their second touch starts from the surface found).
  [[nodiscard]] std::optional<double> early_contact_mm(const machine::PtMeas& p, const machine::Hit& hit) const;
  /// The cycle for probing along -normal (`normal` the surface normal), with optional explicit
  /// feed and approach (FEDRAT/MESVEL, SNSET/APPRCH). When the head already rests on the
  /// approach line beyond the planned start (`resting`) and probing that extra distance is
  /// quicker than a rest-to-rest move closer, the touch starts where the head rests.
  [[nodiscard]] TouchPlan plan(const Vec3& normal, std::optional<double> feed_mm_s, std::optional<double> approach_mm,
                               std::optional<RestingHead> resting = std::nullopt) const;
};

/// Runs the characterisation on `machine` with a tool of `ball_diameter_mm` (defined, selected
/// and qualified on the reference sphere): timed moves per axis and feed, repeated touches on
/// the last qualification point at several feeds, then the derived limits and strategy.
/// `log` receives progress lines (may be empty).
tl::expected<MachineCharacterisation, std::string> characterise(machine::Machine& machine,
                                                                const CharacterisationSettings& settings,
                                                                const std::function<void(const std::string&)>& log = {},
                                                                double ball_diameter_mm = 4.0);

/// Only the acceleration characteristic of one axis (0..2) from timed moves; the controller
/// clock's resolution (its cycle) is stored in `clock_resolution_s` when given.
/// When no family fits, feeds halfway (geometrically) between the timed ones are timed as well,
/// up to twice, before the interpolation is judged.
tl::expected<AxisAcceleration, std::string> measure_axis_acceleration(machine::Machine& machine, int axis,
                                                                      const std::vector<double>& feeds_mm_s, int dither,
                                                                      double* clock_resolution_s = nullptr,
                                                                      const RampFitSettings& fit = {});

/// The characterisation file (docs/touch-trigger.md).
nlohmann::json to_json(const MachineCharacterisation& c);
/// Reads a characterisation file's JSON; errors name the key.
tl::expected<MachineCharacterisation, std::string> characterisation_from_json(const nlohmann::json& j);
/// Writes / reads the file.
tl::expected<void, std::string> save_characterisation(const MachineCharacterisation& c, const std::string& path);
tl::expected<MachineCharacterisation, std::string> load_characterisation(const std::string& path);
/// A human-readable report.
std::string format_characterisation(const MachineCharacterisation& c);
/// How a baseline reads in a report ("two-touch, 1.000 mm back-off, first touch at 26.000 mm/s");
/// `c` gives the default first-touch feed (may be null).
std::string describe(const TouchBaseline& baseline, const MachineCharacterisation* c);

}  // namespace metron::runtime
