// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/interpreter/interpreter.hpp"

#include <cmath>

#include <fmt/format.h>

#include "metron/stdlib/builtins.hpp"

namespace metron::interpreter {
namespace {

using ir::Op;
using ir::Operand;
using runtime::FeatureType;

constexpr double pi = 3.14159265358979323846;

std::optional<FeatureType> feature_type(const std::string& w) {
  static const std::map<std::string, FeatureType> types = {
      {"POINT", FeatureType::Point}, {"PLANE", FeatureType::Plane},   {"LINE", FeatureType::Line},
      {"CIRCLE", FeatureType::Circle}, {"ARC", FeatureType::Arc},     {"SPHERE", FeatureType::Sphere},
      {"CYLNDR", FeatureType::Cylinder}, {"CONE", FeatureType::Cone}};
  auto it = types.find(w);
  if (it == types.end()) return std::nullopt;
  return it->second;
}

std::optional<runtime::Axis> axis_of(const std::string& w) {
  switch (w.empty() ? ' ' : w[0]) {
    case 'X': return runtime::Axis::X;
    case 'Y': return runtime::Axis::Y;
    case 'Z': return runtime::Axis::Z;
    default: return std::nullopt;
  }
}

// The numbers of a DMIS output statement FA(x)=FEAT/..., by parameter position (1-based; words
// are NaN), so OBTAIN/FA(x),n reads what the output file would show.
std::vector<double> output_parameters(const runtime::Geometry& g) {
  const double w = NAN;
  const Vec3& p = g.position;
  const Vec3& d = g.direction;
  switch (g.type) {
    case FeatureType::Point:
    case FeatureType::Plane: return {w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z()};
    case FeatureType::Line: return {w, w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z(), g.normal2.x(), g.normal2.y(), g.normal2.z()};
    case FeatureType::Circle: return {w, w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z(), g.diameter_mm};
    case FeatureType::Arc: return {w, w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z(), g.diameter_mm / 2, g.start_angle_deg, g.included_angle_deg};
    case FeatureType::Sphere: return {w, w, w, p.x(), p.y(), p.z(), g.diameter_mm};
    case FeatureType::Cylinder: return {w, w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z(), g.diameter_mm, g.length_mm};
    case FeatureType::Cone: return {w, w, w, p.x(), p.y(), p.z(), d.x(), d.y(), d.z(), g.apex_angle_deg};
  }
  return {};
}

Value default_value(ValueType t) {
  switch (t) {
    case ValueType::Integer: return Value::integer(0);
    case ValueType::Bool: return Value::boolean_value(false);
    case ValueType::String: return Value::string("");
    default: return Value::real(0);
  }
}

}  // namespace

Interpreter::Interpreter(const ir::Module& module, runtime::MeasurementRuntime& runtime, const SourceManager& sources,
                         DiagnosticSink& sink)
    : m_module(module), m_runtime(runtime), m_sources(sources), m_sink(sink) {}

void Interpreter::start(std::size_t unit) {
  Frame f;
  f.kind = Frame::Kind::Unit;
  f.index = unit;
  m_frames.push_back(std::move(f));
  m_finished = false;
}

const std::vector<ir::Instruction>& Interpreter::code_of(const Frame& f) const {
  return f.kind == Frame::Kind::Unit ? m_module.units.at(f.index).code : m_module.macros.at(f.index).code;
}

const ir::Instruction* Interpreter::current() const {
  if (m_frames.empty()) return nullptr;
  const Frame& f = m_frames.back();
  const auto& code = code_of(f);
  return f.pc < code.size() ? &code[f.pc] : nullptr;
}

ExecStatus Interpreter::run() {
  for (;;) {
    const ExecStatus s = step();
    if (s != ExecStatus::Running) return s;
  }
}

ExecStatus Interpreter::step() {
  if (m_finished) return ExecStatus::Finished;
  while (!m_frames.empty() && m_frames.back().pc >= code_of(m_frames.back()).size()) {
    m_frames.pop_back();  // a unit ran off its end: return to the caller
  }
  if (m_frames.empty()) {
    m_finished = true;
    return ExecStatus::Finished;
  }
  Frame& frame = m_frames.back();
  const ir::Instruction& in = code_of(frame)[frame.pc];
  return execute(in, frame);
}

ExecStatus Interpreter::fail(Span span, std::string message) {
  m_sink.error("run.error", span, std::move(message));
  return ExecStatus::Error;
}

ExecStatus Interpreter::from_runtime(const runtime::RuntimeError& e) {
  if (e.kind == runtime::RuntimeError::Kind::Fault) return ExecStatus::Faulted;
  return fail(e.span, e.message);
}

std::vector<Value>* Interpreter::find_variable(const std::string& name) {
  for (auto it = m_frames.rbegin(); it != m_frames.rend(); ++it) {
    if (auto v = it->locals.find(name); v != it->locals.end()) return &v->second;
    if (it->kind == Frame::Kind::Macro) break;  // macros see their locals and the globals only
  }
  auto g = m_globals.find(name);
  return g == m_globals.end() ? nullptr : &g->second;
}

std::optional<Value> Interpreter::variable(const std::string& name) const {
  auto* self = const_cast<Interpreter*>(this);
  auto* v = self->find_variable(name);
  if (!v || v->empty()) return std::nullopt;
  return v->front();
}

bool Interpreter::set_variable(const std::string& name, const Value& value) {
  auto* v = find_variable(name);
  if (!v || v->empty()) return false;
  Value stored = value;
  if (auto t = m_types.find(name); t != m_types.end()) {
    if (t->second == ValueType::Integer && stored.is_number()) stored = Value::integer(std::trunc(stored.number));
    else if (t->second == ValueType::Real && stored.is_number()) stored = Value::real(stored.number);
  }
  v->front() = stored;
  return true;
}

std::string Interpreter::label_name(const ir::LabelOperand& l) const {
  if (!l.param || m_frames.empty()) return l.name;
  // A macro parameter standing for a label: the caller passed a label or a name.
  for (auto it = m_frames.rbegin(); it != m_frames.rend(); ++it) {
    if (auto v = it->locals.find(l.name); v != it->locals.end() && !v->second.empty()) {
      const Value& a = v->second.front();
      if (a.type == ValueType::Label || a.type == ValueType::String) return a.text;
      return a.to_display();
    }
    if (it->kind == Frame::Kind::Macro) break;
  }
  return l.name;
}

std::string Interpreter::name_of(const ir::Instruction& in) const {
  return in.name_is_param ? label_name({"", in.name, 0, in.span}) : in.name;
}

tl::expected<double, std::string> Interpreter::number(const ir::Expr& e) {
  auto v = evaluate(e);
  if (!v) return tl::unexpected(v.error());
  if (!v->is_number()) return tl::unexpected(fmt::format("expected a number, got {}", to_string(v->type)));
  return v->number;
}

tl::expected<Value, std::string> Interpreter::evaluate(const ir::Expr& e) {
  switch (e.op) {
    case ir::ExprOp::Constant:
      if (e.value.type == ValueType::Label) return Value::label(e.label.prefix, label_name(e.label));
      return e.value;
    case ir::ExprOp::Variable: {
      auto* v = find_variable(e.name);
      if (!v || v->empty()) return tl::unexpected(fmt::format("variable {} has no value here", e.name));
      return v->front();
    }
    case ir::ExprOp::Element: {
      auto* v = find_variable(e.name);
      if (!v) return tl::unexpected(fmt::format("array {} has no value here", e.name));
      auto i = number(e.args.at(0));
      if (!i) return tl::unexpected(i.error());
      const auto k = static_cast<long>(std::llround(*i));
      if (k < 1 || k > static_cast<long>(v->size()))
        return tl::unexpected(fmt::format("index {} is outside {}[1..{}]", k, e.name, v->size()));
      return (*v)[static_cast<std::size_t>(k - 1)];
    }
    case ir::ExprOp::Call: {
      const Builtin* fn = find_builtin(e.name);
      if (!fn) return tl::unexpected(fmt::format("unknown function {}", e.name));
      std::vector<Value> args;
      for (const auto& a : e.args) {
        auto v = evaluate(a);
        if (!v) return v;
        args.push_back(*v);
      }
      return call_builtin(*fn, args, m_degrees);
    }
    case ir::ExprOp::Obtain: {
      auto index = number(e.args.at(0));
      if (!index) return tl::unexpected(index.error());
      auto g = m_runtime.feature_geometry({label_name(e.label), e.label.prefix == "FA"}, e.span);
      if (!g) return tl::unexpected(g.error().message);
      const auto params = output_parameters(*g);
      const auto k = static_cast<long>(std::llround(*index));
      if (k < 1 || k > static_cast<long>(params.size()) || std::isnan(params[static_cast<std::size_t>(k - 1)]))
        return tl::unexpected(fmt::format("OBTAIN index {} is not a number of {}({})", k, e.label.prefix, label_name(e.label)));
      double v = params[static_cast<std::size_t>(k - 1)];
      // Lengths go back to program units; direction cosines and angles do not.
      const bool angle = (g->type == FeatureType::Cone && k == 10) || (g->type == FeatureType::Arc && k >= 11);
      const bool cosine = (k >= 6 && k <= 8 && (g->type == FeatureType::Point || g->type == FeatureType::Plane)) ||
                          (k >= 7 && k <= 9 && g->type != FeatureType::Sphere && g->type != FeatureType::Point && g->type != FeatureType::Plane) ||
                          (k >= 10 && g->type == FeatureType::Line);
      if (!angle && !cosine) v /= m_length_mm;
      return Value::real(v);
    }
    case ir::ExprOp::Unary: {
      auto v = evaluate(e.args.at(0));
      if (!v) return v;
      if (e.name == ".NOT.") {
        if (v->type != ValueType::Bool) return tl::unexpected(std::string(".NOT. needs a BOOL"));
        return Value::boolean_value(!v->boolean);
      }
      if (!v->is_number()) return tl::unexpected(fmt::format("unary {} needs a number", e.name));
      if (e.name == "-") v->number = -v->number;
      return v;
    }
    case ir::ExprOp::Binary: {
      auto a = evaluate(e.args.at(0));
      if (!a) return a;
      const std::string& op = e.name;
      if (op == ".AND." || op == ".OR.") {
        if (a->type != ValueType::Bool) return tl::unexpected(op + " needs BOOL operands");
        if (op == ".AND." && !a->boolean) return Value::boolean_value(false);  // short-circuit
        if (op == ".OR." && a->boolean) return Value::boolean_value(true);
        auto b = evaluate(e.args.at(1));
        if (!b) return b;
        if (b->type != ValueType::Bool) return tl::unexpected(op + " needs BOOL operands");
        return Value::boolean_value(b->boolean);
      }
      auto b = evaluate(e.args.at(1));
      if (!b) return b;
      if (op[0] == '.') {
        int c = 0;
        if (a->is_number() && b->is_number()) c = a->number < b->number ? -1 : (a->number > b->number ? 1 : 0);
        else if (a->type == ValueType::String && b->type == ValueType::String) c = a->text.compare(b->text) < 0 ? -1 : (a->text == b->text ? 0 : 1);
        else if (a->type == ValueType::Bool && b->type == ValueType::Bool) c = a->boolean == b->boolean ? 0 : 1;
        else return tl::unexpected(fmt::format("{} compares a {} with a {}", op, to_string(a->type), to_string(b->type)));
        if (op == ".EQ.") return Value::boolean_value(c == 0);
        if (op == ".NE.") return Value::boolean_value(c != 0);
        if (op == ".LT.") return Value::boolean_value(c < 0);
        if (op == ".LE.") return Value::boolean_value(c <= 0);
        if (op == ".GT.") return Value::boolean_value(c > 0);
        if (op == ".GE.") return Value::boolean_value(c >= 0);
        return tl::unexpected("unknown operator " + op);
      }
      if (!a->is_number() || !b->is_number()) return tl::unexpected(fmt::format("'{}' needs numbers", op));
      const bool integer = a->type == ValueType::Integer && b->type == ValueType::Integer;
      double r = 0;
      if (op == "+") r = a->number + b->number;
      else if (op == "-") r = a->number - b->number;
      else if (op == "*") r = a->number * b->number;
      else if (op == "/") {
        if (b->number == 0) return tl::unexpected(std::string("division by zero"));
        r = a->number / b->number;
      } else if (op == "**") r = std::pow(a->number, b->number);
      else return tl::unexpected("unknown operator " + op);
      if (!std::isfinite(r)) return tl::unexpected(fmt::format("'{}' gives a number that is not finite", op));
      return integer && op != "/" && op != "**" ? Value::integer(r) : Value::real(r);
    }
  }
  return tl::unexpected(std::string("bad expression"));
}

ExecStatus Interpreter::execute(const ir::Instruction& in, Frame& frame) {
  const std::size_t pc = frame.pc;
  ++frame.pc;
  std::vector<double> nums;
  // Evaluates every Expr operand to a number, in order.
  const auto numbers = [&]() -> std::optional<std::string> {
    for (const auto& o : in.operands)
      if (o.kind == Operand::Kind::Expr) {
        auto v = number(o.expr);
        if (!v) return v.error() + " (in " + ir::to_string(o.expr) + ")";
        nums.push_back(*v);
      }
    return std::nullopt;
  };
  const auto words = [&]() {
    std::vector<std::string> w;
    for (const auto& o : in.operands)
      if (o.kind == Operand::Kind::Word) w.push_back(o.word);
    return w;
  };
  const double deg = m_degrees ? 1.0 : 180.0 / pi;  // program angle -> degrees
  const double len = m_length_mm;
  const auto feature_ref = [&](const ir::LabelOperand& l) { return runtime::FeatureRef{label_name(l), l.prefix == "FA"}; };

  switch (in.op) {
    case Op::Nop:
    case Op::JumpLabel:
      return ExecStatus::Running;
    case Op::System: {
      const std::string& arg = in.operands.empty() ? std::string() : in.operands[0].word;
      auto r = in.name == "CHARACTERISE"
                   ? m_runtime.characterise_machine(arg.empty() ? std::nullopt : std::optional<std::string>(arg), in.span)
                   : m_runtime.use_characterisation(arg, in.span);
      if (!r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::End:
      if (frame.kind == Frame::Kind::Unit && frame.call_site.valid()) {
        m_frames.pop_back();  // ENDFIL of a file called with CALL/EXTERN: back to the caller
        return ExecStatus::Running;
      }
      m_finished = true;
      return ExecStatus::Finished;
    case Op::Units: {
      static const std::map<std::string, double> lengths = {{"MM", 1.0}, {"INCH", 25.4}, {"CM", 10.0}, {"M", 1000.0}, {"FEET", 304.8}};
      m_length_mm = lengths.at(in.operands[0].word);
      if (in.operands.size() > 1) m_degrees = in.operands[1].word != "ANGRAD";
      return ExecStatus::Running;
    }
    case Op::Mode: {
      const std::string& w = in.operands[0].word;
      m_runtime.set_mode(w == "AUTO" ? runtime::Mode::Auto : w == "MAN" ? runtime::Mode::Man : runtime::Mode::ProgMan);
      return ExecStatus::Running;
    }
    case Op::Text: {
      auto v = evaluate(in.operands[1].expr);
      if (!v) return fail(in.span, v.error());
      m_runtime.text(in.operands[0].word, v->to_display());
      return ExecStatus::Running;
    }
    case Op::FeatureDef: {
      if (auto e = numbers()) return fail(in.span, *e);
      const auto w = words();
      runtime::Geometry g;
      g.type = *feature_type(w[0]);
      std::size_t k = 1;
      if (k < w.size() && (w[k] == "INNER" || w[k] == "OUTER")) g.side = w[k++] == "INNER" ? runtime::Side::Inner : runtime::Side::Outer;
      if (k < w.size() && (w[k] == "BND" || w[k] == "UNBND")) g.bounded = w[k++] == "BND";
      const bool polar = k < w.size() && w[k] == "POL";
      const auto point = [&](std::size_t i) {
        if (polar) {
          const double a = nums[i + 1] * deg * pi / 180.0;
          return Vec3(nums[i] * len * std::cos(a), nums[i] * len * std::sin(a), nums[i + 2] * len);
        }
        return Vec3(nums[i] * len, nums[i + 1] * len, nums[i + 2] * len);
      };
      const auto vec = [&](std::size_t i) { return Vec3(nums[i], nums[i + 1], nums[i + 2]); };
      g.position = point(0);
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
        case FeatureType::Circle: g.direction = vec(3); g.diameter_mm = nums[6] * len; break;
        case FeatureType::Arc:
          g.direction = vec(3);
          g.diameter_mm = 2 * nums[6] * len;
          g.start_angle_deg = nums[7] * deg;
          g.included_angle_deg = nums[8] * deg;
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
      }
      if (g.direction.norm() < 1e-12) return fail(in.span, "the direction vector i,j,k is zero");
      if (g.type == FeatureType::Line && g.normal2.norm() < 1e-12) g.normal2 = any_perpendicular(g.direction);
      if (auto r = m_runtime.define_feature(name_of(in), g, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::ToleranceDef: {
      if (auto e = numbers()) return fail(in.span, *e);
      runtime::ToleranceSpec t;
      t.label = name_of(in);
      t.defined_at = in.span;
      const auto w = words();
      static const std::map<std::string, runtime::ToleranceKind> kinds = {
          {"DIAM", runtime::ToleranceKind::Diam},     {"RAD", runtime::ToleranceKind::Rad},
          {"DISTB", runtime::ToleranceKind::DistB},   {"POS", runtime::ToleranceKind::Pos},
          {"FLAT", runtime::ToleranceKind::Flat},     {"CIRLTY", runtime::ToleranceKind::Cirlty},
          {"CYLCTY", runtime::ToleranceKind::Cylcty}, {"SPHCTY", runtime::ToleranceKind::Sphcty},
          {"STRGHT", runtime::ToleranceKind::Strght}, {"PERP", runtime::ToleranceKind::Perp},
          {"PARLEL", runtime::ToleranceKind::Parlel}, {"ANGLB", runtime::ToleranceKind::Anglb},
          {"PROFS", runtime::ToleranceKind::Profs}};
      t.kind = kinds.at(w[0]);
      for (const auto& word : w) {
        if (word == "3D") t.three_d = true;
        if (word == "MMC") t.condition = runtime::MaterialCondition::Mmc;
        if (word == "LMC") t.condition = runtime::MaterialCondition::Lmc;
        if (word == "XAXIS") t.axis = runtime::DistanceAxis::XAxis;
        if (word == "YAXIS") t.axis = runtime::DistanceAxis::YAxis;
        if (word == "ZAXIS") t.axis = runtime::DistanceAxis::ZAxis;
      }
      for (const auto& o : in.operands)
        if (o.kind == Operand::Kind::Label) t.datums.push_back(label_name(o.label));
      using K = runtime::ToleranceKind;
      switch (t.kind) {
        case K::Diam:
        case K::Profs: t.lower = nums[0] * len; t.upper = nums[1] * len; break;
        case K::Rad: t.lower = nums[0] * len; t.upper = nums[1] * len; break;
        case K::DistB: t.nominal = nums[0] * len; t.lower = nums[1] * len; t.upper = nums[2] * len; break;
        case K::Anglb: t.nominal = nums[0] * deg; t.lower = nums[1] * deg; t.upper = nums[2] * deg; break;
        default: t.zone = nums[0] * len; break;
      }
      if (auto r = m_runtime.define_tolerance(t); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::SensorDef: {
      if (auto e = numbers()) return fail(in.span, *e);
      const auto w = words();
      const bool polar = std::find(w.begin(), w.end(), "POL") != w.end();
      runtime::SensorDefinition s;
      s.label = in.name;
      s.ball_diameter_mm = nums.back() * len;
      // INDEX,POL: tilt, rotation, i, j, k, length, diameter; CART: x, y, z, i, j, k, diameter.
      if (nums.size() >= 7) {
        s.direction = Vec3(nums[nums.size() - (polar ? 5 : 4)], nums[nums.size() - (polar ? 4 : 3)], nums[nums.size() - (polar ? 3 : 2)]);
        if (polar) s.length_mm = nums[nums.size() - 2] * len;
      }
      if (s.direction.norm() < 1e-12) s.direction = -Vec3::UnitZ();
      if (auto r = m_runtime.define_sensor(s, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::SensorSelect:
      if (auto r = m_runtime.select_sensor(in.name, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::ProbeSet: {
      auto v = number(in.operands[1].expr);
      if (!v) return fail(in.span, v.error());
      auto& p = m_runtime.probe_settings();
      const std::string& w = in.operands[0].word;
      const double d = *v * len;
      if (w == "APPRCH") p.approach_mm = d, p.approach_explicit = true;
      else if (w == "RETRCT") p.retract_mm = d;
      else if (w == "SEARCH") p.search_mm = d;
      else if (w == "CLRSRF") p.clearance_mm = d;
      else if (w == "DEPTH") p.depth_mm = d;
      return ExecStatus::Running;
    }
    case Op::Feed: {
      auto v = number(in.operands[2].expr);
      if (!v) return fail(in.span, v.error());
      const std::string& kind = in.operands[0].word;
      const std::string& unit = in.operands[1].word;
      const auto state = m_runtime.machine().state();
      double mm_s = *v;
      if (unit == "MPM") mm_s = *v * 1000.0 / 60.0;
      else if (unit == "IPM") mm_s = *v * 25.4 / 60.0;
      else if (unit == "IPS") mm_s = *v * 25.4;
      else if (unit == "PCENT") mm_s = *v / 100.0 * (kind == "POSVEL" ? state.positioning_feed_mm_s : state.measuring_feed_mm_s);
      if (kind == "SCNVEL") {
        m_runtime.scan_settings().feed_mm_s = unit == "PCENT" ? *v / 100.0 * state.measuring_feed_mm_s : mm_s;
        return ExecStatus::Running;
      }
      auto r = kind == "POSVEL" ? m_runtime.set_feeds(mm_s, std::nullopt, in.span) : m_runtime.set_feeds(std::nullopt, mm_s, in.span);
      if (!r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Accel: {
      auto v = number(in.operands[2].expr);
      if (!v) return fail(in.span, v.error());
      const std::string& unit = in.operands[1].word;
      double a = *v;
      if (unit == "MPMM") a = *v * 1000.0 / 3600.0;
      else if (unit == "IPMM") a = *v * 25.4 / 3600.0;
      else if (unit == "IPSS") a = *v * 25.4;
      else if (unit == "PCENT") return ExecStatus::Running;  // relative to an unknown maximum: leave unchanged
      if (auto r = m_runtime.set_acceleration(a, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::GoTo: {
      if (auto e = numbers()) return fail(in.span, *e);
      const auto w = words();
      const bool incr = !w.empty() && w[0] == "INCR";
      const bool polar = !w.empty() && w[0] == "POL";
      const Vec3 from = m_block ? m_block_position : m_runtime.position_current();
      Vec3 target;
      if (incr) {
        const Vec3 d(nums[1], nums[2], nums[3]);
        if (d.norm() < 1e-12) return fail(in.span, "the GOTO/INCR direction is a zero vector");
        target = from + nums[0] * len * d.normalized();
      } else if (polar) {
        const double a = nums[1] * deg * pi / 180.0;
        target = Vec3(nums[0] * len * std::cos(a), nums[0] * len * std::sin(a), nums[2] * len);
      } else {
        target = Vec3(nums[0], nums[1], nums[2]) * len;
      }
      if (m_block) {
        m_block->steps.push_back({runtime::MeasStep::Kind::GoTo, target, std::nullopt, in.span, {}});
        m_block_position = target;
        return ExecStatus::Running;
      }
      if (auto r = m_runtime.go_to(target, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::MeasBegin: {
      auto n = number(in.operands[1].expr);
      if (!n) return fail(in.span, n.error());
      runtime::MeasBlock b;
      b.feature = name_of(in);
      b.type = *feature_type(in.operands[0].word);
      b.point_count = static_cast<int>(*n);
      b.span = in.span;
      m_block = b;
      m_block_position = m_runtime.position_current();
      return ExecStatus::Running;
    }
    case Op::PtMeas: {
      if (!m_block) return fail(in.span, "PTMEAS outside a MEAS block");
      if (auto e = numbers()) return fail(in.span, *e);
      const bool polar = in.operands[0].word == "POL";
      Vec3 p;
      if (polar) {
        const double a = nums[1] * deg * pi / 180.0;
        p = Vec3(nums[0] * len * std::cos(a), nums[0] * len * std::sin(a), nums[2] * len);
      } else {
        p = Vec3(nums[0], nums[1], nums[2]) * len;
      }
      std::optional<Vec3> n;
      if (nums.size() >= 6) n = Vec3(nums[3], nums[4], nums[5]);
      if (!in.operands.empty() && in.operands.back().kind == Operand::Kind::Label) {
        // RMEAS: relative to the actual of a reference feature: shift by its deviation.
        const auto ref = feature_ref(in.operands.back().label);
        auto actual = m_runtime.feature_geometry({ref.label, true}, in.span);
        auto nominal = m_runtime.feature_geometry({ref.label, false}, in.span);
        if (!actual) return from_runtime(actual.error());
        p += actual->position - nominal->position;
      }
      m_block->steps.push_back({runtime::MeasStep::Kind::PtMeas, p, n, in.span, {}});
      return ExecStatus::Running;
    }
    case Op::MeasEnd: {
      if (!m_block) return fail(in.span, "ENDMES without MEAS");
      runtime::MeasBlock b = std::move(*m_block);
      m_block.reset();
      if (auto r = m_runtime.measure(b); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Output: {
      std::vector<runtime::OutputItem> items;
      for (const auto& o : in.operands) {
        runtime::OutputItem item;
        if (o.label.prefix == "T" || o.label.prefix == "TA") {
          item.kind = runtime::OutputItem::Kind::Tolerance;
          item.tolerance = label_name(o.label);
        } else {
          item.feature = feature_ref(o.label);
        }
        items.push_back(item);
      }
      if (auto r = m_runtime.output(items, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::DatDef:
      if (auto r = m_runtime.define_datum(feature_ref(in.operands[0].label), label_name(in.operands[1].label), in.span); !r)
        return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::DatSet: {
      runtime::DatsetRequest req;
      for (const auto& o : in.operands) {
        if (o.kind == Operand::Kind::Word && o.word == "MCS") req.mcs = true;
        else if (o.kind == Operand::Kind::Label) req.clauses.push_back({label_name(o.label), std::nullopt, false, {}});
        else if (o.kind == Operand::Kind::Word && !req.clauses.empty()) {
          auto& c = req.clauses.back();
          const auto axis = axis_of(o.word);
          if (o.word.find("ORIG") != std::string::npos) c.origins.push_back(*axis);
          else {
            c.direction = axis;
            c.minus = o.word.find("MINUS") != std::string::npos;
          }
        }
      }
      if (auto r = m_runtime.datset(in.name, req, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Trans: {
      runtime::TransRequest req;
      for (std::size_t i = 0; i + 1 < in.operands.size(); i += 2) {
        const int k = static_cast<int>(*axis_of(in.operands[i].word));
        const Operand& v = in.operands[i + 1];
        if (v.kind == Operand::Kind::Label) {
          req.feature[k] = feature_ref(v.label);
        } else {
          auto x = number(v.expr);
          if (!x) return fail(in.span, x.error());
          req.value[k] = *x * len;
        }
      }
      if (auto r = m_runtime.trans(in.name, req, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Rotate: {
      runtime::RotateRequest req;
      req.about = *axis_of(in.operands[0].word);
      if (in.operands[1].kind == Operand::Kind::Label) {
        req.feature = feature_ref(in.operands[1].label);
        req.align = *axis_of(in.operands[2].word);
      } else {
        auto a = number(in.operands[1].expr);
        if (!a) return fail(in.span, a.error());
        req.angle_deg = *a * deg;
      }
      if (auto r = m_runtime.rotate(in.name, req, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Save:
      if (auto r = m_runtime.save(label_name(in.operands[0].label), in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::Recall:
      if (auto r = m_runtime.recall(label_name(in.operands[0].label), in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::Construct: {
      const std::string& m = in.operands[1].word;
      const auto method = m == "BF" ? runtime::ConstructMethod::BestFit
                          : m == "INTOF" ? runtime::ConstructMethod::Intersection
                          : m == "MIDPT" ? runtime::ConstructMethod::Midpoint
                                         : runtime::ConstructMethod::Projection;
      std::vector<runtime::FeatureRef> sources;
      for (std::size_t i = 2; i < in.operands.size(); ++i) sources.push_back(feature_ref(in.operands[i].label));
      if (auto r = m_runtime.construct(name_of(in), *feature_type(in.operands[0].word), method, sources, in.span); !r)
        return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::Declare: {
      static const std::map<std::string, ValueType> types = {{"INTGR", ValueType::Integer}, {"LONG", ValueType::Integer},
                                                             {"REAL", ValueType::Real},    {"DOUBLE", ValueType::Real},
                                                             {"BOOL", ValueType::Bool},    {"CHAR", ValueType::String}};
      const ValueType t = types.at(in.operands[0].word);
      for (std::size_t i = 0; i < in.names.size(); ++i) {
        const auto size = static_cast<std::size_t>(std::max(1.0, in.operands[i + 1].expr.value.number));
        auto& store = frame.kind == Frame::Kind::Macro ? frame.locals : m_globals;
        store[in.names[i]] = std::vector<Value>(size, default_value(t));
        m_types[in.names[i]] = t;
      }
      return ExecStatus::Running;
    }
    case Op::Assign: {
      auto value = evaluate(in.operands.back().expr);
      if (!value) return fail(in.span, value.error());
      auto* var = find_variable(in.name);
      if (!var) return fail(in.span, fmt::format("variable {} has no storage here", in.name));
      std::size_t index = 0;
      if (in.count > 0) {
        auto k = number(in.operands[0].expr);
        if (!k) return fail(in.span, k.error());
        const auto i = static_cast<long>(std::llround(*k));
        if (i < 1 || i > static_cast<long>(var->size()))
          return fail(in.span, fmt::format("index {} is outside {}[1..{}]", i, in.name, var->size()));
        index = static_cast<std::size_t>(i - 1);
      }
      Value stored = *value;
      if (auto t = m_types.find(in.name); t != m_types.end()) {
        if (t->second == ValueType::Integer && stored.is_number()) stored = Value::integer(std::trunc(stored.number));
        else if (t->second == ValueType::Real && stored.is_number()) stored = Value::real(stored.number);
      }
      (*var)[index] = stored;
      return ExecStatus::Running;
    }
    case Op::Jump:
      frame.pc = static_cast<std::size_t>(in.target);
      return ExecStatus::Running;
    case Op::JumpIfFalse: {
      auto c = evaluate(in.operands[0].expr);
      if (!c) return fail(in.span, c.error());
      if (c->type != ValueType::Bool) return fail(in.span, "the IF condition is not BOOL");
      if (!c->boolean) frame.pc = static_cast<std::size_t>(in.target);
      return ExecStatus::Running;
    }
    case Op::DoInit: {
      if (auto e = numbers()) return fail(in.span, *e);
      const double step = nums.size() > 2 ? nums[2] : 1.0;
      if (step == 0) return fail(in.span, "the DO step is zero");
      if (!set_variable(in.name, Value::real(nums[0]))) return fail(in.span, fmt::format("DO variable {} has no storage", in.name));
      frame.loops[pc] = {nums[1], step};
      if (step > 0 ? nums[0] > nums[1] : nums[0] < nums[1]) frame.pc = static_cast<std::size_t>(in.target);
      return ExecStatus::Running;
    }
    case Op::DoNext: {
      const auto [end, step] = frame.loops.at(static_cast<std::size_t>(in.target - 1));
      auto v = variable(in.name);
      if (!v) return fail(in.span, fmt::format("DO variable {} has no value", in.name));
      const double next = v->number + step;
      set_variable(in.name, Value::real(next));
      if (step > 0 ? next <= end : next >= end) frame.pc = static_cast<std::size_t>(in.target);
      return ExecStatus::Running;
    }
    case Op::CallMacro: {
      const auto& macro = m_module.macros.at(static_cast<std::size_t>(in.target));
      Frame f;
      f.kind = Frame::Kind::Macro;
      f.index = static_cast<std::size_t>(in.target);
      f.call_site = in.span;
      for (std::size_t i = 0; i < macro.params.size(); ++i) {
        auto v = evaluate(in.operands.at(i).expr);
        if (!v) return fail(in.span, v.error());
        f.locals[macro.params[i]] = {*v};
      }
      if (m_frames.size() > 256) return fail(in.span, "macro calls nest deeper than 256: is a macro calling itself?");
      m_frames.push_back(std::move(f));
      return ExecStatus::Running;
    }
    case Op::Return:
      m_frames.pop_back();
      return ExecStatus::Running;
    case Op::CallUnit: {
      Frame f;
      f.kind = Frame::Kind::Unit;
      f.index = static_cast<std::size_t>(in.target);
      f.call_site = in.span;
      m_frames.push_back(std::move(f));
      return ExecStatus::Running;
    }
    case Op::DeviceDef: {
      std::string path;
      if (in.operands.size() > 1) {
        auto v = evaluate(in.operands[1].expr);
        if (!v) return fail(in.span, v.error());
        path = v->to_display();
      }
      if (auto r = m_runtime.define_device(in.name, path, in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    }
    case Op::DeviceOpen:
      if (auto r = m_runtime.open_device(label_name(in.operands[0].label), in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::DeviceClose:
      if (auto r = m_runtime.close_device(label_name(in.operands[0].label), in.span); !r) return from_runtime(r.error());
      return ExecStatus::Running;
    case Op::PathDef:
    case Op::ScanMode:
    case Op::ScanSet:
    case Op::PaMeas:
      return execute_scan(in);
  }
  return fail(in.span, "unknown instruction");
}

}  // namespace metron::interpreter
