// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::machine {

/// What bounds the scan speed at a place on the path.
enum class SpeedLimit {
  Feed,           ///< the requested scan speed
  Segment,        ///< the PCC segment's own speed (from its curvature, set by the path generator)
  Machine,        ///< the machine's path speed limit
  Centripetal,    ///< v^2 * kappa <= the centripetal acceleration limit
  ProbeDynamics,  ///< the stylus must follow the curvature: v <= wp * sqrt(E0 / kappa)
  Acceleration,   ///< speeding up from the start or slowing down for a later limit or the end
};

/// "feed", "segment", "machine", "centripetal", "probe dynamics", "acceleration".
const char* to_string(SpeedLimit limit);

/// A stretch of path over which one limit binds.
struct SpeedLimitSpan {
  double from_mm = 0;                   ///< arc length where it starts
  double to_mm = 0;                     ///< arc length where it ends
  SpeedLimit limit = SpeedLimit::Feed;  ///< which limit
  double min_speed_mm_s = 0;            ///< the lowest planned speed in the stretch
};

/// Inputs of the speed plan: every limit the scan speed must honour.
struct SpeedPlanLimits {
  double feed_mm_s = 10;                       ///< requested speed
  double machine_speed_mm_s = 300;             ///< machine path speed limit
  double acceleration_mm_s2 = 1000;            ///< tangential acceleration used to change speed
  double centripetal_mm_s2 = 500;              ///< centripetal acceleration limit
  double probe_natural_frequency_rad_s = 350;  ///< sqrt(stiffness / stylus mass)
  double reference_deflection_mm = 0.3;        ///< E0
  double end_speed_mm_s = 0.5;                 ///< speed at the path's start and end (a creep, not a stop)
};

/// The path speed Vf as a function of arc length (SEEDS.md 1: "magnitude from the path curvature
/// at i"): the lowest of the limits at each point, then forward and backward passes that keep the
/// tangential acceleration within its limit.
class SpeedPlan {
 public:
  /// Samples the path every `step_mm` of its parameter.
  SpeedPlan(const geometry::PccPath& path, const SpeedPlanLimits& limits, double step_mm = 0.05);
  /// The speed the controller commands at arc length s (interpolated).
  [[nodiscard]] double speed_at(double s_mm) const;
  /// The lowest of the speed limits (without the acceleration passes) at s: the bound a
  /// measured speed must stay under.
  [[nodiscard]] double limit_at(double s_mm) const;
  /// Which limit binds where, merged into stretches.
  [[nodiscard]] const std::vector<SpeedLimitSpan>& spans() const { return m_spans; }
  /// One line per stretch: "0.000-12.500 mm: centripetal, >= 8.944 mm/s".
  [[nodiscard]] std::vector<std::string> log() const;

 private:
  [[nodiscard]] double interpolate(const std::vector<double>& v, double s_mm) const;
  std::vector<double> m_s;      ///< arc length of each sample
  std::vector<double> m_limit;  ///< lowest static limit
  std::vector<double> m_speed;  ///< planned speed
  std::vector<SpeedLimitSpan> m_spans;
};

}  // namespace metron::machine
