// SPDX-License-Identifier: GPL-3.0-or-later
// Input/output statements: UNITS, MODE, TEXT, DEVICE, OPEN, CLOSE (and the statements with no run-time effect).
#include <algorithm>
#include <cmath>

#include "compile/unit_compiler.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;

namespace {
// Statements metron accepts with no run-time effect (settings a virtual CMM does not need).
const char* const no_effect_words[] = {"DMISMN", "DMISMD", "FILNAM", "DISPLY", "PRCOMP", "WKPLAN", "VFORM",
                                       "ERROR", "DMEHW", "DMESW", "FINPOS", "CLMPID", "CLMPSN", "PREVOP",
                                       "OPERID", "PLANID", "PARTID", "PARTRV", "PARTSN", "PROCID", "QISDEF",
                                       "TECOMP", "TEMPF", "TEMPC", "CRMODE", "CRSLCT", "RESUME"};
}  // namespace

void UnitCompiler::add_input_output(StatementTable& t) {
  for (const char* w : no_effect_words) t.emplace(w, &UnitCompiler::no_effect);
  t.emplace("UNITS", &UnitCompiler::units);
  t.emplace("MODE", &UnitCompiler::mode);
  t.emplace("TEXT", &UnitCompiler::text);
  t.emplace("DEVICE", &UnitCompiler::device);
  t.emplace("OPEN", &UnitCompiler::open);
  t.emplace("CLOSE", &UnitCompiler::close);
}

void UnitCompiler::no_effect(const grammar::Statement& s) { emit(make(Op::Nop, s, s.major)); }

// UNITS/MM|INCH|CM|M|FEET,ANGDEC|ANGRAD[,TEMPF|TEMPC]
void UnitCompiler::units(const grammar::Statement& s) {
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
void UnitCompiler::mode(const grammar::Statement& s) {
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
void UnitCompiler::text(const grammar::Statement& s) {
  if (!expect_params(s, 2, "the text kind (OPER, OUTFIL, MAN) and the text")) return;
  auto in = make(Op::Text, s);
  in.operands.push_back(word_operand(s.params[0]));
  auto e = expression(s.params[1]);
  if (!e) return;
  in.operands.push_back(expr_operand(std::move(e->e)));
  emit(std::move(in));
}

// DID(l)=DEVICE/STOR|TERM|PRINT|INCR,'path'
void UnitCompiler::device(const grammar::Statement& s) {
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
void UnitCompiler::open(const grammar::Statement& s) {
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
void UnitCompiler::close(const grammar::Statement& s) {
  if (!expect_params(s, 1, "DID(label)")) return;
  if (!is_label(s.params[0], {"DID"})) return error(s.params[0].span, "sema.expected-device", "expected DID(label) after CLOSE/");
  if (!m_symbols.devices.count(upper(s.params[0].label.name)))
    return error(s.params[0].span, "sema.undefined-device", fmt::format("device DID({}) is not defined", s.params[0].label.name));
  auto in = make(Op::DeviceClose, s);
  in.operands.push_back(label_op(s.params[0]));
  emit(std::move(in));
}

}  // namespace metron::interpreter::detail
