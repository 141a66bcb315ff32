// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/grammar/ast.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/source.hpp"

namespace metron::grammar {

/// Parses one source file into statements. Syntax errors are reported to `sink` with physical
/// positions; the parser resynchronises at the next logical line so all errors are reported.
Program parse_program(const SourceManager& sources, std::uint32_t file, DiagnosticSink& sink);

/// Whether `word` (upper-case) is a DMIS label prefix (F, FA, DAT, ...).
bool is_label_prefix(std::string_view word);

}  // namespace metron::grammar
