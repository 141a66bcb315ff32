// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/stdlib/diagnostic.hpp"

#include <algorithm>

#include "metron/stdlib/file_access.hpp"

namespace metron {

void DiagnosticSink::report(Diagnostic d) {
  if (d.severity == Severity::Error) {
    if (m_errors > max_errors) return;
    if (++m_errors > max_errors) {
      d.code = "diag.too-many";
      d.message = "too many errors: the first " + std::to_string(max_errors) + " are shown, the rest are not";
    }
  } else if (m_errors > max_errors || m_items.size() > 10 * max_errors) {
    return;
  }
  m_items.push_back(std::move(d));
}

bool DiagnosticSink::has_errors() const { return error_count() > 0; }

std::size_t DiagnosticSink::error_count() const {
  return static_cast<std::size_t>(
      std::count_if(m_items.begin(), m_items.end(), [](const Diagnostic& d) { return d.severity == Severity::Error; }));
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
  out += ": " + printable(d.message, 1000) + "\n";
  if (d.span.valid()) {
    const std::string_view line = sources.line_text(d.span.file, d.span.begin);
    constexpr std::size_t shown = 200;
    out += "  ";
    out += printable(line, shown);
    out += "\n  ";
    const Location loc = sources.locate(d.span);
    if (loc.column <= shown) {
      const std::string before = printable(line.substr(0, std::min<std::size_t>(loc.column - 1, line.size())), shown);
      for (const char c : before) out += c == '\t' ? '\t' : ' ';
      out += "^";
    }
    out += "\n";
  }
  for (const auto& n : d.notes) out += "  note: " + printable(n, 1000) + "\n";
  return out;
}

}  // namespace metron
