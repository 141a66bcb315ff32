// SPDX-License-Identifier: GPL-3.0-or-later
// Scanning statements (docs/scanning-paths.md): PATH, SCNMOD, SCNSET, PAMEAS.
#include <cmath>

#include "metron/interpreter/interpreter.hpp"

namespace metron::interpreter {

using ir::Op;
using ir::Operand;

ExecStatus Interpreter::execute_scan(const ir::Instruction& in) {
  std::vector<double> nums;
  std::vector<std::string> words;
  for (const auto& o : in.operands) {
    if (o.kind == Operand::Kind::Word) words.push_back(o.word);
    if (o.kind != Operand::Kind::Expr) continue;
    auto v = number(o.expr);
    if (!v) return fail(in.span, v.error() + " (in " + ir::to_string(o.expr) + ")");
    nums.push_back(*v);
  }
  const double len = m_length_mm;
  const double deg = m_degrees ? 1.0 : 180.0 / 3.14159265358979323846;
  auto& scan = m_runtime.scan_settings();
  switch (in.op) {
    case Op::PathDef: {
      runtime::PathDefinition p;
      p.label = name_of(in);
      const Vec3 a(nums[0], nums[1], nums[2]);
      if (words[0] == "SECTION") {
        p.kind = runtime::PathDefinition::Kind::Section;
        p.model_path = in.names.at(0);
        p.point = a * len;
        p.direction = Vec3(nums[3], nums[4], nums[5]);
        p.point2 = Vec3(nums[6], nums[7], nums[8]) * len;
      } else if (words[0] == "LINE") {
        p.kind = runtime::PathDefinition::Kind::Line;
        p.point = a * len;
        p.point2 = Vec3(nums[3], nums[4], nums[5]) * len;
        p.direction = Vec3(nums[6], nums[7], nums[8]);
      } else {
        p.kind = words[0] == "ARC" ? runtime::PathDefinition::Kind::Arc : runtime::PathDefinition::Kind::Helical;
        p.point = a * len;
        p.direction = Vec3(nums[3], nums[4], nums[5]);
        // Angle 0 along the part's X axis projected on the path's plane (Y when the axis is X).
        const Vec3 axis = p.direction.norm() > 0 ? Vec3(p.direction.normalized()) : Vec3::UnitZ();
        p.reference = std::abs(axis.x()) < 0.99 ? Vec3::UnitX() : Vec3::UnitY();
        p.radius_mm = nums[6] * len;
        p.start_deg = nums[7] * deg;
        p.end_deg = nums[8] * deg;
        if (nums.size() > 9) p.pitch_mm = nums[9] * len;
        p.inner = !(words.size() > 1 && words[1] == "OUTER");
      }
      if (auto r = m_runtime.define_path(p, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::ScanMode:
      scan.scan_mode = words[0] == "ON";
      return ExecStatus::Running;
    case Op::ScanSet: {
      const std::string& w = words[0];
      if (w == "LAW") {
        scan.law = words[1] == "VC1" ? machine::ScanLaw::Vc1 : words[1] == "VC1P" ? machine::ScanLaw::Vc1Prime : machine::ScanLaw::Vc2;
        return ExecStatus::Running;
      }
      const double v = nums[0];
      if (!(v > 0)) return fail(in.span, "the SCNSET/" + w + " value must be positive");
      if (w == "DIST" || w == "DRAG") scan.sample_spacing_mm = v * len;  // DRAG: contact scanning, point spacing
      else if (w == "CHORD") scan.chord_tolerance_mm = v * len;
      else if (w == "ACCEL") scan.centripetal_accel_mm_s2 = v * len;
      else if (w == "DEFLEC") scan.reference_deflection_mm = v * len;
      return ExecStatus::Running;
    }
    case Op::PaMeas: {
      if (!m_block) return fail(in.span, "PAMEAS outside a MEAS block");
      runtime::MeasStep step;
      step.kind = runtime::MeasStep::Kind::Scan;
      step.span = in.span;
      step.path = label_name(in.operands[0].label);
      m_block->steps.push_back(step);
      return ExecStatus::Running;
    }
    default:
      return fail(in.span, "not a scanning instruction");
  }
}

}  // namespace metron::interpreter
