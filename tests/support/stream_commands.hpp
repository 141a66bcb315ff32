// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <vector>

#include <tl/expected.hpp>

#include "metron/machine/fault.hpp"
#include "metron/machine/measurement_command.hpp"
#include "metron/machine/segmented_scanning/segmented_controller.hpp"

// A host loop wired straight to the simulated segmented controller, without the command
// interface: for the tests and the benchmark that study the controller alone. The runtime's host
// (runtime/scan_segmentation.hpp) talks to a machine only through machine::Machine.
namespace metron::test_support {

/// Streams `commands` into `controller`: writes the next command whenever a buffer is writable
/// (SB = 0), then advances the controller one cycle, until the path is scanned; a fault when a
/// load is refused or the run exceeds `max_time_s` of simulated time.
tl::expected<machine::segmented::SegmentedStats, machine::Fault> stream_commands(
    const std::vector<machine::segmented::MeasurementCommand>& commands,
    machine::segmented::SegmentedController& controller, double max_time_s);

}  // namespace metron::test_support
