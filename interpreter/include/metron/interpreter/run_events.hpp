// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>

#include "metron/runtime/run_record.hpp"

namespace metron::interpreter {

/// A run event as `metron run` and the debugger print it: the feature report block, the tolerance
/// line, the TEXT line or the fault report, each ending with a newline.
std::string event_text(const runtime::RunEvent& event);

/// The latest fault of a run as "kind: message" (the debugger's stop detail), or nullopt.
std::optional<std::string> last_fault(const runtime::RunRecord& record);

/// The latest result of tolerance `label` in a run, or nullptr.
const runtime::ToleranceResult* last_tolerance_result(const runtime::RunRecord& record, const std::string& label);

}  // namespace metron::interpreter
