// SPDX-License-Identifier: GPL-3.0-or-later
// Expressions at run time: variables, array elements, intrinsic calls, OBTAIN, operators.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "execute/execute.hpp"
#include "metron/runtime/feature_parameters.hpp"
#include "metron/runtime/tolerance.hpp"
#include "metron/stdlib/builtins.hpp"

namespace metron::interpreter {

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
      std::vector<double> indices;
      for (const auto& a : e.args) {
        auto i = number(a);
        if (!i) return tl::unexpected(i.error());
        indices.push_back(*i);
      }
      auto k = element_offset(e.name, indices, v->size());
      if (!k) return tl::unexpected(k.error());
      return (*v)[*k];
    }
    case ir::ExprOp::Call: {
      if (e.name == "PROMPT") return prompt(e);
      if (auto answered = run_function(e)) return *answered;
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
    case ir::ExprOp::Obtain: return detail::Execute::obtain(*this, e);
    case ir::ExprOp::Query: return detail::Execute::query(*this, e);
    case ir::ExprOp::Unary: {
      auto v = evaluate(e.args.at(0));
      if (!v) return v;
      if (e.name == ".NOT.") {
        if (v->type != ValueType::Bool) return tl::unexpected(std::string(".NOT. needs a BOOL"));
        return Value::boolean_value(!v->boolean);
      }
      if (v->type == ValueType::Vector) {
        if (e.name == "-")
          for (double& c : v->components) c = -c;
        return v;
      }
      if (!v->is_number()) return tl::unexpected(fmt::format("unary {} needs a number", e.name));
      if (e.name == "-") v->number = -v->number;
      return v;
    }
    case ir::ExprOp::Binary: return detail::Execute::binary(*this, e);
  }
  return tl::unexpected(std::string("bad expression"));
}

}  // namespace metron::interpreter

namespace metron::interpreter::detail {

namespace {

// u+v, u-v, s*v, v*s, v/s on VECTORs.
tl::expected<Value, std::string> vector_arithmetic(const std::string& op, const Value& a, const Value& b) {
  const bool va = a.type == ValueType::Vector, vb = b.type == ValueType::Vector;
  Value r = va ? a : b;
  if ((op == "+" || op == "-") && va && vb) {
    for (std::size_t i = 0; i < 3; ++i)
      r.components[i] = op == "+" ? a.components[i] + b.components[i] : a.components[i] - b.components[i];
  } else if (op == "*" && va != vb && (va ? b : a).is_number()) {
    for (double& c : r.components) c *= (va ? b : a).number;
  } else if (op == "/" && va && b.is_number()) {
    if (b.number == 0) return tl::unexpected(std::string("division by zero"));
    for (double& c : r.components) c /= b.number;
  } else {
    return tl::unexpected(
        fmt::format("'{}' does not apply to a {} and a {}", op, to_string(a.type), to_string(b.type)));
  }
  for (double c : r.components)
    if (!std::isfinite(c)) return tl::unexpected(fmt::format("'{}' gives a vector that is not finite", op));
  return r;
}

}  // namespace

// OBTAIN/FA(x),n as a value.
tl::expected<Value, std::string> Execute::obtain(Interpreter& vm, const ir::Expr& e) {
  auto index = vm.number(e.args.at(0));
  if (!index) return tl::unexpected(index.error());
  auto g = vm.m_runtime.feature_geometry({vm.label_name(e.label), e.label.prefix == "FA"}, e.span);
  if (!g) return tl::unexpected(g.error().message);
  // OBTAIN/FA(x),n reads what the DMIS output statement FA(x)=FEAT/... shows: n counts its words
  // first, then the numbers in the one feature layout (runtime/feature_parameters.hpp).
  const auto params = runtime::feature_parameters(*g);
  const auto words = static_cast<long>(runtime::feature_word_count(g->type));
  const auto k = static_cast<long>(std::llround(*index));
  if (k <= words || k > words + static_cast<long>(params.size()))
    return tl::unexpected(
        fmt::format("OBTAIN index {} is not a number of {}({})", k, e.label.prefix, vm.label_name(e.label)));
  const runtime::FeatureParameter& p = params[static_cast<std::size_t>(k - words - 1)];
  // Lengths go back to program units; direction cosines and angles do not.
  const double v = p.unit == runtime::ParameterUnit::Length ? p.value / vm.m_length_mm : p.value;
  return Value::real(v);
}

namespace {
/// A feature's n-th size for VALUE/FA(x),SIZE,n, and whether it is a length (else an angle).
std::optional<std::pair<double, bool>> feature_size(const runtime::Geometry& g, long n) {
  using runtime::FeatureType;
  switch (g.type) {
    case FeatureType::Circle:
    case FeatureType::Sphere:
      if (n == 1) return std::pair{g.diameter_mm, true};
      break;
    case FeatureType::Arc:
      if (n == 1) return std::pair{g.diameter_mm / 2, true};  // FEAT/ARC carries its radius
      break;
    case FeatureType::Cylinder:
      if (n == 1) return std::pair{g.diameter_mm, true};
      if (n == 2) return std::pair{g.length_mm, true};
      break;
    case FeatureType::Cone:
      if (n == 1) return std::pair{g.apex_angle_deg, false};
      break;
    case FeatureType::ParallelPlanes:
      if (n == 1) return std::pair{g.width_mm, true};
      break;
    case FeatureType::ClosedSlot:
      if (n == 1) return std::pair{g.width_mm, true};
      if (n == 2) return std::pair{g.length_mm, true};
      break;
    case FeatureType::Torus:
    case FeatureType::Ellipse:
      if (n == 1) return std::pair{g.diameter_mm, true};
      if (n == 2) return std::pair{g.minor_diameter_mm, true};
      break;
    default: break;
  }
  return std::nullopt;
}
}  // namespace

// VALUE/FA(x),SIZE,n and VALUE/TA(t),ACT|DEV|AMT|INTOL|OUTOL,n as a value.
tl::expected<Value, std::string> Execute::query(Interpreter& vm, const ir::Expr& e) {
  auto index = vm.number(e.args.at(0));
  if (!index) return tl::unexpected(index.error());
  const long n = std::lround(*index);
  const std::string label = vm.label_name(e.label);
  if (e.label.prefix == "TA") {
    const auto* results = vm.m_runtime.last_tolerance_results(label);
    if (!results)
      return tl::unexpected(
          fmt::format("VALUE/TA({}) before T({}) was evaluated (OUTPUT or EVAL with a feature)", label, label));
    if (n < 1 || n > static_cast<long>(results->size()))
      return tl::unexpected(fmt::format("VALUE/TA({}),{},{}: its last evaluation has {} result{}", label, e.name, n,
                                        results->size(), results->size() == 1 ? "" : "s"));
    const runtime::ToleranceResult& r = (*results)[static_cast<std::size_t>(n - 1)];
    if (e.name == "INTOL") return Value::boolean_value(r.in_tolerance);
    if (e.name == "OUTOL") return Value::boolean_value(!r.in_tolerance);
    const bool angle = runtime::is_angle_result(r);
    double v = 0;
    if (e.name == "ACT")
      v = r.actual;
    else if (e.name == "DEV")
      v = r.value;
    else
      v = r.in_tolerance ? 0.0 : std::max(r.lower - r.value, r.value - r.upper);  // AMT: beyond the nearer limit
    return Value::real(angle ? v / degrees(vm) : v / vm.m_length_mm);             // program units
  }
  auto g = vm.m_runtime.feature_geometry({label, e.label.prefix == "FA"}, e.span);
  if (!g) return tl::unexpected(g.error().message);
  const auto size = feature_size(*g, n);
  if (!size)
    return tl::unexpected(fmt::format("VALUE/{}({}),SIZE,{}: a {} has no size {}", e.label.prefix, label, n,
                                      runtime::dmis_word(g->type), n));
  return Value::real(size->second ? size->first / vm.m_length_mm : size->first / degrees(vm));
}

// a op b: arithmetic (+ - * / **), comparisons (.EQ. ... .GE.), .AND. and .OR. (short-circuit).
tl::expected<Value, std::string> Execute::binary(Interpreter& vm, const ir::Expr& e) {
  auto a = vm.evaluate(e.args.at(0));
  if (!a) return a;
  const std::string& op = e.name;
  if (op == ".AND." || op == ".OR.") {
    if (a->type != ValueType::Bool) return tl::unexpected(op + " needs BOOL operands");
    if (op == ".AND." && !a->boolean) return Value::boolean_value(false);  // short-circuit
    if (op == ".OR." && a->boolean) return Value::boolean_value(true);
    auto b = vm.evaluate(e.args.at(1));
    if (!b) return b;
    if (b->type != ValueType::Bool) return tl::unexpected(op + " needs BOOL operands");
    return Value::boolean_value(b->boolean);
  }
  auto b = vm.evaluate(e.args.at(1));
  if (!b) return b;
  if (op[0] == '.') {
    int c = 0;
    if (a->is_number() && b->is_number())
      c = a->number < b->number ? -1 : (a->number > b->number ? 1 : 0);
    else if (a->type == ValueType::String && b->type == ValueType::String)
      c = a->text.compare(b->text) < 0 ? -1 : (a->text == b->text ? 0 : 1);
    else if (a->type == ValueType::Bool && b->type == ValueType::Bool)
      c = a->boolean == b->boolean ? 0 : 1;
    else if (a->type == ValueType::Vector && b->type == ValueType::Vector && (op == ".EQ." || op == ".NE."))
      c = a->components == b->components ? 0 : 1;
    else
      return tl::unexpected(fmt::format("{} compares a {} with a {}", op, to_string(a->type), to_string(b->type)));
    if (op == ".EQ.") return Value::boolean_value(c == 0);
    if (op == ".NE.") return Value::boolean_value(c != 0);
    if (op == ".LT.") return Value::boolean_value(c < 0);
    if (op == ".LE.") return Value::boolean_value(c <= 0);
    if (op == ".GT.") return Value::boolean_value(c > 0);
    if (op == ".GE.") return Value::boolean_value(c >= 0);
    return tl::unexpected("unknown operator " + op);
  }
  if (a->type == ValueType::Vector || b->type == ValueType::Vector) return vector_arithmetic(op, *a, *b);
  if (!a->is_number() || !b->is_number()) return tl::unexpected(fmt::format("'{}' needs numbers", op));
  const bool integer = a->type == ValueType::Integer && b->type == ValueType::Integer;
  double r = 0;
  if (op == "+")
    r = a->number + b->number;
  else if (op == "-")
    r = a->number - b->number;
  else if (op == "*")
    r = a->number * b->number;
  else if (op == "/") {
    if (b->number == 0) return tl::unexpected(std::string("division by zero"));
    r = a->number / b->number;
  } else if (op == "**")
    r = std::pow(a->number, b->number);
  else
    return tl::unexpected("unknown operator " + op);
  if (!std::isfinite(r)) return tl::unexpected(fmt::format("'{}' gives a number that is not finite", op));
  return integer && op != "/" && op != "**" ? Value::integer(r) : Value::real(r);
}

}  // namespace metron::interpreter::detail
