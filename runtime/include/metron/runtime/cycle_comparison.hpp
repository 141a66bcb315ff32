// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/runtime/characterisation.hpp"

/// Touch cycles side by side on a machine (issue 11: the benchmark's conventional baselines from
/// the command line, `metron characterise --compare`): the baselines a careful installer would
/// set and the characterised cycles, timed by the controller clock on the characterisation's own
/// touch point, with their bias against constant-speed touches. Nothing here reads the world.
namespace metron::runtime {

/// One cycle's figures.
struct CycleComparisonRow {
  std::string name;       ///< what the cycle is
  bool baseline = false;  ///< a conventional baseline (not derived from the characterisation)
  double time_s = 0;      ///< mean cycle time, start and end at rest at the clearance
  double bias_um = 0;     ///< mean error against constant-speed touches at the measuring feed
  double spread_um = 0;   ///< range of the errors over the band
};

/// How the cycles are run.
struct CycleComparisonSettings {
  double clearance_mm = 2.0;      ///< start and end at rest this far above nominal + effective radius
  double positioning_mm_s = 200;  ///< positioning feed of every cycle
  int points = 40;                ///< nominal offsets spread over +-nominal tolerance
};

/// The rows and where they were taken.
struct CycleComparison {
  std::vector<CycleComparisonRow> rows;  ///< baselines first
  Vec3 normal = Vec3::UnitZ();           ///< the touch point's surface normal (the cycles probe along -normal)
};

/// Runs every cycle on `machine` (characterised as `c`, with a tool of `ball_diameter_mm`) on the
/// reference sphere's last qualification point.
tl::expected<CycleComparison, std::string> compare_cycles(machine::Machine& machine, const MachineCharacterisation& c,
                                                          const CycleComparisonSettings& settings = {},
                                                          double ball_diameter_mm = 4.0);

/// The rows as a table; `limit_s` > 0 adds a ratio column against it.
std::string format_cycle_comparison(const std::vector<CycleComparisonRow>& rows, double threshold_mm,
                                    double limit_s = 0);

}  // namespace metron::runtime
