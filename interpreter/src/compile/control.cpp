// SPDX-License-Identifier: GPL-3.0-or-later
// Control: assignment (ASSIGN, OBTAIN), IF, DO, JUMPTO, macros, CALL.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "compile/unit_compiler.hpp"
#include "metron/runtime/error_space/calibrate_command.hpp"
#include "metron/runtime/feature_parameters.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;

namespace {

// CALIBRATE WAVEFRONT world [step] (docs/wavefront.md, "Calling it from a DMIS program"): the
// world file and the step (default "all"), or why the words are not that command.
tl::expected<std::pair<std::string, std::string>, std::string> calibrate_wavefront_words(const std::string& text) {
  std::istringstream words(text);
  std::string verb, what, world, step, extra;
  words >> verb >> what >> world >> step >> extra;
  if (upper(what) != "WAVEFRONT")
    return tl::unexpected(
        fmt::format("'{}': metron calibrates WAVEFRONT (CALIBRATE WAVEFRONT world [step]) and ERROR-SPACE "
                    "(CALIBRATE ERROR-SPACE [SIZE=nx,ny,nz ORIGIN=x,y,z STEP=d COMPONENTS=xyz ...])",
                    text));
  if (world.empty())
    return tl::unexpected(
        fmt::format("'{}': name the wavefront world, e.g. CALIBRATE WAVEFRONT station.json a-z", text));
  if (!extra.empty()) return tl::unexpected(fmt::format("too many words in '{}'", text));
  if (step.empty()) step = "all";
  static const char* const steps[] = {"all", "part-on-mount", "gauge-frame", "focus",   "axis-response",
                                      "a-z", "b-rotation",    "c-rotation",  "reversal"};
  if (std::none_of(std::begin(steps), std::end(steps), [&](const char* k) { return step == k; }))
    return tl::unexpected(
        fmt::format("unknown wavefront calibration step '{}' (all, part-on-mount, gauge-frame, focus, "
                    "axis-response, a-z, b-rotation, c-rotation, reversal)",
                    step));
  return std::pair{world, step};
}

}  // namespace

void UnitCompiler::add_control(StatementTable& t) {
  t.insert({{std::string(assignment_row), &UnitCompiler::assignment},
            {"ASSIGN", &UnitCompiler::bad_assign},
            {"OBTAIN", &UnitCompiler::bad_assign},
            {"VALUE", &UnitCompiler::bad_assign},
            {"ENDFIL", &UnitCompiler::endfil},
            {"IF", &UnitCompiler::if_},
            {"ELSE", &UnitCompiler::else_},
            {"ENDIF", &UnitCompiler::endif},
            {"SELECT", &UnitCompiler::select},
            {"CASE", &UnitCompiler::case_},
            {"DFTCAS", &UnitCompiler::case_},
            {"ENDCAS", &UnitCompiler::endcas},
            {"ENDSEL", &UnitCompiler::endsel},
            {"DO", &UnitCompiler::do_},
            {"ENDDO", &UnitCompiler::enddo},
            {"JUMPTO", &UnitCompiler::jumpto},
            {"MACRO", &UnitCompiler::macro},
            {"ENDMAC", &UnitCompiler::endmac},
            {"CALL", &UnitCompiler::call},
            {"EXTFIL", &UnitCompiler::extfil}});
}

// ENDFIL
void UnitCompiler::endfil(const grammar::Statement& s) {
  emit(make(Op::End, s));
  m_ended = true;
}

// V=PROMPT/x,y,w,h,TITLE,'t',BUTTON,x,y,w,h,'label',value,...,TEXT,x,y,w,h,'text' (the dialog CAMIO
// and PC-DMIS write): its question is the title and texts, then the buttons and their values,
// "Calibrare: Vrei sa ...? [DA = 1, NU = 0]". Positions, sizes and pictures are a screen's layout.
ir::Expr UnitCompiler::prompt_dialog_text(const grammar::Statement& s) {
  std::vector<std::string> texts, buttons;
  const auto& p = s.params;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (!is_word(p[k]) || (p[k].text != "TITLE" && p[k].text != "TEXT" && p[k].text != "BUTTON")) continue;
    std::size_t t = k + 1;
    while (t < p.size() && p[t].kind != ExprKind::String && !is_word(p[t])) ++t;
    if (t >= p.size() || p[t].kind != ExprKind::String) continue;
    if (p[k].text != "BUTTON") {
      texts.push_back(p[t].text);
    } else {
      const bool valued = t + 1 < p.size() && p[t + 1].kind == ExprKind::Number;
      buttons.push_back(valued ? fmt::format("{} = {}", p[t].text, p[t + 1].number) : p[t].text);
    }
    k = t;
  }
  std::string question;
  for (const auto& t : texts) question += (question.empty() ? "" : ": ") + t;
  if (!buttons.empty()) {
    question += question.empty() ? "[" : " [";
    for (std::size_t b = 0; b < buttons.size(); ++b) question += (b ? ", " : "") + buttons[b];
    question += "]";
  }
  ir::Expr e;
  e.span = s.span;
  e.op = ir::ExprOp::Constant;
  e.value = Value::string(question);
  e.type = ValueType::String;
  return e;
}

// V=ASSIGN/expr | V[i]=ASSIGN/expr | V=OBTAIN/FA(x),n | V=VALUE/FA(x)|TA(t),word[,n]
void UnitCompiler::assignment(const grammar::Statement& s) {
  const grammar::Expr& v = *s.variable;
  const std::string name = v.text;
  if (s.major != "ASSIGN" && s.major != "OBTAIN" && s.major != "PROMPT" && s.major != "VALUE") {
    // Vendor statements of the form V=XXX/...: warn and skip.
    warn(s.major_span, "sema.unknown-statement", skipped_statement_message(s.major));
    emit(make(Op::Nop, s, s.major));
    return;
  }
  const SymbolTable::VariableInfo* info = variable(name);
  if (!info && !macro_param(name) && s.major == "VALUE" && !m_strict && v.kind != ExprKind::Index) {
    // RationalDMIS saves `KNPTC1 = VALUE/MODE` with no DECL of KNPTC1: read leniently, the VALUE
    // declares it with the type of what it answers.
    auto query = value_query(s);
    if (!query) return;
    if (query->op == ir::ExprOp::Constant) {  // not answered: nothing to declare it with
      emit(make(Op::Nop, s, s.major));
      return;
    }
    warn(v.span, "sema.undeclared-variable",
         fmt::format("variable {} is not declared: this VALUE declares it {} (--strict: an error)", name,
                     declared_word(query->type)));
    declare_implicitly(name, query->type, v.span, s);
    auto in = make(Op::Assign, s, name);
    in.operands.push_back(expr_operand(std::move(*query)));
    emit(std::move(in));
    return;
  }
  if (!info && !macro_param(name))
    return error(v.span, "sema.undeclared-variable",
                 fmt::format("variable {} is not declared: add DECL/REAL,{} (or INTGR, CHAR, BOOL) first", name, name));
  auto in = make(Op::Assign, s, name);
  if (v.kind == ExprKind::Index) {
    if (info && info->size == 0) return error(v.span, "sema.not-array", fmt::format("{} is not an array", name));
    if (info && !check_rank(v, *info)) return;
    for (const auto& a : v.args) {
      if (!push_number(in, a, "an array index")) return;
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
    warn_obtain_index(s.params[0], *idx);
    value.op = ir::ExprOp::Obtain;
    value.span = s.span;
    value.label = label_operand(s.params[0].label);
    value.type = ValueType::Real;
    value.args.push_back(std::move(*idx));
  } else if (s.major == "VALUE") {
    auto query = value_query(s);
    if (!query) return;
    if (query->op == ir::ExprOp::Constant) {  // a VALUE form metron does not answer
      emit(make(Op::Nop, s, s.major));
      return;
    }
    value = std::move(*query);
  } else if (s.major == "PROMPT") {
    // V=PROMPT/'text'[,maxlen]: the operator's answer, typed as V (scripted or a default at run).
    value.op = ir::ExprOp::Call;
    value.name = "PROMPT";
    value.span = s.span;
    value.type = info ? info->type : ValueType::Real;
    if (!s.params.empty() && s.params[0].kind != ExprKind::String && !is_word(s.params[0])) {
      value.args.push_back(prompt_dialog_text(s));
    } else if (!s.params.empty()) {
      auto q = expression(s.params[0]);
      if (!q) return;
      value.args.push_back(std::move(q->e));
    }
  } else {
    if (s.params.size() != 1)
      return error(s.params.empty() ? s.major_span : s.params[1].span, "sema.assign", "ASSIGN expects one expression");
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
                   fmt::format("cannot assign a {} to {}, which is declared {}", to_string(value.type), name,
                               to_string(info->type)));
  }
  in.operands.push_back(expr_operand(std::move(value)));
  emit(std::move(in));
}

// The DECL word of a value type.
const char* UnitCompiler::declared_word(ValueType type) {
  switch (type) {
    case ValueType::Integer: return "INTGR";
    case ValueType::Bool: return "BOOL";
    case ValueType::String: return "CHAR";
    case ValueType::Vector: return "VECTOR";
    default: return "REAL";
  }
}

// DECL/type,name where a statement uses a variable the program does not declare (read leniently).
void UnitCompiler::declare_implicitly(const std::string& name, ValueType type, Span span, const grammar::Statement& s) {
  SymbolTable::VariableInfo info{type, 0, span, {}};
  if (m_macro)
    m_locals[name] = info;
  else
    m_symbols.variables[name] = info;
  auto in = make(Op::Declare, s);
  ir::Operand type_word;
  type_word.kind = ir::Operand::Kind::Word;
  type_word.word = declared_word(type);
  in.operands.push_back(type_word);
  in.names.push_back(name);
  ir::Operand size;
  size.kind = ir::Operand::Kind::Expr;
  size.expr.value = Value::integer(0);
  in.operands.push_back(size);
  emit(std::move(in));
}

// VALUE/FA(x)|F(x),SIZE[,n]: the feature's n-th size (1: diameter, ARC radius, CONE angle, slot
// width; 2: CYLNDR or CPARLN length). VALUE/TA(t),ACT|DEV|AMT|INTOL|OUTOL[,n]: what the last
// OUTPUT or EVAL of T(t) found, for its n-th output feature (DMIS 5 VALUE; the index n as in DMIS
// SIR 97-8). VALUE/MODE and VALUE/SNSLCT: the current mode and sensor, as SMODE() and SCSNS();
// VALUE/SNSET,word and VALUE/FEDRAT,word: the setting in force. Other VALUE forms are one warning,
// and the variable keeps its value; the result is a Constant then.
std::optional<ir::Expr> UnitCompiler::value_query(const grammar::Statement& s) {
  static const char* const size_words[] = {"SIZE"};
  static const char* const tolerance_words[] = {"ACT", "DEV", "AMT", "INTOL", "OUTOL"};
  const auto listed = [](const auto& words, const std::string& w) {
    return std::any_of(std::begin(words), std::end(words), [&](const char* k) { return w == k; });
  };
  ir::Expr q;
  q.span = s.span;
  if (s.params.size() == 1 && is_word(s.params[0], "MODE")) {
    // VALUE/MODE: the current MODE, as SMODE() says it ('AUTO', 'PROG,MAN', 'MAN').
    q.op = ir::ExprOp::Call;
    q.name = "SMODE";
    q.type = ValueType::String;
    return q;
  }
  if (s.params.size() == 1 && is_word(s.params[0], "SNSLCT")) {  // the selected sensor, as SCSNS()
    q.op = ir::ExprOp::Call;
    q.name = "SCSNS";
    q.type = ValueType::String;
    return q;
  }
  // VALUE/SNSET,APPRCH|RETRCT|SEARCH|CLRSRF|DEPTH (program length units) and
  // VALUE/FEDRAT,MESVEL|POSVEL|SCNVEL (mm/s): the setting in force, which a program saves to set
  // it back later. The run answers them by name (Interpreter::run_function).
  static const char* const snset_words[] = {"APPRCH", "RETRCT", "SEARCH", "CLRSRF", "DEPTH"};
  static const char* const feed_words[] = {"MESVEL", "POSVEL", "SCNVEL"};
  if (s.params.size() == 2 && (is_word(s.params[0], "SNSET") || is_word(s.params[0], "FEDRAT")) &&
      is_word(s.params[1]) &&
      (is_word(s.params[0], "SNSET") ? listed(snset_words, s.params[1].text) : listed(feed_words, s.params[1].text))) {
    q.op = ir::ExprOp::Call;
    q.name = fmt::format("VALUE/{},{}", s.params[0].text, s.params[1].text);
    q.type = ValueType::Real;
    return q;
  }
  if (s.params.empty() || !(is_label(s.params[0], {"FA", "F", "TA"}))) {
    warn(s.params.empty() ? s.major_span : s.params[0].span, "sema.value-form",
         "this VALUE form is not answered (metron answers VALUE/FA(x),SIZE, VALUE/TA(t),ACT|DEV|AMT|INTOL|OUTOL, "
         "VALUE/MODE, VALUE/SNSLCT, VALUE/SNSET,word and VALUE/FEDRAT,word); the variable keeps its value");
    return q;
  }
  const grammar::Expr& target = s.params[0];
  const bool tolerance = target.label.prefix == "TA";
  if (s.params.size() < 2 ||
      (s.params.size() > 3 && !(is_word(s.params[1]) && s.params[1].text != "SIZE" && !tolerance && !m_strict)) ||
      !is_word(s.params[1])) {
    error(s.params.size() < 2 ? target.span : s.params[1].span, "sema.value",
          tolerance ? "VALUE/TA(t) expects ACT, DEV, AMT, INTOL or OUTOL[,n]" : "VALUE/FA(x) expects SIZE[,n]");
    return std::nullopt;
  }
  const std::string word = s.params[1].text;
  if (tolerance ? !listed(tolerance_words, word) : !listed(size_words, word)) {
    // Another word of a feature (VALUE/FA(x),FORM, a vendor's): read leniently, an unanswered form
    // as the others; strictly, and for a tolerance (whose words DMIS lists), an error.
    if (!tolerance && !m_strict) {
      warn(s.params[1].span, "sema.value-form",
           fmt::format("VALUE/{}(x),{} is not answered (metron answers VALUE/FA(x),SIZE and VALUE/TA(t),"
                       "ACT|DEV|AMT|INTOL|OUTOL); the variable keeps its value",
                       target.label.prefix, word));
      return q;
    }
    error(s.params[1].span, "sema.value",
          tolerance ? fmt::format("VALUE/TA(t),{}: expected ACT, DEV, AMT, INTOL or OUTOL", word)
                    : fmt::format("VALUE/{}(x),{}: expected SIZE", target.label.prefix, word));
    return std::nullopt;
  }
  if (tolerance) {
    const std::string t = upper(target.label.name);
    if (!named_at_run(t) && !m_symbols.tolerances.count(t)) {
      error(target.span, "sema.undefined-tolerance",
            m_symbols.unevaluated_tolerances.count(t)
                ? fmt::format("T({}) is a tolerance metron does not evaluate; VALUE has nothing to read",
                              target.label.name)
                : fmt::format("tolerance T({}) is not defined", target.label.name));
      return std::nullopt;
    }
    if (auto left = m_symbols.tolerances_left_out.find(t); left != m_symbols.tolerances_left_out.end())
      warn(target.span, "sema.value-left-out",
           fmt::format("T({}) was left out of its last OUTPUT or EVAL (not evaluated for a {}): a run stops at this "
                       "VALUE unless T({}) is evaluated on the way",
                       target.label.name, left->second, target.label.name));
  } else if (!check_feature(target)) {
    return std::nullopt;
  }
  if (s.params.size() == 3) {
    auto n = numeric(s.params[2], "an index n");
    if (!n) return std::nullopt;
    q.args.push_back(std::move(*n));
  } else {
    ir::Expr one;
    one.op = ir::ExprOp::Constant;
    one.type = ValueType::Integer;
    one.value = Value::integer(1);
    q.args.push_back(std::move(one));
  }
  q.op = ir::ExprOp::Query;
  q.label = label_operand(target.label);
  q.name = word;
  q.type = word == "INTOL" || word == "OUTOL" ? ValueType::Bool : ValueType::Real;
  return q;
}

void UnitCompiler::bad_assign(const grammar::Statement& s) {
  error(s.major_span, "sema.missing-variable",
        fmt::format("{} needs a variable on the left: V1={}/...", s.major, s.major));
}

void UnitCompiler::mark_control() {
  for (auto& b : m_blocks)
    if (b.kind == Block::Kind::Meas) b.control = true;
}

// IF/(condition)  |  IF/condition
void UnitCompiler::if_(const grammar::Statement& s) {
  if (s.params.size() != 1)
    return error(s.params.empty() ? s.major_span : s.params[1].span, "sema.if",
                 "IF expects one condition, e.g. IF/(V1.GT.0)");
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

void UnitCompiler::else_(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::If)
    return error(s.major_span, "sema.unmatched", "ELSE without a matching IF");
  Block& b = m_blocks.back();
  if (b.has_else) return error(s.major_span, "sema.unmatched", "a second ELSE for the same IF");
  b.has_else = true;
  b.exits.push_back(emit(make(Op::Jump, s)));
  if (b.branch) code()[*b.branch].target = static_cast<std::int64_t>(code().size());
  b.branch.reset();
}

void UnitCompiler::endif(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::If)
    return error(s.major_span, "sema.unmatched", "ENDIF without a matching IF");
  Block b = m_blocks.back();
  m_blocks.pop_back();
  const std::size_t end = emit(make(Op::Nop, s, "ENDIF"));
  if (b.branch) code()[*b.branch].target = static_cast<std::int64_t>(end);
  for (auto e : b.exits) code()[e].target = static_cast<std::int64_t>(end);
}

// SELECT/expr, then CASE/v1[,v2...] ... ENDCAS for each case and DFTCAS ... ENDCAS for the rest,
// ENDSEL (DMIS 5.x). One case runs, the first whose value equals the selector; none falls
// through. Each CASE is a conditional jump over its block, each ENDCAS a jump to the ENDSEL.
void UnitCompiler::select(const grammar::Statement& s) {
  Block b = block(Block::Kind::Select, s.span);
  if (s.params.size() != 1) {
    m_blocks.push_back(b);
    return error(s.params.empty() ? s.major_span : s.params[1].span, "sema.select",
                 "SELECT expects one value, e.g. SELECT/V1");
  }
  auto e = expression(s.params[0]);
  if (e) b.selector = std::move(e->e);
  mark_control();
  m_blocks.push_back(std::move(b));
  emit(make(Op::Nop, s, "SELECT"));
}

void UnitCompiler::case_(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Select)
    return error(s.major_span, "sema.unmatched", fmt::format("{} without a matching SELECT", s.major));
  Block& b = m_blocks.back();
  if (b.in_case)
    return error(s.major_span, "sema.unmatched", fmt::format("{} before the ENDCAS of the previous case", s.major));
  if (b.has_default)
    return error(s.major_span, "sema.unmatched", fmt::format("{} after DFTCAS: the default case comes last", s.major));
  b.in_case = true;
  if (s.major == "DFTCAS") {
    b.has_default = true;
    return;
  }
  if (s.params.empty()) return error(s.major_span, "sema.select", "CASE expects the values it runs for, e.g. CASE/1");
  if (!b.selector) return;  // the SELECT's own error was reported
  ir::Expr condition;
  for (std::size_t i = 0; i < s.params.size(); ++i) {
    auto v = expression(s.params[i]);
    if (!v) return;
    ir::Expr equal;
    equal.op = ir::ExprOp::Binary;
    equal.name = ".EQ.";
    equal.type = ValueType::Bool;
    equal.span = s.params[i].span;
    equal.args = {*b.selector, std::move(v->e)};
    if (i == 0) {
      condition = std::move(equal);
    } else {
      ir::Expr either;
      either.op = ir::ExprOp::Binary;
      either.name = ".OR.";
      either.type = ValueType::Bool;
      either.span = s.span;
      either.args = {std::move(condition), std::move(equal)};
      condition = std::move(either);
    }
  }
  auto in = make(Op::JumpIfFalse, s);
  in.operands.push_back(expr_operand(std::move(condition)));
  b.branch = emit(std::move(in));
}

void UnitCompiler::endcas(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Select || !m_blocks.back().in_case)
    return error(s.major_span, "sema.unmatched", "ENDCAS without a matching CASE or DFTCAS");
  Block& b = m_blocks.back();
  b.in_case = false;
  b.exits.push_back(emit(make(Op::Jump, s)));
  if (b.branch) code()[*b.branch].target = static_cast<std::int64_t>(code().size());
  b.branch.reset();
}

void UnitCompiler::endsel(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Select)
    return error(s.major_span, "sema.unmatched", "ENDSEL without a matching SELECT");
  if (m_blocks.back().in_case)
    return error(s.major_span, "sema.unmatched", "ENDSEL before the ENDCAS of the last case");
  Block b = m_blocks.back();
  m_blocks.pop_back();
  const std::size_t end = emit(make(Op::Nop, s, "ENDSEL"));
  for (auto e : b.exits) code()[e].target = static_cast<std::int64_t>(end);
}

// DO/V,start,end[,step]
void UnitCompiler::do_(const grammar::Statement& s) {
  Block placeholder = block(Block::Kind::Do, s.span);
  placeholder.start = invalid;
  m_blocks.push_back(placeholder);
  if (s.params.size() < 3 || s.params.size() > 4)
    return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.do",
                 "DO expects a variable, a start, an end and optionally a step");
  const auto& v = s.params[0];
  if (v.kind == ExprKind::Word && !is_variable(v.text) && !m_strict) {
    // A loop counter never declared (a tutorial's DO/I,1,5): read leniently, the DO declares it.
    warn(v.span, "sema.undeclared-variable",
         fmt::format("the DO variable {} is not declared: this DO declares it INTGR (--strict: an error)", v.text));
    declare_implicitly(v.text, ValueType::Integer, v.span, s);
  }
  if (v.kind != ExprKind::Word || !is_variable(v.text))
    return error(v.span, "sema.undeclared-variable",
                 fmt::format("the DO variable {} is not declared: add DECL/INTGR,{}", v.text, v.text));
  const SymbolTable::VariableInfo* info = variable(v.text);
  if (info && info->type != ValueType::Integer && info->type != ValueType::Real)
    return error(v.span, "sema.do",
                 fmt::format("the DO variable {} is {}: a DO counts with a number (DECL/INTGR,{})", v.text,
                             declared_word(info->type), v.text));
  auto in = make(Op::DoInit, s, v.text);
  for (std::size_t i = 1; i < s.params.size(); ++i) {
    auto e = numeric(s.params[i], "a loop bound");
    if (!e) return;
    if (i == 3 && e->op == ir::ExprOp::Constant && e->value.number == 0)
      return error(s.params[i].span, "sema.do", "the DO step must not be zero");
    in.operands.push_back(expr_operand(std::move(*e)));
  }
  mark_control();
  Block b = block(Block::Kind::Do, s.span);
  b.start = emit(std::move(in));
  b.feature = v.text;
  m_blocks.back() = b;
}

void UnitCompiler::enddo(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Do)
    return error(s.major_span, "sema.unmatched", "ENDDO without a matching DO");
  Block b = m_blocks.back();
  m_blocks.pop_back();
  if (b.start == invalid) return;
  auto in = make(Op::DoNext, s, b.feature);
  in.target = static_cast<std::int64_t>(b.start + 1);
  const std::size_t next = emit(std::move(in));
  code()[b.start].target = static_cast<std::int64_t>(next + 1);
}

// JUMPTO/(label)
void UnitCompiler::jumpto(const grammar::Statement& s) {
  if (s.params.size() != 1)
    return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.jumpto",
                 "JUMPTO expects one label, e.g. JUMPTO/(L1)");
  const auto [name, span] = jump_label_name(s.params[0]);
  if (name.empty()) return error(span, "sema.jumpto", "expected a label name after JUMPTO/");
  emit_jump(make(Op::Jump, s, name), name, span);
}

// An instruction whose `target` is a jump label's, resolved when its scope ends.
void UnitCompiler::emit_jump(ir::Instruction in, const std::string& label, Span span) {
  mark_control();
  const std::size_t pc = emit(std::move(in));
  jumps().pending.push_back({pc, {label, span}});
}

// The jump label a parameter `(label)` names (empty when it names none) and its span.
std::pair<std::string, Span> UnitCompiler::jump_label_name(const grammar::Expr& param) const {
  const grammar::Expr* p = &param;
  std::string name;
  if (p->kind == ExprKind::Paren && !p->args.empty()) {
    // A jump label may hold '-', '.' ...: `JUMPTO/(L-1)` parses as the expression L-1, so the
    // label is the text between the parentheses, as `(L-1)` on its own line is read.
    const std::string& text = m_sources.file(p->span.file).text;
    if (p->span.end <= text.size() && p->span.end >= p->span.begin + 2) {
      std::string inner = text.substr(p->span.begin + 1, p->span.end - p->span.begin - 2);
      std::erase_if(inner, [](char c) { return c == ' ' || c == '\t'; });
      const bool plain = !inner.empty() && std::all_of(inner.begin(), inner.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) ||
               std::string_view("_.-#@!~").find(c) != std::string_view::npos;
      });
      if (plain) name = upper(inner);
    }
    p = &p->args[0];
  }
  if (name.empty() && p->kind == ExprKind::Word) name = p->text;
  return {name, p->span};
}

// M(name)=MACRO/'P1','P2' | M(name)=MACRO/P1,P2
void UnitCompiler::macro(const grammar::Statement& s) {
  if (!s.target && !m_strict && !m_macro) {
    // WinWerth wraps a program's body in MACRO/name ... ENDMAC, with nothing to CALL it, and runs
    // it: read leniently so, its statements run where they stand.
    warn(s.span, "sema.unlabelled-macro",
         "MACRO without M(name)= on its left: nothing can CALL it; its statements are run where they stand, up to "
         "its ENDMAC (as WinWerth runs such a block; --strict makes it an error)");
    ++m_unlabelled_macros;
    emit(make(Op::Nop, s, "MACRO"));
    return;
  }
  if (!require_target(s, {"M"}, "M(name)=MACRO/...")) return;
  if (m_macro) return error(s.span, "sema.nested-macro", "a MACRO cannot be defined inside another MACRO");
  ir::Macro m;
  m.name = upper(s.target->name);
  m.span = s.span;
  for (const auto& p : s.params) {
    if (p.kind == ExprKind::String || p.kind == ExprKind::Word)
      m.params.push_back(upper(p.text));
    else
      return error(p.span, "sema.macro-param", "macro parameters are names, e.g. MACRO/'X','Y'");
  }
  if (m_symbols.macros.count(m.name))
    warn(s.target->span, "sema.redefined-macro", fmt::format("macro M({}) is redefined", s.target->name));
  m_module.macros.push_back(std::move(m));
  m_macro = static_cast<int>(m_module.macros.size() - 1);
  m_symbols.macros[m_module.macros.back().name] = *m_macro;
  m_blocks.push_back(block(Block::Kind::Macro, s.span));
}

void UnitCompiler::endmac(const grammar::Statement& s) {
  if ((m_blocks.empty() || m_blocks.back().kind != Block::Kind::Macro) && m_unlabelled_macros > 0) {
    --m_unlabelled_macros;  // the end of a MACRO run in place
    emit(make(Op::Nop, s, "ENDMAC"));
    return;
  }
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Macro)
    return error(s.major_span, "sema.unmatched", "ENDMAC without a matching MACRO");
  m_blocks.pop_back();
  emit(make(Op::Return, s));
  resolve_jumps(m_macro_jumps, m_module.macros[static_cast<std::size_t>(*m_macro)].code);
  m_macro.reset();
  m_locals.clear();
}

// CALL/M(name),args... | CALL/EXTERN,DMIS,'file' | CALL/EXTERN,DMIS,M(name),'file'
void UnitCompiler::call(const grammar::Statement& s) {
  if (!expect_params(s, 1, "M(name) or EXTERN")) return;
  mark_control();
  if (is_word(s.params[0], "EXTERN")) return call_extern(s);
  if (!is_label(s.params[0], {"M"}))
    return error(s.params[0].span, "sema.expected-macro", "expected M(name) or EXTERN after CALL/");
  const std::string name = upper(s.params[0].label.name);
  auto it = m_symbols.macros.find(name);
  if (it == m_symbols.macros.end()) {
    if (const auto later = m_later_macros.find(name); later != m_later_macros.end())
      return error(s.params[0].span, "sema.undefined-macro",
                   fmt::format("macro M({}) is defined at line {}, after this call: a macro is defined before it is "
                               "called",
                               s.params[0].label.name, m_sources.locate(later->second).line));
    if (m_strict || m_repl)
      return error(s.params[0].span, "sema.undefined-macro",
                   fmt::format("macro M({}) is not defined before this call", s.params[0].label.name));
    // A macro of the CMM software's own library (RationalDMIS's EASI_ macros): the program does
    // not hold it, so read leniently the call is skipped, as an unknown statement is.
    warn(s.params[0].span, "sema.undefined-macro",
         fmt::format("macro M({}) is not defined in this program (a macro of the CMM software's own library?): the "
                     "call is skipped (--strict: an error)",
                     s.params[0].label.name));
    emit(make(Op::Nop, s, "CALL"));
    return;
  }
  const auto& macro = m_module.macros[static_cast<std::size_t>(it->second)];
  if (s.params.size() - 1 != macro.params.size())
    return error(s.params.back().span, "sema.arity",
                 fmt::format("M({}) takes {} argument{}, got {}", s.params[0].label.name, macro.params.size(),
                             macro.params.size() == 1 ? "" : "s", s.params.size() - 1));
  auto in = make(Op::CallMacro, s, name);
  in.target = it->second;
  if (auto mf = m_symbols.macro_features.find(name); mf != m_symbols.macro_features.end())
    for (const auto& [index, type] : mf->second) {
      const auto& a = s.params[static_cast<std::size_t>(index) + 1];
      if (a.kind == ExprKind::Label)
        m_symbols.features[upper(a.label.name)] = {type, a.span};
      else if (a.kind == ExprKind::String || a.kind == ExprKind::Word)
        m_symbols.features[upper(a.text)] = {type, a.span};
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

// CALL/EXTERN,DMIS,'file' | CALL/EXTERN,DMIS,M(name),'file' | CALL/EXTERN,SYS,'command'
void UnitCompiler::call_extern(const grammar::Statement& s) {
  if (s.params.size() >= 3 && is_word(s.params[1], "SYS") && s.params[2].kind == ExprKind::String) {
    // metron's own system commands (docs/touch-trigger.md): CHARACTERISE ['file'],
    // CHARACTERISATION 'file'; COMPENSATION 'file' (docs/error-space.md).
    const std::string text = s.params[2].text;
    std::istringstream words(text);
    std::string verb, arg, extra;
    words >> verb >> arg >> extra;
    verb = upper(verb);
    if (verb == "CHARACTERISE" || verb == "CHARACTERIZE" ||
        ((verb == "CHARACTERISATION" || verb == "COMPENSATION") && !arg.empty())) {
      if (!extra.empty())
        return error(s.params[2].span, "sema.system-command", fmt::format("too many words in '{}'", text));
      if ((verb == "CHARACTERISE" || verb == "CHARACTERIZE") && !arg.empty()) {
        // The file is written relative to --out; a path that leaves it is refused when run
        // (docs/security.md), which check can already say.
        const std::filesystem::path p(arg);
        bool leaves = p.is_absolute();
        for (const auto& part : p) leaves = leaves || part == "..";
        if (leaves)
          warn(s.params[2].span, "io.write-outside",
               fmt::format("CHARACTERISE writes '{}' outside the output folder (--out); the run will refuse it", arg));
      }
      if (!arg.empty() && std::filesystem::path(arg).is_relative() && verb != "CHARACTERISE" && verb != "CHARACTERIZE")
        arg = (std::filesystem::path(m_module.units[m_unit].path).parent_path() / arg).string();
      if (verb == "CHARACTERISATION" || verb == "COMPENSATION") warn_if_unreadable(s.params[2].span, verb, arg);
      auto in = make(Op::System, s, verb == "CHARACTERIZE" ? "CHARACTERISE" : verb);
      in.operands.push_back(word_operand(arg, s.params[2].span));
      emit(std::move(in));
      return;
    }
    if (verb == "CALIBRATE" && upper(arg) == "ERROR-SPACE") {
      // CALIBRATE ERROR-SPACE [KEY=VALUE | REVERSAL]... (docs/error-space.md): the words are
      // checked here so that `check` names a bad one; the run reads them again.
      const std::size_t at = upper(text).find("ERROR-SPACE") + std::string("ERROR-SPACE").size();
      const std::string rest = text.substr(at);
      if (auto r = runtime::parse_error_space_request(rest); !r)
        return error(s.params[2].span, "sema.system-command", "CALIBRATE ERROR-SPACE: " + r.error());
      auto in = make(Op::System, s, "CALIBRATE ERROR-SPACE");
      in.operands.push_back(word_operand(rest, s.params[2].span));
      emit(std::move(in));
      return;
    }
    if (verb == "CALIBRATE") {
      auto c = calibrate_wavefront_words(text);
      if (!c) return error(s.params[2].span, "sema.system-command", c.error());
      std::filesystem::path world(c->first);
      if (world.is_relative()) world = std::filesystem::path(m_module.units[m_unit].path).parent_path() / world;
      warn_if_unreadable(s.params[2].span, "CALIBRATE WAVEFRONT", world.string());
      auto in = make(Op::System, s, "CALIBRATE WAVEFRONT");
      for (const std::string& w : {world.string(), c->second}) in.operands.push_back(word_operand(w, s.params[2].span));
      emit(std::move(in));
      return;
    }
    note(s.params[2].span, "sema.unsupported-call",
         fmt::format("unknown system command '{}' (metron knows CHARACTERISE, CHARACTERISATION, COMPENSATION, "
                     "CALIBRATE WAVEFRONT and CALIBRATE ERROR-SPACE); "
                     "the call is skipped",
                     text));
    emit(make(Op::Nop, s, "CALL"));
    return;
  }
  if (s.params.size() >= 2 && (is_word(s.params[1], "DME") || is_word(s.params[1], "SYS"))) {
    // The DME's or the system's own commands: their contents mean nothing to a virtual CMM.
    note(s.params[1].span, "sema.unsupported-call",
         fmt::format("CALL/EXTERN,{} is for the CMM's own software; the call is skipped", s.params[1].text));
    emit(make(Op::Nop, s, "CALL"));
    return;
  }
  if (s.params.size() < 3 || !is_word(s.params[1], "DMIS")) {
    warn(s.params[0].span, "sema.unsupported-call", "only CALL/EXTERN,DMIS,'file' is supported; the call is skipped");
    emit(make(Op::Nop, s, "CALL"));
    return;
  }
  // CALL/EXTERN,DMIS,M(name)[,args...]: a macro of a file EXTFIL declared (MODUS's macro
  // libraries), or of the file named among the arguments.
  if (is_label(s.params[2], {"M"})) return call_external_macro(s);
  // The file is the first string after DMIS. What follows it (CAMIO writes
  // `CALL/EXTERN,DMIS,'sub.dmi',PLNA02`) is not passed: a called file takes no arguments here.
  const auto file_param = std::find_if(s.params.begin() + 2, s.params.end(),
                                       [](const grammar::Expr& e) { return e.kind == ExprKind::String; });
  if (file_param == s.params.end())
    return error(s.params[2].span, "sema.expected-file",
                 "expected the file name as a string, e.g. CALL/EXTERN,DMIS,'sub.dmi'");
  const grammar::Expr& f = *file_param;
  if (file_param != s.params.begin() + 2 || file_param + 1 != s.params.end())
    warn(file_param + 1 != s.params.end() ? (file_param + 1)->span : s.params[2].span, "sema.call-arguments",
         "CALL/EXTERN,DMIS passes nothing but the file: the other parameters of this call are ignored");
  const auto path = called_file(f);
  if (!path) {
    auto in = make(Op::CallUnit, s, f.text);
    in.target = -1;
    emit(std::move(in));
    return;
  }
  auto unit = m_include(path->string(), f.text, f.span);
  if (!unit) return;
  auto in = make(Op::CallUnit, s, path->string());
  in.target = static_cast<std::int64_t>(*unit);
  emit(std::move(in));
}

// Where a file CALL/EXTERN,DMIS or EXTFIL names is: beside the calling file when relative. A path
// written on another machine (`Z:\progs\sub.dmi`, `\\server\...`) is looked up by its base name
// beside the calling file and in the --include folders; not found, it is a warning here (nullopt)
// and an error when the call runs (docs/language.md "CALL/EXTERN").
std::optional<std::filesystem::path> UnitCompiler::called_file(const grammar::Expr& f) {
  const bool foreign = f.text.find('\\') != std::string::npos ||
                       (f.text.size() > 1 && std::isalpha(static_cast<unsigned char>(f.text[0])) && f.text[1] == ':');
  std::filesystem::path path(f.text);
  if (!foreign)
    return path.is_relative() ? std::filesystem::path(m_module.units[m_unit].path).parent_path() / path : path;
  const std::string base = f.text.substr(f.text.find_last_of("\\/:") + 1);
  std::vector<std::filesystem::path> where = {std::filesystem::path(m_module.units[m_unit].path).parent_path()};
  for (const auto& d : m_symbols.include_dirs) where.emplace_back(d);
  std::string searched;
  for (const auto& d : where) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(d / base, ec)) return d / base;
    searched += (searched.empty() ? "" : ", ") + (d.empty() ? std::string(".") : d.string());
  }
  warn(f.span, "sema.foreign-path",
       fmt::format("'{}' was written on another machine and {} is not in {}: give its folder with --include DIR; the "
                   "run stops at this call",
                   f.text, base, searched));
  return std::nullopt;
}

// EXTFIL/DMIS,'file': the file's macros may be called (CALL/M(name) or CALL/EXTERN,DMIS,M(name));
// its statements outside macros are not run. EXTFIL/DME,'file' is the CMM's own: a note.
void UnitCompiler::extfil(const grammar::Statement& s) {
  if (!expect_params(s, 2, "DMIS or DME and the file name")) return;
  if (is_word(s.params[0], "DME")) {
    note(s.params[0].span, "sema.unsupported-call",
         "EXTFIL/DME declares a file of the CMM's own software; nothing to do");
    emit(make(Op::Nop, s, "EXTFIL"));
    return;
  }
  if (!is_word(s.params[0], "DMIS"))
    return error(s.params[0].span, "sema.expected-word", "expected DMIS or DME after EXTFIL/");
  if (s.params[1].kind != ExprKind::String)
    return error(s.params[1].span, "sema.expected-file",
                 "expected the file name as a string, e.g. EXTFIL/DMIS,'macros.dmi'");
  emit(make(Op::Nop, s, "EXTFIL"));
  const auto path = called_file(s.params[1]);
  if (path) m_include(path->string(), s.params[1].text, s.params[1].span);
}

// CALL/EXTERN,DMIS,M(name)[,args...]: the macro M(name) with the arguments, read from an EXTFIL
// file; when M(name) is not defined yet, a string argument that names a readable file is taken
// as its file (and not passed).
void UnitCompiler::call_external_macro(const grammar::Statement& s) {
  grammar::Statement m = s;
  m.params.erase(m.params.begin(), m.params.begin() + 2);  // EXTERN, DMIS
  const std::string name = upper(m.params[0].label.name);
  if (!m_symbols.macros.count(name)) {
    for (auto it = m.params.begin() + 1; it != m.params.end(); ++it) {
      if (it->kind != ExprKind::String) continue;
      const auto path = called_file(*it);
      std::error_code ec;
      if (!path || !std::filesystem::is_regular_file(*path, ec)) continue;
      m_include(path->string(), it->text, it->span);
      m.params.erase(it);
      break;
    }
    if (!m_symbols.macros.count(name))
      return error(
          m.params[0].span, "sema.undefined-macro",
          fmt::format("macro M({}) is not defined: declare the file that holds it with EXTFIL/DMIS,'file' before "
                      "this call",
                      m.params[0].label.name));
  }
  call(m);
}

// OBTAIN/FA(x),n with a constant n that falls on a word of x's output statement (FEAT/type, side,
// CART) or past its last number: the run stops there; check tells where the numbers are.
void UnitCompiler::warn_obtain_index(const grammar::Expr& feature, const ir::Expr& index) {
  if (index.op != ir::ExprOp::Constant || !index.value.is_number()) return;
  const auto type = feature_type(upper(feature.label.name));
  if (!type) return;
  runtime::Geometry g;
  g.type = *type;
  const auto words = static_cast<long>(runtime::feature_word_count(*type));
  const auto last = words + static_cast<long>(runtime::feature_parameters(g).size());
  const auto k = static_cast<long>(std::llround(index.value.number));
  if (k > words && k <= last) return;
  warn(index.span, "sema.obtain-index",
       fmt::format("OBTAIN index {} of {}({}) is not one of its numbers: its output statement has them at {} to {} "
                   "(the first {} are its words); the run stops here",
                   k, feature.label.prefix, feature.label.name, words + 1, last, words));
}

}  // namespace metron::interpreter::detail
