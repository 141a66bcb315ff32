// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <span>
#include <vector>

#include "metron/machine/motion_profile.hpp"
#include "metron/stdlib/geometry/pcc.hpp"

// The per-command speed-pattern planner of segmented continuous scanning (SEEDS.md 2).
namespace metron::machine::segmented {

/// Constraints of the scanning motion along the path.
struct ScanLimits {
  MotionLimits path{100.0, 1000.0, 10000.0};  ///< tangential speed, acceleration and jerk limits
  double normal_acceleration_mm_s2 = 500.0;   ///< centripetal limit: v <= sqrt(a_n / curvature)
};

/// The low-speed region that ends every plan of the seed method (SEEDS.md 2 step 3).
struct LowSpeedRegion {
  double length_mm = 3.0;   ///< L, run at the low speed at the end of a command
  double speed_mm_s = 3.0;  ///< the low speed (the seed claims 1-5 mm/s)
};

/// How a plan begins (SEEDS.md 2 step 3), or which other mode it belongs to.
enum class PlanKind {
  Individual,    ///< seed method: starts from rest (after an approach)
  Connection,    ///< seed method: starts at the low speed, continuing the previous command
  Conventional,  ///< conventional: rest to rest, no low-speed region
  LookAhead,     ///< metron's look-ahead: no low-speed region, junction speed set by the buffer
};

/// A stretch of path with one speed limit; the interpolator's unit of constraint.
struct LimitPiece {
  double start_mm = 0;            ///< global arc length where the piece begins
  double end_mm = 0;              ///< and ends
  double limit_mm_s = 0;          ///< speed limit inside the piece
  double end_cap_mm_s = 0;        ///< extra limit at the piece end (the low speed at a command end)
  geometry::PccSegment segment;   ///< the segment the piece lies on (a copy: buffers get overwritten)
  double segment_start_mm = 0;    ///< global arc length of that segment's start
  double segment_length_mm = 0;   ///< its arc length
  std::size_t command_index = 0;  ///< the command the piece belongs to
};

/// The speed-pattern plan of one measurement command.
struct SpeedPlan {
  PlanKind kind = PlanKind::Individual;
  std::size_t command_index = 0;      ///< i of Ci (0-based)
  double start_mm = 0;                ///< global arc length of the command start
  double end_mm = 0;                  ///< and end
  double low_speed_from_mm = 0;       ///< start of the low-speed region (== end_mm when none)
  double start_speed_mm_s = 0;        ///< 0 (individual, conventional) or the low speed (connection)
  double end_speed_mm_s = 0;          ///< the planned speed at the end (low speed or 0)
  std::vector<LimitPiece> pieces;     ///< limits in path order (segments, split at the region)
  std::vector<double> junction_mm_s;  ///< planned speed at each piece boundary (pieces.size()+1)
  std::vector<double> time_to_end_s;  ///< planned time from each piece boundary to the end
  /// Planned duration tei - tsi.
  [[nodiscard]] double duration_s() const { return time_to_end_s.empty() ? 0 : time_to_end_s.front(); }
};

/// Arc length and curvature speed limit of one segment: the part of the plan that depends only
/// on the geometry (the seed plans "according to the curvature of each segment").
struct SegmentLimit {
  double length_mm = 0;   ///< arc length
  double limit_mm_s = 0;  ///< min(path speed, sqrt(a_n / max curvature), the path's own limit)
};

/// The parameter S at arc length `arc_mm` from the segment start (Newton on the arc length).
double parameter_at_arc(const geometry::PccSegment& segment, double arc_mm, double length_mm);

/// Curvature limit of one segment: curvature sampled at 5 points of S (a cubic's curvature has
/// few extrema; the sampling is documented as the planner's resolution).
SegmentLimit segment_limit(const geometry::PccSegment& segment, const ScanLimits& limits, double path_speed_mm_s = 0);

/// Plans one command: `segments` start at global arc length `start_mm`; `path_speed_mm_s` is the
/// per-segment limit from the path (may be empty). Seed kinds get the low-speed region: the last
/// L of the command (over as many segments as needed) at the low speed, none when the command is
/// shorter than L (then the plan only ends at the low speed).
SpeedPlan plan_command(std::span<const geometry::PccSegment> segments, std::span<const double> path_speed_mm_s,
                       std::size_t command_index, double start_mm, PlanKind kind, const ScanLimits& limits,
                       const LowSpeedRegion& low, bool last_command);

// --- jerk-limited ramp algebra (symmetric S-curve between two speeds, zero acceleration at
// both ends), shared by the planner, the interpolator and the tests ---

/// Duration of a ramp changing the speed by `dv` (>= 0).
double ramp_time_s(double dv_mm_s, const MotionLimits& limits);
/// Distance of a ramp from v0 to v1 (either order): the ramp is symmetric, so it is the mean
/// speed times the duration.
double ramp_distance_mm(double v0_mm_s, double v1_mm_s, const MotionLimits& limits);
/// The highest v1 >= v0 with ramp_distance_mm(v0, v1) <= d (closed form: Cardano / quadratic).
double reachable_speed_mm_s(double v0_mm_s, double d_mm, const MotionLimits& limits);
/// Backward and forward passes over pieces (jerk-limited junction speeds): fills `junction_mm_s`
/// (size pieces+1) with the highest speeds that let every later limit and `end_speed_mm_s` be met
/// and that can be reached from `start_speed_mm_s`; ramps are measured from the binding
/// constraint, across junctions. `middle` (optional) gets the same envelope at each piece middle.
/// With `ongoing`, ramps need not end at zero acceleration (ongoing_speed_mm_s): the envelope of
/// what the interpolator can reach, used for the schedule.
void junction_passes(std::span<const LimitPiece> pieces, double start_speed_mm_s, double end_speed_mm_s,
                     const MotionLimits& limits, std::vector<double>& junction_mm_s,
                     std::vector<double>* middle = nullptr, bool ongoing = false);

/// Speed after `d_mm` of the fastest acceleration from (v0, a = 0): jerk up to the acceleration
/// limit, then constant acceleration (the ramp does not have to end; by time reversal also the
/// speed `d_mm` before a point reached at v0 by the fastest deceleration).
double ongoing_speed_mm_s(double v0_mm_s, double d_mm, const MotionLimits& limits);

/// Fills the plan's junction speeds and schedule (time_to_end_s) from its pieces and end speeds.
void schedule_plan(SpeedPlan& plan, const MotionLimits& limits);

}  // namespace metron::machine::segmented
