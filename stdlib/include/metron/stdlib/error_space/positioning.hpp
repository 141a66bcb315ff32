// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include <tl/expected.hpp>

/// ISO 230-2:2014 positioning measurement records (a laser interferometer along one axis of
/// motion: targets, bidirectional runs, cycles) and their evaluation. The records are plain data
/// with a documented CSV form (docs/error-space.md) that the model-discrepancy analysis reads too.
namespace metron::error_space {

/// One reading: the deviation of the actual from the target position at one target of one run.
struct PositioningRecord {
  int axis = 0;             ///< 0 x, 1 y, 2 z: the axis of motion
  int target = 0;           ///< target index i (0-based)
  double target_mm = 0;     ///< target position P_i (scale reading)
  int cycle = 0;            ///< run number j (0-based)
  int direction = 1;        ///< +1 approached moving in +, -1 in - (ISO 230-2 up/down arrows)
  double deviation_mm = 0;  ///< x_ij = actual - target (laser reading minus target, zeroed at the first target)
  double time_s = 0;        ///< simulated time of the reading
  double line_u_mm = 0;     ///< position of the measuring line on the first other axis (ascending order)
  double line_v_mm = 0;     ///< ... and on the second
};

/// ISO 230-2 evaluation per target.
struct TargetEvaluation {
  double target_mm = 0;     ///< P_i
  double mean_up_mm = 0;    ///< mean unidirectional positional deviation, + direction
  double mean_down_mm = 0;  ///< same, - direction
  double sd_up_mm = 0;      ///< estimator of the unidirectional standard uncertainty s_i up
  double sd_down_mm = 0;    ///< s_i down
  double reversal_mm = 0;   ///< B_i = mean up - mean down
  double mean_mm = 0;       ///< mean bidirectional positional deviation (up + down) / 2
};

/// ISO 230-2 evaluation of one axis.
struct PositioningEvaluation {
  std::vector<TargetEvaluation> targets;  ///< per target, in target order
  double reversal_max_mm = 0;             ///< B = max |B_i|
  double systematic_mm = 0;               ///< E: max - min over the unidirectional means
  double repeatability_mm = 0;            ///< R: max over i of 4 s_i (the larger direction) and the bidirectional range
  double accuracy_mm = 0;                 ///< A: max(mean + 2s) - min(mean - 2s) over both directions
};

/// Evaluates the records of one axis (all directions and cycles). An error message when a target
/// lacks a direction or the records mix axes.
tl::expected<PositioningEvaluation, std::string> evaluate_positioning(const std::vector<PositioningRecord>& records);

/// The CSV form: a header line, then one record per line (docs/error-space.md).
std::string positioning_csv(const std::vector<PositioningRecord>& records);
/// Reads the CSV form; an error "line N: what was expected".
tl::expected<std::vector<PositioningRecord>, std::string> parse_positioning_csv(const std::string& text);

}  // namespace metron::error_space
