// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <deque>
#include <limits>
#include <span>

#include "metron/machine/segmented_scanning/speed_plan.hpp"

namespace metron::machine::segmented {

/// The interpolator's state along the path.
struct PathState {
  double s_mm = 0;     ///< global arc length
  double v_mm_s = 0;   ///< path speed
  double a_mm_s2 = 0;  ///< path acceleration
  double j_mm_s3 = 0;  ///< jerk applied in the last cycle
};

/// Shortest distance to bring the speed to <= vt from (v, a) with the jerk and acceleration
/// limits (0 when the speed never exceeds vt); decelerations run a jerk-limited S-curve.
double brake_distance_mm(double v_mm_s, double a_mm_s2, double vt_mm_s, const MotionLimits& limits);

/// Real-time, jerk-limited look-ahead interpolation over the buffered limit pieces: every cycle
/// it applies the largest jerk whose next state can still meet every speed limit ahead and stop
/// at the end of what is buffered. With the whole path buffered this is the reference planner.
class PathInterpolator {
 public:
  explicit PathInterpolator(MotionLimits limits)
      : m_limits(limits),
        m_check_limits{limits.speed_mm_s, limits.acceleration_mm_s2, limits.jerk_mm_s3 * k_jerk_reserve} {}

  /// The braking checks plan with this share of the jerk limit: the reserve lets a constant
  /// jerk per cycle follow a braking curve whose switching instants fall inside a cycle.
  static constexpr double k_jerk_reserve = 0.97;

  /// Appends pieces (contiguous with the buffered end); the horizon end moves to their end.
  void append(std::span<const LimitPiece> pieces);
  /// Drops pieces that end before the current position (keeps memory bounded).
  void trim();
  /// Advances one cycle of `dt_s`.
  void step(double dt_s);
  /// A feed cap on top of the piece limits (infinity: none), in force from where a jerk-limited
  /// deceleration from the current state can reach it.
  void set_speed_override(double v_mm_s);
  /// Sets the state (e.g. rest at the start after an approach).
  void reset_state(const PathState& state) { m_state = state; }

  /// The state after the last cycle.
  [[nodiscard]] const PathState& state() const { return m_state; }
  /// Global arc length where the buffered pieces end.
  [[nodiscard]] double horizon_end_mm() const { return m_pieces.empty() ? m_state.s_mm : m_pieces.back().end_mm; }
  /// True when the probe rests at the end of the buffered pieces.
  [[nodiscard]] bool at_rest_at_end() const;
  /// The piece at the current position (nullptr when nothing is buffered).
  [[nodiscard]] const LimitPiece* current_piece() const;
  /// Speed limit that applies at the current position (infinity when nothing is buffered).
  [[nodiscard]] double limit_here_mm_s() const;
  /// The motion limits.
  [[nodiscard]] const MotionLimits& limits() const { return m_limits; }

 private:
  [[nodiscard]] bool safe(const PathState& next) const;
  [[nodiscard]] bool speed_can_stay_positive(const PathState& x) const;

  MotionLimits m_limits;
  MotionLimits m_check_limits;
  std::deque<LimitPiece> m_pieces;
  std::size_t m_current = 0;  // index in m_pieces of the piece containing s
  double m_override_mm_s = std::numeric_limits<double>::infinity();
  double m_override_from_mm = 0;
  PathState m_state;
};

}  // namespace metron::machine::segmented
