// SPDX-License-Identifier: GPL-3.0-or-later
// parse_program: one PEGTL parse per logical line; errors become diagnostics and the parser
// moves on to the next line.
#include "metron/grammar/parser.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "detail/actions.hpp"
#include "detail/builder.hpp"
#include "detail/errors.hpp"
#include "detail/rules.hpp"
#include "metron/grammar/preprocess.hpp"

namespace metron::grammar {
namespace {

namespace pegtl = tao::pegtl;

// DMIS label prefixes (sorted for binary search).
constexpr std::array<std::string_view, 63> label_prefixes = {
    "A",  "CI", "CR", "CS", "CZ", "D",  "DA", "DAT", "DATT", "DI", "DID", "DME", "DR", "DS", "DV", "F",
    "FA", "FI", "FS", "G",  "GS", "K",  "KC", "KV",  "L",    "LI", "M",   "MA",  "MD", "ML", "OP", "P",
    "PC", "PL", "PN", "PR", "PS", "PV", "Q",  "QIS", "R",    "RM", "RT",  "S",   "SA", "SE", "SG", "SS",
    "ST", "SW", "SX", "T",  "TA", "TL", "TP", "U",   "V",    "VA", "VF",  "VL",  "VR", "VS", "VW"};
static_assert(std::is_sorted(label_prefixes.begin(), label_prefixes.end()));

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// The label a line defines (`DID(xls) = DEVICE/...` gives "DID(XLS)"), read from its text alone, for
// a line the parser could not read; an actual's prefix is read as its nominal's (FA as F).
std::optional<std::string> defined_label(std::string_view text) {
  std::size_t i = 0;
  const auto skip_blanks = [&] {
    while (i < text.size() && is_blank(text[i])) ++i;
  };
  skip_blanks();
  std::string prefix;
  while (i < text.size() && std::isalpha(static_cast<unsigned char>(text[i])))
    prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(text[i++])));
  skip_blanks();
  if (prefix.empty() || i >= text.size() || text[i] != '(') return std::nullopt;
  const std::size_t close = text.find(')', i);
  if (close == std::string_view::npos) return std::nullopt;
  std::string name;
  for (std::size_t k = i + 1; k < close; ++k)
    if (!is_blank(text[k])) name += static_cast<char>(std::toupper(static_cast<unsigned char>(text[k])));
  i = close + 1;
  skip_blanks();
  if (name.empty() || i >= text.size() || text[i] != '=') return std::nullopt;
  if (prefix.size() == 2 && prefix[1] == 'A' && std::string_view("FDTS").find(prefix[0]) != std::string_view::npos)
    prefix.pop_back();
  return prefix + "(" + name + ")";
}

// Parses one logical line; returns false after reporting a syntax error.
bool parse_line(const LogicalLine& line, std::uint32_t file, DiagnosticSink& sink, Statement& out, bool lenient,
                bool& blank_label_told) {
  detail::Builder b;
  b.file = file;
  b.line = &line;
  b.base = line.text.data();
  try {
    pegtl::memory_input<pegtl::tracking_mode::lazy> in(line.text.data(), line.text.size(), "");
    if (!pegtl::parse<rules::line, detail::action, detail::control>(in, b)) {
      // Unreachable: `line` ends in must<>, which raises instead of failing.
      sink.error("parse.internal", b.point(b.base), "statement could not be parsed");
      return false;
    }
  } catch (const detail::SyntaxError& e) {
    // `XX(name)=MAJOR/...` with a label prefix metron does not know (a vendor's, a newer DMIS's):
    // read leniently, the statement is skipped as an unknown statement is.
    if (lenient && e.code == "parse.unknown-label-prefix")
      sink.warning("parse.unknown-label-prefix", e.span,
                   e.message + ": the statement is skipped (--strict makes it an error)");
    else
      sink.error(e.code, e.span, e.message);
    return false;
  } catch (const std::exception& e) {
    sink.error("parse.internal", b.point(b.base), std::string("internal parser error: ") + e.what());
    return false;
  }
  // The statement runs from its first to its last non-blank byte, across continuation lines.
  std::size_t first = 0, last = line.text.size();
  while (first < last && is_blank(line.text[first])) ++first;
  while (last > first && is_blank(line.text[last - 1])) --last;
  b.stmt.span = b.span(b.base + first, b.base + last);
  if (b.blank_in_label && !lenient) {
    sink.error("parse.blank-in-label", *b.blank_in_label, "a label name has no blanks");
    return false;
  }
  if (b.blank_in_label && !blank_label_told) {
    blank_label_told = true;
    sink.warning("parse.blank-in-label", *b.blank_in_label,
                 "a label name written with blanks: they are dropped (F(HOLE 1) is F(HOLE1)); told once per file, "
                 "--strict makes it an error");
  }
  out = std::move(b.stmt);
  return true;
}

// Where a label starts at `at` (after blanks): the offset of its `(` when a DMIS label prefix
// (F, FA, DAT ...) and `(` follow.
std::optional<std::size_t> label_opening(const std::string& t, std::size_t at) {
  while (at < t.size() && is_blank(t[at])) ++at;
  std::string prefix;
  std::size_t p = at;
  while (p < t.size() && std::isalpha(static_cast<unsigned char>(t[p])))
    prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(t[p++])));
  if (prefix.empty() || p >= t.size() || t[p] != '(' || !is_label_prefix(prefix)) return std::nullopt;
  return p;
}

// `F(A02F1=FEAT/POINT,...`: a generator that left out the `)` of the label being defined (a
// public lab generator of CAMIO programs writes this). When a label prefix, `(`, a name with no
// parenthesis, `=`, a DMIS major word and `/` follow each other, the `)` is put back before the
// `=`; returns the logical offset where it went.
std::optional<std::size_t> restore_target_close(LogicalLine& line) {
  const std::string& t = line.text;
  const auto open = label_opening(t, 0);
  if (!open) return std::nullopt;
  const std::size_t p = *open;
  const std::size_t eq = t.find('=', p + 1);
  if (eq == std::string::npos || eq == p + 1 || t.find_first_of("()'", p + 1) < eq) return std::nullopt;
  std::size_t m = eq + 1;
  while (m < t.size() && is_blank(t[m])) ++m;
  std::string major;
  while (m < t.size() && std::isalpha(static_cast<unsigned char>(t[m])))
    major += static_cast<char>(std::toupper(static_cast<unsigned char>(t[m++])));
  while (m < t.size() && is_blank(t[m])) ++m;
  if (m >= t.size() || t[m] != '/' || !is_major_word(major)) return std::nullopt;
  std::size_t close = eq;
  while (close > p + 1 && is_blank(t[close - 1])) --close;
  line.text.insert(close, 1, ')');
  line.physical.insert(line.physical.begin() + static_cast<std::ptrdiff_t>(close), line.physical[close]);
  return close;
}

// `FA(E02F4)FA(F02F1)`: a generator that left out the comma between two labels (a public lab
// generator of CAMIO programs writes this in long CONST lists). Outside strings, a `)` followed
// by a label prefix and `(` gets its comma back; returns the logical offsets where commas went.
std::vector<std::size_t> restore_commas_between_labels(LogicalLine& line) {
  std::vector<std::size_t> restored;
  bool in_string = false;
  for (std::size_t i = 0; i < line.text.size(); ++i) {
    const char c = line.text[i];
    if (c == '\'') in_string = !in_string;
    if (in_string || c != ')' || !label_opening(line.text, i + 1)) continue;
    line.text.insert(i + 1, 1, ',');
    line.physical.insert(line.physical.begin() + static_cast<std::ptrdiff_t>(i + 1), line.physical[i + 1]);
    restored.push_back(i + 1);
  }
  return restored;
}

// A report's value as a DMIS output file writes it after OUTPUT/R(x): `DATE = 2026/01/01`,
// `TIME = 07:05:05`, `PN(TEIL_NR)= '123456789'` (a label, '=', a string; no major word).
bool report_value_line(const std::string& text) {
  std::size_t i = 0;
  const auto skip_blanks = [&] {
    while (i < text.size() && is_blank(text[i])) ++i;
  };
  skip_blanks();
  const std::size_t word_begin = i;
  while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_')) ++i;
  if (i == word_begin || !std::isalpha(static_cast<unsigned char>(text[word_begin]))) return false;
  std::string word = text.substr(word_begin, i - word_begin);
  for (auto& c : word) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  const bool labelled = i < text.size() && text[i] == '(';
  if (labelled) {
    const std::size_t close = text.find(')', i);
    if (close == std::string::npos) return false;
    i = close + 1;
  }
  skip_blanks();
  if (i >= text.size() || text[i] != '=') return false;
  ++i;
  skip_blanks();
  std::size_t end = text.size();
  while (end > i && is_blank(text[end - 1])) --end;
  if (end <= i) return false;
  const std::string value = text.substr(i, end - i);
  if (labelled)  // a string and nothing else
    return value.size() >= 2 && value.front() == '\'' && value.back() == '\'' &&
           value.find('\'', 1) == value.size() - 1;
  return (word == "DATE" || word == "TIME") && value.find_first_not_of("0123456789/:.- ") == std::string::npos;
}

// `word / CHFILE` (blanks around the slash, any case): where WinWerth's characterisation block
// begins (BEGIN) or ends (END).
bool block_word(const std::string& text, std::string_view word) {
  std::string squeezed;
  for (const char c : text)
    if (!is_blank(c)) squeezed += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return squeezed == std::string(word) + "/CHFILE";
}

}  // namespace

bool is_label_prefix(std::string_view word) {
  return std::binary_search(label_prefixes.begin(), label_prefixes.end(), word);
}

bool looks_like_statement(std::string_view line) {
  std::size_t i = 0;
  while (i < line.size() && is_blank(line[i])) ++i;
  if (i == line.size() || line[i] == '(') return true;
  const auto alpha = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
  const auto alnum = [&](char c) { return alpha(c) || (c >= '0' && c <= '9') || c == '_'; };
  // A separator of symbols only (`//////`, `=====`, `-----`) is a note, whatever its symbols.
  if (std::none_of(line.begin() + static_cast<std::ptrdiff_t>(i), line.end(), alnum)) return false;
  // `=FEAT/PLANE`, `12=...`: a statement with an error, not a note.
  if (line.find_first_of("/=") != std::string_view::npos) return true;
  if (!alpha(line[i])) return false;
  const std::size_t word_begin = i;
  while (i < line.size() && alnum(line[i])) ++i;
  std::string word(line.substr(word_begin, i - word_begin));
  for (auto& c : word) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  while (i < line.size() && is_blank(line[i])) ++i;
  if (i == line.size() || std::string_view("/=([").find(line[i]) != std::string_view::npos) return true;
  return is_major_word(word);
}

Program parse_program(const SourceManager& sources, std::uint32_t file, DiagnosticSink& sink,
                      const ParseOptions& options) {
  Program program;
  program.file = file;
  if (file == 0 || file > sources.size()) {
    sink.error("parse.no-file", Span{}, "no source file with id " + std::to_string(file));
    return program;
  }
  DiagnosticSink after_endfil;  // what follows ENDFIL is reported once, by the compiler
  bool ended = false, blank_label_told = false, in_chfile = false;
  Span chfile_begin;
  bool report_values_told = false;
  for (LogicalLine& line : join_continuations(sources.file(file).text)) {
    // WinWerth opens its programs with a characterisation block of `KEY = value` lines
    // (BEGIN / CHFILE ... END / CHFILE): settings of its own, not statements; one note.
    if (!ended && !options.strict && (in_chfile || block_word(line.text, "BEGIN"))) {
      if (!in_chfile) {
        chfile_begin = Span{file, line.physical.front(), line.physical.back() + 1};
        sink.report({Severity::Note,
                     "parse.characterisation-block",
                     chfile_begin,
                     "a characterisation block (BEGIN/CHFILE ... END/CHFILE, WinWerth's) is skipped: its settings are "
                     "the writing software's",
                     {}});
      }
      in_chfile = !block_word(line.text, "END");
      program.writer = "WinWerth";
      continue;
    }
    if (!ended && !options.strict && report_value_line(line.text)) {
      if (!report_values_told)
        sink.report({Severity::Note,
                     "parse.report-value",
                     Span{file, line.physical.front(), line.physical.back() + 1},
                     "a report's value, as a DMIS output file writes it after OUTPUT/R(x) (DATE = ..., PN(x) = '...'): "
                     "kept as it is (noted once)",
                     {}});
      report_values_told = true;
      continue;
    }
    if (!ended && !options.strict && !looks_like_statement(line.text)) {
      std::size_t first = 0;
      while (first < line.text.size() && is_blank(line.text[first])) ++first;
      std::size_t last = line.text.size();
      while (last > first && is_blank(line.text[last - 1])) --last;
      sink.warning("parse.not-a-statement", Span{file, line.physical[first], line.physical[last - 1] + 1},
                   "this line is not a DMIS statement and is skipped (an operator note? write it as a $$ comment; "
                   "--strict makes it an error)");
      continue;
    }
    if (program.first_word.empty()) {
      std::size_t i = 0;
      while (i < line.text.size() && is_blank(line.text[i])) ++i;
      while (i < line.text.size() && std::isalnum(static_cast<unsigned char>(line.text[i])))
        program.first_word += static_cast<char>(std::toupper(static_cast<unsigned char>(line.text[i++])));
    }
    if (!ended && !options.strict) {
      if (const auto at = restore_target_close(line))
        sink.warning(
            "parse.missing-close", Span{file, line.physical[*at], line.physical[*at] + 1},
            "the label being defined has no ')' before '=': read as if it had one (--strict makes it an error)");
      for (const std::size_t at : restore_commas_between_labels(line))
        sink.warning("parse.missing-comma", Span{file, line.physical[at], line.physical[at] + 1},
                     "no ',' between two labels: read as if it were there (--strict makes it an error)");
    }
    Statement stmt;
    if (parse_line(line, file, ended ? after_endfil : sink, stmt, !options.strict, blank_label_told)) {
      if (stmt.major == "ENDFIL") ended = true;
      program.statements.push_back(std::move(stmt));
    } else if (auto label = defined_label(line.text)) {
      program.unread_definitions.emplace(*label, Span{file, line.physical.front(), line.physical.back() + 1});
    }
  }
  // A block never closed took the rest of the file with it: the program would measure nothing.
  if (in_chfile)
    sink.error("parse.unclosed-block", chfile_begin,
               "BEGIN/CHFILE is never closed by END/CHFILE: every line after it was skipped as its settings");
  return program;
}

}  // namespace metron::grammar
