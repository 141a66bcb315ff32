// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/interpreter/ir/instruction.hpp"
#include "metron/runtime/measurement_runtime.hpp"
#include "metron/stdlib/diagnostic.hpp"

namespace metron::interpreter::passes {

/// The probing-feed pass: with a machine characterisation loaded, every constant probing feed
/// (FEDRAT/MESVEL with a literal value, in the program, its called files and its macros) is checked
/// against the characterised feeds before any motion; each refusal is reported as
/// `run.probing-feed`. Feeds computed at run time or given in PCENT are checked when they run.
void check_probing_feeds(const ir::Module& module, const runtime::MeasurementRuntime& runtime, DiagnosticSink& sink);

}  // namespace metron::interpreter::passes
