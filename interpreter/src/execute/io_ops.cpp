// SPDX-License-Identifier: GPL-3.0-or-later
// Input/output: UNITS, DECPL, MODE, TEXT, DEVICE, OPEN, CLOSE.
#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

void Execute::add_input_output(ExecuteTable& t) {
  add_rows(t, {{Op::Units, &units},
               {Op::DecimalPlaces, &decimal_places},
               {Op::Read, &read},
               {Op::Write, &write},
               {Op::Mode, &mode},
               {Op::Text, &text},
               {Op::Pause, &pause},
               {Op::DeviceDef, &device_def},
               {Op::DeviceOpen, &device_open},
               {Op::DeviceClose, &device_close}});
}

// Op::Pause: the operator's stop (the virtual CMM's operator may put the part in its next set-up).
ExecStatus Execute::pause(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  vm.m_runtime.operator_stop(in.span);
  return ExecStatus::Running;
}

// Op::Units
ExecStatus Execute::units(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const auto& units = std::get<ir::UnitsPayload>(in.payload);
  vm.m_length_mm = ir::millimetres_per(units.length);
  if (units.angle) vm.m_degrees = *units.angle != ir::AngleUnit::Angrad;
  if (units.temperature) vm.m_fahrenheit = *units.temperature == ir::TemperatureUnit::Tempf;
  // Reports and DMIS output files follow the program's units (results.json stays in mm).
  runtime::ReportUnits report = vm.m_runtime.report_units();
  report.mm_per_length = vm.m_length_mm;
  report.length = std::string(ir::word_of(units.length));
  report.radians = !vm.m_degrees;
  vm.m_runtime.set_report_units(report);
  return ExecStatus::Running;
}

// Op::DecimalPlaces: DECPL pairs each word with the number after it; a lone number (or ALL) sets
// lengths and angles alike.
ExecStatus Execute::decimal_places(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto w = words(in);
  runtime::ReportUnits report = vm.m_runtime.report_units();
  for (std::size_t i = 0; i < nums.size(); ++i) {
    if (!(nums[i] >= 0 && nums[i] <= 12))
      return vm.fail(in.span, fmt::format("DECPL: {} decimals is outside 0..12", nums[i]));
    const int decimals = static_cast<int>(std::lround(nums[i]));
    const std::string word = i < w.size() ? w[i] : "ALL";
    if (word == "ALL" || word == "ALLDEC") {
      report.length_decimals = decimals;
      report.angle_decimals = decimals;
    } else if (word == "ANGLE" || word == "ANGL" || word == "ANG") {
      report.angle_decimals = decimals;
    } else {
      report.length_decimals = decimals;
    }
  }
  vm.m_runtime.set_report_units(report);
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
  if (auto r = vm.m_runtime.define_device(vm.name_of(in), path, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DeviceOpen; with INPUT the file is read whole into fields (separated by commas, blanks
// and line ends; a quoted field keeps its commas and blanks) for READ.
ExecStatus Execute::device_open(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const auto w = words(in);
  if (std::find(w.begin(), w.end(), "INPUT") != w.end()) {
    const std::string label = vm.label_name(in.operands[0].label);
    auto text = vm.m_runtime.read_input_device(label, in.span);
    if (!text) return vm.from_runtime(text.error());
    Interpreter::InputFile file;
    std::string field;
    bool quoted = false, any = false;
    std::size_t line = 0;
    const auto keep = [&] {
      if (any) {
        file.fields.push_back(field);
        file.lines.push_back(line);
      }
      field.clear();
      any = false;
    };
    for (const char c : *text) {
      if (c == '\'') {
        quoted = !quoted;
        any = true;
      } else if (!quoted && (c == ',' || c == ' ' || c == '\t' || c == '\n' || c == '\r')) {
        keep();
        if (c == '\n') ++line;
      } else {
        field += c;
        any = true;
      }
    }
    keep();
    vm.m_inputs[label] = std::move(file);
    return ExecStatus::Running;
  }
  const bool direct = std::find(w.begin(), w.end(), "DIRECT") != w.end();
  if (auto r = vm.m_runtime.open_device(vm.label_name(in.operands[0].label), in.span, direct); !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Read: the next fields of the input file into the variables, each converted to its type.
ExecStatus Execute::read(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const std::string label = vm.label_name(in.operands[0].label);
  auto it = vm.m_inputs.find(label);
  if (it == vm.m_inputs.end())
    return vm.fail(in.span, fmt::format("READ/DID({}): the device is not open for INPUT (OPEN/DID({}),DIRECT,INPUT)",
                                        label, label));
  for (const std::string& name : in.names) {
    auto& file = it->second;
    if (file.next >= file.fields.size())
      return vm.fail(
          in.span, fmt::format("READ/DID({}): the file ended before {} (test EOF(DID({})) first)", label, name, label));
    const auto current = vm.variable(name);
    ValueType type = current ? current->type : ValueType::String;
    if (auto declared = vm.m_types.find(name); declared != vm.m_types.end()) type = declared->second;
    // A VECTOR reads three fields, x, y and z.
    std::array<double, 3> numbers{};
    const std::size_t fields = type == ValueType::Vector ? 3 : type == ValueType::String ? 0 : 1;
    for (std::size_t k = 0; k < fields; ++k) {
      if (file.next >= file.fields.size())
        return vm.fail(in.span, fmt::format("READ/DID({}): the file ended inside the vector {}", label, name));
      const std::string& field = file.fields[file.next++];
      char* end = nullptr;
      numbers[k] = std::strtod(field.c_str(), &end);
      if (field.empty() || end != field.c_str() + field.size())
        return vm.fail(in.span, fmt::format("READ/DID({}): '{}' is not a number for {} (field {} of the file)", label,
                                            field, name, file.next));
    }
    Value value = type == ValueType::Vector ? Value::vector(numbers[0], numbers[1], numbers[2])
                  : type == ValueType::Bool ? Value::boolean_value(numbers[0] != 0)
                  : fields == 1             ? Value::real(numbers[0])
                                            : Value::string(file.fields[file.next++]);
    if (auto set = vm.set_variable(name, value); !set) return vm.fail(in.span, set.error());
  }
  return ExecStatus::Running;
}

// A WRITE value in its layout `e:width[:decimals]` (Fortran's Fw.d and Aw): a number with the
// decimals asked for, right-aligned in the width; text left-aligned. A value wider than its field
// is written whole (Fortran writes asterisks: a lost result).
static std::string laid_out(const Value& v, int width, int decimals) {
  std::string text = decimals >= 0 && v.is_number() ? fmt::format("{:.{}f}", v.number, decimals) : v.to_display();
  // -0.0004 to 3 decimals is 0.000, not -0.000.
  if (text.size() > 1 && text.front() == '-' && text.find_first_not_of("0.", 1) == std::string::npos) text.erase(0, 1);
  if (width < 0 || static_cast<int>(text.size()) >= width) return text;
  const std::string pad(static_cast<std::size_t>(width) - text.size(), ' ');
  return v.is_number() ? pad + text : text + pad;
}

// Op::Write
ExecStatus Execute::write(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::string line;
  for (std::size_t i = 1; i < in.operands.size(); ++i) {
    const ir::Operand& o = in.operands[i];
    auto v = vm.evaluate(o.expr);
    if (!v) return vm.fail(in.span, v.error());
    line += laid_out(*v, o.width, o.decimals);
  }
  if (auto r = vm.m_runtime.write_device(vm.label_name(in.operands[0].label), line, in.span); !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DeviceClose
ExecStatus Execute::device_close(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (vm.m_inputs.erase(vm.label_name(in.operands[0].label)) > 0) return ExecStatus::Running;
  if (auto r = vm.m_runtime.close_device(vm.label_name(in.operands[0].label), in.span); !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
