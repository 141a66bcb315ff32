// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string>
#include <string_view>

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

/// A part program in a CMM package's own language (PC-DMIS's, MCOSMOS GEOPAK's ASCII), which
/// looks like DMIS but is not: what it reads as and its first line DMIS has no form for.
struct ForeignDialect {
  std::string dialect;       ///< "PC-DMIS", "MCOSMOS GEOPAK"
  std::string statement;     ///< the statement that tells it (`ENDMEAS/`, `CONTOUR/`)
  std::uint32_t offset = 0;  ///< where that line's statement starts in the text
};
/// A file without DMISMN (or DMISMD) holding a statement of one of those languages.
std::optional<ForeignDialect> recognise_foreign_dialect(std::string_view text);

/// Whether `upper_word` is a DMIS 5.3 major word (FEAT, MEAS, ...).
bool is_major_word(std::string_view upper_word);

/// Whether a logical line reads as a DMIS statement attempt: a jump label `(name)`, a line with a
/// `/` or `=`, a word followed by `(`, `[` or nothing, or a DMIS major word (so `FEAT PLANE` is a
/// statement with an error, `Operator: turn the part` is not a statement).
bool looks_like_statement(std::string_view line);

/// Whether `word` (upper-case) is a DMIS label prefix (F, FA, DAT, ...).
bool is_label_prefix(std::string_view word);

}  // namespace metron::grammar
