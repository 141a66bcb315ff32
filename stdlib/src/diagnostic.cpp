// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/diagnostic.hpp"

#include <algorithm>

namespace metron {

bool DiagnosticSink::has_errors() const { return error_count() > 0; }

std::size_t DiagnosticSink::error_count() const {
  return static_cast<std::size_t>(std::count_if(m_items.begin(), m_items.end(),
      [](const Diagnostic& d) { return d.severity == Severity::Error; }));
}

static const char* severity_word(Severity s) {
  switch (s) {
    case Severity::Note: return "note";
    case Severity::Warning: return "warning";
    case Severity::Error: return "error";
  }
  return "error";
}

std::string format_diagnostic(const Diagnostic& d, const SourceManager& sources) {
  std::string out;
  if (d.span.valid()) {
    const Location loc = sources.locate(d.span);
    out += loc.path + ":" + std::to_string(loc.line) + ":" + std::to_string(loc.column) + ": ";
  }
  out += severity_word(d.severity);
  out += ": " + d.message + "\n";
  if (d.span.valid()) {
    const std::string_view line = sources.line_text(d.span.file, d.span.begin);
    out += "  ";
    out += line;
    out += "\n  ";
    const Location loc = sources.locate(d.span);
    for (std::uint32_t i = 1; i < loc.column && i <= line.size(); ++i)
      out += line[i - 1] == '\t' ? '\t' : ' ';
    out += "^\n";
  }
  for (const auto& n : d.notes) out += "  note: " + n + "\n";
  return out;
}

}  // namespace metron
