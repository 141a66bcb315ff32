// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "metron/runtime/feature.hpp"
#include "metron/runtime/tolerance.hpp"

namespace metron::runtime {

/// A feature as reported by OUTPUT: geometry expressed in the reporting coordinate system.
/// One probed point listed by OUTPUT/FA(x)[first,last], in the report's frame.
struct ListedPoint {
  int index = 0;                      ///< 1-based, in the order the points were taken
  Vec3 surface_mm = Vec3::Zero();     ///< the compensated surface point
  Vec3 approach = Vec3::UnitZ();      ///< the approach (probing) direction
  std::optional<double> residual_mm;  ///< its distance from the fitted feature (+ out of the material)
};

struct FeatureReport {
  std::string label;
  std::string frame = "MCS";       ///< label of the alignment the geometry is expressed in
  Geometry nominal;                ///< in `frame` coordinates
  std::optional<Geometry> actual;  ///< in `frame` coordinates; empty if never measured
  std::optional<FitFigures> fit;
  std::size_t point_count = 0;
  ActualSource source = ActualSource::Measured;
  ReportUnits units;                ///< the program's UNITS and DECPL at the OUTPUT
  std::vector<ListedPoint> points;  ///< OUTPUT/FA(x)[first,last]: those points; else empty
};

/// A position in a source file, resolved for reports (file, line, column).
struct SourcePosition {
  std::string file;
  std::uint32_t line = 0;
  std::uint32_t column = 0;
};

/// A machine fault as the run reports it, with the statement that caused it.
struct FaultReport {
  std::string kind;  ///< machine::to_string(FaultKind)
  std::string message;
  SourcePosition statement;
  std::string statement_text;  ///< the source line of that statement
  Vec3 position_mm = Vec3::Zero();
  double time_s = 0;
};

/// A TEXT/OUTFIL or TEXT/OPER line.
struct TextReport {
  std::string text;
};

/// One thing the run reported, in order.
using RunEvent = std::variant<FeatureReport, ToleranceResult, TextReport, FaultReport>;

/// How a run ended.
/// Refused: not started (bad input, a file the policy does not allow, compile errors before any
/// motion); Interrupted: stopped by SIGINT/SIGTERM or a run limit, the results so far kept.
enum class RunStatus { Completed, Faulted, Error, Refused, Interrupted };

/// Everything a run produced: the input of the report, results.json and the DMIS output file.
struct RunRecord {
  std::string program;  ///< path of the main program
  std::string world;    ///< world name or path
  std::uint64_t seed = 0;
  RunStatus status = RunStatus::Completed;
  std::vector<RunEvent> events;          ///< OUTPUT results, texts and faults, in order
  std::vector<Feature> features;         ///< every feature at the end of the run (MCS), measured points included
  std::vector<std::string> diagnostics;  ///< formatted compile/runtime diagnostics
  std::vector<std::string>
      machine_log;  ///< what the machine logged per command (scan speed limits ...), prefixed with the feature
  double simulated_time_s = 0;
};

}  // namespace metron::runtime
