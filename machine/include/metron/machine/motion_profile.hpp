// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <vector>

namespace metron::machine {

/// Limits of a 1-D motion along a path (all positive).
struct MotionLimits {
  double speed_mm_s = 300;           ///< maximum path speed
  double acceleration_mm_s2 = 1000;  ///< maximum |acceleration|
  double jerk_mm_s3 = 10000;         ///< maximum |jerk|
};

/// Braking limits of a motion whose braking differs from its acceleration (an axis with its own
/// braking law, docs/world.md); where none is given, braking mirrors the acceleration.
struct BrakingLimits {
  double deceleration_mm_s2 = 1000;  ///< maximum |deceleration|
  double jerk_mm_s3 = 10000;         ///< maximum |jerk| while braking
};

/// Kinematic state along the path.
struct MotionState {
  double position_mm = 0;         ///< distance along the path
  double speed_mm_s = 0;          ///< path speed
  double acceleration_mm_s2 = 0;  ///< path acceleration
};

/// One phase of constant jerk.
struct JerkPhase {
  double duration_s = 0;  ///< length of the phase
  double jerk_mm_s3 = 0;  ///< constant jerk during it
};

/// A 1-D jerk-limited motion: a start state followed by phases of constant jerk, so position,
/// speed and acceleration are exact polynomials in time (no integration error). The acceleration
/// mode is "constant rate" (SEEDS.md 3): the acceleration ramps at the jerk limit up to the
/// acceleration limit, so the acceleration distance grows with the square of the feed. With
/// `braking` limits every slow-down uses them instead (asymmetric axes).
class MotionProfile {
 public:
  MotionProfile() = default;
  /// The motion from `start` through `phases` (phases of zero duration are dropped).
  MotionProfile(MotionState start, std::vector<JerkPhase> phases);

  /// Time-optimal rest-to-rest move over `distance_mm` (>= 0): the symmetric 7-phase S-curve
  /// (jerk up, constant acceleration, jerk down, cruise, and mirrored), with the peak speed
  /// lowered when the distance is too short to reach `limits.speed_mm_s`. With `braking` the
  /// second half brakes by those limits.
  static MotionProfile rest_to_rest(double distance_mm, const MotionLimits& limits,
                                    const std::optional<BrakingLimits>& braking = std::nullopt);

  /// A probing move that blends the approach into the probing feed: from rest, as fast as
  /// `limits` allow (up to limits.speed_mm_s), slowing to `feed_mm_s` with zero acceleration
  /// exactly `reach_mm` from the start, at `feed_mm_s` from there on, and to rest at
  /// `distance_mm`. When `reach_mm` is too short to reach the feed, the feed is reached later.
  /// Slowing down (to the feed, to rest) uses `braking` when given.
  static MotionProfile reach_feed(double reach_mm, double distance_mm, double feed_mm_s, const MotionLimits& limits,
                                  const std::optional<BrakingLimits>& braking = std::nullopt);

  /// Shortest jerk-limited stop from `from` (speed >= 0, |acceleration| <= limit). With
  /// `braking`, a rising speed is first ended at the jerk of `limits` (the ramp's own law), then
  /// the stop uses the braking limits.
  static MotionProfile stop(const MotionState& from, const MotionLimits& limits,
                            const std::optional<BrakingLimits>& braking = std::nullopt);

  /// Total time of all phases.
  [[nodiscard]] double duration_s() const { return m_duration_s; }
  /// Position at the end (distance covered plus the start position).
  [[nodiscard]] double end_position_mm() const { return m_end.position_mm; }
  /// State at t = 0.
  [[nodiscard]] const MotionState& start() const { return m_start; }
  /// The phases of constant jerk, in order.
  [[nodiscard]] const std::vector<JerkPhase>& phases() const { return m_phases; }

  /// State at time t (clamped to [0, duration]); exact at the end.
  [[nodiscard]] MotionState at(double t_s) const;
  /// The first time the position reaches `position_mm` (the profiles here never move backward);
  /// duration_s() if it never does.
  [[nodiscard]] double time_at(double position_mm) const;

 private:
  MotionState m_start;
  std::vector<JerkPhase> m_phases;
  std::vector<double> m_phase_start_s;     // cumulative start time of each phase
  std::vector<MotionState> m_phase_state;  // state at the start of each phase
  MotionState m_end;
  double m_duration_s = 0;
};

/// Duration of the rest-to-rest move (closed form, for planning and tests).
double rest_to_rest_time_s(double distance_mm, const MotionLimits& limits,
                           const std::optional<BrakingLimits>& braking = std::nullopt);

}  // namespace metron::machine
