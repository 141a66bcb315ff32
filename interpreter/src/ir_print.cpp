// SPDX-License-Identifier: GPL-3.0-or-later
#include <fmt/format.h>

#include "metron/interpreter/ir/instruction.hpp"

namespace metron::interpreter::ir {

const char* to_string(Op op) {
  switch (op) {
    case Op::Nop: return "NOP";
    case Op::End: return "END";
    case Op::Units: return "UNITS";
    case Op::Mode: return "MODE";
    case Op::Text: return "TEXT";
    case Op::FeatureDef: return "FEATURE_DEF";
    case Op::ToleranceDef: return "TOLERANCE_DEF";
    case Op::SensorDef: return "SENSOR_DEF";
    case Op::SensorSelect: return "SENSOR_SELECT";
    case Op::ProbeSet: return "PROBE_SET";
    case Op::Feed: return "FEED";
    case Op::System: return "SYSTEM";
    case Op::DecimalPlaces: return "DECPL";
    case Op::Read: return "READ";
    case Op::Write: return "WRITE";
    case Op::FitAlgorithm: return "FIT_ALGORITHM";
    case Op::WorkPlane: return "WORK_PLANE";
    case Op::Push: return "PUSH";
    case Op::Pop: return "POP";
    case Op::GoHome: return "GOHOME";
    case Op::SetHome: return "FROM";
    case Op::BadTest: return "BADTST";
    case Op::OnError: return "ON_ERROR";
    case Op::Resume: return "RESUME";
    case Op::Accel: return "ACCEL";
    case Op::GoTo: return "GOTO";
    case Op::MeasBegin: return "MEAS_BEGIN";
    case Op::PtMeas: return "PTMEAS";
    case Op::MeasEnd: return "MEAS_END";
    case Op::Output: return "OUTPUT";
    case Op::Evaluate: return "EVAL";
    case Op::DatDef: return "DATDEF";
    case Op::DatSet: return "DATSET";
    case Op::Trans: return "TRANS";
    case Op::Rotate: return "ROTATE";
    case Op::Locate: return "LOCATE";
    case Op::Iterate: return "ITERAT";
    case Op::Save: return "SAVE";
    case Op::Recall: return "RECALL";
    case Op::Equate: return "EQUATE";
    case Op::Pause: return "PAUSE";
    case Op::Construct: return "CONSTRUCT";
    case Op::Declare: return "DECLARE";
    case Op::Assign: return "ASSIGN";
    case Op::Jump: return "JUMP";
    case Op::JumpIfFalse: return "JUMP_IF_FALSE";
    case Op::DoInit: return "DO_INIT";
    case Op::DoNext: return "DO_NEXT";
    case Op::CallMacro: return "CALL_MACRO";
    case Op::Return: return "RETURN";
    case Op::CallUnit: return "CALL_UNIT";
    case Op::DeviceDef: return "DEVICE_DEF";
    case Op::DeviceOpen: return "DEVICE_OPEN";
    case Op::DeviceClose: return "DEVICE_CLOSE";
    case Op::JumpLabel: return "LABEL";
    case Op::PathDef: return "PATH_DEF";
    case Op::ScanMode: return "SCAN_MODE";
    case Op::ScanSet: return "SCAN_SET";
    case Op::PaMeas: return "PAMEAS";
  }
  return "?";
}

std::string to_string(const Expr& e) {
  switch (e.op) {
    case ExprOp::Constant:
      if (e.value.type == ValueType::String) return "'" + e.value.text + "'";
      return e.value.to_display();
    case ExprOp::Variable: return e.name;
    case ExprOp::Element: {
      // Appended piece by piece: `(i ? "," : "") + to_string(...)` inserts at the front of a
      // temporary, which g++ 12 reports as a false -Wrestrict overlap.
      std::string s = e.name + "[";
      for (std::size_t i = 0; i < e.args.size(); ++i) {
        if (i) s += ',';
        s += to_string(e.args[i]);
      }
      return s + "]";
    }
    case ExprOp::Call: {
      std::string s = e.name + "(";
      for (std::size_t i = 0; i < e.args.size(); ++i) {
        if (i) s += ',';
        s += to_string(e.args[i]);
      }
      return s + ")";
    }
    case ExprOp::Obtain: return fmt::format("OBTAIN({}({}),{})", e.label.prefix, e.label.name, to_string(e.args.at(0)));
    case ExprOp::Query:
      return fmt::format("VALUE({}({}),{},{})", e.label.prefix, e.label.name, e.name, to_string(e.args.at(0)));
    case ExprOp::Unary: {
      std::string s = e.name;
      s += to_string(e.args.at(0));
      return s;
    }
    case ExprOp::Binary: {
      std::string s = "(";
      s += to_string(e.args.at(0));
      s += e.name;
      s += to_string(e.args.at(1));
      s += ')';
      return s;
    }
  }
  return "?";
}

namespace {

template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};
template <class... F>
Overloaded(F...) -> Overloaded<F...>;

}  // namespace

std::vector<std::string> payload_words(const Payload& payload) {
  std::vector<std::string> w;
  const auto add = [&](auto value) { w.emplace_back(word_of(value)); };
  std::visit(Overloaded{
                 [](const std::monostate&) {},
                 [&](const UnitsPayload& p) {
                   add(p.length);
                   if (p.angle) add(*p.angle);
                   if (p.temperature) add(*p.temperature);
                 },
                 [&](const ModePayload& p) { add(p.mode); },
                 [&](const FeaturePayload& p) {
                   add(p.type);
                   if (p.side) w.emplace_back(runtime::dmis_word(*p.side));
                   if (p.bounded) w.emplace_back(*p.bounded ? "BND" : "UNBND");
                   if (p.slot_ends) w.emplace_back(runtime::dmis_word(*p.slot_ends));
                   if (p.form) add(*p.form);
                 },
                 [&](const TolerancePayload& p) { add(p.kind); },
                 [&](const FeedPayload& p) {
                   add(p.kind);
                   add(p.unit);
                 },
                 [&](const FormPayload& p) {
                   if (p.form) add(*p.form);
                   if (p.reference_point) w.emplace_back("REFERENCE");
                 },
                 [&](const ConstructPayload& p) {
                   add(p.type);
                   add(p.method);
                 },
             },
             payload);
  return w;
}

namespace {

std::string operand_text(const Operand& o) {
  switch (o.kind) {
    case Operand::Kind::Expr: {
      std::string text = to_string(o.expr);
      for (int field : {o.width, o.decimals})
        if (field >= 0) text += fmt::format(":{}", field);
      return text;
    }
    case Operand::Kind::Word: return o.word;
    case Operand::Kind::Label: return o.label.prefix + "(" + (o.label.param ? "$" : "") + o.label.name + ")";
  }
  return "?";
}

void print_code(std::string& out, const std::vector<Instruction>& code, const SourceManager& sources) {
  for (std::size_t pc = 0; pc < code.size(); ++pc) {
    const Instruction& in = code[pc];
    const Location loc = sources.locate(in.span);
    std::string line = fmt::format("  {:4}  {:<14}", pc, to_string(in.op));
    if (!in.name.empty()) line += " " + in.name;
    for (std::size_t i = 0; i < in.names.size(); ++i) line += (i ? "," : " ") + in.names[i];
    std::vector<std::string> items = payload_words(in.payload);
    for (const auto& o : in.operands) items.push_back(operand_text(o));
    std::string ops;
    for (std::size_t i = 0; i < items.size(); ++i) ops += (i ? ", " : "") + items[i];
    if (!ops.empty()) line += " [" + ops + "]";
    if (in.target >= 0) line += fmt::format(" -> {}", in.target);
    out += fmt::format("{:<72} ; {}:{}:{}\n", line, loc.path, loc.line, loc.column);
  }
}

}  // namespace

std::string to_string(const Module& module, const SourceManager& sources) {
  std::string out = "; metron IR (docs/ir.md)\n";
  for (std::size_t u = 0; u < module.units.size(); ++u) {
    out += fmt::format("unit {} {}\n", u, module.units[u].path);
    print_code(out, module.units[u].code, sources);
  }
  for (std::size_t m = 0; m < module.macros.size(); ++m) {
    std::string params;
    for (std::size_t i = 0; i < module.macros[m].params.size(); ++i)
      params += (i ? "," : "") + module.macros[m].params[i];
    out += fmt::format("macro {} M({})({})\n", m, module.macros[m].name, params);
    print_code(out, module.macros[m].code, sources);
  }
  return out;
}

}  // namespace metron::interpreter::ir
