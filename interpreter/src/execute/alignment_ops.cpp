// SPDX-License-Identifier: GPL-3.0-or-later
// Alignment and constructions: DATSET, TRANS, ROTATE, SAVE, RECALL, CONST, OUTPUT.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

namespace {

std::optional<runtime::Axis> axis_of(const std::string& w) {
  switch (w.empty() ? ' ' : w[0]) {
    case 'X': return runtime::Axis::X;
    case 'Y': return runtime::Axis::Y;
    case 'Z': return runtime::Axis::Z;
    default: return std::nullopt;
  }
}

}  // namespace

void Execute::add_alignment(ExecuteTable& t) {
  add_rows(t, {{Op::Output, &output},
               {Op::Evaluate, &evaluate},
               {Op::DatSet, &datset},
               {Op::Trans, &trans},
               {Op::Rotate, &rotate},
               {Op::Locate, &locate},
               {Op::Iterate, &iterate},
               {Op::Save, &save},
               {Op::Recall, &recall},
               {Op::Equate, &equate},
               {Op::Construct, &construct}});
}

// The items of an OUTPUT or EVAL, in order.
std::vector<runtime::OutputItem> Execute::output_items(Interpreter& vm, const ir::Instruction& in) {
  std::vector<runtime::OutputItem> items;
  for (std::size_t k = 0; k < in.operands.size(); ++k) {
    const auto& o = in.operands[k];
    if (o.kind == Operand::Kind::Expr) continue;  // a point range, read with its feature below
    runtime::OutputItem item;
    if (o.label.prefix == "T" || o.label.prefix == "TA") {
      item.kind = runtime::OutputItem::Kind::Tolerance;
      item.tolerance = vm.label_name(o.label);
    } else if (o.label.prefix == "S" || o.label.prefix == "SA") {
      item.kind = runtime::OutputItem::Kind::Sensor;
      item.sensor = vm.label_name(o.label);
      item.sensor_actual = o.label.prefix == "SA";
    } else if (o.label.prefix == "D" || o.label.prefix == "DA") {
      item.kind = runtime::OutputItem::Kind::CoordinateSystem;
      item.coordinate_system = vm.label_name(o.label);
      item.coordinate_system_actual = o.label.prefix == "DA";
    } else {
      item.feature = feature_ref(vm, o.label);
      // FA(x)[first,last] or FA(x)[n]: one or two numbers after the label (docs/ir.md).
      std::vector<int> range;
      for (std::size_t j = k + 1; j < in.operands.size() && in.operands[j].kind == Operand::Kind::Expr; ++j) {
        const auto v = vm.number(in.operands[j].expr);
        range.push_back(v && std::isfinite(*v) ? static_cast<int>(std::lround(std::clamp(*v, -1e9, 1e9))) : 0);
      }
      if (!range.empty()) item.points = std::pair{range.front(), range.back()};
    }
    items.push_back(item);
  }
  return items;
}

// Op::Output
ExecStatus Execute::output(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.output(output_items(vm, in), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Evaluate
ExecStatus Execute::evaluate(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.evaluate(output_items(vm, in), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DatSet
ExecStatus Execute::datset(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  runtime::DatsetRequest req;
  for (const auto& o : in.operands) {
    if (o.kind == Operand::Kind::Word && o.word == "MCS")
      req.mcs = true;
    else if (o.kind == Operand::Kind::Label && o.label.prefix == "DAT")
      req.clauses.push_back({vm.label_name(o.label), std::nullopt, std::nullopt, false, {}});
    else if (o.kind == Operand::Kind::Label)  // DATSET/FA(x),...: the feature itself
      req.clauses.push_back({{}, feature_ref(vm, o.label), std::nullopt, false, {}});
    else if (o.kind == Operand::Kind::Word && !req.clauses.empty()) {
      auto& c = req.clauses.back();
      const auto axis = axis_of(o.word);
      if (o.word.find("ORIG") != std::string::npos)
        c.origins.push_back(*axis);
      else {
        c.direction = axis;
        c.minus = o.word.find("MINUS") != std::string::npos;
      }
    }
  }
  if (auto r = vm.m_runtime.datset(vm.name_of(in), req, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Trans
ExecStatus Execute::trans(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const double len = vm.m_length_mm;
  runtime::TransRequest req;
  for (std::size_t i = 0; i + 1 < in.operands.size(); i += 2) {
    const int k = static_cast<int>(*axis_of(in.operands[i].word));
    const Operand& v = in.operands[i + 1];
    if (v.kind == Operand::Kind::Label) {
      req.feature[k] = feature_ref(vm, v.label);
    } else {
      auto x = vm.number(v.expr);
      if (!x) return vm.fail(in.span, x.error());
      req.value[k] = *x * len;
    }
  }
  if (auto r = vm.m_runtime.trans(vm.name_of(in), req, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Rotate
ExecStatus Execute::rotate(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const double deg = degrees(vm);
  runtime::RotateRequest req;
  req.about = *axis_of(in.operands[0].word);
  if (in.operands[1].kind == Operand::Kind::Label) {
    req.feature = feature_ref(vm, in.operands[1].label);
    req.align = *axis_of(in.operands[2].word);
    req.align_negative = in.operands[2].word.ends_with("MINUS");
  } else {
    auto a = vm.number(in.operands[1].expr);
    if (!a) return vm.fail(in.span, a.error());
    req.angle_deg = *a * deg;
  }
  if (auto r = vm.m_runtime.rotate(vm.name_of(in), req, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Locate
ExecStatus Execute::locate(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  runtime::LocateRequest req;
  bool any_along = false, any_about = false;
  std::array<bool, 3> along{}, about{};
  for (const auto& o : in.operands) {
    if (o.kind == Operand::Kind::Word) {
      const int k = static_cast<int>(*axis_of(o.word));
      if (o.word.ends_with("AXIS")) {
        about[static_cast<std::size_t>(k)] = any_about = true;
      } else {
        along[static_cast<std::size_t>(k)] = any_along = true;
      }
    } else if (o.label.prefix == "DAT") {
      req.datums.push_back(vm.label_name(o.label));
    } else {
      req.features.push_back(feature_ref(vm, o.label));
    }
  }
  // No freedom written: all six; freedoms written: those only.
  if (any_along || any_about) {
    req.along = along;
    req.about = about;
  }
  if (auto r = vm.m_runtime.locate(vm.name_of(in), req, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Iterate: a fit, then back to the jump label until the test is within the accuracy or
// `count` fits were made (then a warning, and the last fit stays current).
ExecStatus Execute::iterate(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  const std::size_t pc = frame.pc - 1;
  runtime::LocateRequest req;
  std::vector<double> nums;
  bool incremental = false;
  for (const auto& o : in.operands) {
    if (o.kind == Operand::Kind::Expr) {
      auto v = vm.number(o.expr);
      if (!v) return vm.fail(in.span, v.error());
      nums.push_back(*v);
    } else if (o.kind == Operand::Kind::Word) {
      incremental = o.word == "INCR";
    } else if (o.label.prefix == "DAT") {
      req.datums.push_back(vm.label_name(o.label));
    } else {
      req.features.push_back(feature_ref(vm, o.label));
    }
  }
  const double accuracy_mm = nums.at(0) * vm.m_length_mm;
  const double count = nums.at(1);
  if (!(accuracy_mm >= 0) || !(count >= 1) || count > 1e6)
    return vm.fail(in.span, fmt::format("ITERAT needs an accuracy of 0 or more and a count from 1 to 10^6 (got {}, {})",
                                        nums[0], nums[1]));
  auto criterion = vm.m_runtime.iterate(vm.name_of(in), req, incremental, in.span);
  if (!criterion) return vm.from_runtime(criterion.error());
  const int fits = ++frame.iterations[pc];
  if (*criterion <= accuracy_mm) {
    frame.iterations.erase(pc);
    return ExecStatus::Running;
  }
  if (fits < count) {
    frame.pc = static_cast<std::size_t>(in.target);
    return ExecStatus::Running;
  }
  frame.iterations.erase(pc);
  vm.m_runtime.warning(in.span, fmt::format("ITERAT D({}): not within {} after {} fits; the last fit is kept",
                                            vm.name_of(in), nums[0], fits));
  return ExecStatus::Running;
}

// Op::Save
ExecStatus Execute::save(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.save(vm.label_name(in.operands[0].label), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Recall
ExecStatus Execute::recall(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.recall(vm.label_name(in.operands[0].label), in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Equate
ExecStatus Execute::equate(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.equate(vm.label_name(in.operands[0].label), vm.label_name(in.operands[1].label), in.span);
      !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Construct
ExecStatus Execute::construct(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  const auto& words = std::get<ir::ConstructPayload>(in.payload);
  vm.m_current_feature = vm.name_of(in);
  using M = ir::ConstructionMethod;
  if (words.method == M::Movept) {
    std::vector<double> offset;
    if (auto e = numbers(vm, in, offset)) return vm.fail(in.span, *e);
    if (offset.size() != 3) return vm.fail(in.span, "MOVEPT needs dx, dy, dz");
    const double len = vm.m_length_mm;
    if (auto r = vm.m_runtime.construct_moved_point(vm.name_of(in), feature_ref(vm, in.operands[0].label),
                                                    Vec3(offset[0] * len, offset[1] * len, offset[2] * len), in.span);
        !r)
      return vm.from_runtime(r.error());
    return ExecStatus::Running;
  }
  if (words.method == M::Extrem) {
    // operands: the source, MIN|MAX, then a direction word (RADIAL: from the source's axis), an
    // axis feature or i, j, k
    if (in.operands.at(2).kind == Operand::Kind::Word && in.operands[2].word == "RADIAL") {
      if (auto r = vm.m_runtime.construct_radial_extreme_point(vm.name_of(in), feature_ref(vm, in.operands[0].label),
                                                               in.operands[1].word == "MIN", in.span);
          !r)
        return vm.from_runtime(r.error());
      return ExecStatus::Running;
    }
    Vec3 direction = Vec3::Zero();
    std::optional<runtime::FeatureRef> axis;
    const auto& d = in.operands.at(2);
    if (d.kind == Operand::Kind::Label) {
      axis = feature_ref(vm, d.label);
    } else if (d.kind == Operand::Kind::Word) {
      const bool minus = d.word.find("MINUS") != std::string::npos;
      direction[d.word[0] - 'X'] = minus ? -1 : 1;
    } else {
      for (int k = 0; k < 3; ++k) {
        auto v = vm.number(in.operands.at(2 + static_cast<std::size_t>(k)).expr);
        if (!v) return vm.fail(in.span, v.error());
        direction[k] = *v;
      }
    }
    if (auto r = vm.m_runtime.construct_extreme_point(vm.name_of(in), feature_ref(vm, in.operands[0].label), axis,
                                                      direction, in.operands[1].word == "MIN", in.span);
        !r)
      return vm.from_runtime(r.error());
    return ExecStatus::Running;
  }
  if (words.method == M::Cone) {
    auto v = vm.number(in.operands.at(2).expr);
    if (!v) return vm.fail(in.span, v.error());
    if (auto r = vm.m_runtime.construct_cone_section(vm.name_of(in), feature_ref(vm, in.operands[0].label),
                                                     in.operands[1].word == "DIAM", *v * vm.m_length_mm, in.span);
        !r)
      return vm.from_runtime(r.error());
    return ExecStatus::Running;
  }
  if (words.method == M::Offset) {
    auto d = vm.number(in.operands.at(1).expr);
    if (!d) return vm.fail(in.span, d.error());
    if (auto r = vm.m_runtime.construct_offset_plane(vm.name_of(in), feature_ref(vm, in.operands[0].label),
                                                     *d * vm.m_length_mm, in.span);
        !r)
      return vm.from_runtime(r.error());
    return ExecStatus::Running;
  }
  if (words.method == M::Tanto) {
    std::vector<runtime::FeatureRef> sources;
    std::optional<double> diameter_mm;
    for (const auto& o : in.operands) {
      if (o.kind == Operand::Kind::Label) {
        sources.push_back(feature_ref(vm, o.label));
        continue;
      }
      auto d = vm.number(o.expr);
      if (!d) return vm.fail(in.span, d.error());
      diameter_mm = *d * vm.m_length_mm;
    }
    if (auto r = vm.m_runtime.construct_tangent(vm.name_of(in), words.type, sources, diameter_mm, in.span); !r)
      return vm.from_runtime(r.error());
    return ExecStatus::Running;
  }
  const auto method = words.method == M::Bf                                   ? runtime::ConstructMethod::BestFit
                      : words.method == M::Intof || words.method == M::Pierce ? runtime::ConstructMethod::Intersection
                      : words.method == M::Midpt                              ? runtime::ConstructMethod::Midpoint
                      : words.method == M::Parto  ? runtime::ConstructMethod::ParallelThrough
                      : words.method == M::Perpto ? runtime::ConstructMethod::PerpendicularThrough
                      : words.method == M::Midpl || words.method == M::Midli ? runtime::ConstructMethod::Midpoint
                      : words.method == M::Cast                              ? runtime::ConstructMethod::Cast
                      : words.method == M::Copy                              ? runtime::ConstructMethod::Copy
                      : words.method == M::Vertex                            ? runtime::ConstructMethod::Vertex
                                                  : runtime::ConstructMethod::Projection;  // PROJPT, PROJLN, PROJCT
  std::vector<runtime::FeatureRef> sources;
  for (const auto& o : in.operands) sources.push_back(feature_ref(vm, o.label));
  if (auto r = vm.m_runtime.construct(vm.name_of(in), words.type, method, sources, in.span); !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
