// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/fault.hpp"
#include "metron/machine/machine.hpp"
#include "metron/machine/measurement_command.hpp"
#include "metron/stdlib/geometry/pcc.hpp"

// Host side of segmented continuous scanning (SEEDS.md 2 steps 1-2): cut the path into
// measurement commands and stream them into the controller's buffers as they free up.
namespace metron::runtime {

/// Segment counts of C1..Cn+1 for a path of `segments` (M) segments and buffers of `per_command`
/// (P) segments. With M = P*n + m: m = 0 gives n commands of P; m >= P/4 a last command of m;
/// 0 < m < P/4 (4m < P) the last two commands share P+m, (P+m)/2 each; when P+m is odd the
/// earlier one gets the extra segment, so the last command (the one that ends at rest) is the
/// shorter. A path shorter than one buffer is one command.
std::vector<std::size_t> command_sizes(std::size_t segments, std::size_t per_command);

/// The measurement commands of `path` split with command_sizes().
std::vector<machine::segmented::MeasurementCommand> split_commands(const geometry::PccPath& path,
                                                                   std::size_t per_command);

/// What a streamed scan returned.
struct SegmentedScanResult {
  std::vector<machine::ScanSample> samples;  ///< every sample, in path order (up to a fault)
  std::optional<machine::Fault> fault;       ///< why the scan stopped early
  std::size_t commands = 0;                  ///< measurement commands written (0: one ScanPath)
  std::vector<std::string> log;              ///< the machine's scan log lines
};

/// The machine commands for one scan (SEEDS.md 2 step 1 on the command interface): the ScanPath
/// itself when it fits a buffer of `capacity` segments (or capacity is 0), else one
/// ScanBufferWrite per measurement command of split_commands(). Queued in order, the machine
/// takes each when a buffer is free and answers it with the samples recorded meanwhile.
std::vector<machine::Command> scan_commands(const machine::ScanPath& scan, std::size_t capacity);

/// Scans `scan` on `machine` (SEEDS.md 2 steps 1-2 over the command interface): a path that fits
/// one command buffer (MachineState::scan_buffer_segments) goes as one ScanPath; a longer one is
/// split with split_commands() and written command by command as ScanBufferWrite, each once the
/// machine has answered the previous (it answers when a buffer was free). The host only calls
/// down (ARCHITECTURE.md rule 6): the machine never asks for the next command, it answers.
SegmentedScanResult scan_segmented(machine::Machine& machine, const machine::ScanPath& scan, std::uint64_t tag);

}  // namespace metron::runtime
