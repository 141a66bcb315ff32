// SPDX-License-Identifier: GPL-3.0-or-later
// Input/output: UNITS, MODE, TEXT, DEVICE, OPEN, CLOSE.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

void Execute::add_input_output(ExecuteTable& t) {
  add_rows(t, {
      {Op::Units, &units}, {Op::Mode, &mode}, {Op::Text, &text}, {Op::DeviceDef, &device_def},
      {Op::DeviceOpen, &device_open}, {Op::DeviceClose, &device_close}
  });
}

// Op::Units
ExecStatus Execute::units(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const auto& units = std::get<ir::UnitsPayload>(in.payload);
  vm.m_length_mm = ir::millimetres_per(units.length);
  if (units.angle) vm.m_degrees = *units.angle != ir::AngleUnit::Angrad;
  return ExecStatus::Running;
}

// Op::Mode
ExecStatus Execute::mode(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  switch (std::get<ir::ModePayload>(in.payload).mode) {
    case ir::RunMode::Auto: vm.m_runtime.set_mode(runtime::Mode::Auto); break;
    case ir::RunMode::ProgMan: vm.m_runtime.set_mode(runtime::Mode::ProgMan); break;
    case ir::RunMode::Man: vm.m_runtime.set_mode(runtime::Mode::Man); break;
  }
  return ExecStatus::Running;
}

// Op::Text
ExecStatus Execute::text(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  auto v = vm.evaluate(in.operands[1].expr);
  if (!v) return vm.fail(in.span, v.error());
  vm.m_runtime.text(in.operands[0].word, v->to_display());
  return ExecStatus::Running;
}

// Op::DeviceDef
ExecStatus Execute::device_def(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::string path;
  if (in.operands.size() > 1) {
    auto v = vm.evaluate(in.operands[1].expr);
    if (!v) return vm.fail(in.span, v.error());
    path = v->to_display();
  }
  if (auto r = vm.m_runtime.define_device(in.name, path, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DeviceOpen
ExecStatus Execute::device_open(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.open_device(vm.label_name(in.operands[0].label), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DeviceClose
ExecStatus Execute::device_close(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.close_device(vm.label_name(in.operands[0].label), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
