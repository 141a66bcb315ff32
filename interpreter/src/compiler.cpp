// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/compiler.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <sstream>

#include <fmt/format.h>

#include "metron/grammar/parser.hpp"
#include "metron/stdlib/builtins.hpp"

namespace metron::interpreter {
namespace {

using grammar::ExprKind;
using ir::Op;

std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

const std::set<std::string> feature_types = {"POINT", "PLANE", "LINE", "CIRCLE", "ARC", "SPHERE", "CYLNDR", "CONE"};
const std::set<std::string> tolerance_kinds = {"DIAM", "RAD", "DISTB", "POS", "FLAT", "CIRLTY", "CYLCTY",
                                               "SPHCTY", "STRGHT", "PERP", "PARLEL", "ANGLB", "PROFS"};
// Statements metron accepts with no run-time effect (settings a virtual CMM does not need).
const std::set<std::string> no_effect = {"DMISMN", "DMISMD", "FILNAM", "DISPLY", "PRCOMP", "WKPLAN", "VFORM",
                                         "ERROR", "DMEHW", "DMESW", "FINPOS", "CLMPID", "CLMPSN", "PREVOP",
                                         "OPERID", "PLANID", "PARTID", "PARTRV", "PARTSN", "PROCID", "QISDEF",
                                         "TECOMP", "TEMPF", "TEMPC", "CRMODE", "CRSLCT", "RESUME"};

// Which tolerance kinds apply to which feature types (checked at OUTPUT when both are known).
bool tolerance_applies(const std::string& kind, const std::string& type) {
  const auto in = [&](std::initializer_list<const char*> ts) {
    return std::any_of(ts.begin(), ts.end(), [&](const char* t) { return type == t; });
  };
  if (kind == "DIAM" || kind == "RAD") return in({"CIRCLE", "ARC", "SPHERE", "CYLNDR"});
  if (kind == "FLAT") return in({"PLANE"});
  if (kind == "CIRLTY") return in({"CIRCLE", "ARC"});
  if (kind == "CYLCTY") return in({"CYLNDR"});
  if (kind == "SPHCTY") return in({"SPHERE"});
  if (kind == "STRGHT") return in({"LINE"});
  if (kind == "POS") return !in({"PLANE", "LINE"});
  if (kind == "PROFS") return in({"PLANE", "CIRCLE", "ARC", "SPHERE", "CYLNDR", "CONE"});
  return true;
}

// The number of numeric parameters each feature form takes, after the words.
struct FeatureForm {
  std::size_t min_numbers;
  std::size_t max_numbers;
  const char* meaning;
};

FeatureForm feature_form(const std::string& type, bool bounded) {
  if (type == "POINT") return {6, 6, "x,y,z,i,j,k"};
  if (type == "PLANE") return {6, 6, "x,y,z,i,j,k"};
  if (type == "LINE") return bounded ? FeatureForm{9, 9, "x1,y1,z1,x2,y2,z2,i,j,k"} : FeatureForm{9, 9, "x,y,z,i,j,k,i2,j2,k2"};
  if (type == "CIRCLE") return {7, 7, "x,y,z,i,j,k,diam"};
  if (type == "ARC") return {9, 9, "x,y,z,i,j,k,rad,ang1,ang2"};
  if (type == "SPHERE") return {4, 7, "x,y,z,diam (or x,y,z,i,j,k,diam)"};
  if (type == "CYLNDR") return {7, 8, "x,y,z,i,j,k,diam[,len]"};
  if (type == "CONE") return {7, 8, "x,y,z,i,j,k,angle[,len]"};
  return {0, 0, ""};
}

class UnitCompiler {
 public:
  UnitCompiler(SymbolTable& symbols, ir::Module& module, SourceManager& sources, DiagnosticSink& sink,
               std::size_t unit, std::function<std::optional<std::size_t>(const std::string&, const std::string&, Span)> include)
      : m_symbols(symbols), m_module(module), m_sources(sources), m_sink(sink), m_unit(unit),
        m_include(std::move(include)) {}

  void compile(const grammar::Program& program, bool repl) {
    m_repl = repl;
    const auto& st = program.statements;
    if (!repl && !m_included && !st.empty() && st.front().major != "DMISMN")
      warn(st.front().span, "sema.no-dmismn", "the program does not start with DMISMN");
    for (const auto& s : st) {
      if (m_ended) {
        warn(s.span, "sema.after-endfil", "statement after ENDFIL is ignored");
        break;
      }
      statement(s);
    }
    for (auto it = m_blocks.rbegin(); it != m_blocks.rend(); ++it) {
      static const char* closers[] = {"ENDMES", "ENDIF", "ENDDO", "ENDMAC"};
      static const char* openers[] = {"MEAS", "IF", "DO", "MACRO"};
      error(it->span, "sema.unclosed-block",
            fmt::format("{} is never closed: expected {} before the end of the file",
                        openers[static_cast<int>(it->kind)], closers[static_cast<int>(it->kind)]));
    }
    resolve_jumps(m_unit_jumps, m_module.units[m_unit].code);
    if (!repl && !m_ended && !st.empty() && !m_included)
      warn(st.back().span, "sema.no-endfil", "the program does not end with ENDFIL");
  }
  void set_included(bool v) { m_included = v; }
  void set_runtime_names(const std::set<std::string>& names) { m_runtime_names = names; }
  /// An expression parameter compiled in this unit's context (labels allowed: `print FA(x)`).
  std::optional<ir::Expr> standalone_expression(const grammar::Expr& g) {
    auto t = expression(g, true);
    if (!t) return std::nullopt;
    return std::move(t->e);
  }

 private:
  struct Block {
    enum class Kind { Meas, If, Do, Macro } kind = Kind::Meas;
    Span span;
    std::size_t start = 0;
    std::vector<std::size_t> exits;      // jumps to patch to the end
    std::optional<std::size_t> branch;   // IF: the JumpIfFalse to patch at ELSE/ENDIF
    bool has_else = false;
    int ptmeas = 0;
    int declared = 0;
    bool control = false;                // control flow inside a MEAS: counts are not static
    bool scanned = false;                // PAMEAS inside: the point count is the machine's
    std::string feature, type;
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
  void error(Span span, const char* code, std::string message) { m_sink.error(code, span, std::move(message)); }
  void warn(Span span, const char* code, std::string message) { m_sink.warning(code, span, std::move(message)); }

  // ---- emission -----------------------------------------------------------------------------
  std::vector<ir::Instruction>& code() {
    return m_macro ? m_module.macros[static_cast<std::size_t>(*m_macro)].code : m_module.units[m_unit].code;
  }
  std::size_t emit(ir::Instruction in) {
    code().push_back(std::move(in));
    return code().size() - 1;
  }
  static ir::Instruction make(Op op, const grammar::Statement& s, std::string name = {}) {
    ir::Instruction in;
    in.op = op;
    in.span = s.span;
    in.name = std::move(name);
    return in;
  }
  JumpScope& jumps() { return m_macro ? m_macro_jumps : m_unit_jumps; }
  void resolve_jumps(JumpScope& scope, std::vector<ir::Instruction>& target_code) {
    for (const auto& [pc, ref] : scope.pending) {
      auto it = scope.labels.find(ref.first);
      if (it == scope.labels.end())
        error(ref.second, "sema.undefined-jump-label", fmt::format("JUMPTO target ({}) is not defined", ref.first));
      else
        target_code[pc].target = static_cast<std::int64_t>(it->second);
    }
    scope = {};
  }

  // ---- operand helpers ----------------------------------------------------------------------
  static bool is_word(const grammar::Expr& e) { return e.kind == ExprKind::Word; }
  static bool is_word(const grammar::Expr& e, std::string_view w) { return e.kind == ExprKind::Word && e.text == w; }
  static bool is_label(const grammar::Expr& e, std::initializer_list<const char*> prefixes) {
    if (e.kind != ExprKind::Label) return false;
    return std::any_of(prefixes.begin(), prefixes.end(), [&](const char* p) { return e.label.prefix == p; });
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
  ir::LabelOperand label_operand(const grammar::LabelRef& l) {
    ir::LabelOperand out{upper(l.prefix), upper(l.name), std::nullopt, l.span};
    out.param = macro_param(out.name);
    return out;
  }
  ir::Operand word_operand(const grammar::Expr& e) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Word;
    o.word = e.text;
    o.span = e.span;
    return o;
  }
  ir::Operand label_op(const grammar::Expr& e) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Label;
    o.label = label_operand(e.label);
    o.span = e.span;
    return o;
  }
  ir::Operand expr_operand(ir::Expr e) {
    ir::Operand o;
    o.kind = ir::Operand::Kind::Expr;
    o.span = e.span;
    o.expr = std::move(e);
    return o;
  }

  // ---- expressions --------------------------------------------------------------------------
  struct Typed {
    ir::Expr e;
    bool dynamic = false;  // type known only at run time (macro parameter)
  };

  std::optional<Typed> expression(const grammar::Expr& g, bool allow_labels = false) {
    Typed t;
    t.e.span = g.span;
    switch (g.kind) {
      case ExprKind::Number:
        t.e.op = ir::ExprOp::Constant;
        t.e.value = Value::real(g.number);
        t.e.type = ValueType::Real;
        return t;
      case ExprKind::String:
        t.e.op = ir::ExprOp::Constant;
        t.e.value = Value::string(g.text);
        t.e.type = ValueType::String;
        return t;
      case ExprKind::Word: {
        if (g.text == ".TRUE." || g.text == ".FALSE.") {
          t.e.op = ir::ExprOp::Constant;
          t.e.value = Value::boolean_value(g.text == ".TRUE.");
          t.e.type = ValueType::Bool;
          return t;
        }
        t.e.op = ir::ExprOp::Variable;
        t.e.name = g.text;
        if (macro_param(g.text) || m_runtime_names.count(g.text)) {
          t.dynamic = true;
          return t;
        }
        if (auto it = m_locals.find(g.text); it != m_locals.end()) {
          t.e.type = it->second.type;
          return t;
        }
        if (auto it = m_symbols.variables.find(g.text); it != m_symbols.variables.end()) {
          if (it->second.size > 0) {
            error(g.span, "sema.array-without-index", fmt::format("array {} needs an index, e.g. {}[1]", g.text, g.text));
            return std::nullopt;
          }
          t.e.type = it->second.type;
          return t;
        }
        if (g.text.empty()) {
          error(g.span, "sema.missing-value", "expected a value, got an empty parameter");
          return std::nullopt;
        }
        error(g.span, "sema.undeclared-variable",
              fmt::format("variable {} is not declared: add DECL/REAL,{} (or INTGR, CHAR, BOOL) before its use", g.text, g.text));
        return std::nullopt;
      }
      case ExprKind::Label: {
        if (!allow_labels) {
          error(g.span, "sema.label-not-value", fmt::format("expected a value, got the label {}({})", g.label.prefix, g.label.name));
          return std::nullopt;
        }
        t.e.op = ir::ExprOp::Constant;
        t.e.label = label_operand(g.label);
        t.e.value = Value::label(t.e.label.prefix, t.e.label.name);
        t.e.type = ValueType::Label;
        return t;
      }
      case ExprKind::Paren:
        return g.args.empty() ? std::nullopt : expression(g.args[0], allow_labels);
      case ExprKind::Index: {
        t.e.op = ir::ExprOp::Element;
        t.e.name = g.text;
        auto it = m_symbols.variables.find(g.text);
        auto lt = m_locals.find(g.text);
        const SymbolTable::VariableInfo* info = lt != m_locals.end() ? &lt->second : (it != m_symbols.variables.end() ? &it->second : nullptr);
        if (!info) {
          error(g.span, "sema.undeclared-variable", fmt::format("array {} is not declared", g.text));
          return std::nullopt;
        }
        if (info->size == 0) {
          error(g.span, "sema.not-array", fmt::format("{} is not an array", g.text));
          return std::nullopt;
        }
        t.e.type = info->type;
        for (const auto& a : g.args) {
          auto i = expression(a);
          if (!i) return std::nullopt;
          if (!i->dynamic && !(i->e.type == ValueType::Real || i->e.type == ValueType::Integer)) {
            error(a.span, "sema.type", "an array index must be a number");
            return std::nullopt;
          }
          t.e.args.push_back(std::move(i->e));
        }
        return t;
      }
      case ExprKind::Call: {
        const Builtin* fn = find_builtin(g.text);
        if (!fn) {
          error(g.span, "sema.unknown-function", fmt::format("unknown function {}", g.text));
          return std::nullopt;
        }
        const int n = static_cast<int>(g.args.size());
        if (n < fn->min_args || n > fn->max_args) {
          error(g.span, "sema.arity",
                fn->min_args == fn->max_args
                    ? fmt::format("{} takes {} argument{}, got {}", g.text, fn->min_args, fn->min_args == 1 ? "" : "s", n)
                    : fmt::format("{} takes {} to {} arguments, got {}", g.text, fn->min_args, fn->max_args, n));
          return std::nullopt;
        }
        t.e.op = ir::ExprOp::Call;
        t.e.name = g.text;
        t.e.type = fn->result;
        for (const auto& a : g.args) {
          auto x = expression(a);
          if (!x) return std::nullopt;
          if (!x->dynamic && x->e.type == ValueType::Bool) {
            error(a.span, "sema.type", fmt::format("{} does not take a BOOL argument", g.text));
            return std::nullopt;
          }
          if (!x->dynamic && !fn->string_args && g.text != "STR" && x->e.type == ValueType::String) {
            error(a.span, "sema.type", fmt::format("{} expects a number, got a string", g.text));
            return std::nullopt;
          }
          t.dynamic |= x->dynamic;
          t.e.args.push_back(std::move(x->e));
        }
        return t;
      }
      case ExprKind::Unary: {
        auto x = expression(g.args.at(0));
        if (!x) return std::nullopt;
        t.e.op = ir::ExprOp::Unary;
        t.e.name = g.text;
        t.dynamic = x->dynamic;
        if (g.text == ".NOT.") {
          if (!x->dynamic && x->e.type != ValueType::Bool) {
            error(g.span, "sema.type", fmt::format(".NOT. needs a BOOL, got {}", to_string(x->e.type)));
            return std::nullopt;
          }
          t.e.type = ValueType::Bool;
        } else {
          if (!x->dynamic && !(x->e.type == ValueType::Real || x->e.type == ValueType::Integer)) {
            error(g.span, "sema.type", fmt::format("unary {} needs a number, got {}", g.text, to_string(x->e.type)));
            return std::nullopt;
          }
          t.e.type = x->e.type;
        }
        t.e.args.push_back(std::move(x->e));
        return t;
      }
      case ExprKind::Binary: {
        auto a = expression(g.args.at(0));
        auto b = expression(g.args.at(1));
        if (!a || !b) return std::nullopt;
        t.e.op = ir::ExprOp::Binary;
        t.e.name = g.text;
        t.dynamic = a->dynamic || b->dynamic;
        const auto number = [](ValueType v) { return v == ValueType::Real || v == ValueType::Integer; };
        const std::string& op = g.text;
        if (op == ".AND." || op == ".OR.") {
          if (!t.dynamic && (a->e.type != ValueType::Bool || b->e.type != ValueType::Bool)) {
            error(g.span, "sema.type", fmt::format("{} needs BOOL operands", op));
            return std::nullopt;
          }
          t.e.type = ValueType::Bool;
        } else if (op[0] == '.') {
          if (!t.dynamic && !((number(a->e.type) && number(b->e.type)) ||
                              (a->e.type == ValueType::String && b->e.type == ValueType::String) ||
                              (a->e.type == ValueType::Bool && b->e.type == ValueType::Bool && (op == ".EQ." || op == ".NE.")))) {
            error(g.span, "sema.type", fmt::format("{} compares a {} with a {}", op, to_string(a->e.type), to_string(b->e.type)));
            return std::nullopt;
          }
          t.e.type = ValueType::Bool;
        } else {
          if (!t.dynamic && op == "+" && a->e.type == ValueType::String && b->e.type == ValueType::String) {
            error(g.span, "sema.type", "strings are joined with CONCAT(a,b), not +");
            return std::nullopt;
          }
          if (!t.dynamic && (!number(a->e.type) || !number(b->e.type))) {
            error(g.span, "sema.type", fmt::format("'{}' needs numbers, got {} and {}", op, to_string(a->e.type), to_string(b->e.type)));
            return std::nullopt;
          }
          t.e.type = (a->e.type == ValueType::Integer && b->e.type == ValueType::Integer && op != "/" && op != "**")
                         ? ValueType::Integer : ValueType::Real;
        }
        t.e.args.push_back(std::move(a->e));
        t.e.args.push_back(std::move(b->e));
        return t;
      }
    }
    return std::nullopt;
  }

  // A numeric parameter (a number, a variable or an arithmetic expression).
  std::optional<ir::Expr> numeric(const grammar::Expr& g, const char* what) {
    if (g.kind == ExprKind::Word && !g.text.empty() && !is_variable(g.text)) {
      error(g.span, "sema.expected-number", fmt::format("expected {} (a number), got the word {}", what, g.text));
      return std::nullopt;
    }
    if (g.kind == ExprKind::String) {
      error(g.span, "sema.expected-number", fmt::format("expected {} (a number), got a string", what));
      return std::nullopt;
    }
    auto t = expression(g);
    if (!t) return std::nullopt;
    if (!t->dynamic && !(t->e.type == ValueType::Real || t->e.type == ValueType::Integer)) {
      error(g.span, "sema.expected-number", fmt::format("expected {} (a number), got a {}", what, to_string(t->e.type)));
      return std::nullopt;
    }
    return std::move(t->e);
  }

  // ---- name checks --------------------------------------------------------------------------
  // A feature label must be defined before use; FA() needs it measured or constructed at run time.
  bool check_feature(const grammar::Expr& e) {
    const std::string name = upper(e.label.name);
    if (macro_param(name)) return true;
    if (m_symbols.features.count(name)) return true;
    if (auto it = m_symbols.skipped.find("F:" + name); it != m_symbols.skipped.end()) {
      Diagnostic d{Severity::Error, "sema.skipped-definition", e.span,
                   fmt::format("feature {}({}) is defined only by a statement metron skipped", e.label.prefix, e.label.name), {}};
      const Location loc = m_sources.locate(it->second);
      d.notes.push_back(fmt::format("the unsupported statement is at {}:{}:{}", loc.path, loc.line, loc.column));
      m_sink.report(std::move(d));
      return false;
    }
    error(e.span, "sema.undefined-feature",
          fmt::format("feature {}({}) is used before its definition: define it with F({})=FEAT/...", e.label.prefix, e.label.name, e.label.name));
    return false;
  }
  std::string feature_type(const std::string& name) const {
    auto it = m_symbols.features.find(name);
    return it == m_symbols.features.end() ? std::string() : it->second.type;
  }

  // ---- statements ---------------------------------------------------------------------------
  void statement(const grammar::Statement& s) {
    if (s.jump_label) {
      jumps().labels[upper(*s.jump_label)] = code().size();
      emit(make(Op::JumpLabel, s, upper(*s.jump_label)));
      return;
    }
    const std::string& m = s.major;
    if (!m_blocks.empty() && m_blocks.back().kind == Block::Kind::Meas) {
      static const std::set<std::string> allowed = {"GOTO", "PTMEAS", "RMEAS", "PAMEAS", "ENDMES", "ENDFIL", "SNSET", "FEDRAT", "TEXT",
                                                    "IF", "ELSE", "ENDIF", "DO", "ENDDO", "ASSIGN", "CALL", "DISPLY"};
      if (!allowed.count(m) && !s.variable) {
        error(s.major_span, "sema.not-in-meas", fmt::format("{} is not allowed inside a MEAS block (close it with ENDMES first)", m));
        return;
      }
    }
    if (s.variable) return assignment(s);
    if (m == "ENDFIL") {
      emit(make(Op::End, s));
      m_ended = true;
      return;
    }
    if (no_effect.count(m)) {
      emit(make(Op::Nop, s, m));
      return;
    }
    using Handler = void (UnitCompiler::*)(const grammar::Statement&);
    static const std::map<std::string, Handler> handlers = {
        {"UNITS", &UnitCompiler::units},       {"MODE", &UnitCompiler::mode},
        {"TEXT", &UnitCompiler::text},         {"FEAT", &UnitCompiler::feat},
        {"SNSDEF", &UnitCompiler::snsdef},     {"SNSMNT", &UnitCompiler::snsmnt},
        {"SNSLCT", &UnitCompiler::snslct},     {"SNSET", &UnitCompiler::snset},
        {"FEDRAT", &UnitCompiler::fedrat},     {"ACLRAT", &UnitCompiler::aclrat},
        {"GOTO", &UnitCompiler::go_to},        {"MEAS", &UnitCompiler::meas},
        {"ENDMES", &UnitCompiler::endmes},     {"PTMEAS", &UnitCompiler::ptmeas},
        {"RMEAS", &UnitCompiler::ptmeas},      {"TOL", &UnitCompiler::tol},
        {"OUTPUT", &UnitCompiler::output},     {"DATDEF", &UnitCompiler::datdef},
        {"DATSET", &UnitCompiler::datset},     {"TRANS", &UnitCompiler::trans},
        {"ROTATE", &UnitCompiler::rotate},     {"SAVE", &UnitCompiler::save},
        {"RECALL", &UnitCompiler::recall},     {"CONST", &UnitCompiler::construct},
        {"DECL", &UnitCompiler::decl},         {"IF", &UnitCompiler::if_},
        {"ELSE", &UnitCompiler::else_},        {"ENDIF", &UnitCompiler::endif},
        {"DO", &UnitCompiler::do_},            {"ENDDO", &UnitCompiler::enddo},
        {"JUMPTO", &UnitCompiler::jumpto},     {"MACRO", &UnitCompiler::macro},
        {"ENDMAC", &UnitCompiler::endmac},     {"CALL", &UnitCompiler::call},
        {"DEVICE", &UnitCompiler::device},     {"OPEN", &UnitCompiler::open},
        {"CLOSE", &UnitCompiler::close},       {"ASSIGN", &UnitCompiler::bad_assign},
        {"OBTAIN", &UnitCompiler::bad_assign},  {"PATH", &UnitCompiler::path},
        {"PAMEAS", &UnitCompiler::pameas},      {"SCNMOD", &UnitCompiler::scnmod},
        {"SCNSET", &UnitCompiler::scnset},
    };
    auto it = handlers.find(m);
    if (it == handlers.end()) return unknown(s);
    (this->*(it->second))(s);
  }

  // A vendor or unsupported statement: warn and skip; remember labels it would have defined.
  void unknown(const grammar::Statement& s) {
    warn(s.major_span, "sema.unknown-statement", fmt::format("unknown statement {} is skipped", s.major.empty() ? "?" : s.major));
    if (s.target) m_symbols.skipped[(s.target->prefix == "F" ? "F:" : s.target->prefix + ":") + upper(s.target->name)] = s.span;
    emit(make(Op::Nop, s, s.major));
  }

  bool expect_params(const grammar::Statement& s, std::size_t n, const char* what) {
    if (s.params.size() >= n) return true;
    error(s.params.empty() ? s.major_span : s.params.back().span, "sema.missing-parameter",
          fmt::format("expected {} after {}", what, s.params.empty() ? s.major + "/" : "'" + s.major + "' parameters"));
    return false;
  }

  bool require_target(const grammar::Statement& s, std::initializer_list<const char*> prefixes, const char* example) {
    if (s.target && std::any_of(prefixes.begin(), prefixes.end(), [&](const char* p) { return s.target->prefix == p; }))
      return true;
    error(s.span, "sema.missing-label", fmt::format("{} needs a label on the left: {}", s.major, example));
    return false;
  }

  // UNITS/MM|INCH|CM|M|FEET,ANGDEC|ANGRAD[,TEMPF|TEMPC]
  void units(const grammar::Statement& s) {
    if (!expect_params(s, 1, "a length unit (MM, INCH, CM, M, FEET)")) return;
    auto in = make(Op::Units, s);
    static const std::set<std::string> lengths = {"MM", "INCH", "CM", "M", "FEET"};
    static const std::set<std::string> angles = {"ANGDEC", "ANGRAD", "ANGDMS"};
    if (!is_word(s.params[0]) || !lengths.count(s.params[0].text))
      return error(s.params[0].span, "sema.bad-unit", "expected a length unit (MM, INCH, CM, M, FEET) after UNITS/");
    in.operands.push_back(word_operand(s.params[0]));
    if (s.params.size() > 1) {
      if (!is_word(s.params[1]) || !angles.count(s.params[1].text))
        return error(s.params[1].span, "sema.bad-unit", "expected an angle unit (ANGDEC, ANGRAD) after the length unit");
      if (s.params[1].text == "ANGDMS") warn(s.params[1].span, "sema.angdms", "ANGDMS is read as decimal degrees");
      in.operands.push_back(word_operand(s.params[1]));
    }
    emit(std::move(in));
  }

  // MODE/AUTO | MODE/PROG,MAN | MODE/MAN
  void mode(const grammar::Statement& s) {
    if (!expect_params(s, 1, "AUTO, PROG,MAN or MAN")) return;
    auto in = make(Op::Mode, s);
    std::string w;
    for (const auto& p : s.params) w += (w.empty() ? "" : " ") + p.text;
    if (w != "AUTO" && w != "PROG MAN" && w != "MAN")
      return error(s.params[0].span, "sema.bad-mode", "expected AUTO, PROG,MAN or MAN after MODE/");
    ir::Operand o;
    o.kind = ir::Operand::Kind::Word;
    o.word = w;
    o.span = s.params[0].span;
    in.operands.push_back(o);
    emit(std::move(in));
  }

  // TEXT/OPER|OUTFIL|MAN|DISPLY,'text'
  void text(const grammar::Statement& s) {
    if (!expect_params(s, 2, "the text kind (OPER, OUTFIL, MAN) and the text")) return;
    auto in = make(Op::Text, s);
    in.operands.push_back(word_operand(s.params[0]));
    auto e = expression(s.params[1]);
    if (!e) return;
    in.operands.push_back(expr_operand(std::move(e->e)));
    emit(std::move(in));
  }

  // F(l)=FEAT/CIRCLE,INNER|OUTER,CART,x,y,z,i,j,k,d  (likewise POINT, PLANE, LINE, ARC, SPHERE, CYLNDR, CONE; CART|POL)
  void feat(const grammar::Statement& s) {
    if (!require_target(s, {"F"}, "F(label)=FEAT/...")) return;
    if (!expect_params(s, 1, "the feature type")) return;
    const std::string label = upper(s.target->name);
    const auto& p = s.params;
    if (!is_word(p[0]) || !feature_types.count(p[0].text)) {
      if (is_word(p[0]) && (p[0].text == "GCURVE" || p[0].text == "GSURF" || p[0].text == "EDGEPT" || p[0].text == "TORUS" ||
                            p[0].text == "PARPLN" || p[0].text == "RCTNGL" || p[0].text == "CPARLN" || p[0].text == "ELLIPS")) {
        warn(p[0].span, "sema.unsupported-feature", fmt::format("feature type {} is not supported yet; F({}) is skipped", p[0].text, s.target->name));
        m_symbols.skipped["F:" + label] = s.span;
        emit(make(Op::Nop, s, "FEAT"));
        return;
      }
      return error(p[0].span, "sema.bad-feature-type",
                   "expected a feature type (POINT, PLANE, LINE, CIRCLE, ARC, SPHERE, CYLNDR, CONE) after FEAT/");
    }
    const std::string type = p[0].text;
    auto in = make(Op::FeatureDef, s, label);
    in.operands.push_back(word_operand(p[0]));
    std::size_t i = 1;
    const bool sized = type == "CIRCLE" || type == "ARC" || type == "SPHERE" || type == "CYLNDR" || type == "CONE";
    bool bounded = false;
    if (sized) {
      if (i >= p.size() || !(is_word(p[i], "INNER") || is_word(p[i], "OUTER")))
        return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-side",
                     fmt::format("expected INNER or OUTER after the feature type {}", type));
      in.operands.push_back(word_operand(p[i++]));
    }
    if (type == "LINE") {
      if (i < p.size() && (is_word(p[i], "BND") || is_word(p[i], "UNBND"))) {
        bounded = p[i].text == "BND";
        in.operands.push_back(word_operand(p[i++]));
      } else {
        return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-bnd", "expected BND or UNBND after LINE");
      }
    }
    if (i >= p.size() || !(is_word(p[i], "CART") || is_word(p[i], "POL")))
      return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-form",
                   fmt::format("expected CART or POL after the feature type {}", type));
    in.operands.push_back(word_operand(p[i++]));
    const FeatureForm form = feature_form(type, bounded);
    const std::size_t n = p.size() - i;
    if (n < form.min_numbers || n > form.max_numbers)
      return error(n > form.max_numbers ? p[i + form.max_numbers].span : p.back().span, "sema.feature-arity",
                   fmt::format("FEAT/{} expects {} numbers ({}), got {}", type,
                               form.min_numbers == form.max_numbers ? fmt::format("{}", form.min_numbers)
                                                                    : fmt::format("{} to {}", form.min_numbers, form.max_numbers),
                               form.meaning, n));
    bool ok = true;
    std::vector<double> literal;
    for (; i < p.size(); ++i) {
      auto e = numeric(p[i], "a feature coordinate");
      if (!e) { ok = false; continue; }
      literal.push_back(e->op == ir::ExprOp::Constant ? e->value.number
                        : (e->op == ir::ExprOp::Unary && e->args[0].op == ir::ExprOp::Constant ? -e->args[0].value.number : NAN));
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    if (!ok) return;
    // Static checks on literal values: a zero direction, a non-positive size.
    if (type != "SPHERE" || n == 7) {
      const std::size_t d = (type == "LINE" && bounded) ? 6 : 3;
      if (literal.size() >= d + 3 && literal[d] == 0 && literal[d + 1] == 0 && literal[d + 2] == 0)
        return error(s.params[s.params.size() - n + d].span, "sema.zero-vector", "the direction vector i,j,k is zero");
    }
    if (sized && type != "CONE") {
      const double size = type == "ARC" ? literal[6] : literal.back();
      const std::size_t idx = type == "ARC" ? 6 : (type == "CYLNDR" && n == 8 ? n - 2 : n - 1);
      const double sz = type == "CYLNDR" && n == 8 ? literal[6] : size;
      if (!std::isnan(sz) && sz <= 0)
        return error(s.params[s.params.size() - n + idx].span, "sema.bad-size", fmt::format("the {} of F({}) must be positive", type == "ARC" ? "radius" : "diameter", s.target->name));
    }
    if (type == "CONE" && !std::isnan(literal[6]) && (literal[6] <= 0 || literal[6] >= 180))
      return error(s.params[s.params.size() - n + 6].span, "sema.bad-size", "the cone angle must be between 0 and 180 degrees");
    if (auto it = m_symbols.features.find(label); it != m_symbols.features.end() && !m_repl) {
      const Location loc = m_sources.locate(it->second.span);
      warn(s.target->span, "sema.redefined-feature", fmt::format("F({}) is redefined (first defined at line {})", s.target->name, loc.line));
    }
    if (auto param = macro_param(label)) {
      in.name_is_param = true;
      m_symbols.macro_features[m_module.macros[static_cast<std::size_t>(*m_macro)].name][*param] = type;
    }
    m_symbols.features[label] = {type, s.span};
    m_symbols.skipped.erase("F:" + label);
    emit(std::move(in));
  }

  // S(l)=SNSDEF/PROBE,FIXED|INDEX,CART|POL,...,diam
  void snsdef(const grammar::Statement& s) {
    if (!require_target(s, {"S"}, "S(label)=SNSDEF/PROBE,...")) return;
    if (!expect_params(s, 1, "the sensor type")) return;
    if (!is_word(s.params[0], "PROBE")) {
      warn(s.params[0].span, "sema.unsupported-sensor", fmt::format("sensor type {} is not supported; S({}) is skipped", s.params[0].text, s.target->name));
      m_symbols.skipped["S:" + upper(s.target->name)] = s.span;
      emit(make(Op::Nop, s, "SNSDEF"));
      return;
    }
    auto in = make(Op::SensorDef, s, upper(s.target->name));
    std::size_t i = 0;
    for (; i < s.params.size() && is_word(s.params[i]) && !is_variable(s.params[i].text); ++i)
      in.operands.push_back(word_operand(s.params[i]));
    const std::size_t n = s.params.size() - i;
    if (n < 4) return error(s.params.back().span, "sema.sensor-arity", "SNSDEF/PROBE expects the stylus vector and the tip diameter after the words");
    for (; i < s.params.size(); ++i) {
      auto e = numeric(s.params[i], "a sensor parameter");
      if (!e) return;
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    m_symbols.sensors.insert(upper(s.target->name));
    emit(std::move(in));
  }

  // SNSMNT/XVEC,i,j,k,ZVEC,i,j,k,MNTLEN,x,y,z: the probe mount; the virtual CMM's head is fixed.
  void snsmnt(const grammar::Statement& s) { emit(make(Op::Nop, s, "SNSMNT")); }

  // SNSLCT/S(l)
  void snslct(const grammar::Statement& s) {
    if (!expect_params(s, 1, "a sensor label S(...)")) return;
    if (!is_label(s.params[0], {"S", "SA"})) return error(s.params[0].span, "sema.expected-sensor", "expected a sensor label S(...) after SNSLCT/");
    const std::string name = upper(s.params[0].label.name);
    if (!m_symbols.sensors.count(name)) {
      if (auto it = m_symbols.skipped.find("S:" + name); it != m_symbols.skipped.end())
        return error(s.params[0].span, "sema.skipped-definition", fmt::format("sensor S({}) was defined by a skipped statement", s.params[0].label.name));
      return error(s.params[0].span, "sema.undefined-sensor", fmt::format("sensor S({}) is not defined: define it with S({})=SNSDEF/PROBE,...", s.params[0].label.name, s.params[0].label.name));
    }
    emit(make(Op::SensorSelect, s, name));
  }

  // SNSET/APPRCH|RETRCT|SEARCH|CLRSRF|DEPTH,dist[, ...]
  void snset(const grammar::Statement& s) {
    static const std::set<std::string> words = {"APPRCH", "RETRCT", "SEARCH", "CLRSRF", "DEPTH"};
    if (!expect_params(s, 2, "a setting (APPRCH, RETRCT, SEARCH, CLRSRF, DEPTH) and a distance")) return;
    for (std::size_t i = 0; i < s.params.size(); i += 2) {
      if (!is_word(s.params[i]) || !words.count(s.params[i].text)) {
        if (is_word(s.params[i])) {
          warn(s.params[i].span, "sema.unsupported-setting", fmt::format("SNSET/{} is not supported and is ignored", s.params[i].text));
          emit(make(Op::Nop, s, "SNSET"));
          return;
        }
        return error(s.params[i].span, "sema.bad-setting", "expected APPRCH, RETRCT, SEARCH, CLRSRF or DEPTH");
      }
      if (i + 1 >= s.params.size()) return error(s.params[i].span, "sema.missing-parameter", fmt::format("expected a distance after {}", s.params[i].text));
      auto e = numeric(s.params[i + 1], "a distance");
      if (!e) return;
      if (e->op == ir::ExprOp::Constant && e->value.number < 0 && s.params[i].text != "DEPTH")
        return error(s.params[i + 1].span, "sema.negative-distance", fmt::format("the {} distance must not be negative", s.params[i].text));
      auto in = make(Op::ProbeSet, s);
      in.operands.push_back(word_operand(s.params[i]));
      in.operands.push_back(expr_operand(std::move(*e)));
      emit(std::move(in));
    }
  }

  // FEDRAT/MESVEL|POSVEL|SCNVEL,MPM|MMPS|IPM|IPS|PCENT,v   (HEDROT/HEDMVEL... skipped)
  void fedrat(const grammar::Statement& s) {
    if (!expect_params(s, 3, "MESVEL|POSVEL, a unit (MPM, MMPS, IPM, IPS, PCENT) and a value")) return;
    static const std::set<std::string> kinds = {"MESVEL", "POSVEL", "SCNVEL"};
    static const std::set<std::string> units = {"MPM", "MMPS", "IPM", "IPS", "PCENT"};
    if (is_word(s.params[0]) && !kinds.count(s.params[0].text)) {
      warn(s.params[0].span, "sema.unsupported-setting", fmt::format("FEDRAT/{} is not supported and is ignored", s.params[0].text));
      emit(make(Op::Nop, s, "FEDRAT"));
      return;
    }
    if (!is_word(s.params[0])) return error(s.params[0].span, "sema.bad-setting", "expected MESVEL, POSVEL or SCNVEL after FEDRAT/");
    if (!is_word(s.params[1]) || !units.count(s.params[1].text))
      return error(s.params[1].span, "sema.bad-unit", fmt::format("expected a feed unit (MPM, MMPS, IPM, IPS, PCENT) after {}", s.params[0].text));
    auto e = numeric(s.params[2], "a feed rate");
    if (!e) return;
    if (e->op == ir::ExprOp::Constant && e->value.number <= 0) return error(s.params[2].span, "sema.bad-feed", "a feed rate must be positive");
    auto in = make(Op::Feed, s);
    in.operands.push_back(word_operand(s.params[0]));
    in.operands.push_back(word_operand(s.params[1]));
    in.operands.push_back(expr_operand(std::move(*e)));
    emit(std::move(in));
  }

  // ACLRAT/MESACL|POSACL,MPMM|MMPSS|IPMM|IPSS|PCENT,v
  void aclrat(const grammar::Statement& s) {
    if (!expect_params(s, 3, "MESACL|POSACL, a unit and a value")) return;
    auto e = numeric(s.params[2], "an acceleration");
    if (!e) return;
    auto in = make(Op::Accel, s);
    in.operands.push_back(word_operand(s.params[0]));
    in.operands.push_back(word_operand(s.params[1]));
    in.operands.push_back(expr_operand(std::move(*e)));
    emit(std::move(in));
  }

  // GOTO/x,y,z | GOTO/CART,x,y,z | GOTO/INCR,dist,i,j,k | GOTO/POL,r,a,h
  void go_to(const grammar::Statement& s) {
    auto in = make(Op::GoTo, s);
    std::size_t i = 0;
    if (!s.params.empty() && (is_word(s.params[0], "INCR") || is_word(s.params[0], "CART") || is_word(s.params[0], "POL")))
      in.operands.push_back(word_operand(s.params[i++]));
    const bool incr = !in.operands.empty() && in.operands[0].word == "INCR";
    const std::size_t n = s.params.size() - i;
    if (incr ? n != 4 : (n != 3 && n != 6))
      return error(n == 0 ? s.major_span : s.params.back().span, "sema.goto-arity",
                   incr ? fmt::format("GOTO/INCR expects a distance and a direction i,j,k, got {} numbers", n)
                        : fmt::format("GOTO expects x,y,z (optionally i,j,k), got {} numbers", n));
    for (; i < s.params.size(); ++i) {
      auto e = numeric(s.params[i], "a coordinate");
      if (!e) return;
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    emit(std::move(in));
  }

  // MEAS/type,F(l),n
  void meas(const grammar::Statement& s) {
    // Open the block first, so that a bad MEAS does not also make its ENDMES an error.
    Block placeholder = block(Block::Kind::Meas, s.span);
    placeholder.start = invalid;
    placeholder.control = true;
    m_blocks.push_back(placeholder);
    if (!expect_params(s, 3, "the feature type, F(label) and the number of points")) return;
    if (!is_word(s.params[0]) || !feature_types.count(s.params[0].text))
      return error(s.params[0].span, "sema.bad-feature-type", "expected a feature type after MEAS/");
    if (!is_label(s.params[1], {"F"})) return error(s.params[1].span, "sema.expected-feature", "expected F(label) after the feature type");
    if (!check_feature(s.params[1])) return;
    const std::string label = upper(s.params[1].label.name);
    const std::string type = feature_type(label);
    if (!type.empty() && type != s.params[0].text)
      return error(s.params[0].span, "sema.meas-type", fmt::format("MEAS/{} on F({}), which is a {}", s.params[0].text, s.params[1].label.name, type));
    auto count = numeric(s.params[2], "the number of points");
    if (!count) return;
    Block b = block(Block::Kind::Meas, s.span);
    b.feature = label;
    b.type = s.params[0].text;
    if (count->op == ir::ExprOp::Constant) {
      b.declared = static_cast<int>(count->value.number);
      if (count->value.number < 0 || count->value.number != std::floor(count->value.number))
        return error(s.params[2].span, "sema.bad-count", "the number of points must be a whole number >= 0");
    }
    auto in = make(Op::MeasBegin, s, label);
    in.name_is_param = macro_param(label).has_value();
    in.operands.push_back(word_operand(s.params[0]));
    in.operands.push_back(expr_operand(std::move(*count)));
    b.start = emit(std::move(in));
    m_blocks.back() = b;
  }

  // ENDMES
  void endmes(const grammar::Statement& s) {
    if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Meas)
      return error(s.major_span, "sema.unmatched", "ENDMES without a matching MEAS");
    Block b = m_blocks.back();
    m_blocks.pop_back();
    if (b.start == invalid) return;
    if (!b.control && !b.scanned && b.ptmeas > 0 && b.declared > 0 && b.ptmeas != b.declared)
      error(b.span, "sema.point-count", fmt::format("MEAS declares {} points but the block has {} PTMEAS", b.declared, b.ptmeas));
    static const std::map<std::string, int> minimum = {{"POINT", 1}, {"LINE", 2}, {"PLANE", 3}, {"CIRCLE", 3}, {"ARC", 3},
                                                       {"SPHERE", 4}, {"CYLNDR", 5}, {"CONE", 6}};
    const int n = b.ptmeas > 0 ? b.ptmeas : b.declared;
    if (!b.control && !b.scanned && n > 0 && n < minimum.at(b.type))
      error(b.span, "sema.too-few-points", fmt::format("a {} needs at least {} points, the block has {}", b.type, minimum.at(b.type), n));
    const std::size_t end = emit(make(Op::MeasEnd, s));
    code()[b.start].target = static_cast<std::int64_t>(end);
  }

  // PTMEAS/CART,x,y,z[,i,j,k]  |  RMEAS/CART,x,y,z,i,j,k[,FA(ref)]
  void ptmeas(const grammar::Statement& s) {
    if (m_blocks.empty() || std::none_of(m_blocks.begin(), m_blocks.end(), [](const Block& b) { return b.kind == Block::Kind::Meas; }))
      return error(s.major_span, "sema.ptmeas-outside", fmt::format("{} outside a MEAS block", s.major));
    if (!expect_params(s, 1, "CART or POL")) return;
    if (!is_word(s.params[0], "CART") && !is_word(s.params[0], "POL"))
      return error(s.params[0].span, "sema.expected-form", fmt::format("expected CART or POL after {}/", s.major));
    auto in = make(Op::PtMeas, s);
    in.operands.push_back(word_operand(s.params[0]));
    std::size_t end = s.params.size();
    if (s.major == "RMEAS" && end > 0 && s.params[end - 1].kind == ExprKind::Label) {
      if (!is_label(s.params[end - 1], {"FA", "F"})) return error(s.params[end - 1].span, "sema.expected-feature", "expected FA(label) as the RMEAS reference");
      if (!check_feature(s.params[end - 1])) return;
      --end;
    }
    const std::size_t n = end - 1;
    if (n != 3 && n != 6) return error(s.params.back().span, "sema.ptmeas-arity", fmt::format("{} expects x,y,z and optionally i,j,k, got {} numbers", s.major, n));
    std::vector<double> v;
    for (std::size_t i = 1; i < end; ++i) {
      auto e = numeric(s.params[i], "a coordinate");
      if (!e) return;
      v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    if (n == 6 && v[3] == 0 && v[4] == 0 && v[5] == 0) return error(s.params[4].span, "sema.zero-vector", "the approach vector i,j,k is zero");
    if (end < s.params.size()) in.operands.push_back(label_op(s.params[end]));
    for (auto& b : m_blocks)
      if (b.kind == Block::Kind::Meas) ++b.ptmeas;
    emit(std::move(in));
  }

  // P(l)=PATH/LINE,CART,x1,y1,z1,x2,y2,z2,i,j,k
  // P(l)=PATH/ARC,CART,x,y,z,i,j,k,rad,ang1,ang2[,INNER|OUTER]
  // P(l)=PATH/HELICAL,CART,x,y,z,i,j,k,rad,ang1,ang2,pitch[,INNER|OUTER]
  void path(const grammar::Statement& s) {
    if (!require_target(s, {"P"}, "P(label)=PATH/...")) return;
    if (!expect_params(s, 1, "the path type (LINE, ARC, HELICAL, SECTION)")) return;
    const auto& p = s.params;
    const std::string name = upper(s.target->name);
    if (is_word(p[0], "SECTION")) return path_section(s);
    static const std::set<std::string> kinds = {"LINE", "ARC", "HELICAL"};
    if (!is_word(p[0]) || !kinds.count(p[0].text)) {
      if (is_word(p[0])) {
        warn(p[0].span, "sema.unsupported-path", fmt::format("PATH/{} is not supported; P({}) is skipped", p[0].text, s.target->name));
        m_symbols.skipped["P:" + name] = s.span;
        emit(make(Op::Nop, s, "PATH"));
        return;
      }
      return error(p[0].span, "sema.bad-path", "expected LINE, ARC or HELICAL after PATH/");
    }
    const std::string kind = p[0].text;
    if (p.size() < 2 || !(is_word(p[1], "CART") || is_word(p[1], "POL")))
      return error(p.size() < 2 ? p[0].span : p[1].span, "sema.expected-form", fmt::format("expected CART after PATH/{}", kind));
    if (is_word(p[1], "POL")) return error(p[1].span, "sema.unsupported-form", "PATH with POL coordinates is not supported: use CART");
    auto in = make(Op::PathDef, s, name);
    in.operands.push_back(word_operand(p[0]));
    std::size_t end = p.size();
    std::optional<ir::Operand> side;
    if (kind != "LINE" && end > 2 && is_word(p[end - 1]) && !is_variable(p[end - 1].text)) {
      if (!is_word(p[end - 1], "INNER") && !is_word(p[end - 1], "OUTER"))
        return error(p[end - 1].span, "sema.expected-side", fmt::format("expected INNER or OUTER at the end of PATH/{}", kind));
      side = word_operand(p[end - 1]);
      --end;
    }
    const std::size_t want = kind == "LINE" ? 9 : kind == "ARC" ? 9 : 10;
    const char* form = kind == "LINE" ? "x1,y1,z1,x2,y2,z2,i,j,k" : kind == "ARC" ? "x,y,z,i,j,k,rad,ang1,ang2" : "x,y,z,i,j,k,rad,ang1,ang2,pitch";
    const std::size_t n = end - 2;
    if (n != want)
      return error(end > 2 ? p[end - 1].span : p[1].span, "sema.path-arity", fmt::format("PATH/{} expects {} numbers ({}), got {}", kind, want, form, n));
    if (side) in.operands.push_back(*side);
    std::vector<double> v;
    for (std::size_t i = 2; i < end; ++i) {
      auto e = numeric(p[i], "a path parameter");
      if (!e) return;
      v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    const std::size_t vec = kind == "LINE" ? 6 : 3;
    if (v[vec] == 0 && v[vec + 1] == 0 && v[vec + 2] == 0) return error(p[2 + vec].span, "sema.zero-vector", "the path vector i,j,k is zero");
    if (kind != "LINE" && v[6] <= 0) return error(p[8].span, "sema.bad-size", fmt::format("the radius of P({}) must be positive", s.target->name));
    if (kind != "LINE" && v[7] == v[8]) return error(p[10].span, "sema.bad-angle", "the start and end angles of the path are equal");
    if (kind == "LINE" && v[0] == v[3] && v[1] == v[4] && v[2] == v[5]) return error(p[5].span, "sema.bad-path", "the line's end points are the same");
    m_symbols.paths.insert(name);
    m_symbols.skipped.erase("P:" + name);
    emit(std::move(in));
  }

  // P(l)=PATH/SECTION,'file',x,y,z,i,j,k,xs,ys,zs   (metron: a plane section of a CAD model)
  void path_section(const grammar::Statement& s) {
    const auto& p = s.params;
    if (p.size() < 2 || p[1].kind != ExprKind::String)
      return error(p.size() < 2 ? p[0].span : p[1].span, "sema.expected-file", "expected the CAD file name as a string after PATH/SECTION, e.g. 'part.stl'");
    std::filesystem::path file(p[1].text);
    if (file.is_relative()) file = std::filesystem::path(m_module.units[m_unit].path).parent_path() / file;
    if (!std::filesystem::exists(file)) return error(p[1].span, "sema.missing-file", fmt::format("CAD file '{}' not found", p[1].text));
    const std::size_t n = p.size() - 2;
    if (n != 9)
      return error(p.back().span, "sema.path-arity", fmt::format("PATH/SECTION expects the file and 9 numbers (plane point x,y,z, plane normal i,j,k, start near xs,ys,zs), got {}", n));
    auto in = make(Op::PathDef, s, upper(s.target->name));
    in.operands.push_back(word_operand(p[0]));
    in.names.push_back(file.string());
    std::vector<double> v;
    for (std::size_t i = 2; i < p.size(); ++i) {
      auto e = numeric(p[i], "a path parameter");
      if (!e) return;
      v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    if (v[3] == 0 && v[4] == 0 && v[5] == 0) return error(p[5].span, "sema.zero-vector", "the plane normal i,j,k is zero");
    m_symbols.paths.insert(upper(s.target->name));
    m_symbols.skipped.erase("P:" + upper(s.target->name));
    emit(std::move(in));
  }

  // PAMEAS/P(l): scan along a path inside a MEAS block
  void pameas(const grammar::Statement& s) {
    if (m_blocks.empty() || std::none_of(m_blocks.begin(), m_blocks.end(), [](const Block& b) { return b.kind == Block::Kind::Meas; }))
      return error(s.major_span, "sema.ptmeas-outside", "PAMEAS outside a MEAS block");
    if (!expect_params(s, 1, "P(label)")) return;
    if (s.params.size() != 1 || !is_label(s.params[0], {"P"}))
      return error(s.params[s.params.size() == 1 ? 0 : 1].span, "sema.expected-path", "expected a single P(label) after PAMEAS/");
    const std::string name = upper(s.params[0].label.name);
    if (!m_symbols.paths.count(name) && !macro_param(name)) {
      if (auto it = m_symbols.skipped.find("P:" + name); it != m_symbols.skipped.end())
        return error(s.params[0].span, "sema.skipped-definition", fmt::format("path P({}) was defined by a skipped statement", s.params[0].label.name));
      return error(s.params[0].span, "sema.undefined-path", fmt::format("path P({}) is not defined: define it with P({})=PATH/...", s.params[0].label.name, s.params[0].label.name));
    }
    auto in = make(Op::PaMeas, s);
    in.operands.push_back(label_op(s.params[0]));
    for (auto& b : m_blocks)
      if (b.kind == Block::Kind::Meas) b.scanned = true;
    emit(std::move(in));
  }

  // SCNMOD/ON|OFF
  void scnmod(const grammar::Statement& s) {
    if (!expect_params(s, 1, "ON or OFF")) return;
    if (s.params.size() != 1 || !(is_word(s.params[0], "ON") || is_word(s.params[0], "OFF")))
      return error(s.params[s.params.size() == 1 ? 0 : 1].span, "sema.bad-setting", "expected ON or OFF after SCNMOD/");
    auto in = make(Op::ScanMode, s);
    in.operands.push_back(word_operand(s.params[0]));
    emit(std::move(in));
  }

  // SCNSET/DRAG|DIST|CHORD|ACCEL|DEFLEC,value | SCNSET/LAW,VC1|VC1P|VC2 [, ...]
  void scnset(const grammar::Statement& s) {
    static const std::set<std::string> values = {"DIST", "DRAG", "CHORD", "ACCEL", "DEFLEC"};
    if (!expect_params(s, 2, "a scan setting (DRAG, DIST, CHORD, ACCEL, DEFLEC, LAW) and its value")) return;
    for (std::size_t i = 0; i < s.params.size(); i += 2) {
      const auto& w = s.params[i];
      if (!is_word(w) || (!values.count(w.text) && w.text != "LAW")) {
        if (is_word(w)) {
          warn(w.span, "sema.unsupported-setting", fmt::format("SCNSET/{} is not supported and is ignored", w.text));
          emit(make(Op::Nop, s, "SCNSET"));
          return;
        }
        return error(w.span, "sema.bad-setting", "expected DRAG, DIST, CHORD, ACCEL, DEFLEC or LAW");
      }
      if (i + 1 >= s.params.size()) return error(w.span, "sema.missing-parameter", fmt::format("expected a value after {}", w.text));
      auto in = make(Op::ScanSet, s);
      in.operands.push_back(word_operand(w));
      if (w.text == "LAW") {
        const auto& law = s.params[i + 1];
        if (!(is_word(law, "VC1") || is_word(law, "VC1P") || is_word(law, "VC2")))
          return error(law.span, "sema.bad-setting", "expected VC1, VC1P or VC2 after LAW");
        in.operands.push_back(word_operand(law));
      } else {
        auto e = numeric(s.params[i + 1], "a value");
        if (!e) return;
        if (e->op == ir::ExprOp::Constant && !(e->value.number > 0))
          return error(s.params[i + 1].span, "sema.bad-setting", fmt::format("the SCNSET/{} value must be positive", w.text));
        in.operands.push_back(expr_operand(std::move(*e)));
      }
      emit(std::move(in));
    }
  }

  // T(l)=TOL/kind,...
  void tol(const grammar::Statement& s) {
    if (!require_target(s, {"T"}, "T(label)=TOL/...")) return;
    if (!expect_params(s, 1, "the tolerance type")) return;
    const auto& p = s.params;
    if (!is_word(p[0]) || !tolerance_kinds.count(p[0].text)) {
      if (is_word(p[0])) {
        warn(p[0].span, "sema.unsupported-tolerance", fmt::format("tolerance type {} is not supported; T({}) is skipped", p[0].text, s.target->name));
        m_symbols.skipped["T:" + upper(s.target->name)] = s.span;
        emit(make(Op::Nop, s, "TOL"));
        return;
      }
      return error(p[0].span, "sema.bad-tolerance", "expected a tolerance type (DIAM, RAD, DISTB, POS, FLAT, ...) after TOL/");
    }
    const std::string kind = p[0].text;
    auto in = make(Op::ToleranceDef, s, upper(s.target->name));
    in.name_is_param = macro_param(upper(s.target->name)).has_value();
    in.operands.push_back(word_operand(p[0]));
    std::vector<double> numbers;
    for (std::size_t i = 1; i < p.size(); ++i) {
      if (p[i].kind == ExprKind::Label) {
        if (!is_label(p[i], {"DAT", "DATT"})) return error(p[i].span, "sema.expected-datum", "expected a datum DAT(x)");
        const std::string d = upper(p[i].label.name);
        if (!m_symbols.datums.count(d) && !macro_param(d))
          warn(p[i].span, "sema.datum-later", fmt::format("datum DAT({}) is not defined yet; it must be defined by DATDEF before the OUTPUT", p[i].label.name));
        in.operands.push_back(label_op(p[i]));
      } else if (is_word(p[i]) && !is_variable(p[i].text)) {
        in.operands.push_back(word_operand(p[i]));
      } else {
        auto e = numeric(p[i], "a tolerance value");
        if (!e) return;
        numbers.push_back(e->op == ir::ExprOp::Constant ? e->value.number
                          : (e->op == ir::ExprOp::Unary && e->args[0].op == ir::ExprOp::Constant ? -e->args[0].value.number : NAN));
        in.operands.push_back(expr_operand(std::move(*e)));
      }
    }
    static const std::map<std::string, std::pair<std::size_t, const char*>> needs = {
        {"DIAM", {2, "lower and upper tolerance"}}, {"RAD", {2, "lower and upper tolerance"}},
        {"DISTB", {3, "nominal distance, lower and upper tolerance"}}, {"POS", {1, "the tolerance zone"}},
        {"FLAT", {1, "the tolerance zone"}}, {"CIRLTY", {1, "the tolerance zone"}}, {"CYLCTY", {1, "the tolerance zone"}},
        {"SPHCTY", {1, "the tolerance zone"}}, {"STRGHT", {1, "the tolerance zone"}}, {"PERP", {1, "the tolerance zone"}},
        {"PARLEL", {1, "the tolerance zone"}}, {"ANGLB", {3, "nominal angle, lower and upper tolerance"}},
        {"PROFS", {2, "lower and upper tolerance"}}};
    const auto& need = needs.at(kind);
    if (numbers.size() < need.first)
      return error(p.back().span, "sema.tolerance-arity", fmt::format("TOL/{} expects {} ({} number{}), got {}", kind, need.second, need.first, need.first == 1 ? "" : "s", numbers.size()));
    if ((kind == "DIAM" || kind == "RAD" || kind == "PROFS") && numbers[0] > numbers[1])
      return error(p[2].span, "sema.tolerance-order", fmt::format("the lower tolerance {} is above the upper tolerance {}", numbers[0], numbers[1]));
    if ((kind == "PERP" || kind == "PARLEL") &&
        std::none_of(in.operands.begin(), in.operands.end(), [](const ir::Operand& o) { return o.kind == ir::Operand::Kind::Label; }))
      return error(p.back().span, "sema.expected-datum", fmt::format("TOL/{} needs a datum DAT(x)", kind));
    if (kind == "POS" && !(is_word(p[1], "2D") || is_word(p[1], "3D")))
      return error(p.size() > 1 ? p[1].span : p[0].span, "sema.expected-dimension", "expected 2D or 3D after TOL/POS");
    if (!std::isnan(numbers[0]) && need.second == std::string("the tolerance zone") && numbers[0] < 0)
      return error(p.back().span, "sema.negative-zone", "a tolerance zone must not be negative");
    m_symbols.tolerances[upper(s.target->name)] = kind;
    if (std::any_of(in.operands.begin(), in.operands.end(), [](const ir::Operand& o) { return o.kind == ir::Operand::Kind::Label; }))
      m_symbols.tolerance_datums.insert(upper(s.target->name));
    else
      m_symbols.tolerance_datums.erase(upper(s.target->name));
    emit(std::move(in));
  }

  // OUTPUT/FA(x),TA(t),...
  void output(const grammar::Statement& s) {
    if (!expect_params(s, 1, "feature or tolerance labels")) return;
    auto in = make(Op::Output, s);
    std::vector<std::string> types;
    for (const auto& p : s.params) {
      if (is_label(p, {"F", "FA"})) {
        if (!check_feature(p)) return;
        types.push_back(feature_type(upper(p.label.name)));
      } else if (is_label(p, {"T", "TA"})) {
        const std::string t = upper(p.label.name);
        if (!macro_param(t)) {
          auto it = m_symbols.tolerances.find(t);
          if (it == m_symbols.tolerances.end())
            return error(p.span, m_symbols.skipped.count("T:" + t) ? "sema.skipped-definition" : "sema.undefined-tolerance",
                         m_symbols.skipped.count("T:" + t) ? fmt::format("tolerance T({}) was defined by a skipped statement", p.label.name)
                                                           : fmt::format("tolerance T({}) is not defined", p.label.name));
          const std::string& kind = it->second;
          if (kind == "DISTB" && types.size() != 2)
            return error(p.span, "sema.distb-features", "TOL/DISTB is output with two features: OUTPUT/FA(a),FA(b),TA(t)");
          if (kind == "ANGLB" && types.size() != 2 && m_symbols.tolerance_datums.count(t) == 0)
            return error(p.span, "sema.anglb-reference", "TOL/ANGLB needs a datum DAT(x) or a second feature: OUTPUT/FA(a),FA(b),TA(t)");
          for (const auto& type : types)
            if (!type.empty() && !tolerance_applies(kind, type))
              return error(p.span, "sema.tolerance-type", fmt::format("TOL/{} of T({}) does not apply to a {}", kind, p.label.name, type));
          if (types.empty()) return error(p.span, "sema.tolerance-without-feature", fmt::format("T({}) is output without a feature to apply it to", p.label.name));
        }
      } else if (p.kind == ExprKind::Label) {
        warn(p.span, "sema.unsupported-output", fmt::format("OUTPUT of {}() labels is not supported and is ignored", p.label.prefix));
        continue;
      } else {
        return error(p.span, "sema.expected-label", "expected F(), FA(), T() or TA() labels after OUTPUT/");
      }
      in.operands.push_back(label_op(p));
    }
    emit(std::move(in));
  }

  // DATDEF/FA(x),DAT(A)
  void datdef(const grammar::Statement& s) {
    if (!expect_params(s, 2, "a feature FA(x) and a datum DAT(y)")) return;
    if (!is_label(s.params[0], {"F", "FA"})) return error(s.params[0].span, "sema.expected-feature", "expected FA(label) after DATDEF/");
    if (!check_feature(s.params[0])) return;
    if (!is_label(s.params[1], {"DAT"})) return error(s.params[1].span, "sema.expected-datum", "expected DAT(label) after the feature");
    m_symbols.datums.insert(upper(s.params[1].label.name));
    auto in = make(Op::DatDef, s);
    in.operands.push_back(label_op(s.params[0]));
    in.operands.push_back(label_op(s.params[1]));
    emit(std::move(in));
  }

  // D(l)=DATSET/MCS | D(l)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,...
  void datset(const grammar::Statement& s) {
    if (!require_target(s, {"D"}, "D(label)=DATSET/...")) return;
    if (!expect_params(s, 1, "MCS or datums")) return;
    auto in = make(Op::DatSet, s, upper(s.target->name));
    static const std::set<std::string> words = {"XDIR", "YDIR", "ZDIR", "XMINUS", "YMINUS", "ZMINUS", "XORIG", "YORIG", "ZORIG"};
    if (is_word(s.params[0], "MCS")) {
      in.operands.push_back(word_operand(s.params[0]));
    } else {
      bool have_datum = false;
      for (const auto& p : s.params) {
        if (is_label(p, {"DAT"})) {
          const std::string d = upper(p.label.name);
          if (!m_symbols.datums.count(d) && !macro_param(d))
            return error(p.span, "sema.undefined-datum", fmt::format("datum DAT({}) is not defined: use DATDEF/FA(x),DAT({}) first", p.label.name, p.label.name));
          in.operands.push_back(label_op(p));
          have_datum = true;
        } else if (is_word(p) && words.count(p.text)) {
          if (!have_datum) return error(p.span, "sema.expected-datum", fmt::format("expected DAT(label) before {}", p.text));
          in.operands.push_back(word_operand(p));
        } else {
          return error(p.span, "sema.bad-datset", "expected DAT(label) or XDIR, YDIR, ZDIR, XMINUS, ..., XORIG, YORIG, ZORIG");
        }
      }
    }
    m_symbols.alignments.insert(upper(s.target->name));
    emit(std::move(in));
  }

  // D(l)=TRANS/XORIG,v|FA(f),YORIG,...
  void trans(const grammar::Statement& s) {
    if (!require_target(s, {"D"}, "D(label)=TRANS/...")) return;
    if (s.params.empty() || s.params.size() % 2 != 0)
      return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.trans-arity", "TRANS expects pairs of XORIG|YORIG|ZORIG and a value or feature");
    auto in = make(Op::Trans, s, upper(s.target->name));
    for (std::size_t i = 0; i < s.params.size(); i += 2) {
      const auto& w = s.params[i];
      if (!(is_word(w, "XORIG") || is_word(w, "YORIG") || is_word(w, "ZORIG")))
        return error(w.span, "sema.bad-trans", "expected XORIG, YORIG or ZORIG");
      in.operands.push_back(word_operand(w));
      const auto& v = s.params[i + 1];
      if (is_label(v, {"F", "FA"})) {
        if (!check_feature(v)) return;
        in.operands.push_back(label_op(v));
      } else {
        auto e = numeric(v, "an origin coordinate");
        if (!e) return;
        in.operands.push_back(expr_operand(std::move(*e)));
      }
    }
    m_symbols.alignments.insert(upper(s.target->name));
    emit(std::move(in));
  }

  // D(l)=ROTATE/XAXIS|YAXIS|ZAXIS,angle | ROTATE/ZAXIS,FA(f),XDIR|YDIR|ZDIR
  void rotate(const grammar::Statement& s) {
    if (!require_target(s, {"D"}, "D(label)=ROTATE/...")) return;
    if (!expect_params(s, 2, "an axis (XAXIS, YAXIS, ZAXIS) and an angle or feature")) return;
    auto in = make(Op::Rotate, s, upper(s.target->name));
    if (!(is_word(s.params[0], "XAXIS") || is_word(s.params[0], "YAXIS") || is_word(s.params[0], "ZAXIS")))
      return error(s.params[0].span, "sema.bad-rotate", "expected XAXIS, YAXIS or ZAXIS after ROTATE/");
    in.operands.push_back(word_operand(s.params[0]));
    if (is_label(s.params[1], {"F", "FA"})) {
      if (!check_feature(s.params[1])) return;
      if (s.params.size() != 3 || !(is_word(s.params[2], "XDIR") || is_word(s.params[2], "YDIR") || is_word(s.params[2], "ZDIR")))
        return error(s.params.back().span, "sema.bad-rotate", "expected XDIR, YDIR or ZDIR after the feature");
      if (s.params[2].text[0] == s.params[0].text[0])
        return error(s.params[2].span, "sema.bad-rotate", "the aligned axis cannot be the rotation axis");
      in.operands.push_back(label_op(s.params[1]));
      in.operands.push_back(word_operand(s.params[2]));
    } else {
      if (s.params.size() != 2) return error(s.params.back().span, "sema.bad-rotate", "ROTATE/axis,angle takes one angle");
      auto e = numeric(s.params[1], "an angle");
      if (!e) return;
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    m_symbols.alignments.insert(upper(s.target->name));
    emit(std::move(in));
  }

  // SAVE/DA(l)
  void save(const grammar::Statement& s) {
    if (!expect_params(s, 1, "a coordinate system DA(label)")) return;
    if (!is_label(s.params[0], {"DA", "D"})) return error(s.params[0].span, "sema.expected-alignment", "expected DA(label) after SAVE/");
    const std::string name = upper(s.params[0].label.name);
    if (!m_symbols.alignments.count(name))
      return error(s.params[0].span, "sema.undefined-alignment", fmt::format("coordinate system D({}) is not defined", s.params[0].label.name));
    m_symbols.saved.insert(name);
    auto in = make(Op::Save, s);
    in.operands.push_back(label_op(s.params[0]));
    emit(std::move(in));
  }

  // RECALL/DA(l) | RECALL/D(l)
  void recall(const grammar::Statement& s) {
    if (!expect_params(s, 1, "a coordinate system D(label) or DA(label)")) return;
    if (!is_label(s.params[0], {"DA", "D"})) {
      if (s.params[0].kind == ExprKind::Label) {  // RECALL/SA(), RECALL/FA() ...: not supported
        warn(s.params[0].span, "sema.unsupported-recall", fmt::format("RECALL of {}() is not supported and is ignored", s.params[0].label.prefix));
        emit(make(Op::Nop, s, "RECALL"));
        return;
      }
      return error(s.params[0].span, "sema.expected-alignment", "expected D(label) or DA(label) after RECALL/");
    }
    const std::string name = upper(s.params[0].label.name);
    if (!m_symbols.alignments.count(name) && !m_symbols.saved.count(name) && name != "MCS")
      return error(s.params[0].span, "sema.undefined-alignment", fmt::format("coordinate system D({}) is not defined", s.params[0].label.name));
    auto in = make(Op::Recall, s);
    in.operands.push_back(label_op(s.params[0]));
    emit(std::move(in));
  }

  // CONST/type,F(l),BF|INTOF|MIDPT|PROJPT|PROJLN,FA(a),FA(b),...
  void construct(const grammar::Statement& s) {
    if (!expect_params(s, 4, "the type, F(label), the method and the source features")) return;
    const auto& p = s.params;
    if (!is_word(p[0]) || !feature_types.count(p[0].text)) return error(p[0].span, "sema.bad-feature-type", "expected a feature type after CONST/");
    if (!is_label(p[1], {"F"})) return error(p[1].span, "sema.expected-feature", "expected F(label) after the feature type");
    const std::string label = upper(p[1].label.name);
    const std::string type = feature_type(label);
    if (!type.empty() && type != p[0].text)
      return error(p[0].span, "sema.const-type", fmt::format("CONST/{} on F({}), which is a {}", p[0].text, p[1].label.name, type));
    static const std::set<std::string> methods = {"BF", "INTOF", "MIDPT", "PROJPT", "PROJLN", "PROJCT"};
    if (!is_word(p[2]) || !methods.count(p[2].text)) {
      if (is_word(p[2])) {
        warn(p[2].span, "sema.unsupported-construction", fmt::format("construction method {} is not supported; F({}) gets no actual", p[2].text, p[1].label.name));
        emit(make(Op::Nop, s, "CONST"));
        return;
      }
      return error(p[2].span, "sema.bad-construction", "expected a construction method (BF, INTOF, MIDPT, PROJPT) after the feature");
    }
    auto in = make(Op::Construct, s, label);
    in.name_is_param = macro_param(label).has_value();
    in.operands.push_back(word_operand(p[0]));
    in.operands.push_back(word_operand(p[2]));
    for (std::size_t i = 3; i < p.size(); ++i) {
      if (!is_label(p[i], {"FA", "F"})) return error(p[i].span, "sema.expected-feature", "expected FA(label) source features");
      if (!check_feature(p[i])) return;
      in.operands.push_back(label_op(p[i]));
    }
    const std::size_t sources = p.size() - 3;
    const std::string& m = p[2].text;
    if ((m == "INTOF" || m == "MIDPT" || m == "PROJPT" || m == "PROJLN" || m == "PROJCT") && sources != 2)
      return error(p.back().span, "sema.construction-arity", fmt::format("{} takes two source features, got {}", m, sources));
    if (m_symbols.features.find(label) == m_symbols.features.end()) {
      m_symbols.features[label] = {p[0].text, s.span};
    }
    emit(std::move(in));
  }

  // DECL/[COMMON|GLOBAL|LOCAL,]INTGR|LONG|REAL|DOUBLE|BOOL|CHAR,n|VECTOR,V1,V2[10]
  void decl(const grammar::Statement& s) {
    if (!expect_params(s, 2, "a type and variable names")) return;
    std::size_t i = 0;
    if (is_word(s.params[0], "COMMON") || is_word(s.params[0], "GLOBAL") || is_word(s.params[0], "LOCAL")) ++i;
    if (i >= s.params.size() || !is_word(s.params[i])) return error(s.params[i < s.params.size() ? i : 0].span, "sema.bad-type", "expected a type (INTGR, LONG, REAL, DOUBLE, BOOL, CHAR) after DECL/");
    static const std::map<std::string, ValueType> types = {{"INTGR", ValueType::Integer}, {"LONG", ValueType::Integer},
                                                           {"REAL", ValueType::Real},    {"DOUBLE", ValueType::Real},
                                                           {"BOOL", ValueType::Bool},    {"CHAR", ValueType::String}};
    auto t = types.find(s.params[i].text);
    if (t == types.end()) {
      if (s.params[i].text == "VECTOR") return error(s.params[i].span, "sema.unsupported-type", "VECTOR variables are not supported yet");
      return error(s.params[i].span, "sema.bad-type", fmt::format("unknown type {}: expected INTGR, LONG, REAL, DOUBLE, BOOL or CHAR", s.params[i].text));
    }
    auto in = make(Op::Declare, s);
    ir::Operand type_word;
    type_word.kind = ir::Operand::Kind::Word;
    type_word.word = s.params[i].text;
    in.operands.push_back(type_word);
    ++i;
    if (t->second == ValueType::String && i < s.params.size() && s.params[i].kind == ExprKind::Number) ++i;  // CHAR length
    if (i >= s.params.size()) return error(s.params.back().span, "sema.missing-parameter", "expected variable names after the type");
    for (; i < s.params.size(); ++i) {
      const auto& p = s.params[i];
      int size = 0;
      if (p.kind == ExprKind::Index) {
        if (p.args.size() != 1 || p.args[0].kind != ExprKind::Number || p.args[0].number < 1)
          return error(p.span, "sema.bad-array", "an array declaration needs a positive size, e.g. V1[10]");
        size = static_cast<int>(p.args[0].number);
      } else if (p.kind != ExprKind::Word || p.text.empty()) {
        return error(p.span, "sema.expected-name", "expected a variable name");
      }
      SymbolTable::VariableInfo info{t->second, size, p.span};
      if (m_macro) m_locals[p.text] = info;
      else m_symbols.variables[p.text] = info;
      in.names.push_back(p.text);
      ir::Operand sz;
      sz.kind = ir::Operand::Kind::Expr;
      sz.expr.value = Value::integer(size);
      in.operands.push_back(sz);
    }
    emit(std::move(in));
  }

  void bad_assign(const grammar::Statement& s) {
    error(s.major_span, "sema.missing-variable", fmt::format("{} needs a variable on the left: V1={}/...", s.major, s.major));
  }

  // V=ASSIGN/expr | V[i]=ASSIGN/expr | V=OBTAIN/FA(x),n
  void assignment(const grammar::Statement& s) {
    const grammar::Expr& v = *s.variable;
    const std::string name = v.text;
    if (s.major != "ASSIGN" && s.major != "OBTAIN") {
      // Vendor statements of the form V=XXX/...: warn and skip.
      warn(s.major_span, "sema.unknown-statement", fmt::format("unknown statement {} is skipped", s.major));
      emit(make(Op::Nop, s, s.major));
      return;
    }
    const SymbolTable::VariableInfo* info = nullptr;
    if (auto it = m_locals.find(name); it != m_locals.end()) info = &it->second;
    else if (auto jt = m_symbols.variables.find(name); jt != m_symbols.variables.end()) info = &jt->second;
    if (!info && !macro_param(name))
      return error(v.span, "sema.undeclared-variable", fmt::format("variable {} is not declared: add DECL/REAL,{} (or INTGR, CHAR, BOOL) first", name, name));
    auto in = make(Op::Assign, s, name);
    if (v.kind == ExprKind::Index) {
      if (info && info->size == 0) return error(v.span, "sema.not-array", fmt::format("{} is not an array", name));
      for (const auto& a : v.args) {
        auto e = numeric(a, "an array index");
        if (!e) return;
        in.operands.push_back(expr_operand(std::move(*e)));
      }
      in.count = static_cast<int>(v.args.size());
    } else if (info && info->size > 0) {
      return error(v.span, "sema.array-without-index", fmt::format("array {} needs an index", name));
    }
    ir::Expr value;
    bool dynamic = false;
    if (s.major == "OBTAIN") {
      if (s.params.size() != 2 || !is_label(s.params[0], {"FA", "F"}))
        return error(s.params.empty() ? s.major_span : s.params[0].span, "sema.obtain", "OBTAIN expects FA(label),index");
      if (!check_feature(s.params[0])) return;
      auto idx = numeric(s.params[1], "a parameter index");
      if (!idx) return;
      value.op = ir::ExprOp::Obtain;
      value.span = s.span;
      value.label = label_operand(s.params[0].label);
      value.type = ValueType::Real;
      value.args.push_back(std::move(*idx));
    } else {
      if (s.params.size() != 1) return error(s.params.empty() ? s.major_span : s.params[1].span, "sema.assign", "ASSIGN expects one expression");
      auto e = expression(s.params[0]);
      if (!e) return;
      dynamic = e->dynamic;
      value = std::move(e->e);
    }
    if (info && !dynamic) {
      const bool num = info->type == ValueType::Real || info->type == ValueType::Integer;
      const bool vnum = value.type == ValueType::Real || value.type == ValueType::Integer;
      if (num != vnum || (!num && info->type != value.type))
        return error(s.params.empty() ? s.span : s.params[0].span, "sema.type",
                     fmt::format("cannot assign a {} to {}, which is declared {}", to_string(value.type), name, to_string(info->type)));
    }
    in.operands.push_back(expr_operand(std::move(value)));
    emit(std::move(in));
  }

  void mark_control() {
    for (auto& b : m_blocks)
      if (b.kind == Block::Kind::Meas) b.control = true;
  }

  // IF/(condition)  |  IF/condition
  void if_(const grammar::Statement& s) {
    if (s.params.size() != 1) return error(s.params.empty() ? s.major_span : s.params[1].span, "sema.if", "IF expects one condition, e.g. IF/(V1.GT.0)");
    auto c = expression(s.params[0]);
    if (!c) {
      m_blocks.push_back(block(Block::Kind::If, s.span));
      return;
    }
    if (!c->dynamic && c->e.type != ValueType::Bool)
      error(s.params[0].span, "sema.type", fmt::format("the IF condition must be BOOL, got {}", to_string(c->e.type)));
    mark_control();
    auto in = make(Op::JumpIfFalse, s);
    in.operands.push_back(expr_operand(std::move(c->e)));
    Block b = block(Block::Kind::If, s.span);
    b.branch = emit(std::move(in));
    m_blocks.push_back(b);
  }

  void else_(const grammar::Statement& s) {
    if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::If) return error(s.major_span, "sema.unmatched", "ELSE without a matching IF");
    Block& b = m_blocks.back();
    if (b.has_else) return error(s.major_span, "sema.unmatched", "a second ELSE for the same IF");
    b.has_else = true;
    b.exits.push_back(emit(make(Op::Jump, s)));
    if (b.branch) code()[*b.branch].target = static_cast<std::int64_t>(code().size());
    b.branch.reset();
  }

  void endif(const grammar::Statement& s) {
    if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::If) return error(s.major_span, "sema.unmatched", "ENDIF without a matching IF");
    Block b = m_blocks.back();
    m_blocks.pop_back();
    const std::size_t end = emit(make(Op::Nop, s, "ENDIF"));
    if (b.branch) code()[*b.branch].target = static_cast<std::int64_t>(end);
    for (auto e : b.exits) code()[e].target = static_cast<std::int64_t>(end);
  }

  // DO/V,start,end[,step]
  void do_(const grammar::Statement& s) {
    Block placeholder = block(Block::Kind::Do, s.span);
    placeholder.start = invalid;
    m_blocks.push_back(placeholder);
    if (s.params.size() < 3 || s.params.size() > 4)
      return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.do", "DO expects a variable, a start, an end and optionally a step");
    const auto& v = s.params[0];
    if (v.kind != ExprKind::Word || !is_variable(v.text))
      return error(v.span, "sema.undeclared-variable", fmt::format("the DO variable {} is not declared: add DECL/INTGR,{}", v.text, v.text));
    auto in = make(Op::DoInit, s, v.text);
    for (std::size_t i = 1; i < s.params.size(); ++i) {
      auto e = numeric(s.params[i], "a loop bound");
      if (!e) return;
      if (i == 3 && e->op == ir::ExprOp::Constant && e->value.number == 0) return error(s.params[i].span, "sema.do", "the DO step must not be zero");
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    mark_control();
    Block b = block(Block::Kind::Do, s.span);
    b.start = emit(std::move(in));
    b.feature = v.text;
    m_blocks.back() = b;
  }

  void enddo(const grammar::Statement& s) {
    if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Do) return error(s.major_span, "sema.unmatched", "ENDDO without a matching DO");
    Block b = m_blocks.back();
    m_blocks.pop_back();
    if (b.start == invalid) return;
    auto in = make(Op::DoNext, s, b.feature);
    in.target = static_cast<std::int64_t>(b.start + 1);
    const std::size_t next = emit(std::move(in));
    code()[b.start].target = static_cast<std::int64_t>(next + 1);
  }

  // JUMPTO/(label)
  void jumpto(const grammar::Statement& s) {
    if (s.params.size() != 1) return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.jumpto", "JUMPTO expects one label, e.g. JUMPTO/(L1)");
    const grammar::Expr* p = &s.params[0];
    if (p->kind == ExprKind::Paren && !p->args.empty()) p = &p->args[0];
    if (p->kind != ExprKind::Word) return error(p->span, "sema.jumpto", "expected a label name after JUMPTO/");
    mark_control();
    const std::size_t pc = emit(make(Op::Jump, s, p->text));
    jumps().pending.push_back({pc, {p->text, p->span}});
  }

  // M(name)=MACRO/'P1','P2' | M(name)=MACRO/P1,P2
  void macro(const grammar::Statement& s) {
    if (!require_target(s, {"M"}, "M(name)=MACRO/...")) return;
    if (m_macro) return error(s.span, "sema.nested-macro", "a MACRO cannot be defined inside another MACRO");
    ir::Macro m;
    m.name = upper(s.target->name);
    m.span = s.span;
    for (const auto& p : s.params) {
      if (p.kind == ExprKind::String || p.kind == ExprKind::Word) m.params.push_back(upper(p.text));
      else return error(p.span, "sema.macro-param", "macro parameters are names, e.g. MACRO/'X','Y'");
    }
    if (m_symbols.macros.count(m.name)) warn(s.target->span, "sema.redefined-macro", fmt::format("macro M({}) is redefined", s.target->name));
    m_module.macros.push_back(std::move(m));
    m_macro = static_cast<int>(m_module.macros.size() - 1);
    m_symbols.macros[m_module.macros.back().name] = *m_macro;
    m_blocks.push_back(block(Block::Kind::Macro, s.span));
  }

  void endmac(const grammar::Statement& s) {
    if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Macro) return error(s.major_span, "sema.unmatched", "ENDMAC without a matching MACRO");
    m_blocks.pop_back();
    emit(make(Op::Return, s));
    resolve_jumps(m_macro_jumps, m_module.macros[static_cast<std::size_t>(*m_macro)].code);
    m_macro.reset();
    m_locals.clear();
  }

  // CALL/M(name),args... | CALL/EXTERN,DMIS,'file' | CALL/EXTERN,DMIS,M(name),'file'
  void call(const grammar::Statement& s) {
    if (!expect_params(s, 1, "M(name) or EXTERN")) return;
    mark_control();
    if (is_word(s.params[0], "EXTERN")) {
      if (s.params.size() >= 3 && is_word(s.params[1], "SYS") && s.params[2].kind == ExprKind::String) {
        // metron's own system commands (docs/touch-trigger.md): CHARACTERISE ['file'],
        // CHARACTERISATION 'file'.
        const std::string text = s.params[2].text;
        std::istringstream words(text);
        std::string verb, arg, extra;
        words >> verb >> arg >> extra;
        verb = upper(verb);
        if (verb == "CHARACTERISE" || verb == "CHARACTERIZE" || (verb == "CHARACTERISATION" && !arg.empty())) {
          if (!extra.empty())
            return error(s.params[2].span, "sema.system-command", fmt::format("too many words in '{}'", text));
          if (!arg.empty() && std::filesystem::path(arg).is_relative() && verb != "CHARACTERISE" && verb != "CHARACTERIZE")
            arg = (std::filesystem::path(m_module.units[m_unit].path).parent_path() / arg).string();
          auto in = make(Op::System, s, verb == "CHARACTERIZE" ? "CHARACTERISE" : verb);
          ir::Operand o;
          o.kind = ir::Operand::Kind::Word;
          o.word = arg;
          o.span = s.params[2].span;
          in.operands.push_back(o);
          emit(std::move(in));
          return;
        }
        warn(s.params[2].span, "sema.unsupported-call",
             fmt::format("unknown system command '{}' (metron knows CHARACTERISE and CHARACTERISATION); the call is skipped", text));
        emit(make(Op::Nop, s, "CALL"));
        return;
      }
      if (s.params.size() < 3 || !is_word(s.params[1], "DMIS")) {
        warn(s.params[0].span, "sema.unsupported-call", "only CALL/EXTERN,DMIS,'file' is supported; the call is skipped");
        emit(make(Op::Nop, s, "CALL"));
        return;
      }
      const grammar::Expr& f = s.params.back();
      if (f.kind != ExprKind::String) return error(f.span, "sema.expected-file", "expected the file name as a string, e.g. CALL/EXTERN,DMIS,'sub.dmi'");
      std::filesystem::path path(f.text);
      if (path.is_relative()) path = std::filesystem::path(m_module.units[m_unit].path).parent_path() / path;
      auto unit = m_include(path.string(), f.text, f.span);
      if (!unit) return;
      auto in = make(Op::CallUnit, s, path.string());
      in.target = static_cast<std::int64_t>(*unit);
      emit(std::move(in));
      return;
    }
    if (!is_label(s.params[0], {"M"})) return error(s.params[0].span, "sema.expected-macro", "expected M(name) or EXTERN after CALL/");
    const std::string name = upper(s.params[0].label.name);
    auto it = m_symbols.macros.find(name);
    if (it == m_symbols.macros.end()) return error(s.params[0].span, "sema.undefined-macro", fmt::format("macro M({}) is not defined before this call", s.params[0].label.name));
    const auto& macro = m_module.macros[static_cast<std::size_t>(it->second)];
    if (s.params.size() - 1 != macro.params.size())
      return error(s.params.back().span, "sema.arity", fmt::format("M({}) takes {} argument{}, got {}", s.params[0].label.name, macro.params.size(), macro.params.size() == 1 ? "" : "s", s.params.size() - 1));
    auto in = make(Op::CallMacro, s, name);
    in.target = it->second;
    if (auto mf = m_symbols.macro_features.find(name); mf != m_symbols.macro_features.end())
      for (const auto& [index, type] : mf->second) {
        const auto& a = s.params[static_cast<std::size_t>(index) + 1];
        if (a.kind == ExprKind::Label) m_symbols.features[upper(a.label.name)] = {type, a.span};
        else if (a.kind == ExprKind::String || a.kind == ExprKind::Word) m_symbols.features[upper(a.text)] = {type, a.span};
      }
    for (std::size_t i = 1; i < s.params.size(); ++i) {
      const auto& a = s.params[i];
      if (a.kind == ExprKind::Word && !is_variable(a.text)) {
        // A bare word argument stands for itself (a name), as DMIS macros substitute text.
        ir::Expr e;
        e.op = ir::ExprOp::Constant;
        e.value = Value::string(a.text);
        e.type = ValueType::String;
        e.span = a.span;
        in.operands.push_back(expr_operand(std::move(e)));
        continue;
      }
      auto e = expression(a, true);
      if (!e) return;
      in.operands.push_back(expr_operand(std::move(e->e)));
    }
    emit(std::move(in));
  }

  // DID(l)=DEVICE/STOR|TERM|PRINT|INCR,'path'
  void device(const grammar::Statement& s) {
    if (!require_target(s, {"DID"}, "DID(label)=DEVICE/STOR,'file'")) return;
    if (!expect_params(s, 1, "the device kind")) return;
    auto in = make(Op::DeviceDef, s, upper(s.target->name));
    in.operands.push_back(word_operand(s.params[0]));
    if (s.params.size() > 1) {
      auto e = expression(s.params[1]);
      if (!e) return;
      in.operands.push_back(expr_operand(std::move(e->e)));
    }
    m_symbols.devices.insert(upper(s.target->name));
    emit(std::move(in));
  }

  // OPEN/DID(l),FDATA|DIRECT,DMIS|V(...),OUTPUT|INPUT|APPEND|OVERWR
  void open(const grammar::Statement& s) {
    if (!expect_params(s, 1, "DID(label)")) return;
    if (!is_label(s.params[0], {"DID"})) return error(s.params[0].span, "sema.expected-device", "expected DID(label) after OPEN/");
    if (!m_symbols.devices.count(upper(s.params[0].label.name)))
      return error(s.params[0].span, "sema.undefined-device", fmt::format("device DID({}) is not defined", s.params[0].label.name));
    for (const auto& p : s.params)
      if (is_word(p, "INPUT")) {
        warn(p.span, "sema.unsupported-input", "OPEN for INPUT is not supported; the statement is skipped");
        emit(make(Op::Nop, s, "OPEN"));
        return;
      }
    auto in = make(Op::DeviceOpen, s);
    in.operands.push_back(label_op(s.params[0]));
    emit(std::move(in));
  }

  // CLOSE/DID(l)
  void close(const grammar::Statement& s) {
    if (!expect_params(s, 1, "DID(label)")) return;
    if (!is_label(s.params[0], {"DID"})) return error(s.params[0].span, "sema.expected-device", "expected DID(label) after CLOSE/");
    if (!m_symbols.devices.count(upper(s.params[0].label.name)))
      return error(s.params[0].span, "sema.undefined-device", fmt::format("device DID({}) is not defined", s.params[0].label.name));
    auto in = make(Op::DeviceClose, s);
    in.operands.push_back(label_op(s.params[0]));
    emit(std::move(in));
  }

  SymbolTable& m_symbols;
  ir::Module& m_module;
  SourceManager& m_sources;
  DiagnosticSink& m_sink;
  std::size_t m_unit;
  std::function<std::optional<std::size_t>(const std::string&, const std::string&, Span)> m_include;
  std::vector<Block> m_blocks;
  std::optional<int> m_macro;
  std::map<std::string, SymbolTable::VariableInfo> m_locals;
  JumpScope m_unit_jumps, m_macro_jumps;
  bool m_ended = false;
  bool m_repl = false;
  bool m_included = false;
  std::set<std::string> m_runtime_names;
};

}  // namespace

Compiler::Compiler(SourceManager& sources, DiagnosticSink& sink) : m_sources(sources), m_sink(sink) {}

std::size_t Compiler::compile_program(std::uint32_t file, const std::string& path) {
  const grammar::Program program = grammar::parse_program(m_sources, file, m_sink);
  const std::size_t unit = m_module.units.size();
  m_module.units.push_back({path, file, {}});
  UnitCompiler uc(m_symbols, m_module, m_sources, m_sink, unit,
                  [this](const std::string& p, const std::string& written, Span from) { return compile_file(p, from, written); });
  uc.set_included(unit > 0);
  uc.compile(program, path.rfind("<repl", 0) == 0);
  return unit;
}

std::optional<ir::Expr> Compiler::compile_expression(const std::string& text, const std::set<std::string>& runtime_names) {
  const std::uint32_t file = m_sources.add("<expression>", "EXPR/" + text + "\n");
  const grammar::Program program = grammar::parse_program(m_sources, file, m_sink);
  if (program.statements.size() != 1 || program.statements[0].params.size() != 1) {
    if (!m_sink.has_errors()) m_sink.error("repl.expression", Span{file, 5, 5}, "expected one expression");
    return std::nullopt;
  }
  UnitCompiler uc(m_symbols, m_module, m_sources, m_sink, 0, [](const std::string&, const std::string&, Span) {
    return std::optional<std::size_t>();
  });
  uc.set_runtime_names(runtime_names);
  return uc.standalone_expression(program.statements[0].params[0]);
}

std::optional<std::size_t> Compiler::compile_file(const std::string& path, Span included_from, const std::string& written) {
  const std::string& shown = written.empty() ? path : written;
  const std::string key = std::filesystem::weakly_canonical(path).string();
  if (m_symbols.units_in_progress.count(key)) {
    m_sink.error("sema.recursive-call", included_from, fmt::format("{} calls itself through CALL/EXTERN", shown));
    return std::nullopt;
  }
  // A file called several times is compiled once: its definitions are not redefinitions.
  if (auto done = m_symbols.compiled_units.find(key); done != m_symbols.compiled_units.end() && included_from.valid())
    return done->second;
  const std::uint32_t file = m_sources.load(path);
  if (file == 0) {
    m_sink.error("io.cannot-read", included_from, fmt::format("cannot read {}", shown));
    return std::nullopt;
  }
  m_symbols.units_in_progress.insert(key);
  const std::size_t unit = compile_program(file, path);
  m_symbols.units_in_progress.erase(key);
  if (included_from.valid()) m_symbols.compiled_units[key] = unit;
  return unit;
}

std::size_t Compiler::compile_text(const std::string& name, const std::string& text) {
  const std::uint32_t file = m_sources.add(name, text);
  return compile_program(file, name);
}

}  // namespace metron::interpreter
