// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <vector>

#include "metron/stdlib/geometry/pcc.hpp"

namespace metron::machine::segmented {

/// One measurement command Ci: a run of consecutive PCC segments of the scan path (SEEDS.md 2).
/// The one type for it on both sides of the wall: the host (runtime) cuts a path into these, sends
/// each in a ScanBufferWrite, and the controller's buffers hold it as sent.
struct MeasurementCommand {
  std::size_t index = 0;                       ///< i (0-based, consecutive)
  std::size_t first_segment = 0;               ///< index of its first segment in the whole path
  std::vector<geometry::PccSegment> segments;  ///< the segments (at most one buffer's capacity)
  /// Nominal surface normals at the segment ends (segments.size() + 1), or empty.
  std::vector<Vec3> normals;
  std::vector<double> speed_mm_s;  ///< per-segment speed limit from the path (may be empty)
  bool last = false;               ///< Cn+1: the path ends with it
};

}  // namespace metron::machine::segmented
