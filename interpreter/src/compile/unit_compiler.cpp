// SPDX-License-Identifier: GPL-3.0-or-later
// The unit compiler's dispatcher: blocks, jump labels, name checks, the statement table.

#include "compile/unit_compiler.hpp"

#include "metron/grammar/parser.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;

void UnitCompiler::compile(const grammar::Program& program, bool repl) {
  m_repl = repl;
  m_writer = program.writer;
  const auto& st = program.statements;
  // An empty file (or one of comments only) is an error, not a clean check: it is never the
  // program meant. Statements the parser could not read have their own errors.
  if (!repl && !m_included && st.empty()) {
    if (program.first_word.empty())
      error(Span{program.file, 0, 0}, "sema.empty-program",
            "the program has no statements: the file is empty or holds only comments, and measures nothing");
    else
      warn(Span{program.file, 0, 0}, "sema.empty-program",
           "the program has no statements: it does not start with DMISMN nor end with ENDFIL, and measures nothing");
  }
  m_unread_definitions = program.unread_definitions;
  // Features defined anywhere in this unit: a use before its FEAT says where the definition is.
  for (const auto& s : st) {
    if (s.target && upper(s.target->prefix) == "F" && s.major == "FEAT")
      m_later_features.emplace(upper(s.target->name), s.span);
    if (s.target && upper(s.target->prefix) == "T" && s.major == "TOL")
      m_later_tolerances.emplace(upper(s.target->name), s.span);
    if (s.target && upper(s.target->prefix) == "M" && s.major == "MACRO")
      m_later_macros.emplace(upper(s.target->name), s.span);
    if (s.target && ((upper(s.target->prefix) == "FA" && s.major == "FEAT") ||
                     (upper(s.target->prefix) == "TA" && s.major == "TOL")))
      m_reported_results.emplace(upper(s.target->prefix) + ":" + upper(s.target->name), s.span);
  }
  static const std::set<std::string> measuring = {"MEAS", "RMEAS", "PTMEAS", "PAMEAS", "GOTO", "SNSLCT", "CALL"};
  m_output_file =
      !repl && !m_reported_results.empty() &&
      std::none_of(st.begin(), st.end(), [](const grammar::Statement& s) { return measuring.count(s.major) > 0; });
  // A DMIS output file starts with FILNAM (NIST's output.dms, metron's own).
  // A DMIS module (DMISMD, as MODUS's helper tools write) starts as a program does, or with
  // FILNAM followed by DMISMD (MODUS's macro libraries).
  const bool module_after_filnam = st.size() > 1 && st.front().major == "FILNAM" && st[1].major == "DMISMD";
  // A first line DMISMN the parser could not read has its own error: no second message about it.
  const bool unread_start = program.first_word == "DMISMN" || program.first_word == "DMISMD";
  if (!repl && !m_included && !st.empty() && st.front().major != "DMISMN" && st.front().major != "DMISMD" &&
      !(m_output_file && st.front().major == "FILNAM") && !module_after_filnam && !unread_start)
    warn(st.front().span, "sema.no-dmismn", "the program does not start with DMISMN (or DMISMD, a module)");
  for (std::size_t i = 0; i < st.size(); ++i) {
    const auto& s = st[i];
    if (m_ended) {
      const bool second = std::any_of(st.begin() + static_cast<std::ptrdiff_t>(i), st.end(),
                                      [](const grammar::Statement& t) { return t.major == "DMISMN"; });
      warn(s.span, "sema.after-endfil",
           fmt::format("{} statement{} after ENDFIL {} ignored{}", st.size() - i, st.size() - i == 1 ? "" : "s",
                       st.size() - i == 1 ? "is" : "are",
                       second ? ": the file holds a second program (DMISMN after ENDFIL)" : ""));
      break;
    }
    statement(s);
  }
  for (auto it = m_blocks.rbegin(); it != m_blocks.rend(); ++it) {
    static const char* closers[] = {"ENDMES", "ENDIF", "ENDDO", "ENDMAC", "ENDSEL"};
    static const char* openers[] = {"MEAS", "IF", "DO", "MACRO", "SELECT"};
    error(it->span, "sema.unclosed-block",
          fmt::format("{} is never closed: expected {} before the end of the file", openers[static_cast<int>(it->kind)],
                      closers[static_cast<int>(it->kind)]));
  }
  if (m_go_target)
    error(m_go_target->span, "sema.unclosed-block",
          "GOTARG is never closed: expected ENDGO before the end of the file");
  resolve_jumps(m_unit_jumps, m_module.units[m_unit].code);
  if (!repl && !m_ended && !st.empty() && !m_included)
    warn(st.back().span, "sema.no-endfil", "the program does not end with ENDFIL");
}

std::optional<ir::Expr> UnitCompiler::standalone_expression(const grammar::Expr& g) {
  auto t = expression(g, true);
  if (!t) return std::nullopt;
  return std::move(t->e);
}

void UnitCompiler::resolve_jumps(JumpScope& scope, std::vector<ir::Instruction>& target_code) {
  for (const auto& [pc, ref] : scope.pending) {
    auto it = scope.labels.find(ref.first);
    if (it == scope.labels.end())
      error(ref.second, "sema.undefined-jump-label", fmt::format("JUMPTO target ({}) is not defined", ref.first));
    else
      target_code[pc].target = static_cast<std::int64_t>(it->second);
  }
  scope = {};
}

bool UnitCompiler::unsupported_feature_word(std::string_view word) {
  // DIST and LOCTOL are WinWerth's: a distance and a location tolerance held as features.
  return word == "COMPOUND" || word == "OBJECT" || word == "SYMPLN" || word == "CONRADSEGMNT" || word == "REVSURF" ||
         word == "DIST" || word == "LOCTOL";
}

// A feature label must be defined before use; FA() needs it measured or constructed at run time.
bool UnitCompiler::check_feature(const grammar::Expr& e) {
  const std::string name = upper(e.label.name);
  if (named_at_run(name) || defines_indirectly()) return true;
  if (m_symbols.features.count(name)) return true;
  if (m_symbols.patterns.count(name)) {
    error(e.span, "sema.pattern-use",
          fmt::format("{}({}) is a pattern (FEAT/PATERN): OUTPUT takes it; here name its features one by one",
                      e.label.prefix, e.label.name));
    return false;
  }
  if (auto it = m_symbols.skipped.find("F:" + name); it != m_symbols.skipped.end()) {
    // A feature of a type metron skips, read leniently: a warning, and the run stops where its
    // actual is needed.
    const bool lenient = !m_strict && !m_repl && m_symbols.unsupported_features.count(name);
    Diagnostic d{
        lenient ? Severity::Warning : Severity::Error,
        "sema.skipped-definition",
        e.span,
        fmt::format("feature {}({}) is defined only by a statement metron skipped{}", e.label.prefix, e.label.name,
                    lenient ? ": it has no actual, and a run stops here (--strict makes it an error)" : ""),
        {}};
    const Location loc = m_sources.locate(it->second);
    d.notes.push_back(fmt::format("the unsupported statement is at {}:{}:{}", loc.path, loc.line, loc.column));
    m_sink.report(std::move(d));
    return lenient;
  }
  // Shop software keeps the actuals of its last run: a program may use FA(x) that it measures
  // only further on, or never (CAMIO). Read leniently that is a warning, and the run stops at the
  // use unless x has an actual by then.
  const auto later = m_later_features.find(name);
  const bool rejected =
      later != m_later_features.end() && later->second.file == e.span.file && later->second.begin < e.span.begin;
  if (upper(e.label.prefix) == "FA" && !m_strict && !m_repl && !rejected) {
    warn(e.span, "sema.actual-from-before",
         later != m_later_features.end()
             ? fmt::format(
                   "feature FA({}) is used before its definition at line {}: CMM software may keep its actual from "
                   "an earlier run, metron does not; a run stops here unless it has one (--strict makes it an "
                   "error)",
                   e.label.name, m_sources.locate(later->second).line)
             : fmt::format("feature FA({}) is not defined in this program: CMM software may keep its actual from an "
                           "earlier run, metron does not; a run stops here (--strict makes it an error)",
                           e.label.name));
    return true;
  }
  if (later != m_later_features.end()) {
    const Location loc = m_sources.locate(later->second);
    // A definition above the use that did not define the feature was rejected (its error is above).
    error(e.span, "sema.undefined-feature",
          rejected
              ? fmt::format("feature {}({}) has no definition: its FEAT at line {} was rejected (see the error there)",
                            e.label.prefix, e.label.name, loc.line)
              : fmt::format("feature {}({}) is used before its definition at line {}", e.label.prefix, e.label.name,
                            loc.line));
    return false;
  }
  error(e.span, "sema.undefined-feature",
        fmt::format("feature {}({}) is not defined: define it with F({})=FEAT/...", e.label.prefix, e.label.name,
                    e.label.name));
  return false;
}

// Whether this unit defines a feature through an indirect label (F(@V)=FEAT/...): then any name
// may be defined at run, and check cannot call one undefined.
bool UnitCompiler::defines_indirectly() const {
  const auto indirect = [](const auto& table) {
    const auto it = table.lower_bound("@");
    return it != table.end() && it->first.rfind('@', 0) == 0;
  };
  return indirect(m_later_features) || indirect(m_symbols.features);
}

// A feature label no statement of the program defines, before or after (nor a skipped one).
bool UnitCompiler::never_defined(const std::string& name) const {
  return !named_at_run(name) && !defines_indirectly() && !m_symbols.features.count(name) &&
         !m_symbols.skipped.count("F:" + name) && !m_later_features.count(name);
}

std::optional<runtime::FeatureType> UnitCompiler::feature_type(const std::string& name) const {
  auto it = m_symbols.features.find(name);
  if (it == m_symbols.features.end()) return std::nullopt;
  return it->second.type;
}

void UnitCompiler::note_definition(const char* kind, const std::string& name, Span span) {
  const std::string key = std::string(kind) + ":" + name;
  if (auto prior = m_defined_here.find(key); prior != m_defined_here.end() && !m_repl) {
    const Location at = m_sources.locate(prior->second);
    warn(span, "sema.redefined",
         fmt::format("{}({}) is defined again (first at line {}); the later definition replaces it", kind, name,
                     at.line));
  }
  m_defined_here[key] = span;
}

void UnitCompiler::warn_if_unreadable(Span span, const std::string& what, const std::string& path) {
  if (!m_read_policy) return;
  if (auto refused = m_read_policy->refuse_read(path))
    warn(span, "io.read-outside", fmt::format("{}: {}; the run will refuse it", what, *refused));
}

// Indexed labels (`F(HOLE[I])`): each index is compiled once, as a number, and kept with the text
// the label's name holds; the interpreter evaluates it where the label is used.
bool UnitCompiler::label_indices(const grammar::LabelRef& label) {
  if (label.index.empty()) return true;
  const auto open = label.name.find('[');
  const std::string text = label.name.substr(open + 1, label.name.size() - open - 2);
  auto e = numeric(label.index.front(), "a label's index");
  if (!e) return false;
  m_module.label_indices.emplace(text, std::move(*e));
  return true;
}
bool UnitCompiler::label_indices(const grammar::Expr& e) {
  if (e.kind == grammar::ExprKind::Label && !label_indices(e.label)) return false;
  return std::all_of(e.args.begin(), e.args.end(), [&](const grammar::Expr& a) { return label_indices(a); });
}

// FA(V) where V is a CHAR variable and no feature is named V: MODUS reads the variable's value as
// the feature's name, as DMIS writes FA(@V). Rewritten to the `@` form, with one note per unit.
bool UnitCompiler::names_feature_by_variable(const grammar::LabelRef& l) const {
  if ((l.prefix != "F" && l.prefix != "FA") || !l.index.empty()) return false;
  const std::string name = upper(l.name);
  const auto local = m_locals.find(name);
  const auto global = m_symbols.variables.find(name);
  const bool char_variable = (local != m_locals.end() && local->second.type == ValueType::String) ||
                             (global != m_symbols.variables.end() && global->second.type == ValueType::String);
  return char_variable && !m_symbols.features.count(name);
}

bool UnitCompiler::names_by_variable(const grammar::Expr& e) const {
  if (e.kind == grammar::ExprKind::Label && names_feature_by_variable(e.label)) return true;
  return std::any_of(e.args.begin(), e.args.end(), [&](const grammar::Expr& a) { return names_by_variable(a); });
}

bool UnitCompiler::variable_label_names(grammar::Expr& e) {
  bool changed = false;
  if (e.kind == grammar::ExprKind::Label && names_feature_by_variable(e.label)) {
    note_once(
        m_variable_labels_noted, e.span, "sema.variable-label",
        fmt::format("{}({}): {} is a CHAR variable and no feature has its name, so its value names the feature, as "
                    "{}(@{}) (MODUS reads it so)",
                    e.label.prefix, e.label.name, e.label.name, e.label.prefix, e.label.name));
    e.label.name = "@" + e.label.name;
    changed = true;
  }
  for (auto& a : e.args) changed |= variable_label_names(a);
  return changed;
}

void UnitCompiler::statement(const grammar::Statement& given) {
  grammar::Statement rewritten;
  bool changed = false;
  if (!m_repl && std::any_of(given.params.begin(), given.params.end(),
                             [&](const grammar::Expr& p) { return names_by_variable(p); })) {
    rewritten = given;
    for (auto& p : rewritten.params) changed |= variable_label_names(p);
  }
  const grammar::Statement& s = changed ? rewritten : given;
  if ((s.target && !label_indices(*s.target)) ||
      !std::all_of(s.params.begin(), s.params.end(), [&](const grammar::Expr& p) { return label_indices(p); }))
    return;
  if (s.jump_label) {
    const std::string name = upper(*s.jump_label);
    if (auto prior = jumps().labels.find(name); prior != jumps().labels.end() && prior->second < code().size()) {
      // JUMPTO would go to one of them silently (the last); a program must not be ambiguous.
      const Location at = m_sources.locate(code()[prior->second].span);
      error(s.span, "sema.duplicate-label",
            fmt::format("label ({}) is defined twice (first at line {}): JUMPTO({}) would be ambiguous", *s.jump_label,
                        at.line, *s.jump_label));
      return;
    }
    jumps().labels[name] = code().size();
    emit(make(Op::JumpLabel, s, upper(*s.jump_label)));
    return;
  }
  const std::string& m = s.major;
  // The body of a MEAS of a skipped feature: skipped with it (the MEAS told why).
  if (!m_blocks.empty() && m_blocks.back().skipped && m != "ENDMES" && m != "ENDFIL") return;
  if (!m_blocks.empty() && m_blocks.back().kind == Block::Kind::Meas) {
    // What a measurement block may hold: its motions and points, the probing settings (a SNSLCT
    // switches the sensor between the block's points), and the flow of control.
    static const std::set<std::string> allowed = {
        "GOTO",   "GOTARG", "ENDGO",  "PTMEAS", "RMEAS",  "RPTMEAS", "PAMEAS", "ENDMES", "ENDFIL", "SNSET",
        "FEDRAT", "ACLRAT", "SNSLCT", "WKPLAN", "TEXT",   "IF",      "ELSE",   "ENDIF",  "DO",     "ENDDO",
        "SELECT", "CASE",   "DFTCAS", "ENDCAS", "ENDSEL", "JUMPTO",  "ASSIGN", "CALL",   "DISPLY"};
    // Settings and records shop software writes inside blocks: no motion, no definition.
    static const std::set<std::string> tolerated = {
        "FLY",    "DMESW", "DMESWI", "DMESWV", "DMEHW",  "PTBUFF", "SCNSET", "DECPL", "PAUSE",  "TECOMP", "PRCOMP",
        "CRMODE", "DECL",  "WRITE",  "READ",   "GEOALG", "RECALL", "MODE",   "WRIST", "FINPOS", "SNSMNT", "CZSLCT"};
    // A word metron does not know (a vendor's, RationalDMIS's SETMACREF) is skipped as it is
    // outside a block, read leniently: one warning below, from unknown().
    const bool unknown_word = !statements().count(m) && !m_strict;
    if (!allowed.count(m) && !s.variable && !unknown_word) {
      if (m_strict || !tolerated.count(m)) {
        error(s.major_span, "sema.not-in-meas",
              fmt::format("{} is not allowed inside a MEAS block (close it with ENDMES first)", m));
        return;
      }
      // Read leniently, they are carried out where they stand, before the points ENDMES measures
      // (told once per word: WinWerth writes a CZSLCT in every block).
      if (m_noted_kinds.insert("in MEAS: " + m).second)
        warn(s.major_span, "sema.not-in-meas",
             fmt::format("{} inside a MEAS block is not DMIS: it is carried out where it stands, before the block's "
                         "points, which are measured at ENDMES (told once; --strict: an error)",
                         m));
    }
  }
  // V=ASSIGN/... and V=OBTAIN/... are a row of their own (the grammar parsed the variable).
  const auto& rows = statements();
  auto it = rows.find(s.variable ? std::string_view(assignment_row) : std::string_view(m));
  if (it == rows.end()) return unknown(s);
  // A point range FA(x)[i,j] is OUTPUT's (MODUS); elsewhere it would be dropped unseen.
  for (const auto& p : s.params)
    if (p.kind == grammar::ExprKind::Label && !p.label.points.empty() && m != "OUTPUT")
      return error(p.span, "sema.point-range",
                   fmt::format("a point range {}({})[...] is read only in OUTPUT", p.label.prefix, p.label.name));
  (this->*(it->second))(s);
}

const StatementTable& UnitCompiler::statements() {
  static const StatementTable table = [] {
    StatementTable t;
    add_input_output(t);
    add_definitions(t);
    add_measurement(t);
    add_alignment(t);
    add_control(t);
    return t;
  }();
  return table;
}

// A vendor or unsupported statement: warn and skip; remember labels it would have defined.
std::optional<std::string> UnitCompiler::unread_definition_of(Span span, std::string_view code) const {
  if (m_unread_definitions.empty() || code.find("undefined") == std::string_view::npos || !span.valid())
    return std::nullopt;
  const std::string& text = m_sources.file(span.file).text;
  if (span.end > text.size() || span.begin >= span.end) return std::nullopt;
  // The label as the parser keys it: upper case, no blanks, an actual's prefix as its nominal's.
  std::string label;
  for (std::uint32_t k = span.begin; k < span.end; ++k)
    if (text[k] != ' ' && text[k] != '\t')
      label += static_cast<char>(std::toupper(static_cast<unsigned char>(text[k])));
  if (const auto open = label.find('(');
      open == 2 && label[1] == 'A' && std::string_view("FDTS").find(label[0]) != std::string_view::npos)
    label.erase(1, 1);
  const auto it = m_unread_definitions.find(label);
  if (it == m_unread_definitions.end()) return std::nullopt;
  return fmt::format("its definition at line {} could not be read (the error there is the one to fix)",
                     m_sources.locate(it->second).line);
}

void UnitCompiler::unknown(const grammar::Statement& s) {
  // Told once per word (a vendor's statement, WinWerth's PIEZOWFP, stands before every block);
  // --strict tells each.
  if (m_strict || m_noted_kinds.insert("unknown: " + s.major).second)
    warn(s.major_span, "sema.unknown-statement",
         skipped_statement_message(s.major) + (m_strict ? "" : " (told once per word)"));
  if (s.target)
    m_symbols.skipped[(s.target->prefix == "F" ? "F:" : s.target->prefix + ":") + upper(s.target->name)] = s.span;
  emit(make(Op::Nop, s, s.major));
}

// A DMIS 5.3 statement metron does not carry out is named so; anything else is unknown.
std::string UnitCompiler::skipped_statement_message(const std::string& major) {
  if (major.empty()) return "unknown statement ? is skipped";
  if (!grammar::is_major_word(major)) return fmt::format("unknown statement {} is skipped", major);
  std::string message = fmt::format("the DMIS statement {} is not supported by metron and is skipped", major);
  if (major == "EQUATE")
    message += ": the coordinate systems are not equated, so results in them may be in another frame";
  return message;
}

bool UnitCompiler::expect_params(const grammar::Statement& s, std::size_t n, const char* what) {
  if (s.params.size() >= n) return true;
  error(s.params.empty() ? s.major_span : s.params.back().span, "sema.missing-parameter",
        fmt::format("expected {} after {}", what, s.params.empty() ? s.major + "/" : "'" + s.major + "' parameters"));
  return false;
}

bool UnitCompiler::require_target(const grammar::Statement& s, std::initializer_list<const char*> prefixes,
                                  const char* example) {
  if (s.target && std::any_of(prefixes.begin(), prefixes.end(), [&](const char* p) { return s.target->prefix == p; }))
    return true;
  error(s.span, "sema.missing-label", fmt::format("{} needs a label on the left: {}", s.major, example));
  return false;
}

}  // namespace metron::interpreter::detail
