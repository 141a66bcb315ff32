// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/machine/world.hpp"

namespace metron::machine {

/// The cycle the touch benchmark and its tests compare every strategy with (docs/touch-trigger.md,
/// "physical limit"): one touch that starts at rest `clearance_mm` above nominal + effective
/// radius, measures at constant `feed_mm_s` a surface anywhere within +-`tolerance_mm` of its
/// nominal, and ends at rest `clearance_mm` above the latched point. Derived from the world's
/// hidden truth alone (true ramps, pre-travel, delays), not from any planner's formula.
struct TouchCycleLimit {
  /// Distance from the start to the earliest possible contact: the feed must be reached (with
  /// zero acceleration) by here. Contact happens q = pre-travel + F_q * mean delay closer to the
  /// start than nominal + effective radius (the qualified radius absorbed q), and the surface
  /// may be `tolerance` higher: clearance - q - tolerance.
  double reach_mm = 0;
  double q_mm = 0;            ///< pre-travel + qualification feed * mean delay (true)
  double time_s = 0;          ///< mean cycle time over the band, jerk-limited moves
  double no_jerk_time_s = 0;  ///< the same with acceleration limits only: a looser, simpler lower bound
};

/// The limit along unit `direction` (from the start toward the surface) on `config` + `truth`,
/// the tool qualified at `qualification_feed_mm_s`, positioning at `positioning_feed_mm_s`.
TouchCycleLimit touch_cycle_limit(const MachineConfig& config, const WorldTruth& truth, const Vec3& direction,
                                  double feed_mm_s, double clearance_mm, double tolerance_mm,
                                  double positioning_feed_mm_s, double qualification_feed_mm_s);

}  // namespace metron::machine
