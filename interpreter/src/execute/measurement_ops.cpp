// SPDX-License-Identifier: GPL-3.0-or-later
// Measurement: SNSLCT, SNSET, FEDRAT, ACLRAT, GOTO, MEAS ... ENDMES, PTMEAS, RMEAS.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

void Execute::add_measurement(ExecuteTable& t) {
  add_rows(t, {{Op::SensorSelect, &sensor_select},
               {Op::FitAlgorithm, &fit_algorithm},
               {Op::WorkPlane, &work_plane},
               {Op::Push, &push},
               {Op::Pop, &pop},
               {Op::ProbeSet, &probe_set},
               {Op::Feed, &feed},
               {Op::Accel, &accel},
               {Op::GoTo, &go_to},
               {Op::GoHome, &go_home},
               {Op::SetHome, &set_home},
               {Op::MeasBegin, &meas_begin},
               {Op::PtMeas, &ptmeas},
               {Op::MeasEnd, &meas_end}});
}

// Op::SensorSelect
ExecStatus Execute::sensor_select(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (vm.m_block) {  // inside MEAS: the sensor changes between the block's points (measured at ENDMES)
    runtime::MeasStep step;
    step.kind = runtime::MeasStep::Kind::SelectSensor;
    step.path = vm.name_of(in);
    step.requalify = in.count == 1;
    step.span = in.span;
    vm.m_block->steps.push_back(std::move(step));
    return ExecStatus::Running;
  }
  if (auto r = vm.m_runtime.select_sensor(vm.name_of(in), in.span, in.count == 1); !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::FitAlgorithm: GEOALG/type,algorithm
ExecStatus Execute::fit_algorithm(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  using F = runtime::MeasurementRuntime::FitAlgorithm;
  const std::string& word = in.operands.at(1).word;
  // The compiler wrote a feature type word (CIRCLE, SPHERE, CYLNDR, PLANE, LINE).
  vm.m_runtime.set_fit_algorithm(ir::parse_word<FeatureType>(in.operands.at(0).word).value_or(FeatureType::Circle),
                                 word == "MAXINS"   ? F::MaximumInscribed
                                 : word == "MINCIR" ? F::MinimumCircumscribed
                                 : word == "MINMAX" ? F::MinimumZone
                                                    : F::LeastSquares);
  return ExecStatus::Running;
}

// Op::WorkPlane: WKPLAN/XYPLAN|YZPLAN|ZXPLAN
ExecStatus Execute::work_plane(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const std::string& word = in.operands.at(0).word;
  vm.m_runtime.set_working_plane(word == "YZPLAN"   ? runtime::WorkingPlane::YZ
                                 : word == "ZXPLAN" ? runtime::WorkingPlane::ZX
                                                    : runtime::WorkingPlane::XY);
  return ExecStatus::Running;
}

// Op::Push: each word's state saved on its stack
ExecStatus Execute::push(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  for (const auto& o : in.operands) vm.m_runtime.push_state(o.word);
  return ExecStatus::Running;
}

// Op::Pop: each word's state restored, in order
ExecStatus Execute::pop(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  for (const auto& o : in.operands)
    if (auto r = vm.m_runtime.pop_state(o.word, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::ProbeSet
ExecStatus Execute::probe_set(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const double len = vm.m_length_mm;
  auto v = vm.number(in.operands.back().expr);
  if (!v) return vm.fail(in.span, v.error());
  const std::string w = in.operands[0].word;
  const double d = *v * len;
  const Span span = in.span;
  if (in.operands.size() == 3) {  // SNSET/CLRSRF,F(plane),d
    return apply_setting(vm, in,
                         [ref = feature_ref(vm, in.operands[1].label), d, span](runtime::MeasurementRuntime& rt) {
                           return rt.set_clearance_surface(ref, d, span);
                         });
  }
  return apply_setting(vm, in, [w, d](runtime::MeasurementRuntime& rt) -> runtime::Result<void> {
    auto& p = rt.probe_settings();
    if (w == "CLRSRF") p.clearance_plane.reset();
    if (w == "APPRCH")
      p.approach_mm = d, p.approach_explicit = true;
    else if (w == "RETRCT")
      p.retract_mm = d;
    else if (w == "SEARCH")
      p.search_mm = d;
    else if (w == "CLRSRF")
      p.clearance_mm = d;
    else if (w == "DEPTH")
      p.depth_mm = d;
    return {};
  });
}

ExecStatus Execute::apply_setting(Interpreter& vm, const ir::Instruction& in, SettingFn apply) {
  if (vm.m_block) {
    runtime::MeasStep step;
    step.kind = runtime::MeasStep::Kind::Setting;
    step.span = in.span;
    step.apply = std::move(apply);
    vm.m_block->steps.push_back(std::move(step));
    return ExecStatus::Running;
  }
  if (auto r = apply(vm.m_runtime); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Feed
ExecStatus Execute::feed(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  auto v = vm.number(in.operands.at(0).expr);
  if (!v) return vm.fail(in.span, v.error());
  const auto [kind, unit] = std::get<ir::FeedPayload>(in.payload);
  return apply_setting(
      vm, in,
      [kind = kind, unit = unit, value = *v, span = in.span](runtime::MeasurementRuntime& rt) -> runtime::Result<void> {
        if (unit == ir::FeedUnit::Defalt) {
          if (kind != ir::FeedKind::Scnvel) return rt.restore_default_feed(kind == ir::FeedKind::Posvel, span);
          rt.scan_settings().feed_mm_s.reset();  // a scan runs at the measuring feed again
          return {};
        }
        const auto state = rt.machine().state();
        // PCENT: of the current positioning feed for POSVEL, of the measuring feed otherwise.
        const double percent_of =
            kind == ir::FeedKind::Posvel ? state.positioning_feed_mm_s : state.measuring_feed_mm_s;
        const double mm_s = ir::feed_mm_s(value, unit).value_or(value / 100.0 * percent_of);
        if (kind == ir::FeedKind::Scnvel) {
          rt.scan_settings().feed_mm_s = mm_s;
          return {};
        }
        return kind == ir::FeedKind::Posvel ? rt.set_feeds(mm_s, std::nullopt, span)
                                            : rt.set_feeds(std::nullopt, mm_s, span);
      });
}

// Op::Accel
ExecStatus Execute::accel(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const Span span = in.span;
  if (in.operands.size() == 1)  // DEFALT
    return apply_setting(vm, in,
                         [span](runtime::MeasurementRuntime& rt) { return rt.restore_default_acceleration(span); });
  auto v = vm.number(in.operands[2].expr);
  if (!v) return vm.fail(in.span, v.error());
  const std::string& unit = in.operands[1].word;
  double a = *v;
  if (unit == "MPMM")
    a = *v * 1000.0 / 3600.0;
  else if (unit == "IPMM")
    a = *v * 25.4 / 3600.0;
  else if (unit == "IPSS")
    a = *v * 25.4;
  else if (unit == "PCENT")
    return ExecStatus::Running;  // relative to an unknown maximum: leave unchanged
  return apply_setting(vm, in, [a, span](runtime::MeasurementRuntime& rt) { return rt.set_acceleration(a, span); });
}

// Op::GoTo
ExecStatus Execute::go_to(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  const double len = vm.m_length_mm;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto form = std::get<ir::FormPayload>(in.payload).form.value_or(ir::CoordinateForm::Cart);
  const Vec3 from = vm.m_block ? vm.m_block_position : vm.m_runtime.position_current();
  Vec3 target;
  if (form == ir::CoordinateForm::Incr) {
    const Vec3 d(nums[1], nums[2], nums[3]);
    if (d.norm() < 1e-12) return vm.fail(in.span, "the GOTO/INCR direction is a zero vector");
    target = from + nums[0] * len * d.normalized();
  } else {
    target = position(vm, form, nums[0], nums[1], nums[2]);
  }
  if (vm.m_block) {
    vm.m_block->steps.push_back({runtime::MeasStep::Kind::GoTo, target, std::nullopt, in.span, {}, false, {}});
    vm.m_block_position = target;
    return ExecStatus::Running;
  }
  if (auto r = vm.m_runtime.go_to(target, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::GoHome
ExecStatus Execute::go_home(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (vm.m_block) return vm.fail(in.span, "GOHOME is not allowed inside a MEAS block");  // check refuses it first
  if (auto r = vm.m_runtime.go_home(in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::SetHome (FROM)
ExecStatus Execute::set_home(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto form = std::get<ir::FormPayload>(in.payload).form.value_or(ir::CoordinateForm::Cart);
  vm.m_runtime.set_home(position(vm, form, nums[0], nums[1], nums[2]));
  return ExecStatus::Running;
}

// Op::MeasBegin
ExecStatus Execute::meas_begin(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  auto n = vm.number(in.operands[0].expr);
  if (!n) return vm.fail(in.span, n.error());
  if (vm.m_block)  // a JUMPTO left the earlier block before its ENDMES
    return vm.fail(in.span,
                   fmt::format("MEAS of {} while the block of {} is still open (a JUMPTO out of it skipped its ENDMES)",
                               vm.name_of(in), vm.m_block->feature));
  vm.m_bad_point = vm.m_bad_geometry = false;  // BADPT and BADGT tell of this measurement from here on
  runtime::MeasBlock b;
  b.feature = vm.name_of(in);
  vm.m_current_feature = b.feature;
  b.type = std::get<ir::FeaturePayload>(in.payload).type;
  b.point_count = static_cast<int>(*n);
  b.span = in.span;
  vm.m_block = b;
  vm.m_block_position = vm.m_runtime.position_current();
  return ExecStatus::Running;
}

// Op::PtMeas
ExecStatus Execute::ptmeas(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  if (!vm.m_block) return vm.fail(in.span, "PTMEAS outside a MEAS block");
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto form = std::get<ir::FormPayload>(in.payload).form.value_or(ir::CoordinateForm::Cart);
  Vec3 p = position(vm, form, nums[0], nums[1], nums[2]);
  std::optional<Vec3> n;
  if (nums.size() >= 6) n = Vec3(nums[3], nums[4], nums[5]);
  if (!in.operands.empty() && in.operands.back().kind == Operand::Kind::Label) {
    // RMEAS: relative to the actual of a reference feature: shift by its deviation.
    const auto ref = feature_ref(vm, in.operands.back().label);
    auto actual = vm.m_runtime.feature_geometry({ref.label, true}, in.span);
    auto nominal = vm.m_runtime.feature_geometry({ref.label, false}, in.span);
    if (!actual) return vm.from_runtime(actual.error());
    p += actual->position - nominal->position;
  }
  const auto kind = std::get<ir::FormPayload>(in.payload).reference_point ? runtime::MeasStep::Kind::Reference
                                                                          : runtime::MeasStep::Kind::PtMeas;
  vm.m_block->steps.push_back({kind, p, n, in.span, {}, false, {}});
  return ExecStatus::Running;
}

// Op::MeasEnd
ExecStatus Execute::meas_end(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (!vm.m_block) return vm.fail(in.span, "ENDMES without MEAS");
  runtime::MeasBlock b = std::move(*vm.m_block);
  vm.m_block.reset();
  if (auto r = vm.m_runtime.measure(b); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
