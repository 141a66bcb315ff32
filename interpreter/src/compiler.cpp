// SPDX-License-Identifier: GPL-3.0-or-later
// The Compiler: units, called files and the REPL's entries; the statements are compiled by
// detail::UnitCompiler (compile/), one file per DMIS statement family.
#include "metron/interpreter/compiler.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include <fmt/format.h>

#include "compile/unit_compiler.hpp"
#include "metron/grammar/parser.hpp"
#include "passes/actuals_pass.hpp"

namespace metron::interpreter {

using detail::UnitCompiler;

Compiler::Compiler(SourceManager& sources, DiagnosticSink& sink) : m_sources(sources), m_sink(sink) {}

// A file with no DMISMN whose lines mostly are not DMIS statements (a text, a report, source code,
// a package's language with no signature recognise_foreign_dialect knows) is told once, not with
// an error or a warning on each line, and nothing of it is compiled. A DMIS module without DMISMN
// (a CALL/EXTERN file) reads as DMIS line by line and is compiled as before.
bool Compiler::reads_as_dmis(std::uint32_t file, const grammar::Program& program, const DiagnosticSink& parsed) {
  const bool has_start =
      program.first_word == "DMISMN" || std::any_of(program.statements.begin(), program.statements.end(),
                                                    [](const grammar::Statement& s) { return s.major == "DMISMN"; });
  if (has_start) return true;
  std::set<std::uint32_t> failed_lines;
  Span first;
  for (const auto& d : parsed.items()) {
    if (d.code.rfind("parse.", 0) != 0 || d.span.file != file || d.severity == Severity::Note) continue;
    const std::uint32_t line = m_sources.locate(d.span).line;
    if (failed_lines.insert(line).second && (first.file == 0 || d.span.begin < first.begin)) first = d.span;
  }
  constexpr std::size_t k_min_failed_lines = 5;
  const std::size_t read = program.statements.size();
  if (failed_lines.size() < k_min_failed_lines || failed_lines.size() < 2 * read) return true;
  m_sink.error(
      "parse.not-dmis", first,
      fmt::format("this file does not read as DMIS: {} of its lines are not DMIS statements (this is the first), "
                  "{} {}, and it has no DMISMN; nothing of it is compiled. metron runs DMIS 5.x programs",
                  failed_lines.size(), read, read == 1 ? "line reads as one" : "lines read as statements"));
  return false;
}

std::size_t Compiler::compile_program(std::uint32_t file, const std::string& path, UnitKind kind) {
  if (kind != UnitKind::ReplEntry) {
    if (const auto foreign = grammar::recognise_foreign_dialect(m_sources.file(file).text)) {
      // One clear error, not a syntax error on each of its lines; nothing of it is compiled.
      std::string_view line = m_sources.line_text(file, foreign->offset);
      line.remove_prefix(std::min(line.size(), line.find_first_not_of(" \t")));
      line = line.substr(0, line.find_last_not_of(" \t\r") + 1);
      const auto width = std::max<std::uint32_t>(1, static_cast<std::uint32_t>(line.size()));
      const std::string message =
          foreign->dialect == "I++ DME"
              ? fmt::format(
                    "this file is not DMIS: it reads as an I++ DME command stream, a client's tagged commands ({} "
                    "here, and no DMISMN). metron answers such commands as a server: `metron serve --world W` "
                    "(docs/ipp-dme.md)",
                    foreign->statement)
              : fmt::format(
                    "this file is not DMIS: it reads as a part program in {}'s own language ({} here, and no "
                    "DMISMN). metron runs DMIS 5.x programs: this one needs {}, or a DMIS export of it",
                    foreign->dialect, foreign->statement, foreign->dialect);
      m_sink.error("parse.foreign-language", Span{file, foreign->offset, foreign->offset + width}, message);
      const std::size_t unit = m_module.units.size();
      m_module.units.push_back({path, file, {}});
      return unit;
    }
  }
  DiagnosticSink parsed;
  const grammar::Program program = grammar::parse_program(m_sources, file, parsed, m_parse_options);
  if (kind != UnitKind::ReplEntry && !reads_as_dmis(file, program, parsed)) {
    const std::size_t unit = m_module.units.size();
    m_module.units.push_back({path, file, {}});
    return unit;
  }
  for (const auto& d : parsed.items()) m_sink.report(d);
  const std::size_t unit = m_module.units.size();
  m_module.units.push_back({path, file, {}});
  UnitCompiler uc(
      m_symbols, m_module, m_sources, m_sink, unit,
      [this](const std::string& p, const std::string& written, Span from) { return compile_file(p, from, written); });
  uc.set_included(unit > 0);
  uc.set_strict(m_parse_options.strict);
  uc.set_read_policy(&m_policy);
  uc.compile(program, kind == UnitKind::ReplEntry);
  // The main program compiles its called files as it goes: the whole program is known now.
  if (unit == 0 && kind != UnitKind::ReplEntry) passes::warn_features_never_measured(m_module, m_sources, m_sink);
  return unit;
}

std::optional<ir::Expr> Compiler::compile_expression(const std::string& text,
                                                     const std::set<std::string>& runtime_names) {
  const std::uint32_t file = m_sources.add("<expression>", "EXPR/" + text + "\n");
  const grammar::Program program = grammar::parse_program(m_sources, file, m_sink);
  if (program.statements.size() != 1 || program.statements[0].params.size() != 1) {
    if (!m_sink.has_errors()) m_sink.error("repl.expression", Span{file, 5, 5}, "expected one expression");
    return std::nullopt;
  }
  UnitCompiler uc(m_symbols, m_module, m_sources, m_sink, 0,
                  [](const std::string&, const std::string&, Span) { return std::optional<std::size_t>(); });
  uc.set_runtime_names(runtime_names);
  return uc.standalone_expression(program.statements[0].params[0]);
}

std::optional<std::size_t> Compiler::compile_file(const std::string& path, Span included_from,
                                                  const std::string& written) {
  const std::string& shown = written.empty() ? path : written;
  // A pipe (`metron check /dev/stdin`) has no canonical path: the error_code overload does not
  // throw, and the path as given is the key.
  std::error_code ec;
  std::string key = std::filesystem::weakly_canonical(path, ec).string();
  if (ec || key.empty()) key = path;
  if (m_symbols.units_in_progress.count(key)) {
    m_sink.error("sema.recursive-call", included_from, fmt::format("{} calls itself through CALL/EXTERN", shown));
    return std::nullopt;
  }
  // A file called several times is compiled once: its definitions are not redefinitions.
  if (auto done = m_symbols.compiled_units.find(key); done != m_symbols.compiled_units.end() && included_from.valid())
    return done->second;
  if (!included_from.valid()) {
    // The main program: its folder and the --include folders are what CALL/EXTERN may read.
    std::vector<std::string> dirs{std::filesystem::path(path).parent_path().string()};
    dirs.insert(dirs.end(), m_include_dirs.begin(), m_include_dirs.end());
    m_policy = FileAccessPolicy(dirs, ".");
  } else if (auto refused = m_policy.refuse_read(path)) {
    m_sink.error("io.refused", included_from, "CALL/EXTERN,DMIS: " + *refused);
    return std::nullopt;
  }
  auto text = read_input_file(path);
  if (!text) {
    const std::string reason = text.error().substr(text.error().rfind(": ") + 2);
    m_sink.error("io.cannot-read", included_from,
                 reason == "no such file" ? fmt::format("cannot read {}", shown)
                                          : fmt::format("cannot read {}: {}", shown, reason));
    return std::nullopt;
  }
  // CR-only line ends (classic Mac OS) made the whole file one line, a leading comment swallowing
  // every statement: read them as line ends (same length, so positions are unchanged).
  bool cr_only = text->find('\r') != std::string::npos && text->find('\n') == std::string::npos;
  if (cr_only) std::replace(text->begin(), text->end(), '\r', '\n');
  const std::uint32_t file = m_sources.add(path, std::move(*text));
  m_symbols.units_in_progress.insert(key);
  const std::size_t unit = compile_program(file, path, UnitKind::File);
  m_symbols.units_in_progress.erase(key);
  if (included_from.valid()) m_symbols.compiled_units[key] = unit;
  return unit;
}

std::size_t Compiler::compile_text(const std::string& name, const std::string& text, UnitKind kind) {
  const std::uint32_t file = m_sources.add(name, text);
  return compile_program(file, name, kind);
}

std::vector<std::string> Compiler::statement_words() {
  std::vector<std::string> words;
  for (const auto& [word, handler] : UnitCompiler::statements())
    if (word != UnitCompiler::assignment_row) words.push_back(word);
  return words;
}

}  // namespace metron::interpreter
