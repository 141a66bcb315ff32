// SPDX-License-Identifier: GPL-3.0-or-later
// Scanning statements (docs/scanning-paths.md): PATH, SCNMOD, SCNSET, PAMEAS.
#include <cmath>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;

void Execute::add_scanning(ExecuteTable& t) {
  add_rows(t, {{Op::PathDef, &path_def}, {Op::ScanMode, &scan_mode}, {Op::ScanSet, &scan_set}, {Op::PaMeas, &pameas}});
}

// Op::PathDef
ExecStatus Execute::path_def(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto w = words(in);
  const double len = vm.m_length_mm;
  const double deg = degrees(vm);
  runtime::PathDefinition p;
  p.label = vm.name_of(in);
  const Vec3 a(nums[0], nums[1], nums[2]);
  if (w[0] == "SECTION") {
    p.kind = runtime::PathDefinition::Kind::Section;
    p.model_path = in.names.at(0);
    p.point = a * len;
    p.direction = Vec3(nums[3], nums[4], nums[5]);
    p.point2 = Vec3(nums[6], nums[7], nums[8]) * len;
    if (nums.size() >= 12) p.point3 = Vec3(nums[9], nums[10], nums[11]) * len;
  } else if (w[0] == "LINE") {
    p.kind = runtime::PathDefinition::Kind::Line;
    p.point = a * len;
    p.point2 = Vec3(nums[3], nums[4], nums[5]) * len;
    p.direction = Vec3(nums[6], nums[7], nums[8]);
  } else {
    p.kind = w[0] == "ARC" ? runtime::PathDefinition::Kind::Arc : runtime::PathDefinition::Kind::Helical;
    p.point = a * len;
    p.direction = Vec3(nums[3], nums[4], nums[5]);
    // Angle 0 along the part's X axis projected on the path's plane (Y when the axis is X).
    const Vec3 axis = p.direction.norm() > 0 ? Vec3(p.direction.normalized()) : Vec3::UnitZ();
    p.reference = std::abs(axis.x()) < 0.99 ? Vec3::UnitX() : Vec3::UnitY();
    p.radius_mm = nums[6] * len;
    p.start_deg = nums[7] * deg;
    p.end_deg = nums[8] * deg;
    if (nums.size() > 9) p.pitch_mm = nums[9] * len;
    p.inner = !(w.size() > 1 && w[1] == "OUTER");
  }
  if (auto r = vm.m_runtime.define_path(p, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::ScanMode
ExecStatus Execute::scan_mode(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  vm.m_runtime.scan_settings().scan_mode = in.operands[0].word == "ON";
  return ExecStatus::Running;
}

// Op::ScanSet
ExecStatus Execute::scan_set(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto words = Execute::words(in);
  auto& scan = vm.m_runtime.scan_settings();
  const double len = vm.m_length_mm;
  const std::string& w = words[0];
  if (w == "LAW") {
    scan.law = words[1] == "VC1"    ? machine::ScanLaw::Vc1
               : words[1] == "VC1P" ? machine::ScanLaw::Vc1Prime
                                    : machine::ScanLaw::Vc2;
    return ExecStatus::Running;
  }
  const double v = nums[0];
  if (!(v > 0)) return vm.fail(in.span, "the SCNSET/" + w + " value must be positive");
  if (w == "DIST" || w == "DRAG")
    scan.sample_spacing_mm = v * len;  // DRAG: contact scanning, point spacing
  else if (w == "CHORD")
    scan.chord_tolerance_mm = v * len;
  else if (w == "ACCEL")
    scan.centripetal_accel_mm_s2 = v * len;
  else if (w == "DEFLEC")
    scan.reference_deflection_mm = v * len;
  return ExecStatus::Running;
}

// Op::PaMeas
ExecStatus Execute::pameas(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (!vm.m_block) return vm.fail(in.span, "PAMEAS outside a MEAS block");
  runtime::MeasStep step;
  step.kind = runtime::MeasStep::Kind::Scan;
  step.span = in.span;
  step.path = vm.label_name(in.operands[0].label);
  vm.m_block->steps.push_back(step);
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
