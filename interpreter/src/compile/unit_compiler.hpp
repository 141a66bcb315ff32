// SPDX-License-Identifier: GPL-3.0-or-later
// The compiler of one unit (a file, a called file or a REPL entry), private to the interpreter.
// The statement handlers live in one file per DMIS statement family (compile/*.cpp); each family
// adds its rows to the statement table (major word -> handler), so the dispatcher in
// unit_compiler.cpp knows no statement by name.
#pragma once
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "metron/stdlib/text_encoding.hpp"

#include "metron/grammar/ast.hpp"
#include "metron/interpreter/compiler.hpp"

namespace metron::interpreter::detail {

/// Labels and words compare in upper case, accented letters included (F(Alésage) is FA(ALÉSAGE)).
inline std::string upper(const std::string& s) { return upper_utf8(s); }

class UnitCompiler;
using StatementHandler = void (UnitCompiler::*)(const grammar::Statement&);
/// Major word -> handler; each statement family adds its own rows.
using StatementTable = std::map<std::string, StatementHandler, std::less<>>;

/// Resolves a CALL/EXTERN,DMIS file: (path, path as written, span of the call) -> unit index.
using IncludeFile = std::function<std::optional<std::size_t>(const std::string&, const std::string&, Span)>;

class UnitCompiler {
 public:
  UnitCompiler(SymbolTable& symbols, ir::Module& module, SourceManager& sources, DiagnosticSink& sink, std::size_t unit,
               IncludeFile include)
      : m_symbols(symbols),
        m_module(module),
        m_sources(sources),
        m_sink(sink),
        m_unit(unit),
        m_include(std::move(include)) {}

  /// Compiles a parsed program into this unit; `repl` relaxes the checks that suit whole files.
  void compile(const grammar::Program& program, bool repl);
  void set_included(bool v) { m_included = v; }
  /// Strict reading (`--strict`): what the lenient reader forgives is an error.
  void set_strict(bool v) { m_strict = v; }
  void set_runtime_names(const std::set<std::string>& names) { m_runtime_names = names; }
  /// The run's read policy (docs/security.md): files the program names are checked against it
  /// at compile time, so that `check` warns where the run will refuse.
  void set_read_policy(const FileAccessPolicy* policy) { m_read_policy = policy; }
  /// An expression parameter compiled in this unit's context (labels allowed: `print FA(x)`).
  std::optional<ir::Expr> standalone_expression(const grammar::Expr& g);

  /// The statement table: every family's rows (built once).
  static const StatementTable& statements();
  /// The row of `V=ASSIGN/...` and `V=OBTAIN/...` (and vendor `V=XXX/...`) statements.
  static constexpr std::string_view assignment_row = "V=";

 private:
  // Each family's rows (one function per compile/*.cpp file).
  static void add_input_output(StatementTable& t);
  static void add_definitions(StatementTable& t);
  static void add_measurement(StatementTable& t);
  static void add_alignment(StatementTable& t);
  static void add_control(StatementTable& t);

  struct Block {
    enum class Kind { Meas, If, Do, Macro, Select } kind = Kind::Meas;
    Span span;
    std::size_t start = 0;
    std::vector<std::size_t> exits;     // jumps to patch to the end
    std::optional<std::size_t> branch;  // IF: the JumpIfFalse to patch at ELSE/ENDIF
    bool has_else = false;
    int ptmeas = 0;
    int declared = 0;
    bool control = false;                  // control flow inside a MEAS: counts are not static
    bool skipped = false;                  // MEAS of a feature metron skipped: its body is skipped too
    bool scanned = false;                  // PAMEAS inside, or SCNMOD/ON: the point count is the machine's
    bool scan_pairs = false;               // SCNMOD/ON before it: its PTMEAS are the ends of scans
    Span last_ptmeas;                      // MEAS: where its last PTMEAS stands
    std::string feature;                   // MEAS: the feature label; DO: the loop variable
    std::optional<ir::Expr> selector;      // SELECT: the value CASE compares with (evaluated at each CASE)
    bool in_case = false;                  // SELECT: inside CASE or DFTCAS, before its ENDCAS
    bool has_default = false;              // SELECT: DFTCAS seen
    std::optional<ir::Operand> reference;  // RMEAS block: the feature its points are relative to
    runtime::FeatureType type = runtime::FeatureType::Point;  // MEAS
  };
  static constexpr std::size_t invalid = static_cast<std::size_t>(-1);
  static Block block(Block::Kind kind, Span span) {
    Block b;
    b.kind = kind;
    b.span = span;
    return b;
  }
  struct JumpScope {
    std::map<std::string, std::size_t> labels;
    std::vector<std::pair<std::size_t, std::pair<std::string, Span>>> pending;
  };

  // ---- diagnostics --------------------------------------------------------------------------
  void error(Span span, const char* code, std::string message) {
    if (auto unread = unread_definition_of(span, code))
      return note(span, code, fmt::format("{}: {}", message, *unread));
    m_sink.error(code, span, std::move(message));
  }
  /// For an error that a label is not defined, where a line the parser could not read defined it:
  /// what to say instead (the error at that line is the one to fix).
  [[nodiscard]] std::optional<std::string> unread_definition_of(Span span, std::string_view code) const;
  void warn(Span span, const char* code, std::string message) {
    if (auto unread = unread_definition_of(span, code))
      return note(span, code, fmt::format("{}: {}", message, *unread));
    m_sink.warning(code, span, std::move(message));
  }
  void note(Span span, const char* code, std::string message) {
    m_sink.report({Severity::Note, code, span, std::move(message), {}});
  }  /// One note per unit for what `noted` stands for (the later statements of the kind are quiet).
  void note_once(bool& noted, Span span, const char* code, std::string message) {
    if (noted) return;
    note(span, code, std::move(message));
    noted = true;
  }
  /// One warning per unit for what `warned` stands for.
  void warn_once(bool& warned, Span span, const char* code, std::string message) {
    if (warned) return;
    warn(span, code, std::move(message));
    warned = true;
  }

  /// A sensor the program does not define: taken from the machine's probe library at run
  /// (docs/language.md "Sensors from the probe library"); one note per name.
  void library_sensor(const grammar::Expr& label);

  // ---- emission -----------------------------------------------------------------------------
  std::vector<ir::Instruction>& code() {
    return m_macro ? m_module.macros[static_cast<std::size_t>(*m_macro)].code : m_module.units[m_unit].code;
  }
  std::size_t emit(ir::Instruction in) {
    code().push_back(std::move(in));
    return code().size() - 1;
  }
  static ir::Instruction make(ir::Op op, const grammar::Statement& s, std::string name = {}) {
    ir::Instruction in;
    in.op = op;
    in.span = s.span;
    in.name = std::move(name);
    return in;
  }
  JumpScope& jumps() { return m_macro ? m_macro_jumps : m_unit_jumps; }
  void resolve_jumps(JumpScope& scope, std::vector<ir::Instruction>& target_code);

  // ---- operand helpers ----------------------------------------------------------------------
  static bool is_word(const grammar::Expr& e) { return e.kind == grammar::ExprKind::Word; }
  static bool is_word(const grammar::Expr& e, std::string_view w) {
    return e.kind == grammar::ExprKind::Word && e.text == w;
  }
  static bool is_label(const grammar::Expr& e, std::initializer_list<const char*> prefixes) {
    if (e.kind != grammar::ExprKind::Label) return false;
    return std::any_of(prefixes.begin(), prefixes.end(), [&](const char* p) { return e.label.prefix == p; });
  }
  /// A declared variable: the macro's local of that name, else the program's; null when neither.
  const SymbolTable::VariableInfo* variable(const std::string& name) const {
    if (auto it = m_locals.find(name); it != m_locals.end()) return &it->second;
    if (auto jt = m_symbols.variables.find(name); jt != m_symbols.variables.end()) return &jt->second;
    return nullptr;
  }
  bool is_variable(const std::string& name) const {
    return m_symbols.variables.count(name) || m_locals.count(name) || macro_param(name).has_value();
  }
  std::optional<int> macro_param(const std::string& name) const {
    if (!m_macro) return std::nullopt;
    const auto& params = m_module.macros[static_cast<std::size_t>(*m_macro)].params;
    auto it = std::find(params.begin(), params.end(), name);
    if (it == params.end()) return std::nullopt;
    return static_cast<int>(it - params.begin());
  }
  /// A label whose name is known only at run time: a macro parameter, or an indirect reference
  /// `F(@V)` (DMIS 5.x 5.1.2.4: the CHAR variable V holds the name). `check` cannot say whether
  /// it is defined; `run` resolves it where it is used.
  bool defines_indirectly() const;
  /// D(x)/DA(x) names a coordinate system the program defines, MCS, or one named at run; else an
  /// error (strict) or a warning that the run stops at `statement` (lenient: true is returned).
  bool known_alignment(const grammar::Expr& label, const std::string& statement);
  bool named_at_run(const std::string& name) const { return macro_param(name).has_value() || name.rfind('@', 0) == 0; }
  ir::LabelOperand label_operand(const grammar::LabelRef& l) {
    ir::LabelOperand out{upper(l.prefix), upper(l.name), std::nullopt, l.span};
    out.param = macro_param(out.name);
    return out;
  }
  static ir::Operand word_operand(std::string word, Span span) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Word;
    o.word = std::move(word);
    o.span = span;
    return o;
  }
  static ir::Operand word_operand(const grammar::Expr& e) { return word_operand(e.text, e.span); }
  ir::Operand label_op(const grammar::Expr& e) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Label;
    o.label = label_operand(e.label);
    o.span = e.span;
    return o;
  }
  static ir::Operand expr_operand(ir::Expr e) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Expr;
    o.span = e.span;
    o.expr = std::move(e);
    return o;
  }

  // ---- expressions (compile/expressions.cpp) -------------------------------------------------
  struct Typed {
    ir::Expr e;
    bool dynamic = false;  // type known only at run time (macro parameter)
  };
  std::optional<Typed> expression(const grammar::Expr& g, bool allow_labels = false);
  std::optional<Typed> word_expression(const grammar::Expr& g);
  bool check_rank(const grammar::Expr& element, const SymbolTable::VariableInfo& info);
  std::optional<Typed> element_expression(const grammar::Expr& g);
  std::optional<Typed> call_expression(const grammar::Expr& g);
  std::optional<Typed> elapsed_time_expression(const grammar::Expr& g);
  ir::Expr prompt_dialog_text(const grammar::Statement& s);
  std::optional<Typed> unary_expression(const grammar::Expr& g);
  std::optional<Typed> binary_expression(const grammar::Expr& g);
  std::optional<ir::Expr> numeric(const grammar::Expr& g, const char* what);
  /// A numeric parameter appended to `in` as an operand; false (reported) when it is not one.
  bool push_number(ir::Instruction& in, const grammar::Expr& g, const char* what) {
    auto e = numeric(g, what);
    if (e) in.operands.push_back(expr_operand(std::move(*e)));
    return e.has_value();
  }

  // ---- name checks and the dispatcher (compile/unit_compiler.cpp) ---------------------------
  bool check_feature(const grammar::Expr& e);
  bool never_defined(const std::string& name) const;
  void warn_obtain_index(const grammar::Expr& feature, const ir::Expr& index);
  std::optional<runtime::FeatureType> feature_type(const std::string& name) const;
  /// A feature type word parameter (MEAS/, CONST/), or nullopt.
  static std::optional<runtime::FeatureType> type_word(const grammar::Expr& e) {
    if (is_word(e, "EDGEPT")) return runtime::FeatureType::Point;       // measured as a point (FEAT/EDGEPT)
    if (is_word(e, "RCTNGL")) return runtime::FeatureType::ClosedSlot;  // measured as CPARLN,FLAT (FEAT/RCTNGL)
    return is_word(e) ? ir::parse_word<runtime::FeatureType>(e.text) : std::nullopt;
  }
  void statement(const grammar::Statement& s);
  bool names_feature_by_variable(const grammar::LabelRef& l) const;
  bool names_by_variable(const grammar::Expr& e) const;
  bool variable_label_names(grammar::Expr& e);
  bool label_indices(const grammar::LabelRef& label);
  bool label_indices(const grammar::Expr& e);
  void unknown(const grammar::Statement& s);
  void pattern(const grammar::Statement& s);
  bool complete_line_normal(const grammar::Statement& s, std::vector<grammar::Expr>& p, bool bounded,
                            ir::CoordinateForm form);
  static std::string skipped_statement_message(const std::string& major);
  /// The DMIS feature types metron reads and skips (COMPOUND, OBJECT, SYMPLN, CONRADSEGMNT, REVSURF).
  static bool unsupported_feature_word(std::string_view word);
  bool expect_params(const grammar::Statement& s, std::size_t n, const char* what);
  bool require_target(const grammar::Statement& s, std::initializer_list<const char*> prefixes, const char* example);

  // ---- input/output: UNITS, MODE, TEXT, DEVICE, OPEN, CLOSE (compile/input_output.cpp) ------
  void no_effect(const grammar::Statement& s);
  void geometry_algorithm(const grammar::Statement& s);
  void work_plane(const grammar::Statement& s);
  void push_pop(const grammar::Statement& s);
  void note_push_balance(bool push, const grammar::Expr& word);
  void go_home(const grammar::Statement& s);
  void from(const grammar::Statement& s);
  std::optional<ir::Instruction> point_instruction(const grammar::Statement& s, ir::Op op, const char* what);
  void go_target(const grammar::Statement& s);
  void end_go(const grammar::Statement& s);
  static grammar::Expr unsigned_direction(const grammar::Expr& e);
  void noted_no_effect(const grammar::Statement& s);
  void on_error(const grammar::Statement& s);
  void bad_test(const grammar::Statement& s);
  void resume(const grammar::Statement& s);
  std::pair<std::string, Span> jump_label_name(const grammar::Expr& param) const;
  void emit_jump(ir::Instruction in, const std::string& label, Span span);
  void extreme_point(const grammar::Statement& s, ir::Instruction in);
  void tangent(const grammar::Statement& s, ir::Instruction in, runtime::FeatureType type, const std::string& label);
  void units(const grammar::Statement& s);
  void mode(const grammar::Statement& s);
  void pause(const grammar::Statement& s);
  void decpl(const grammar::Statement& s);
  void read(const grammar::Statement& s);
  void write(const grammar::Statement& s);
  void text(const grammar::Statement& s);
  void text_query(const grammar::Statement& s);
  void device(const grammar::Statement& s);
  bool check_device(const grammar::Statement& s);
  void open(const grammar::Statement& s);
  void cad_geometry(const grammar::Statement& s);
  void equate(const grammar::Statement& s);
  void close(const grammar::Statement& s);

  // ---- definitions: FEAT, SNSDEF, TOL, DATDEF, PATH, DECL (compile/definitions.cpp) ---------
  void feat(const grammar::Statement& s);
  bool check_feature_numbers(const grammar::Statement& s, const std::vector<grammar::Expr>& params,
                             const ir::FeaturePayload& form, const std::vector<double>& literal);
  void snsdef(const grammar::Statement& s);
  void tol(const grammar::Statement& s);
  void datdef(const grammar::Statement& s);
  void path(const grammar::Statement& s);
  void path_section(const grammar::Statement& s);
  void decl(const grammar::Statement& s);

  // ---- measurement: SNSLCT ... SCNSET, GOTO, MEAS, PTMEAS, PAMEAS (compile/measurement.cpp) --
  void snsmnt(const grammar::Statement& s);
  void snslct(const grammar::Statement& s);
  void calib(const grammar::Statement& s);
  void snset(const grammar::Statement& s);
  void fedrat(const grammar::Statement& s);
  void aclrat(const grammar::Statement& s);
  void go_to(const grammar::Statement& s);
  void meas(const grammar::Statement& s);
  void endmes(const grammar::Statement& s);
  void ptmeas(const grammar::Statement& s);
  void rmeas_block(const grammar::Statement& s);
  void pameas(const grammar::Statement& s);
  void scnmod(const grammar::Statement& s);
  void scnset(const grammar::Statement& s);

  // ---- alignment and constructions: DATSET ... RECALL, CONST, OUTPUT (compile/alignment.cpp) -
  void datset(const grammar::Statement& s);
  void trans(const grammar::Statement& s);
  void rotate(const grammar::Statement& s);
  void locate(const grammar::Statement& s);
  void iterate(const grammar::Statement& s);
  std::optional<bool> push_datum_or_feature(ir::Instruction& in, const grammar::Expr& p);
  void save(const grammar::Statement& s);
  void recall(const grammar::Statement& s);
  void construct(const grammar::Statement& s);
  void output(const grammar::Statement& s);
  void evaluate(const grammar::Statement& s);
  /// OUTPUT and EVAL: the labels checked and put on `in`; false after an error.
  bool output_labels(const grammar::Statement& s, ir::Instruction& in, std::size_t& echoed);

  // ---- control: assignment, IF, DO, JUMPTO, macros, CALL (compile/control.cpp) --------------
  void endfil(const grammar::Statement& s);
  static const char* declared_word(ValueType type);
  void declare_implicitly(const std::string& name, ValueType type, Span span, const grammar::Statement& s);
  void assignment(const grammar::Statement& s);
  void bad_assign(const grammar::Statement& s);
  std::optional<ir::Expr> value_query(const grammar::Statement& s);
  void mark_control();
  void if_(const grammar::Statement& s);
  void else_(const grammar::Statement& s);
  void endif(const grammar::Statement& s);
  void select(const grammar::Statement& s);
  void case_(const grammar::Statement& s);
  void endcas(const grammar::Statement& s);
  void endsel(const grammar::Statement& s);
  void do_(const grammar::Statement& s);
  void enddo(const grammar::Statement& s);
  void jumpto(const grammar::Statement& s);
  void macro(const grammar::Statement& s);
  void endmac(const grammar::Statement& s);
  void call(const grammar::Statement& s);
  void call_extern(const grammar::Statement& s);
  void call_external_macro(const grammar::Statement& s);
  void extfil(const grammar::Statement& s);
  std::optional<std::filesystem::path> called_file(const grammar::Expr& f);

  SymbolTable& m_symbols;
  ir::Module& m_module;
  SourceManager& m_sources;
  DiagnosticSink& m_sink;
  std::size_t m_unit;
  IncludeFile m_include;
  std::vector<Block> m_blocks;
  std::optional<ir::Instruction> m_go_target;  ///< an open GOTARG: its move, emitted at ENDGO
  std::optional<int> m_macro;
  std::map<std::string, SymbolTable::VariableInfo> m_locals;
  JumpScope m_unit_jumps, m_macro_jumps;
  bool m_ended = false;
  bool m_repl = false;
  /// Labels defined in this unit ("T:NAME", "S:NAME", "DID:NAME", "DAT:NAME") and where: a second
  /// definition is warned about (it silently replaced the first).
  std::map<std::string, Span> m_defined_here;
  /// Warns when `kind`(`name`) was already defined in this unit; remembers this definition.
  void note_definition(const char* kind, const std::string& name, Span span);
  /// Warns when the read policy will refuse `path` (named by the statement as `what`) at run time.
  void warn_if_unreadable(Span span, const std::string& what, const std::string& path);
  const FileAccessPolicy* m_read_policy = nullptr;
  bool m_included = false;
  bool m_strict = false;
  std::set<std::string> m_runtime_names;
  bool m_paused = false;  // PAUSE noted once
  // SCNMOD/ON seen (in program order) and not turned OFF since: a block's PTMEAS then come in pairs,
  // each the ends of a scan, so its point count is the machine's (as with PAMEAS).
  bool m_scan_mode_on = false;
  std::set<std::string> m_noted_kinds;        // ERROR, GEOALG: noted once each
  std::set<std::string> m_push_words_warned;  // PUSH/POP words metron does not save: told once each
  std::string m_writer;                       // grammar::Program::writer: the software that wrote the file
  bool m_circle_radius_noted = false;
  bool m_distance_features_noted = false;
  // WinWerth's location tolerances: CONST/LOCTOL,F(x),kind,FA(datum),FA(toleranced) and
  // T(t)=TOL/LOCTOL,zone, evaluated where OUTPUT/F(x),T(t) names them (compile/alignment.cpp).
  struct LocationFeature {
    std::string kind;          ///< PARLEL, PERP, CONCEN, ...
    grammar::Expr toleranced;  ///< the feature the zone applies to
    grammar::Expr datum;       ///< DAT(LOCTOL_x), defined on the reference feature
  };
  std::map<std::string, LocationFeature> m_location_features;
  std::map<std::string, grammar::Statement> m_location_zones;  ///< T(t)=TOL/LOCTOL,zone by t
  bool m_location_noted = false;
  int m_unlabelled_macros = 0;                       // MACRO/name without M(name)=, run in place (WinWerth)
  std::map<std::string, int> m_pushes_open;          // PUSH/word less POP/word so far in this unit's text
  std::map<std::string, Span> m_later_features;      // F(label)=FEAT anywhere in this unit -> its statement
  std::map<std::string, Span> m_later_tolerances;    // T(label)=TOL anywhere in this unit -> its statement
  std::map<std::string, Span> m_later_macros;        // M(label)=MACRO anywhere in this unit -> its statement
  std::map<std::string, Span> m_unread_definitions;  // Program::unread_definitions
  /// FA(label)=FEAT and TA(label)=TOL anywhere in this unit (the result lines of a DMIS output
  /// file): "FA:label" / "TA:label" -> the statement. An OUTPUT before them echoes them.
  std::map<std::string, Span> m_reported_results;
  bool m_reported_results_noted = false;  // one note per unit for reported results
  bool m_sensor_mount_noted = false;      ///< SNSDEF/...,SW(x): the sensor's mount, told once
  /// A DMIS output file: it states results (FA(x)=FEAT, TA(t)=TOL) and measures nothing. Its
  /// echoed DATDEF and DATSET lines name features it does not restate.
  bool m_output_file = false;
  std::set<std::string> m_echoed_datums;  ///< DATDEFs of an output file whose feature it does not state
  bool m_echo_noted = false;
  bool m_calib_artifact_noted = false;
  bool m_report_layout_noted =
      false;  // one note per unit: OUTPUT/...,R(x)   // one note per unit: CALIB/SENS uses the world's sphere
  bool m_edge_points_noted = false;      // one note per unit for FEAT/EDGEPT
  bool m_rectangles_noted = false;       // one note per unit for FEAT/RCTNGL
  bool m_line_normals_warned = false;    // one warning per unit for a FEAT/LINE without its plane's normal
  bool m_patterns_noted = false;         // one note per unit for FEAT/PATERN
  bool m_meas_clearance_noted = false;   // one note per unit for MEAS/...,CLRSRF (RationalDMIS)
  bool m_sensor_saves_noted = false;     // one note per unit for SAVE/SA()
  bool m_variable_labels_noted = false;  // one note per unit for FA(V), V a CHAR variable
};

}  // namespace metron::interpreter::detail
