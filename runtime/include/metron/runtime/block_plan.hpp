// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "metron/machine/command.hpp"
#include "metron/machine/machine.hpp"
#include "metron/runtime/alignment.hpp"
#include "metron/runtime/characterisation.hpp"
#include "metron/runtime/feature.hpp"
#include "metron/runtime/requests.hpp"
#include "metron/runtime/runtime_error.hpp"
#include "metron/runtime/scan.hpp"
#include "metron/stdlib/geometry/contour.hpp"
#include "metron/stdlib/span.hpp"

// Planning a MEAS block: from the block and the program's settings to the machine commands that
// measure it, without a machine (the runtime then submits them and collects the points).
namespace metron::runtime {

/// What planning a MEAS block reads: the program's settings and the machine's state when the
/// block starts. Nothing here is sent to the machine.
struct BlockPlanContext {
  Alignment alignment;                                           ///< the current frame: the block's points are in it
  ProbeSettings probe;                                           ///< SNSET
  ScanSettings scan;                                             ///< SCNMOD, SCNSET, FEDRAT/SCNVEL
  Mode mode = Mode::Auto;                                        ///< MODE
  const std::map<std::string, PathDefinition>* paths = nullptr;  ///< P(label) definitions (MCS); null: none
  const MachineCharacterisation* characterisation = nullptr;     ///< null: the machine is not characterised
  std::optional<TouchBaseline> touch_baseline;  ///< `run --touch-baseline`: this cycle instead of the characterised one
  std::optional<double> measuring_feed_mm_s;  ///< FEDRAT/MESVEL as the program gave it (overrides the characterisation)
  machine::MachineState state;                ///< position, active tool, feeds and scan buffer size
};

/// The machine commands of one MEAS block, in order, with the statement each comes from.
struct BlockPlan {
  std::vector<machine::Command> commands;   ///< tags 0: numbered when submitted
  std::vector<Span> spans;                  ///< one a command: the PTMEAS, PAMEAS or MEAS it implements
  std::vector<double> measuring_feed_mm_s;  ///< one a command: a PtMeas's probing feed, 0 for the others
};

/// The commands that measure `block` on a feature with nominal `nominal` (MCS): its GOTO, PTMEAS
/// and PAMEAS steps in order; in scan mode (SCNMOD/ON) PTMEAS pairs as scans, or the nominal
/// scanned when there are none; with no steps, the automatic points of measurement_plan.hpp.
/// Errors are the program's (an undefined path, a zero direction, an unpaired scan PTMEAS ...).
Result<BlockPlan> plan_block(const MeasBlock& block, const Geometry& nominal, const BlockPlanContext& context);

/// Whether the block's steps take points (PTMEAS, a scan), not moves alone: without, plan_block
/// plans the points (AUTO, a nominal scan) when the block lets it.
bool takes_points(const MeasBlock& block);

/// The machine command that scans `contour` (MCS) with the context's tool, scan and probe settings.
Result<machine::ScanPath> scan_command(const geometry::Contour& contour, const BlockPlanContext& context, Span span);

}  // namespace metron::runtime
