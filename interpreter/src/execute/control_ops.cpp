// SPDX-License-Identifier: GPL-3.0-or-later
// Control: assignment, IF, DO, JUMPTO, macros, CALL (units, macros, system commands), ENDFIL.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

void Execute::add_control(ExecuteTable& t) {
  add_rows(t, {{Op::Nop, &nothing},
               {Op::JumpLabel, &nothing},
               {Op::System, &system},
               {Op::End, &end},
               {Op::Assign, &assign},
               {Op::Jump, &jump},
               {Op::JumpIfFalse, &jump_if_false},
               {Op::DoInit, &do_init},
               {Op::DoNext, &do_next},
               {Op::CallMacro, &call_macro},
               {Op::Return, &return_},
               {Op::CallUnit, &call_unit},
               {Op::OnError, &on_error},
               {Op::Resume, &resume},
               {Op::BadTest, &bad_test}});
}

// Op::OnError: ERROR/(label)|AUTO,condition or ERROR/OFF
ExecStatus Execute::on_error(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  const std::string& how = in.operands.at(0).word;
  if (how == "OFF") {
    vm.m_on_error.reset();
    return ExecStatus::Running;
  }
  Interpreter::ErrorHandling h;
  h.automatic = how == "AUTO";
  h.condition = in.operands.at(1).word;
  h.frame = vm.m_frames.size() - 1;
  h.kind = frame.kind;
  h.index = frame.index;
  h.target = h.automatic ? 0 : static_cast<std::size_t>(in.target);
  vm.m_on_error = h;
  return ExecStatus::Running;
}

// Op::BadTest: BADTST/ON|OFF
ExecStatus Execute::bad_test(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  vm.m_bad_test = in.operands.at(0).word == "ON";
  return ExecStatus::Running;
}

// Op::Resume: where the handler of a machine fault goes on.
ExecStatus Execute::resume(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  if (!vm.m_handled) return vm.fail(in.span, "RESUME outside an error handler: no machine fault is being handled");
  const Interpreter::HandledFault h = *vm.m_handled;
  vm.m_handled.reset();
  const std::string& where = in.operands.at(0).word;
  if (where == "JUMP") {
    frame.pc = static_cast<std::size_t>(in.target);
    return ExecStatus::Running;
  }
  if (where == "END") {
    vm.m_finished = true;
    return ExecStatus::Finished;
  }
  if (h.frame >= vm.m_frames.size()) return vm.fail(in.span, "RESUME: the statement that faulted is no longer running");
  vm.m_frames.resize(h.frame + 1);
  // metron runs a MEAS block at its ENDMES, so the next line and the next measurement are one.
  vm.m_frames.back().pc = where == "CURMEAS" ? h.measurement : h.failed + 1;
  return ExecStatus::Running;
}

// Op::Nop, Op::JumpLabel
ExecStatus Execute::nothing(Interpreter&, const ir::Instruction&, CallFrame&) { return ExecStatus::Running; }

// Op::System
ExecStatus Execute::system(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const std::string& arg = in.operands.empty() ? std::string() : in.operands[0].word;
  if (in.name == "CALIBRATE ERROR-SPACE") {  // operand: the words after ERROR-SPACE (compile/control.cpp)
    auto request = runtime::parse_error_space_request(arg);
    if (!request) return vm.fail(in.span, request.error());
    auto c = vm.m_runtime.calibrate_error_space(*request, in.span);
    if (!c) return vm.from_runtime(c.error());
    return ExecStatus::Running;
  }
  if (in.name == "CALIBRATE WAVEFRONT") {  // operands: the world file, the step (compile/control.cpp)
    auto w = vm.m_runtime.calibrate_wavefront(arg, in.operands.at(1).word, in.span);
    if (!w) return vm.from_runtime(w.error());
    return ExecStatus::Running;
  }
  auto r = in.name == "CHARACTERISE" ? vm.m_runtime.characterise_machine(
                                           arg.empty() ? std::nullopt : std::optional<std::string>(arg), in.span)
           : in.name == "COMPENSATION" ? vm.m_runtime.use_compensation(arg, in.span)
                                       : vm.m_runtime.use_characterisation(arg, in.span);
  if (!r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::End
ExecStatus Execute::end(Interpreter& vm, const ir::Instruction&, CallFrame& frame) {
  if (frame.kind == CallFrame::Kind::Unit && frame.call_site.valid()) {
    vm.m_frames.pop_back();  // ENDFIL of a file called with CALL/EXTERN: back to the caller
    return ExecStatus::Running;
  }
  vm.m_finished = true;
  return ExecStatus::Finished;
}

// Op::Assign
ExecStatus Execute::assign(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  auto value = vm.evaluate(in.operands.back().expr);
  if (!value) return vm.fail(in.span, value.error());
  auto* var = vm.find_variable(in.name);
  if (!var) return vm.fail(in.span, fmt::format("variable {} has no storage here", in.name));
  std::size_t index = 0;
  if (in.count > 0) {
    std::vector<double> indices;
    for (int k = 0; k < in.count; ++k) {
      auto i = vm.number(in.operands[static_cast<std::size_t>(k)].expr);
      if (!i) return vm.fail(in.span, i.error());
      indices.push_back(*i);
    }
    auto offset = vm.element_offset(in.name, indices, var->size());
    if (!offset) return vm.fail(in.span, offset.error());
    index = *offset;
  }
  auto stored = vm.typed_value(in.name, *value);
  if (!stored) return vm.fail(in.span, stored.error());
  (*var)[index] = std::move(*stored);
  return ExecStatus::Running;
}

// Op::Jump
ExecStatus Execute::jump(Interpreter&, const ir::Instruction& in, CallFrame& frame) {
  frame.pc = static_cast<std::size_t>(in.target);
  return ExecStatus::Running;
}

// Op::JumpIfFalse
ExecStatus Execute::jump_if_false(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  auto c = vm.evaluate(in.operands[0].expr);
  if (!c) return vm.fail(in.span, c.error());
  if (c->type != ValueType::Bool) return vm.fail(in.span, "the IF condition is not BOOL");
  if (!c->boolean) frame.pc = static_cast<std::size_t>(in.target);
  return ExecStatus::Running;
}

// Op::DoInit
ExecStatus Execute::do_init(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  std::vector<double> nums;
  const std::size_t pc = frame.pc - 1;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const double step = nums.size() > 2 ? nums[2] : 1.0;
  if (step == 0) return vm.fail(in.span, "the DO step is zero");
  if (auto set = vm.set_variable(in.name, Value::real(nums[0])); !set) return vm.fail(in.span, "DO: " + set.error());
  frame.loops[pc] = {nums[1], step};
  if (step > 0 ? nums[0] > nums[1] : nums[0] < nums[1]) frame.pc = static_cast<std::size_t>(in.target);
  return ExecStatus::Running;
}

// Op::DoNext
ExecStatus Execute::do_next(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  const auto [end, step] = frame.loops.at(static_cast<std::size_t>(in.target - 1));
  auto v = vm.variable(in.name);
  if (!v) return vm.fail(in.span, fmt::format("DO variable {} has no value", in.name));
  const double next = v->number + step;
  if (auto set = vm.set_variable(in.name, Value::real(next)); !set) return vm.fail(in.span, "DO: " + set.error());
  if (step > 0 ? next <= end : next >= end) frame.pc = static_cast<std::size_t>(in.target);
  return ExecStatus::Running;
}

// Op::CallMacro
ExecStatus Execute::call_macro(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const auto& macro = vm.m_module.macros.at(static_cast<std::size_t>(in.target));
  CallFrame f;
  f.kind = CallFrame::Kind::Macro;
  f.index = static_cast<std::size_t>(in.target);
  f.call_site = in.span;
  for (std::size_t i = 0; i < macro.params.size(); ++i) {
    auto v = vm.evaluate(in.operands.at(i).expr);
    if (!v) return vm.fail(in.span, v.error());
    f.locals[macro.params[i]] = {*v};
  }
  if (vm.m_frames.size() > 256) return vm.fail(in.span, "macro calls nest deeper than 256: is a macro calling itself?");
  vm.m_frames.push_back(std::move(f));
  return ExecStatus::Running;
}

// Op::Return
ExecStatus Execute::return_(Interpreter& vm, const ir::Instruction&, CallFrame&) {
  vm.m_frames.pop_back();
  return ExecStatus::Running;
}

// Op::CallUnit
ExecStatus Execute::call_unit(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  // A called file that check could not find (a path of another machine): an error only now.
  if (in.target < 0)
    return vm.fail(in.span,
                   fmt::format("CALL/EXTERN,DMIS file {} was not found (give its folder with --include DIR)", in.name));
  CallFrame f;
  f.kind = CallFrame::Kind::Unit;
  f.index = static_cast<std::size_t>(in.target);
  f.call_site = in.span;
  vm.m_frames.push_back(std::move(f));
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
