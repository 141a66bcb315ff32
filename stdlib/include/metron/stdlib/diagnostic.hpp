// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <string>
#include <vector>

#include "metron/stdlib/source.hpp"
#include "metron/stdlib/span.hpp"

namespace metron {

enum class Severity { Note, Warning, Error };

/// A diagnostic is data: collected in a sink, printed as `file:line:col: error: message`.
struct Diagnostic {
  Severity severity = Severity::Error;
  std::string code;     ///< stable identifier, e.g. "parse.expected" or "sema.undefined-feature"
  Span span;            ///< where; invalid span = no position
  std::string message;  ///< lowercase, says what was expected after what
  std::vector<std::string> notes;
};

/// Collects diagnostics from every phase so later phases can report all errors.
class DiagnosticSink {
 public:
  /// Errors kept at most: hostile input (1 MB of random bytes) must not flood the terminal; the
  /// error after the last kept one says how the list was cut.
  static constexpr std::size_t max_errors = 100;
  void report(Diagnostic d);
  void error(std::string code, Span span, std::string message) {
    report({Severity::Error, std::move(code), span, std::move(message), {}});
  }
  void warning(std::string code, Span span, std::string message) {
    report({Severity::Warning, std::move(code), span, std::move(message), {}});
  }
  [[nodiscard]] bool has_errors() const;
  [[nodiscard]] std::size_t error_count() const;
  [[nodiscard]] const std::vector<Diagnostic>& items() const { return m_items; }
  void clear() {
    m_items.clear();
    m_errors = 0;
  }

 private:
  std::vector<Diagnostic> m_items;
  std::size_t m_errors = 0;
};

/// `file:line:col: error: message`, then the source line and a caret under the column. Control
/// bytes of the message and the line are shown escaped (\xNN) and the line is cut at 200 bytes.
std::string format_diagnostic(const Diagnostic& d, const SourceManager& sources);

}  // namespace metron
