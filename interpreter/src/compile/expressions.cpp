// SPDX-License-Identifier: GPL-3.0-or-later
// Expressions: typing and lowering of values, variables, calls and operators.
#include <algorithm>
#include <cmath>

#include "metron/stdlib/builtins.hpp"

#include "compile/unit_compiler.hpp"

namespace metron::interpreter::detail {

namespace {
/// Whether `a` becomes `b` by one insertion, deletion or substitution (Levenshtein distance 1).
bool one_edit_apart(std::string_view a, std::string_view b) {
  if (a.size() > b.size()) std::swap(a, b);
  if (b.size() - a.size() > 1) return false;
  std::size_t i = 0;
  while (i < a.size() && a[i] == b[i]) ++i;
  if (a.size() == b.size()) return i < a.size() && a.substr(i + 1) == b.substr(i + 1);
  return a.substr(i) == b.substr(i + 1);
}
}  // namespace

using grammar::ExprKind;
using ir::Op;

std::optional<UnitCompiler::Typed> UnitCompiler::expression(const grammar::Expr& g, bool allow_labels) {
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
    case ExprKind::Word: return word_expression(g);
    case ExprKind::Label: {
      if (!allow_labels) {
        error(g.span, "sema.label-not-value",
              fmt::format("expected a value, got the label {}({})", g.label.prefix, g.label.name));
        return std::nullopt;
      }
      t.e.op = ir::ExprOp::Constant;
      t.e.label = label_operand(g.label);
      t.e.value = Value::label(t.e.label.prefix, t.e.label.name);
      t.e.type = ValueType::Label;
      return t;
    }
    case ExprKind::Paren: return g.args.empty() ? std::nullopt : expression(g.args[0], allow_labels);
    case ExprKind::Index: return element_expression(g);
    case ExprKind::Format:
      error(g.span, "sema.format-outside-write", "a layout ':width:decimals' belongs to the values of WRITE only");
      return std::nullopt;
    case ExprKind::Call: return call_expression(g);
    case ExprKind::Unary: return unary_expression(g);
    case ExprKind::Binary: return binary_expression(g);
  }
  return std::nullopt;
}

// .TRUE., .FALSE. or a variable name
std::optional<UnitCompiler::Typed> UnitCompiler::word_expression(const grammar::Expr& g) {
  Typed t;
  t.e.span = g.span;
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
        fmt::format("variable {} is not declared: add DECL/REAL,{} (or INTGR, CHAR, BOOL) before its use", g.text,
                    g.text));
  return std::nullopt;
}

// V[i,...]: an array element
std::optional<UnitCompiler::Typed> UnitCompiler::element_expression(const grammar::Expr& g) {
  Typed t;
  t.e.span = g.span;
  t.e.op = ir::ExprOp::Element;
  t.e.name = g.text;
  auto it = m_symbols.variables.find(g.text);
  auto lt = m_locals.find(g.text);
  const SymbolTable::VariableInfo* info =
      lt != m_locals.end() ? &lt->second : (it != m_symbols.variables.end() ? &it->second : nullptr);
  if (!info) {
    error(g.span, "sema.undeclared-variable", fmt::format("array {} is not declared", g.text));
    return std::nullopt;
  }
  if (info->size == 0) {
    error(g.span, "sema.not-array", fmt::format("{} is not an array", g.text));
    return std::nullopt;
  }
  if (!check_rank(g, *info)) return std::nullopt;
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

// V[i,j] of an array declared V[3,30]: as many indices as dimensions (a second index was ignored).
bool UnitCompiler::check_rank(const grammar::Expr& element, const SymbolTable::VariableInfo& info) {
  const std::size_t rank = std::max<std::size_t>(1, info.dims.size());
  if (element.args.size() == rank) return true;
  std::string form = element.text + "[i";
  for (std::size_t k = 1; k < rank; ++k)
    form += k < 18 ? fmt::format(",{}", static_cast<char>('i' + k)) : fmt::format(",i{}", k + 1);  // i..z, then i19 ...
  error(element.span, "sema.array-rank",
        fmt::format("array {} has {} dimension{}: write {}]", element.text, rank, rank == 1 ? "" : "s", form));
  return false;
}

// NAME(args...): an intrinsic function
std::optional<UnitCompiler::Typed> UnitCompiler::call_expression(const grammar::Expr& g) {
  Typed t;
  t.e.span = g.span;
  const Builtin* fn = find_builtin(g.text);
  if (!fn) {
    // One letter off an intrinsic (SQRTT, CONCT) is a typo, not a vendor's function: an error.
    const auto near = std::find_if(builtins().begin(), builtins().end(),
                                   [&](const Builtin& b) { return one_edit_apart(b.name, g.text); });
    if (m_strict || m_repl || near != builtins().end()) {
      error(g.span, "sema.unknown-function",
            near != builtins().end() ? fmt::format("unknown function {} (did you mean {}?)", g.text, near->name)
                                     : fmt::format("unknown function {}", g.text));
      return std::nullopt;
    }
    // A vendor's function (MODUS, CAMIO ...): read leniently, it stops a run only where evaluated.
    warn(g.span, "sema.unknown-function",
         fmt::format("unknown function {}: a run that evaluates it stops there (--strict makes it an error)", g.text));
    t.e.op = ir::ExprOp::Call;
    t.e.name = g.text;
    t.dynamic = true;
    return t;
  }
  const int n = static_cast<int>(g.args.size());
  if (g.text == "SELAPSETIME" && n > 0) return elapsed_time_expression(g);
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
  // EOF(DID(x)), EOLN(DID(x)) and PTDATA(FA(x)) take a label; EXIST any label.
  const bool exist = g.text == "EXIST";
  const char* label_kind = g.text == "EOF" || g.text == "EOLN" ? "DID"
                           : g.text == "PTDATA"                ? "FA"
                           : exist                             ? "F"
                                                               : nullptr;
  for (const auto& a : g.args) {
    if (exist && a.kind != ExprKind::Label) {
      error(a.span, "sema.type", "EXIST takes a label: F(x), FA(x), D(x), DA(x), T(x), TA(x), S(x), SA(x) or DID(x)");
      return std::nullopt;
    }
    if (label_kind && !exist &&
        !(a.kind == ExprKind::Label && (is_label(a, {label_kind}) || (g.text == "PTDATA" && is_label(a, {"F"}))))) {
      error(a.span, "sema.type", fmt::format("{} takes {}(label)", g.text, label_kind));
      return std::nullopt;
    }
    auto x = expression(a, label_kind != nullptr);
    if (!x) return std::nullopt;
    if (!x->dynamic && x->e.type == ValueType::Bool && !(g.text == "STR" && g.args.size() == 1)) {
      error(a.span, "sema.type", fmt::format("{} does not take a BOOL argument", g.text));
      return std::nullopt;
    }
    if (!x->dynamic && g.text != "STR" && fn->vector_args != (x->e.type == ValueType::Vector)) {
      error(a.span, "sema.type",
            fn->vector_args ? fmt::format("{} takes VECTOR arguments, got a {}", g.text, to_string(x->e.type))
                            : fmt::format("{} does not take a VECTOR argument", g.text));
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

// SELAPSETIME(start, end[, LONG|SHORT]): the time between two SDATETIME strings, as CAMIO's
// programs write it to a CHAR variable. No public text of its definition was found: metron's
// reading is a string, 'HH:MM:SS' (LONG, the default) or whole seconds (SHORT); docs/language.md.
std::optional<UnitCompiler::Typed> UnitCompiler::elapsed_time_expression(const grammar::Expr& g) {
  if (g.args.size() < 2 || g.args.size() > 3) {
    error(g.span, "sema.arity",
          fmt::format("SELAPSETIME takes no argument (the seconds since the run started) or two date-times and a "
                      "format word, got {} arguments",
                      g.args.size()));
    return std::nullopt;
  }
  Typed t;
  t.e.span = g.span;
  t.e.op = ir::ExprOp::Call;
  t.e.name = g.text;
  t.e.type = ValueType::String;
  for (std::size_t k = 0; k < 2; ++k) {
    auto x = expression(g.args[k]);
    if (!x) return std::nullopt;
    if (!x->dynamic && x->e.type != ValueType::String) {
      error(g.args[k].span, "sema.type",
            fmt::format("SELAPSETIME takes date-times as SDATETIME writes them, got a {}", to_string(x->e.type)));
      return std::nullopt;
    }
    t.dynamic |= x->dynamic;
    t.e.args.push_back(std::move(x->e));
  }
  if (g.args.size() == 3) {
    const auto& format = g.args[2];
    if (format.kind != ExprKind::Word || (format.text != "LONG" && format.text != "SHORT")) {
      error(format.span, "sema.type", "SELAPSETIME's format is LONG ('HH:MM:SS') or SHORT (seconds)");
      return std::nullopt;
    }
    ir::Expr word;
    word.span = format.span;
    word.op = ir::ExprOp::Constant;
    word.value = Value::string(format.text);
    word.type = ValueType::String;
    t.e.args.push_back(std::move(word));
  }
  return t;
}

// -x, +x, .NOT.b
std::optional<UnitCompiler::Typed> UnitCompiler::unary_expression(const grammar::Expr& g) {
  Typed t;
  t.e.span = g.span;
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
    if (!x->dynamic &&
        !(x->e.type == ValueType::Real || x->e.type == ValueType::Integer || x->e.type == ValueType::Vector)) {
      error(g.span, "sema.type",
            fmt::format("unary {} needs a number or a VECTOR, got {}", g.text, to_string(x->e.type)));
      return std::nullopt;
    }
    t.e.type = x->e.type;
  }
  t.e.args.push_back(std::move(x->e));
  return t;
}

// a op b: arithmetic, comparison, .AND., .OR.
std::optional<UnitCompiler::Typed> UnitCompiler::binary_expression(const grammar::Expr& g) {
  Typed t;
  t.e.span = g.span;
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
                        ((a->e.type == ValueType::Bool || a->e.type == ValueType::Vector) && b->e.type == a->e.type &&
                         (op == ".EQ." || op == ".NE.")))) {
      error(g.span, "sema.type",
            fmt::format("{} compares a {} with a {}", op, to_string(a->e.type), to_string(b->e.type)));
      return std::nullopt;
    }
    t.e.type = ValueType::Bool;
  } else {
    if (!t.dynamic && op == "+" && a->e.type == ValueType::String && b->e.type == ValueType::String) {
      error(g.span, "sema.type", "strings are joined with CONCAT(a,b), not +");
      return std::nullopt;
    }
    const bool va = a->e.type == ValueType::Vector, vb = b->e.type == ValueType::Vector;
    if (va || vb) {
      // Vector arithmetic: u+v, u-v, s*v, v*s, v/s.
      const bool fits = ((op == "+" || op == "-") && va && vb) ||
                        (op == "*" && (va != vb) && number(va ? b->e.type : a->e.type)) ||
                        (op == "/" && va && number(b->e.type));
      if (!t.dynamic && !fits) {
        error(g.span, "sema.type",
              fmt::format("'{}' does not apply to a {} and a {} (vectors add, subtract, and scale by a number)", op,
                          to_string(a->e.type), to_string(b->e.type)));
        return std::nullopt;
      }
      t.e.type = ValueType::Vector;
    } else {
      if (!t.dynamic && (!number(a->e.type) || !number(b->e.type))) {
        error(g.span, "sema.type",
              fmt::format("'{}' needs numbers, got {} and {}", op, to_string(a->e.type), to_string(b->e.type)));
        return std::nullopt;
      }
      t.e.type = (a->e.type == ValueType::Integer && b->e.type == ValueType::Integer && op != "/" && op != "**")
                     ? ValueType::Integer
                     : ValueType::Real;
    }
  }
  t.e.args.push_back(std::move(a->e));
  t.e.args.push_back(std::move(b->e));
  return t;
}

// A numeric parameter (a number, a variable or an arithmetic expression).
std::optional<ir::Expr> UnitCompiler::numeric(const grammar::Expr& g, const char* what) {
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

}  // namespace metron::interpreter::detail
