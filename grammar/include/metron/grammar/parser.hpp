// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include "metron/grammar/ast.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/source.hpp"

namespace metron::grammar {

/// How the reader treats what shop software writes besides DMIS (docs/language.md "Lenient reading").
struct ParseOptions {
  /// false (the default): a line that is not a DMIS statement at all (an operator note, a
  /// separator line: no major word followed by `/`, `=` or a label) is one warning and skipped;
  /// true: it is a syntax error like any other.
  bool strict = false;
};

/// Parses one source file into statements. Syntax errors are reported to `sink` with physical
/// positions; the parser resynchronises at the next logical line so all errors are reported.
/// Lines after ENDFIL are parsed without diagnostics (the compiler reports them once).
Program parse_program(const SourceManager& sources, std::uint32_t file, DiagnosticSink& sink,
                      const ParseOptions& options = {});

/// Whether `upper_word` is a DMIS 5.3 major word (FEAT, MEAS, ...).
bool is_major_word(std::string_view upper_word);

/// Whether a logical line reads as a DMIS statement attempt: a jump label `(name)`, a line with a
/// `/` or `=`, a word followed by `(`, `[` or nothing, or a DMIS major word (so `FEAT PLANE` is a
/// statement with an error, `Operator: turn the part` is not a statement).
bool looks_like_statement(std::string_view line);

/// Whether `word` (upper-case) is a DMIS label prefix (F, FA, DAT, ...).
bool is_label_prefix(std::string_view word);

}  // namespace metron::grammar
