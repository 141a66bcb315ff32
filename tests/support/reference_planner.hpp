// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>

#include "metron/machine/segmented_scanning/scan_recorder.hpp"
#include "metron/machine/segmented_scanning/speed_plan.hpp"
#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::test_support {

/// The limit every mode is compared with: the whole path in the interpolator's horizon (no
/// buffers, no planning time), rest to rest under the same limits.
struct ReferenceProfile {
  double time_s = 0;         ///< scan time of the reference motion
  double lower_bound_s = 0;  ///< sum of length / speed limit: no acceleration or jerk cost at all
  double length_mm = 0;      ///< path length
  std::size_t cycles = 0;    ///< control cycles
};

/// Runs the reference motion (used only for comparison); `recorder` gets every cycle.
ReferenceProfile reference_profile(const geometry::PccPath& path, const machine::segmented::ScanLimits& limits,
                                   double dt_s, machine::segmented::ScanRecorder* recorder = nullptr);

}  // namespace metron::test_support
