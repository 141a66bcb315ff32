// SPDX-License-Identifier: GPL-3.0-or-later
// Definitions: FEAT, TOL, SNSDEF, DATDEF, DECL (PATH: scan_ops.cpp).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"

namespace metron::interpreter::detail {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

namespace {

Value default_value(ValueType t) {
  switch (t) {
    case ValueType::Integer: return Value::integer(0);
    case ValueType::Bool: return Value::boolean_value(false);
    case ValueType::String: return Value::string("");
    case ValueType::Vector: return Value::vector(0, 0, 0);
    default: return Value::real(0);
  }
}

}  // namespace

void Execute::add_definitions(ExecuteTable& t) {
  add_rows(t, {{Op::FeatureDef, &feature_def},
               {Op::ToleranceDef, &tolerance_def},
               {Op::SensorDef, &sensor_def},
               {Op::DatDef, &datdef},
               {Op::Declare, &declare}});
}

// Op::FeatureDef
ExecStatus Execute::feature_def(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  const double deg = degrees(vm);
  const double len = vm.m_length_mm;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto& words = std::get<ir::FeaturePayload>(in.payload);
  runtime::Geometry g;
  g.type = words.type;
  if (words.side) g.side = *words.side;
  if (words.bounded) g.bounded = *words.bounded;
  const auto form = words.form.value_or(ir::CoordinateForm::Cart);
  const auto point = [&](std::size_t i) { return position(vm, form, nums[i], nums[i + 1], nums[i + 2]); };
  const auto vec = [&](std::size_t i) { return Vec3(nums[i], nums[i + 1], nums[i + 2]); };
  if (!nums.empty()) g.position = point(0);  // a bare GSURF or GCURVE has no numbers
  switch (g.type) {
    case FeatureType::Point:
    case FeatureType::Plane: g.direction = vec(3); break;
    case FeatureType::Line:
      if (g.bounded) {
        const Vec3 b = point(3);
        g.direction = b - g.position;
        g.length_mm = g.direction.norm();
        g.normal2 = vec(6);
      } else {
        g.direction = vec(3);
        g.normal2 = vec(6);
      }
      break;
    case FeatureType::Circle:
      g.direction = vec(3);
      g.diameter_mm = nums[6] * len;
      break;
    case FeatureType::Arc:
      g.direction = vec(3);
      g.diameter_mm = 2 * nums[6] * len;
      g.start_angle_deg = nums[7] * deg;
      g.included_angle_deg = nums[8] * deg;
      if (nums.size() == 12) {
        g.arc_reference = vec(9);
        const Vec3 n = g.direction.normalized();
        g.arc_reference -= g.arc_reference.dot(n) * n;  // in the arc's plane
        if (g.arc_reference.norm() < 1e-9)
          return vm.fail(in.span, "the arc's reference direction i2,j2,k2 is zero or along its axis");
      }
      break;
    case FeatureType::Sphere:
      if (nums.size() == 7) g.direction = vec(3);
      g.diameter_mm = nums.back() * len;
      break;
    case FeatureType::Cylinder:
      g.direction = vec(3);
      g.diameter_mm = nums[6] * len;
      if (nums.size() > 7) g.length_mm = nums[7] * len;
      break;
    case FeatureType::Cone:
      g.direction = vec(3);
      g.apex_angle_deg = nums[6] * deg;
      if (nums.size() > 7) g.length_mm = nums[7] * len;
      break;
    case FeatureType::ParallelPlanes:
      g.direction = vec(3);
      g.width_mm = nums[6] * len;
      break;
    case FeatureType::GenericSurface:
    case FeatureType::GenericCurve:
      if (nums.size() == 6) g.direction = vec(3);
      break;
    case FeatureType::ClosedSlot:
      g.direction = vec(3);
      g.slot_axis = vec(6);
      g.length_mm = nums[9] * len;
      g.width_mm = nums[10] * len;
      g.slot_ends = words.slot_ends.value_or(runtime::SlotEnds::Round);
      break;
    case FeatureType::Torus:
      g.direction = vec(3);
      g.diameter_mm = nums[6] * len;
      g.minor_diameter_mm = nums[7] * len;
      break;
    case FeatureType::Ellipse:
      g.direction = vec(3);
      g.slot_axis = vec(6);
      g.diameter_mm = nums[9] * len;
      g.minor_diameter_mm = nums[10] * len;
      break;
  }
  if (g.direction.norm() < 1e-12) return vm.fail(in.span, "the direction vector i,j,k is zero");
  // Sizes the compiler could not check (computed: a variable never assigned is 0).
  const bool diameter = g.type == FeatureType::Circle || g.type == FeatureType::Arc || g.type == FeatureType::Sphere ||
                        g.type == FeatureType::Cylinder || g.type == FeatureType::Torus ||
                        g.type == FeatureType::Ellipse;
  if (diameter && !(g.diameter_mm > 0))
    return vm.fail(in.span, fmt::format("the {} of F({}) is {}: it must be positive (a variable never assigned?)",
                                        g.type == FeatureType::Arc ? "radius" : "diameter", vm.name_of(in),
                                        g.type == FeatureType::Arc ? g.diameter_mm / 2 : g.diameter_mm));
  if (g.type == FeatureType::ParallelPlanes && !(g.width_mm > 0))
    return vm.fail(in.span, fmt::format("the width of F({}) is {}: it must be positive (a variable never assigned?)",
                                        vm.name_of(in), g.width_mm));
  if (g.type == FeatureType::ClosedSlot) {
    // Computed numbers get the compiler's checks here (compile/definitions.cpp).
    if (g.slot_axis.norm() < 1e-12) return vm.fail(in.span, "the long axis i2,j2,k2 is zero");
    const Vec3 n = g.direction.normalized();
    if (std::abs(n.dot(g.slot_axis.normalized())) > 1e-3)
      return vm.fail(in.span, "the long axis i2,j2,k2 is not perpendicular to the normal i1,j1,k1");
    if (!(g.width_mm > 0) || !(g.length_mm > 0))
      return vm.fail(in.span, "the length and width of a CPARLN must be positive");
    if (g.slot_ends == runtime::SlotEnds::Round && g.width_mm >= g.length_mm)
      return vm.fail(
          in.span, "the width of a ROUND CPARLN must be less than its length (its ends are semicircles of the width)");
    g.slot_axis = (g.slot_axis - g.slot_axis.dot(n) * n).normalized();  // within the rounding of the program's numbers
  }
  if (g.type == FeatureType::Ellipse) {
    // Computed numbers get the compiler's checks here (compile/definitions.cpp).
    const Vec3 n = g.direction.normalized();
    if (g.slot_axis.norm() < 1e-12) return vm.fail(in.span, "the major axis i2,j2,k2 is zero");
    if (std::abs(n.dot(g.slot_axis.normalized())) > 1e-3)
      return vm.fail(in.span, "the major axis i2,j2,k2 is not perpendicular to the normal i1,j1,k1");
    if (!(g.minor_diameter_mm > 0 && g.minor_diameter_mm <= g.diameter_mm))
      return vm.fail(in.span, "an ELLIPS's minor diameter must be positive and not more than its major diameter");
    g.slot_axis = (g.slot_axis - g.slot_axis.dot(n) * n).normalized();
  }
  if (g.type == FeatureType::Torus && !(g.minor_diameter_mm > 0 && g.minor_diameter_mm < g.diameter_mm))
    return vm.fail(in.span, "a TORUS's tube diameter (mindiam) must be positive and less than its major diameter");
  if (g.type == FeatureType::Line && g.normal2.norm() < 1e-12) g.normal2 = any_perpendicular(g.direction);
  // count 1: FA(l)=FEAT/..., a stated actual (a DMIS output file's line).
  const auto r = in.count == 1 ? vm.m_runtime.define_reported_actual(vm.name_of(in), g, in.span)
                               : vm.m_runtime.define_feature(vm.name_of(in), g, in.span);
  if (!r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::ToleranceDef
ExecStatus Execute::tolerance_def(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  const double deg = degrees(vm);
  const double len = vm.m_length_mm;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  runtime::ToleranceSpec t;
  t.label = vm.name_of(in);
  t.defined_at = in.span;
  t.kind = std::get<ir::TolerancePayload>(in.payload).kind;
  for (const auto& word : words(in)) {  // the modifiers
    if (word == "3D") t.three_d = true;
    if (word == "LONG") t.long_side = true;  // TOL/WIDTH,lo,hi,LONG
    if (word == "MMC") t.condition = runtime::MaterialCondition::Mmc;
    if (word == "LMC") t.condition = runtime::MaterialCondition::Lmc;
    if (word == "XAXIS") t.axis = runtime::DistanceAxis::XAxis;
    if (word == "YAXIS") t.axis = runtime::DistanceAxis::YAxis;
    if (word == "ZAXIS") t.axis = runtime::DistanceAxis::ZAxis;
    if (word == "RADIUS") t.polar = runtime::PolarCoordinate::Radius;  // TOL/CORTOL,RADIUS|ANGLE,lo,up
    if (word == "ANGLE") t.polar = runtime::PolarCoordinate::Angle;
    if (word == "LIMIT") t.limits = true;  // TOL/DISTB|DISTWRT,LIMIT,lolim,uplim,...
    if (word == "MINIM") t.extent = runtime::DistanceExtent::Minimum;
    if (word == "MAXIM") t.extent = runtime::DistanceExtent::Maximum;
    // TOL/DIAM|RAD,lo,up,AVG|MAX|MIN (DMIS 5.x): the least-squares size, or the largest or smallest.
    const bool size = t.kind == runtime::ToleranceKind::Diam || t.kind == runtime::ToleranceKind::Rad;
    if (size && word == "MAX") t.extent = runtime::DistanceExtent::Maximum;
    if (size && word == "MIN") t.extent = runtime::DistanceExtent::Minimum;
    if (size && word == "DIAMLP") t.two_point_size = true;  // RationalDMIS: ISO 14405-1's LP
  }
  bool feature_tier = false;  // COMPOS: after FEATUR, the modifier and datums are the second tier's
  for (const auto& o : in.operands) {
    if (o.kind == Operand::Kind::Word && o.word == "FEATUR") feature_tier = true;
    if (feature_tier && o.kind == Operand::Kind::Word && (o.word == "MMC" || o.word == "LMC"))
      t.feature_condition = o.word == "MMC" ? runtime::MaterialCondition::Mmc : runtime::MaterialCondition::Lmc;
    if (o.kind == Operand::Kind::Word && (o.word == "DATUM-MMC" || o.word == "DATUM-LMC") &&
        !t.datum_conditions.empty())
      t.datum_conditions.back() =
          o.word == "DATUM-MMC" ? runtime::MaterialCondition::Mmc : runtime::MaterialCondition::Lmc;
    if (o.kind != Operand::Kind::Label) continue;
    if (o.label.prefix == "F" || o.label.prefix == "FA") {
      t.reference_feature = vm.label_name(o.label);  // DISTWRT, ANGWRT
    } else if (feature_tier) {
      t.feature_datums.push_back(vm.label_name(o.label));
    } else {
      t.datums.push_back(vm.label_name(o.label));
      t.datum_conditions.push_back(runtime::MaterialCondition::Rfs);
    }
  }
  if (t.kind == runtime::ToleranceKind::Compos) {
    // The PATERN tier's modifier is the one before FEATUR.
    t.condition = runtime::MaterialCondition::Rfs;
    for (const auto& o : in.operands) {
      if (o.kind == Operand::Kind::Word && o.word == "FEATUR") break;
      if (o.kind == Operand::Kind::Word && (o.word == "MMC" || o.word == "LMC"))
        t.condition = o.word == "MMC" ? runtime::MaterialCondition::Mmc : runtime::MaterialCondition::Lmc;
    }
  }
  using K = runtime::ToleranceKind;
  switch (t.kind) {
    case K::Profs:
    case K::Profl:
    case K::Profp:
      if (nums.size() == 1) {  // one number: a zone of that width centred on the profile (the compiler warned)
        if (nums[0] < 0) return vm.fail(in.span, "a tolerance zone must not be negative");
        t.lower = -nums[0] / 2 * len;
        t.upper = nums[0] / 2 * len;
        break;
      }
      t.lower = nums[0] * len;
      t.upper = nums[1] * len;
      break;
    case K::Diam:
    case K::Width:
      t.lower = nums[0] * len;
      t.upper = nums[1] * len;
      break;
    case K::Rad:
      t.lower = nums[0] * len;
      t.upper = nums[1] * len;
      break;
    case K::DistB:
    case K::DistWrt:
      if (t.limits) {  // the limits' middle is the nominal the deviations are reported from
        if (nums[0] > nums[1])
          return vm.fail(in.span, fmt::format("the lower limit {} is above the upper limit {}", nums[0], nums[1]));
        t.nominal = (nums[0] + nums[1]) / 2 * len;
        t.lower = nums[0] * len - t.nominal;
        t.upper = nums[1] * len - t.nominal;
      } else {
        t.nominal = nums[0] * len;
        t.lower = nums[1] * len;
        t.upper = nums[2] * len;
      }
      break;
    case K::Cortol: {
      const double unit = t.polar == runtime::PolarCoordinate::Angle ? deg : len;
      t.lower = nums[0] * unit;
      t.upper = nums[1] * unit;
      break;
    }
    case K::AngWrt:
    case K::Anglb:
      t.nominal = nums[0] * deg;
      t.lower = nums[1] * deg;
      t.upper = nums[2] * deg;
      break;
    case K::Anglr: {  // the zone and the basic angle in either order: the angle is the larger (docs/tolerances.md)
      const bool angle_first = std::abs(nums[0]) >= std::abs(nums[1]);
      const double zone = angle_first ? nums[1] : nums[0];
      if (zone < 0) return vm.fail(in.span, "a tolerance zone must not be negative");
      t.zone = zone * len;
      t.nominal = (angle_first ? nums[0] : nums[1]) * deg;
      break;
    }
    case K::Angl:
      t.lower = nums[0] * deg;
      t.upper = nums[1] * deg;
      break;
    case K::Compos:
      t.zone = nums[0] * len;
      t.feature_zone = nums[1] * len;
      break;
    case K::Flat:
    case K::Strght:
      t.zone = nums[0] * len;
      if (nums.size() >= 3) {  // FLAT,t,tu,a[,b] and STRGHT,t,tu,l: a zone per unit area or length
        t.unit_zone = nums[1] * len;
        t.unit_length = nums[2] * len;
        t.unit_width = nums.size() >= 4 ? nums[3] * len : t.unit_length;
        if (!(t.unit_zone >= 0 && t.unit_length > 0 && t.unit_width > 0))
          return vm.fail(in.span, "a zone per unit must not be negative, and the unit's sides must be positive");
      }
      break;
    default: t.zone = nums[0] * len; break;
  }
  if (auto r = vm.m_runtime.define_tolerance(t); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::SensorDef
ExecStatus Execute::sensor_def(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  std::vector<double> nums;
  const double len = vm.m_length_mm;
  if (auto e = numbers(vm, in, nums)) return vm.fail(in.span, *e);
  const auto w = words(in);
  const bool polar = std::find(w.begin(), w.end(), "POL") != w.end();
  runtime::SensorDefinition s;
  s.label = vm.name_of(in);
  s.ball_diameter_mm = nums.back() * len;
  // INDEX,POL: tilt, rotation, i, j, k, length, diameter; CART: x, y, z, i, j, k, diameter.
  if (nums.size() >= 7) {
    s.direction = Vec3(nums[nums.size() - (polar ? 5 : 4)], nums[nums.size() - (polar ? 4 : 3)],
                       nums[nums.size() - (polar ? 3 : 2)]);
    if (polar) s.length_mm = nums[nums.size() - 2] * len;
  }
  if (s.direction.norm() < 1e-12) s.direction = -Vec3::UnitZ();
  if (auto r = vm.m_runtime.define_sensor(s, in.span); !r) return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::DatDef
ExecStatus Execute::datdef(Interpreter& vm, const ir::Instruction& in, CallFrame&) {
  if (auto r = vm.m_runtime.define_datum(feature_ref(vm, in.operands[0].label), vm.label_name(in.operands[1].label),
                                         in.span);
      !r)
    return vm.from_runtime(r.error());
  return ExecStatus::Running;
}

// Op::Declare
ExecStatus Execute::declare(Interpreter& vm, const ir::Instruction& in, CallFrame& frame) {
  const ValueType t = *declared_type(in.operands[0].word);  // the compiler admitted only DECL types
  for (std::size_t i = 0; i < in.names.size(); ++i) {
    const auto size = static_cast<std::size_t>(std::max(1.0, in.operands[i + 1].expr.value.number));
    auto& store = frame.kind == CallFrame::Kind::Macro ? frame.locals : vm.m_globals;
    store[in.names[i]] = std::vector<Value>(size, default_value(t));
    vm.m_types[in.names[i]] = t;
    if (const auto& dims = in.operands[i + 1].expr.args; dims.size() > 1) {
      auto& kept = vm.m_dims[in.names[i]];
      kept.clear();
      for (const auto& d : dims) kept.push_back(static_cast<std::size_t>(d.value.number));
    } else {
      vm.m_dims.erase(in.names[i]);
    }
    if (in.operands[0].word == "INTGR")
      vm.m_intgr.insert(in.names[i]);
    else
      vm.m_intgr.erase(in.names[i]);
  }
  return ExecStatus::Running;
}

}  // namespace metron::interpreter::detail
