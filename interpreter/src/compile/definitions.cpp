// SPDX-License-Identifier: GPL-3.0-or-later
// Definitions: FEAT, SNSDEF, TOL, DATDEF, PATH, DECL.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "compile/unit_compiler.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;
using runtime::FeatureType;
using runtime::ToleranceKind;

namespace {

// The number of numeric parameters each feature form takes, after the words.
struct FeatureForm {
  std::size_t min_numbers;
  std::size_t max_numbers;
  const char* meaning;
};

FeatureForm feature_form(FeatureType type, bool bounded) {
  switch (type) {
    case FeatureType::Point:
    case FeatureType::Plane: return {6, 6, "x,y,z,i,j,k"};
    case FeatureType::Line:
      return bounded ? FeatureForm{9, 9, "x1,y1,z1,x2,y2,z2,i,j,k"} : FeatureForm{9, 9, "x,y,z,i,j,k,i2,j2,k2"};
    case FeatureType::Circle: return {7, 7, "x,y,z,i,j,k,diam"};
    case FeatureType::Arc: return {9, 12, "x,y,z,i,j,k,rad,ang1,ang2[,i2,j2,k2]"};
    case FeatureType::Sphere: return {4, 7, "x,y,z,diam (or x,y,z,i,j,k,diam)"};
    case FeatureType::Cylinder: return {7, 8, "x,y,z,i,j,k,diam[,len]"};
    case FeatureType::Cone: return {7, 8, "x,y,z,i,j,k,angle[,len]"};
    case FeatureType::ParallelPlanes:
      return {7, 7, "x,y,z,i,j,k,width (a point on the median plane, its normal, the width)"};
    case FeatureType::GenericSurface: return {0, 6, "none, or x,y,z,i,j,k (a point of the surface and its normal)"};
    case FeatureType::GenericCurve:
      return {0, 6, "none, or x,y,z,i,j,k (a point of the curve and the normal of its plane)"};
    case FeatureType::Torus:
      return {8, 8, "x,y,z,i,j,k,majdiam,mindiam (the centre, the axis, the centre circle's and the tube's diameters)"};
    case FeatureType::ClosedSlot:
      return {11, 11,
              "x,y,z,i1,j1,k1,i2,j2,k2,len,wid (the centre, the normal of its plane, its long axis, the length end to "
              "end, the width)"};
    case FeatureType::Ellipse:
      return {11, 11,
              "x,y,z,i1,j1,k1,i2,j2,k2,majdiam,mindiam (the centre, the normal of its plane, its major axis, the "
              "major and minor diameters)"};
  }
  return {0, 0, ""};
}

// A literal number (or a negated one), NaN for anything computed at run time.
double literal_value(const ir::Expr& e) {
  if (e.op == ir::ExprOp::Constant) return e.value.number;
  return e.op == ir::ExprOp::Unary && e.args[0].op == ir::ExprOp::Constant ? -e.args[0].value.number : NAN;
}

// The numbers a TOL statement of each kind needs (after the kind word).
struct ToleranceNumbers {
  std::size_t count;
  const char* meaning;
  bool zone;  ///< the number is a tolerance zone (not negative)
};

ToleranceNumbers tolerance_numbers(ToleranceKind kind) {
  switch (kind) {
    case ToleranceKind::Diam:
    case ToleranceKind::Rad:
    case ToleranceKind::Profs:
    case ToleranceKind::Profl:
    case ToleranceKind::Profp:
    case ToleranceKind::Width: return {2, "lower and upper tolerance", false};
    case ToleranceKind::Angl: return {2, "lower and upper angle tolerance", false};
    case ToleranceKind::Compos: return {2, "the PATERN and FEATUR zones", true};
    case ToleranceKind::DistB:
    case ToleranceKind::DistWrt: return {3, "nominal distance, lower and upper tolerance", false};
    case ToleranceKind::AngWrt: return {3, "nominal angle, lower and upper tolerance", false};
    case ToleranceKind::Cortol: return {2, "lower and upper tolerance", false};
    case ToleranceKind::Anglb: return {3, "nominal angle, lower and upper tolerance", false};
    case ToleranceKind::Anglr: return {2, "the tolerance zone and the basic angle", false};
    default: return {1, "the tolerance zone", true};
  }
}

}  // namespace

void UnitCompiler::add_definitions(StatementTable& t) {
  t.insert({{"FEAT", &UnitCompiler::feat},
            {"SNSDEF", &UnitCompiler::snsdef},
            {"TOL", &UnitCompiler::tol},
            {"DATDEF", &UnitCompiler::datdef},
            {"PATH", &UnitCompiler::path},
            {"DECL", &UnitCompiler::decl}});
}

// F(l)=FEAT/CIRCLE,INNER|OUTER,CART,x,y,z,i,j,k,d  (likewise POINT, PLANE, LINE, ARC, SPHERE, CYLNDR, CONE, PARPLN;
// CART|POL) F(l)=FEAT/CPARLN,INNER|OUTER,ROUND|FLAT,CART,x,y,z,i1,j1,k1,i2,j2,k2,len,wid
void UnitCompiler::feat(const grammar::Statement& s) {
  if (!require_target(s, {"F", "FA"}, "F(label)=FEAT/...")) return;
  // FA(l)=FEAT/... states a feature's actual, as DMIS output files report it: metron takes it as
  // the feature's actual (docs/language.md, "DMIS output files").
  const bool reported_actual = upper(s.target->prefix) == "FA";
  if (!expect_params(s, 1, "the feature type")) return;
  const std::string label = upper(s.target->name);
  auto p = s.params;
  // FEAT/EDGEPT,CART,x,y,z,i,j,k,ei,ej,ek[,thickness]: a point on a surface near an edge. metron
  // measures it as a POINT on the surface (x,y,z along i,j,k); the edge vector does not enter.
  if (is_word(p[0], "EDGEPT")) {
    if (p.size() < 11 || p.size() > 12)
      return error(
          p.back().span, "sema.feature-arity",
          fmt::format("FEAT/EDGEPT expects CART or POL and 9 or 10 numbers (x,y,z,i,j,k,ei,ej,ek[,thickness]), got {} "
                      "parameters",
                      p.size() - 1));
    note_once(m_edge_points_noted, p[0].span, "sema.edge-point",
              "FEAT/EDGEPT is measured as a POINT on its surface (x,y,z along i,j,k); the edge vector is not used");
    p.resize(8);
    p[0].text = "POINT";
  }
  // F(p)=FEAT/PATERN,F(a),F(b),...: a pattern of features (a bolt circle) that an OUTPUT reports
  // and judges together (docs/tolerances.md "Composite position").
  if (is_word(p[0], "PATERN")) return pattern(s);
  // FEAT/RCTNGL,INNER|OUTER,CART|POL,x,y,z,i1,j1,k1,i2,j2,k2,len,wid[,depth]: a rectangular
  // pocket or block outline in its plane, which is a closed slot with square ends: metron
  // measures and reports it as CPARLN,FLAT (the same numbers in the same order).
  if (is_word(p[0], "RCTNGL")) {
    const std::size_t numbers = p.size() > 3 ? p.size() - 3 : 0;
    if (numbers != 11 && numbers != 12)
      return error(p.back().span, "sema.feature-arity",
                   fmt::format("FEAT/RCTNGL expects INNER or OUTER, CART or POL and 11 or 12 numbers "
                               "(x,y,z,i1,j1,k1,i2,j2,k2,len,wid[,depth]: the centre, the normal of its plane, the "
                               "direction of its length, the length, the width), got {} parameters",
                               p.size() - 1));
    note_once(m_rectangles_noted, p[0].span, "sema.rectangle",
              "FEAT/RCTNGL is measured and reported as a CPARLN with FLAT ends (a rectangle's outline in its plane)"
              "; a depth after the width is not used");
    if (numbers == 12) p.pop_back();
    p[0].text = "CPARLN";
    grammar::Expr flat = p[1];
    flat.text = "FLAT";
    p.insert(p.begin() + 2, flat);
  }
  const auto parsed = is_word(p[0]) ? ir::parse_word<FeatureType>(p[0].text) : std::nullopt;
  if (!parsed) {
    if (is_word(p[0]) && unsupported_feature_word(p[0].text)) {
      warn(p[0].span, "sema.unsupported-feature",
           fmt::format("feature type {} is not supported yet; F({}) is skipped", p[0].text, s.target->name));
      m_symbols.skipped["F:" + label] = s.span;
      m_symbols.unsupported_features[label] = p[0].text;
      emit(make(Op::Nop, s, "FEAT"));
      return;
    }
    return error(p[0].span, "sema.bad-feature-type",
                 fmt::format("expected a feature type ({}) after FEAT/", ir::word_list<FeatureType>()));
  }
  const FeatureType type = *parsed;
  const std::string& word = p[0].text;
  auto in = make(Op::FeatureDef, s, label);
  ir::FeaturePayload payload;
  payload.type = type;
  std::size_t i = 1;
  const bool sized = type != FeatureType::Point && type != FeatureType::Plane && type != FeatureType::Line &&
                     !runtime::is_point_set(type);
  if (sized) {
    if (i >= p.size() || !(is_word(p[i], "INNER") || is_word(p[i], "OUTER")))
      return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-side",
                   fmt::format("expected INNER or OUTER after the feature type {}", word));
    payload.side = p[i++].text == "INNER" ? runtime::Side::Inner : runtime::Side::Outer;
  }
  if (type == FeatureType::ClosedSlot) {
    if (i < p.size() && (is_word(p[i], "ROUND") || is_word(p[i], "FLAT")))
      payload.slot_ends = p[i++].text == "FLAT" ? runtime::SlotEnds::Flat : runtime::SlotEnds::Round;
    else
      return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-slot-ends",
                   "expected ROUND or FLAT after CPARLN,INNER|OUTER");
  }
  if (type == FeatureType::Line) {
    if (i < p.size() && (is_word(p[i], "BND") || is_word(p[i], "UNBND")))
      payload.bounded = p[i++].text == "BND";
    else
      return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-bnd", "expected BND or UNBND after LINE");
  }
  // A GSURF or GCURVE may have no numbers at all: its points carry their nominals.
  const bool bare = runtime::is_point_set(type) && i >= p.size();
  if (!bare && (i >= p.size() || !(is_word(p[i], "CART") || is_word(p[i], "POL"))))
    return error(i < p.size() ? p[i].span : p.back().span, "sema.expected-form",
                 fmt::format("expected CART or POL after the feature type {}", word));
  if (!bare) payload.form = *ir::parse_word<ir::CoordinateForm>(p[i++].text);
  const bool bounded = payload.bounded.value_or(false);
  const FeatureForm form = feature_form(type, bounded);
  std::size_t n = p.size() - i;
  if (type == FeatureType::Line && n == 6 &&
      !complete_line_normal(s, p, bounded, payload.form.value_or(ir::CoordinateForm::Cart)))
    return;
  n = p.size() - i;
  // More numbers than the form takes (DMIS 5.3's longer forms, vendors' extra sizes such as a
  // cone's two distances): read leniently, the form's numbers are used and the rest ignored, with
  // a warning; --strict: an error below.
  std::vector<grammar::Expr> trimmed;
  const std::size_t most = type == FeatureType::Arc ? 12 : runtime::is_point_set(type) ? 6 : form.max_numbers;
  if (n > most && !m_strict) {
    warn(p[i + most].span, "sema.feature-arity",
         fmt::format(
             "FEAT/{} takes at most {} numbers ({}); the {} after them {} ignored (--strict makes this an error)", word,
             most, form.meaning, n - most, n - most == 1 ? "is" : "are"));
    trimmed.assign(p.begin(), p.begin() + static_cast<std::ptrdiff_t>(i + most));
    n = most;
  }
  const std::vector<grammar::Expr>& used = trimmed.empty() ? p : trimmed;
  // An ARC's reference direction comes whole (three numbers) or not at all.
  if (n < form.min_numbers || n > form.max_numbers || (runtime::is_point_set(type) && n != 0 && n != 6) ||
      (type == FeatureType::Arc && n != 9 && n != 12))
    return error(n > form.max_numbers ? p[i + form.max_numbers].span : p.back().span, "sema.feature-arity",
                 fmt::format("FEAT/{} expects {} numbers ({}), got {}", word,
                             form.min_numbers == form.max_numbers ? fmt::format("{}", form.min_numbers)
                             : type == FeatureType::Arc           ? std::string("9 or 12")
                                                        : fmt::format("{} to {}", form.min_numbers, form.max_numbers),
                             form.meaning, n));
  bool ok = true;
  std::vector<double> literal;
  for (; i < used.size(); ++i) {
    auto e = numeric(used[i], "a feature coordinate");
    if (!e) {
      ok = false;
      continue;
    }
    literal.push_back(literal_value(*e));
    in.operands.push_back(expr_operand(std::move(*e)));
  }
  if (!ok) return;
  if (type == FeatureType::Circle && m_writer == "WinWerth" && !m_strict && !literal.empty()) {
    // WinWerth writes a circle's radius where DMIS has its diameter (its PTMEAS points lie at that
    // radius from the centre, its TOL/DIAM labels name twice it): read as the diameter it is.
    note_once(m_circle_radius_noted, s.span, "sema.circle-radius",
              "this file was written by WinWerth (its BEGIN/CHFILE block), which writes a FEAT/CIRCLE's radius where "
              "DMIS has its diameter: its circles are read with twice the size written (noted once)");
    ir::Operand& size = in.operands.back();
    ir::Expr twice;
    twice.span = size.expr.span;
    twice.op = ir::ExprOp::Binary;
    twice.name = std::string(1, '*');  // not = "*": GCC 12 warns falsely (-Wrestrict)
    twice.type = ValueType::Real;
    ir::Expr two;
    two.span = size.expr.span;
    two.op = ir::ExprOp::Constant;
    two.value = Value::real(2);
    two.type = ValueType::Real;
    twice.args = {std::move(two), std::move(size.expr)};
    size = expr_operand(std::move(twice));
    literal.back() *= 2;
  }
  if (!check_feature_numbers(s, used, payload, literal)) return;
  if (type == FeatureType::Point && literal.size() >= 6 && literal[3] == 0 && literal[4] == 0 && literal[5] == 0) {
    ir::Expr up;  // the zero direction check_feature_numbers let through leniently
    up.span = used[used.size() - literal.size() + 5].span;
    up.op = ir::ExprOp::Constant;
    up.value = Value::real(1);
    up.type = ValueType::Real;
    in.operands[in.operands.size() - literal.size() + 5] = expr_operand(std::move(up));
  }
  if (auto it = m_symbols.features.find(label); it != m_symbols.features.end() && !m_repl && !reported_actual) {
    const Location loc = m_sources.locate(it->second.span);
    // DMIS lets a feature's nominal label be defined again (only other labels are unique): a note.
    note(s.target->span, "sema.redefined-feature",
         fmt::format("F({}) is defined again (first at line {}): the new nominal holds from here", s.target->name,
                     loc.line));
  }
  if (auto param = macro_param(label)) {
    in.name_is_param = true;
    m_symbols.macro_features[m_module.macros[static_cast<std::size_t>(*m_macro)].name][*param] = type;
  }
  if (reported_actual) {
    in.count = 1;  // the actual, not the nominal
    note_once(m_reported_results_noted, s.target->span, "sema.reported-actual",
              fmt::format("FA({})=FEAT/... states a measured actual, as a DMIS output file does: it becomes the "
                          "feature's actual (the nominal too when the feature has none)",
                          s.target->name));
    if (!m_symbols.features.count(label)) m_symbols.features[label] = {type, s.span};
  } else {
    m_symbols.features[label] = {type, s.span};
  }
  m_symbols.skipped.erase("F:" + label);
  in.payload = payload;
  emit(std::move(in));
}

// FEAT/LINE written with 6 numbers, without the normal of the plane the line lies in (generators
// write UNBND,x,y,z,i,j,k and BND,x1,y1,z1,x2,y2,z2 so): the normal is the coordinate axis the line
// is most perpendicular to (Z first, the default working plane's, then Y, then X), made exactly
// perpendicular to it; the line is probed on the face whose normal is direction x that axis, as for
// a line written whole. Appends the three numbers to `p`; false (an error told) where the direction
// is not written in literal numbers or --strict asks for the standard's 9.
bool UnitCompiler::complete_line_normal(const grammar::Statement& s, std::vector<grammar::Expr>& p, bool bounded,
                                        ir::CoordinateForm form) {
  const std::size_t first = p.size() - 6;
  const char* meaning = bounded ? "x1,y1,z1,x2,y2,z2,i,j,k" : "x,y,z,i,j,k,i2,j2,k2";
  const auto literal = [](const grammar::Expr& e) -> double {
    if (e.kind == ExprKind::Number) return e.number;
    if (e.kind == ExprKind::Unary && e.args.size() == 1 && e.args[0].kind == ExprKind::Number)
      return e.text == "-" ? -e.args[0].number : e.text == "+" ? e.args[0].number : NAN;
    return NAN;
  };
  std::array<double, 6> v{};
  for (std::size_t k = 0; k < 6; ++k) v[k] = literal(p[first + k]);
  const Vec3 direction = bounded ? Vec3(v[3] - v[0], v[4] - v[1], v[5] - v[2]) : Vec3(v[3], v[4], v[5]);
  const char* why = m_strict ? " (without --strict the normal of its plane is taken from its direction)"
                    : bounded && form != ir::CoordinateForm::Cart
                        ? ": the normal of its plane can be left out only where a BND line's ends are in CART"
                    : !direction.allFinite()
                        ? ": the normal of its plane can be left out only where the line's direction is written in "
                          "numbers"
                    : direction.norm() == 0 ? (bounded ? ": its two ends are one point, it has no direction"
                                                       : ": its direction is the zero vector")
                                            : nullptr;
  if (why)
    return error(p.back().span, "sema.feature-arity",
                 fmt::format("FEAT/LINE expects 9 numbers ({}), got 6{}", meaning, why)),
           false;
  const Vec3 d = direction.normalized();
  Vec3 axis = Vec3::UnitZ();
  for (const Vec3& candidate : {Vec3(Vec3::UnitY()), Vec3(Vec3::UnitX())})
    if (std::abs(candidate.dot(d)) < std::abs(axis.dot(d)) - 1e-12) axis = candidate;
  const Vec3 normal = (axis - axis.dot(d) * d).normalized();
  warn_once(m_line_normals_warned, p.back().span, "sema.line-normal",
            fmt::format("FEAT/LINE of F({}) has 6 numbers, without the normal of the plane it lies in ({}): metron "
                        "takes {:g},{:g},{:g}, the axis it is most perpendicular to, and likewise for every such "
                        "LINE after it (--strict makes this an error)",
                        s.target->name, meaning, normal.x() + 0.0, normal.y() + 0.0, normal.z() + 0.0));
  for (int k = 0; k < 3; ++k) {
    grammar::Expr number;
    number.kind = ExprKind::Number;
    number.span = p.back().span;
    number.number = normal[k];
    p.push_back(std::move(number));
  }
  return true;
}

// F(p)=FEAT/PATERN,F(a),F(b)[,...]: the members must be features defined before.
void UnitCompiler::pattern(const grammar::Statement& s) {
  const std::string label = upper(s.target->name);
  if (s.params.size() < 3)
    return error(s.params.back().span, "sema.pattern-members",
                 "FEAT/PATERN lists the pattern's features: F(p)=FEAT/PATERN,F(a),F(b)[,...]");
  std::vector<std::string> members;
  for (std::size_t i = 1; i < s.params.size(); ++i) {
    const grammar::Expr& e = s.params[i];
    if (!is_label(e, {"F", "FA"}))
      return error(e.span, "sema.pattern-members",
                   "FEAT/PATERN lists the pattern's features: F(p)=FEAT/PATERN,F(a),F(b)[,...]");
    if (m_symbols.patterns.count(upper(e.label.name)))
      return error(e.span, "sema.pattern-members",
                   fmt::format("F({}) is a pattern: a pattern lists features", e.label.name));
    if (!check_feature(e)) return;
    members.push_back(upper(e.label.name));
  }
  note_once(
      m_patterns_noted, s.target->span, "sema.pattern",
      fmt::format("F({}) is a pattern of {} features: OUTPUT/FA({}) reports them and judges its tolerances on them "
                  "together; other statements take its features one by one",
                  s.target->name, members.size(), s.target->name));
  m_symbols.patterns[label] = std::move(members);
  m_symbols.skipped.erase("F:" + label);
  emit(make(Op::Nop, s, "FEAT"));
}

// Static checks on the literal numbers of a FEAT (the last of `params`; NaN where computed at run time): a zero
// direction, a non-positive size, a cone angle outside (0, 180).
bool UnitCompiler::check_feature_numbers(const grammar::Statement& s, const std::vector<grammar::Expr>& params,
                                         const ir::FeaturePayload& form, const std::vector<double>& literal) {
  const FeatureType type = form.type;
  const std::size_t n = literal.size();
  const auto fail = [&](std::size_t k, const char* code, std::string message) {
    error(params[params.size() - n + k].span, code, std::move(message));
    return false;
  };
  if ((type != FeatureType::Sphere || n == 7) && n > 0) {
    const std::size_t d = (type == FeatureType::Line && form.bounded.value_or(false)) ? 6 : 3;
    if (literal.size() >= d + 3 && literal[d] == 0 && literal[d + 1] == 0 && literal[d + 2] == 0) {
      // WinWerth gives a point it constructs (BF of points) no direction: read leniently, the
      // caller gives it +Z, which no construction of a point uses.
      if (type == FeatureType::Point && !m_strict) {
        warn(params[params.size() - n + d].span, "sema.zero-vector",
             "the direction vector i,j,k is zero: the point is given 0,0,1 (--strict makes it an error)");
        return true;
      }
      return fail(d, "sema.zero-vector", "the direction vector i,j,k is zero");
    }
  }
  if (type == FeatureType::ClosedSlot || type == FeatureType::Ellipse) {
    // x,y,z,i1,j1,k1,i2,j2,k2,...: the long (major) axis lies in the plane (normal to i1,j1,k1).
    const char* axis_name = type == FeatureType::Ellipse ? "major axis" : "long axis";
    if (literal[6] == 0 && literal[7] == 0 && literal[8] == 0)
      return fail(6, "sema.zero-vector", fmt::format("the {} i2,j2,k2 is zero", axis_name));
    const Vec3 normal(literal[3], literal[4], literal[5]), axis(literal[6], literal[7], literal[8]);
    const double cos_angle = normal.normalized().dot(axis.normalized());
    if (std::isfinite(cos_angle) && std::abs(cos_angle) > 1e-3)
      return fail(
          6, "sema.slot-axis",
          fmt::format("the {} i2,j2,k2 of F({}) is not perpendicular to the normal i1,j1,k1 of its plane "
                      "(at {:.3f} deg to it, not 90)",
                      axis_name, s.target->name, std::acos(std::clamp(cos_angle, -1.0, 1.0)) * 180 / std::numbers::pi));
  }
  if (type == FeatureType::Ellipse) {
    for (std::size_t k : {9, 10})
      if (!std::isnan(literal[k]) && literal[k] <= 0)
        return fail(
            k, "sema.bad-size",
            fmt::format("the {} diameter of F({}) must be positive", k == 9 ? "major" : "minor", s.target->name));
    if (literal[10] > literal[9])
      return fail(10, "sema.bad-size",
                  fmt::format("the minor diameter {} of F({}) is more than its major diameter {} (the major diameter "
                              "comes first, along i2,j2,k2)",
                              literal[10], s.target->name, literal[9]));
    return true;
  }
  if (type == FeatureType::ClosedSlot) {
    for (std::size_t k : {9, 10})
      if (!std::isnan(literal[k]) && literal[k] <= 0)
        return fail(k, "sema.bad-size",
                    fmt::format("the {} of F({}) must be positive", k == 9 ? "length" : "width", s.target->name));
    if (form.slot_ends == runtime::SlotEnds::Round && literal[10] >= literal[9])
      return fail(
          10, "sema.bad-size",
          fmt::format("the width {} of F({}) is not less than its length {}: a ROUND slot's ends are semicircles "
                      "of its width, so the length (end to end) must exceed it",
                      literal[10], s.target->name, literal[9]));
    return true;
  }
  if (type == FeatureType::Torus) {
    for (std::size_t k : {6, 7})
      if (!std::isnan(literal[k]) && literal[k] <= 0)
        return fail(
            k, "sema.bad-size",
            fmt::format("the {} diameter of F({}) must be positive", k == 6 ? "major" : "minor", s.target->name));
    if (literal[7] >= literal[6])
      return fail(7, "sema.bad-size",
                  fmt::format("the tube's diameter {} of F({}) is not less than its major diameter {}: a torus's tube "
                              "circles round its axis",
                              literal[7], s.target->name, literal[6]));
    return true;
  }
  if (form.side && type != FeatureType::Cone) {
    const bool arc = type == FeatureType::Arc;
    const bool with_length = type == FeatureType::Cylinder && n == 8;
    const std::size_t idx = arc ? 6 : (with_length ? n - 2 : n - 1);
    const double size = arc || with_length ? literal[6] : literal.back();
    if (!std::isnan(size) && size <= 0)
      return fail(idx, "sema.bad-size",
                  fmt::format("the {} of F({}) must be positive",
                              arc                                   ? "radius"
                              : type == FeatureType::ParallelPlanes ? "width"
                                                                    : "diameter",
                              s.target->name));
  }
  if (type == FeatureType::Cone && !std::isnan(literal[6]) && (literal[6] <= 0 || literal[6] >= 180))
    return fail(6, "sema.bad-size", "the cone angle must be between 0 and 180 degrees");
  return true;
}

// S(l)=SNSDEF/PROBE,FIXED|INDEX,CART|POL,...,diam
void UnitCompiler::snsdef(const grammar::Statement& s) {
  if (!require_target(s, {"S"}, "S(label)=SNSDEF/PROBE,...")) return;
  if (!expect_params(s, 1, "the sensor type")) return;
  if (!is_word(s.params[0], "PROBE")) {
    warn(s.params[0].span, "sema.unsupported-sensor",
         fmt::format("sensor type {} is not supported; S({}) is skipped", s.params[0].text, s.target->name));
    m_symbols.skipped["S:" + upper(s.target->name)] = s.span;
    emit(make(Op::Nop, s, "SNSDEF"));
    return;
  }
  auto in = make(Op::SensorDef, s, upper(s.target->name));
  std::size_t i = 0;
  for (; i < s.params.size() && is_word(s.params[i]) && !is_variable(s.params[i].text); ++i)
    in.operands.push_back(word_operand(s.params[i]));
  const std::size_t n = s.params.size() - i;
  if (n < 4)
    return error(s.params.back().span, "sema.sensor-arity",
                 "SNSDEF/PROBE expects the stylus vector and the tip diameter after the words");
  // Every number zero (WinWerth's SNSDEF of a probe its own library holds): a placeholder. Read
  // leniently, the sensor is the machine's probe library's, as one the program never defines.
  if (!m_strict && std::all_of(s.params.begin() + static_cast<std::ptrdiff_t>(i), s.params.end(),
                               [](const grammar::Expr& e) { return e.kind == ExprKind::Number && e.number == 0; })) {
    const std::string name = upper(s.target->name);
    warn(s.span, "sema.placeholder-sensor",
         fmt::format("S({}) has no geometry (its numbers are all zero): it is taken from the machine's probe library, "
                     "as a sensor the program does not define (a 4 mm default tip, with a warning, when the library "
                     "does not hold it; --strict makes it an error at run)",
                     s.target->name));
    m_symbols.library_sensors.insert(name);
    emit(make(Op::Nop, s, "SNSDEF"));
    return;
  }
  for (; i < s.params.size(); ++i) {
    // `VEC,i,j,k` (`...,POL,0,0,VEC,0,0,1,50,4`, as DMIS 5.x programs write the stylus vector):
    // the word names the three numbers that follow.
    if (is_word(s.params[i], "VEC") && s.params.size() - i > 3) continue;
    // The wrist, extension or sensor it is mounted on (`...,100,4,SW(W1)`): the virtual CMM's
    // sensors hang from the head by their own offset.
    if (s.params[i].kind == ExprKind::Label && i + 1 == s.params.size()) {
      note_once(
          m_sensor_mount_noted, s.params[i].span, "sema.sensor-mount",
          fmt::format("S({}) names the {}({}) it is mounted on: the virtual CMM places a sensor by its own offset and "
                      "vector, the mount is not used (noted once)",
                      s.target->name, upper(s.params[i].label.prefix), s.params[i].label.name));
      break;
    }
    // The tip's shape after its diameter (`...,115,12,DISC,3`): the virtual CMM's tips are balls.
    if (is_word(s.params[i]) && !is_variable(s.params[i].text)) {
      const std::string& shape = s.params[i].text;
      static const std::set<std::string> shapes = {"SPHERE", "CYLNDR", "DISC", "DISK", "POINT", "OPTIC"};
      if (!shapes.count(shape))
        return error(
            s.params[i].span, "sema.sensor-shape",
            fmt::format(
                "expected a sensor parameter (a number) or the tip's shape (SPHERE, CYLNDR, DISC), got the word {}",
                shape));
      if (shape != "SPHERE")
        warn(s.params[i].span, "sema.sensor-shape",
             fmt::format("S({}) has a {} tip: the virtual CMM probes with a ball of its diameter; the shape's other "
                         "sizes are not used",
                         s.target->name, shape));
      break;
    }
    if (!push_number(in, s.params[i], "a sensor parameter")) return;
  }
  note_definition("S", upper(s.target->name), s.span);
  m_symbols.sensors.insert(upper(s.target->name));
  emit(std::move(in));
}

// T(l)=TOL/kind,...
void UnitCompiler::tol(const grammar::Statement& s) {
  if (!require_target(s, {"T", "TA"}, "T(label)=TOL/...")) return;
  if (upper(s.target->prefix) == "TA") {
    // TA(l)=TOL/kind,value,INTOL|OUTOL: a tolerance result a DMIS output file reports.
    note_once(m_reported_results_noted, s.target->span, "sema.reported-tolerance",
              fmt::format("TA({})=TOL/... is a reported tolerance result (a DMIS output file's line): kept as it is, "
                          "not evaluated",
                          s.target->name));
    emit(make(Op::Nop, s, "TOL"));
    return;
  }
  if (!expect_params(s, 1, "the tolerance type")) return;
  const auto& p = s.params;
  auto parsed = is_word(p[0]) ? ir::parse_word<ToleranceKind>(p[0].text) : std::nullopt;
  // Older and vendor spellings of the runouts: RUNOUT (circular, or TOTAL when the word follows),
  // TRNOUT for total runout.
  if (!parsed && is_word(p[0], "RUNOUT"))
    parsed = std::any_of(p.begin(), p.end(), [](const grammar::Expr& e) { return is_word(e, "TOTAL"); })
                 ? ToleranceKind::Totrun
                 : ToleranceKind::Crnout;
  if (!parsed && is_word(p[0], "TRNOUT")) parsed = ToleranceKind::Totrun;
  if (!parsed && (is_word(p[0], "SYMMETRY") || is_word(p[0], "SYM"))) parsed = ToleranceKind::Symmty;
  // DMIS spells the angle to a reference ANGLWRT and coaxiality COAXL in places.
  if (!parsed && is_word(p[0], "ANGLWRT")) parsed = ToleranceKind::AngWrt;
  if (!parsed && is_word(p[0], "COAXL")) parsed = ToleranceKind::Coaxial;
  // TOL/COMPOS[,2D|3D],PATERN,zone[,MMC|LMC|RFS][,DAT()...],FEATUR,zone[,MMC|LMC|RFS][,DAT()...]
  // (composite position). Another layout is read as before: not evaluated, with a warning.
  if (parsed == ToleranceKind::Compos) {
    const std::size_t tier1 = p.size() > 1 && (is_word(p[1], "2D") || is_word(p[1], "3D")) ? 2 : 1;
    const auto featur = std::find_if(p.begin() + static_cast<std::ptrdiff_t>(std::min(tier1, p.size())), p.end(),
                                     [](const grammar::Expr& e) { return is_word(e, "FEATUR"); });
    if (p.size() <= tier1 || !is_word(p[tier1], "PATERN") || featur == p.end()) parsed.reset();
  }
  if (!parsed) {
    // DMIS 5.3 tolerance types a CMM program uses that metron does not evaluate yet: the OUTPUT
    // of one is left out with a warning instead of failing the program.
    // A type metron does not know (a vendor's, or one of another DMIS version)
    // is treated alike: one program's unknown tolerance must not stop the rest of it.
    static const std::set<std::string> standard = {"PROFT",  "CPARLN", "USETOL", "COMPOS", "GAP",
                                                   "PNTDEF", "CPROFS", "CPROFL", "FLUSH"};
    if (is_word(p[0], "LOCTOL") && p.size() == 2 && !m_strict) {
      // WinWerth's: the zone of the CONST/LOCTOL feature an OUTPUT names with it.
      m_location_zones[upper(s.target->name)] = s;
      m_symbols.unevaluated_tolerances[upper(s.target->name)] = p[0].text;
      m_symbols.tolerances.erase(upper(s.target->name));
      emit(make(Op::Nop, s, "TOL"));
      return;
    }
    if (is_word(p[0])) {
      warn(p[0].span, "sema.unevaluated-tolerance",
           fmt::format("tolerance type {} {}; the OUTPUT of T({}) will be left out", p[0].text,
                       standard.count(p[0].text) ? "is not evaluated by metron" : "is not one metron knows",
                       s.target->name));
      m_symbols.unevaluated_tolerances[upper(s.target->name)] = p[0].text;
      m_symbols.tolerances.erase(upper(s.target->name));
      emit(make(Op::Nop, s, "TOL"));
      return;
    }
    return error(p[0].span, "sema.bad-tolerance",
                 "expected a tolerance type (DIAM, RAD, DISTB, POS, FLAT, ...) after TOL/");
  }
  // Forms of known types metron does not evaluate (CORTOL with a coordinate other than XAXIS,
  // YAXIS, ZAXIS, RADIUS or ANGLE): left out as an unknown type is, with the form named.
  const auto any_word = [&](std::initializer_list<const char*> ws) {
    return std::any_of(p.begin() + 1, p.end(), [&](const grammar::Expr& e) {
      return std::any_of(ws.begin(), ws.end(), [&](const char* w) { return is_word(e, w); });
    });
  };
  std::string form;
  if (*parsed == ToleranceKind::Cortol && !any_word({"XAXIS", "YAXIS", "ZAXIS", "RADIUS", "ANGLE"}))
    for (std::size_t i = 1; i < p.size() && form.empty(); ++i)
      if (is_word(p[i]) && !is_variable(p[i].text)) form = p[0].text + "," + p[i].text;
  // TOL/DISTB|DISTWRT,LIMIT,lolim,uplim,...: the distance's limits instead of a nominal and tolerances.
  const bool limit_form = (*parsed == ToleranceKind::DistB || *parsed == ToleranceKind::DistWrt) && any_word({"LIMIT"});
  if (!form.empty()) {
    warn(p[0].span, "sema.unevaluated-tolerance",
         fmt::format("TOL/{} is not evaluated by metron; the OUTPUT of T({}) will be left out", form, s.target->name));
    m_symbols.unevaluated_tolerances[upper(s.target->name)] = form;
    m_symbols.tolerances.erase(upper(s.target->name));
    emit(make(Op::Nop, s, "TOL"));
    return;
  }
  const ToleranceKind kind = *parsed;
  const std::string& word = p[0].text;
  auto in = make(Op::ToleranceDef, s, upper(s.target->name));
  in.name_is_param = macro_param(upper(s.target->name)).has_value();
  in.payload = ir::TolerancePayload{kind};
  std::vector<double> numbers;
  std::vector<std::size_t> number_operands;  // where each number stands among the operands
  bool has_reference = false;
  // TOL/POS,DIAM,...: a generator's way to ask for a diametral zone (the drawing's diameter sign)
  // where DMIS writes 2D: read as 2D (a circular zone about the nominal position in the plane
  // normal to the feature, a cylindrical one about an axis); --strict: an error below.
  const bool diametral_position = kind == ToleranceKind::Pos && p.size() > 1 && is_word(p[1], "DIAM") && !m_strict;
  if (diametral_position)
    warn(p[1].span, "sema.position-diam",
         std::string("TOL/POS takes 2D or 3D; DIAM (a diametral zone) is read as 2D, the zone of 2D being diametral "
                     "about the nominal position (--strict makes this an error)"));
  for (std::size_t i = 1; i < p.size(); ++i) {
    if (diametral_position && i == 1) {
      in.operands.push_back(word_operand("2D", p[1].span));
      continue;
    }
    // A material modifier right after a datum is the datum's (`DAT(B),MMC`), not the feature's:
    // it is not passed on, so it cannot change the feature's condition, and it is told.
    if (i > 1 && is_label(p[i - 1], {"DAT", "DATT"}) &&
        (is_word(p[i], "MMC") || is_word(p[i], "LMC") || is_word(p[i], "RFS"))) {
      if (is_word(p[i], "RFS")) continue;
      if (kind == ToleranceKind::Pos) {  // the datum shift of POS (docs/tolerances.md "Datum shift")
        in.operands.push_back(word_operand("DATUM-" + p[i].text, p[i].span));
        continue;
      }
      warn(p[i].span, "sema.datum-modifier",
           fmt::format("DAT({}) at {}: the datums of TOL/{} are evaluated RFS, metron applies no datum shift",
                       p[i - 1].label.name, p[i].text, p[0].text));
      continue;
    }
    if (p[i].kind == ExprKind::Label && (kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt) &&
        is_label(p[i], {"F", "FA"})) {
      // TOL/DISTWRT,NOMINL,d,lo,hi,FA(ref),XAXIS,AVG: the reference feature is part of the tolerance.
      if (!check_feature(p[i])) return;
      in.operands.push_back(label_op(p[i]));
      has_reference = true;
    } else if (p[i].kind == ExprKind::Label) {
      if (!is_label(p[i], {"DAT", "DATT"})) return error(p[i].span, "sema.expected-datum", "expected a datum DAT(x)");
      const std::string d = upper(p[i].label.name);
      if (!m_symbols.datums.count(d) && !named_at_run(d))
        warn(p[i].span, "sema.datum-later",
             fmt::format("datum DAT({}) is not defined yet; it must be defined by DATDEF before the OUTPUT",
                         p[i].label.name));
      in.operands.push_back(label_op(p[i]));
      // DISTWRT and ANGWRT are taken with respect to a feature or, as written here, a datum's.
      if (kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt) has_reference = true;
    } else if (is_word(p[i]) && !is_variable(p[i].text)) {
      // DIAM and RAD take one word, AVG|MAX|MIN, or DIAMLP (RationalDMIS: the two-point size of
      // ISO 14405-1); another is not applied, and is told rather than dropped unseen.
      if ((kind == ToleranceKind::Diam || kind == ToleranceKind::Rad) &&
          !(is_word(p[i], "AVG") || is_word(p[i], "MAX") || is_word(p[i], "MIN") || is_word(p[i], "DIAMLP"))) {
        warn(p[i].span, "sema.size-modifier",
             fmt::format("TOL/{} takes AVG, MAX, MIN or DIAMLP after its limits; {} is not applied: T({}) is the "
                         "least-squares size (AVG)",
                         p[0].text, p[i].text, s.target->name));
        continue;
      }
      in.operands.push_back(word_operand(p[i]));
    } else {
      auto e = numeric(p[i], "a tolerance value");
      if (!e) return;
      numbers.push_back(literal_value(*e));
      number_operands.push_back(in.operands.size());
      in.operands.push_back(expr_operand(std::move(*e)));
    }
  }
  ToleranceNumbers need =
      limit_form ? ToleranceNumbers{2, "the lower and upper limit of the distance", false} : tolerance_numbers(kind);
  // TOL/PROFS|PROFL|PROFP,t[,DAT...]: one number is the zone's width, centred on the nominal
  // profile as ISO 1101 draws it (-t/2, +t/2); DMIS writes the two limits.
  const bool profile = kind == ToleranceKind::Profs || kind == ToleranceKind::Profl || kind == ToleranceKind::Profp;
  if (profile && numbers.size() == 1) {
    if (!std::isnan(numbers[0]) && numbers[0] < 0)
      return error(p.back().span, "sema.negative-zone", "a tolerance zone must not be negative");
    warn(p[0].span, "sema.profile-zone",
         fmt::format("TOL/{} takes the lower and upper tolerance; the one number is read as a zone of that width "
                     "centred on the nominal profile (-t/2 to +t/2), as ISO 1101 draws it",
                     word));
    need = ToleranceNumbers{1, "the tolerance zone", true};
  }
  if (numbers.size() < need.count)
    return error(p.back().span, "sema.tolerance-arity",
                 fmt::format("TOL/{} expects {} ({} number{}), got {}", word, need.meaning, need.count,
                             need.count == 1 ? "" : "s", numbers.size()));
  if ((kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt) && !has_reference)
    return error(p.back().span, "sema.expected-feature",
                 fmt::format("TOL/{} needs the reference feature FA(x) or datum DAT(x)", word));
  if (kind == ToleranceKind::Cortol && !any_word({"XAXIS", "YAXIS", "ZAXIS", "RADIUS", "ANGLE"}))
    return error(p[0].span, "sema.expected-axis",
                 "TOL/CORTOL needs the coordinate: XAXIS, YAXIS, ZAXIS, RADIUS or ANGLE");
  // The lower and upper tolerance: the first two numbers, after the nominal for a distance or an
  // angle (not LIMIT's limits, below).
  const bool two_limits = kind == ToleranceKind::Diam || kind == ToleranceKind::Rad || kind == ToleranceKind::Profs ||
                          kind == ToleranceKind::Profl || kind == ToleranceKind::Profp ||
                          kind == ToleranceKind::Cortol || kind == ToleranceKind::Width || kind == ToleranceKind::Angl;
  const bool after_nominal = !limit_form && (kind == ToleranceKind::DistB || kind == ToleranceKind::DistWrt ||
                                             kind == ToleranceKind::AngWrt || kind == ToleranceKind::Anglb);
  const std::size_t lo = after_nominal ? 1 : 0, hi = lo + 1;
  if ((two_limits || after_nominal) && numbers.size() > hi && numbers[lo] > numbers[hi]) {
    const Span at = in.operands[number_operands[hi]].expr.span;
    if (m_strict)
      return error(at, "sema.tolerance-order",
                   fmt::format("the lower tolerance {} is above the upper tolerance {}", numbers[lo], numbers[hi]));
    // WinWerth writes the upper tolerance first (TOL/DIAM,-0.03,-0.05): read leniently as the
    // two limits of the zone they bound.
    warn(at, "sema.tolerance-order",
         fmt::format("the lower tolerance {} is above the upper tolerance {}: read as lower {} and upper {} (the "
                     "upper written first; --strict makes it an error)",
                     numbers[lo], numbers[hi], numbers[hi], numbers[lo]));
    std::swap(numbers[lo], numbers[hi]);
    std::swap(in.operands[number_operands[lo]], in.operands[number_operands[hi]]);
  }
  if (limit_form && numbers[0] > numbers[1])
    return error(p[3].span, "sema.tolerance-order",
                 fmt::format("the lower limit {} is above the upper limit {}", numbers[0], numbers[1]));
  if ((kind == ToleranceKind::Perp || kind == ToleranceKind::Parlel || kind == ToleranceKind::Anglr ||
       kind == ToleranceKind::Concen || kind == ToleranceKind::Coaxial || kind == ToleranceKind::Crnout ||
       kind == ToleranceKind::Totrun || kind == ToleranceKind::Symmty) &&
      std::none_of(in.operands.begin(), in.operands.end(),
                   [](const ir::Operand& o) { return o.kind == ir::Operand::Kind::Label; }))
    return error(p.back().span, "sema.expected-datum", fmt::format("TOL/{} needs a datum DAT(x)", word));
  if (kind == ToleranceKind::Compos) {
    // One zone in each tier.
    std::size_t in_tier = 0;
    for (std::size_t i = 1; i <= p.size(); ++i) {
      if (i == p.size() || is_word(p[i], "FEATUR")) {
        if (in_tier != 1)
          return error(p[i - 1].span, "sema.tolerance-arity",
                       fmt::format("each tier of TOL/COMPOS takes one zone, got {} in the {} tier", in_tier,
                                   i == p.size() ? "FEATUR" : "PATERN"));
        in_tier = 0;
        continue;
      }
      if (!is_word(p[i]) && p[i].kind != ExprKind::Label) ++in_tier;
    }
  }
  if (kind == ToleranceKind::Pos && !diametral_position && !(is_word(p[1], "2D") || is_word(p[1], "3D")))
    return error(p.size() > 1 ? p[1].span : p[0].span, "sema.expected-dimension", "expected 2D or 3D after TOL/POS");
  // TOL/ANGLR,zone,angle: no public DMIS text gives the order; the basic angle is the number of
  // the larger magnitude, the zone the other, whichever comes first (docs/tolerances.md
  // "Angularity").
  if (kind == ToleranceKind::Anglr && !std::isnan(numbers[0]) && !std::isnan(numbers[1]) &&
      (std::abs(numbers[0]) < std::abs(numbers[1]) ? numbers[0] : numbers[1]) < 0)
    return error(p.back().span, "sema.negative-zone", "a tolerance zone must not be negative");
  if (!std::isnan(numbers[0]) && need.zone && numbers[0] < 0)
    return error(p.back().span, "sema.negative-zone", "a tolerance zone must not be negative");
  // TOL/FLAT,t,tu,a[,b] and TOL/STRGHT,t,tu,l: a zone per unit area (a x b; a square of a) or per
  // unit length (DMIS 5.x; ASME Y14.5 "per unit" form).
  const bool per_unit = (kind == ToleranceKind::Flat && (numbers.size() == 3 || numbers.size() == 4)) ||
                        (kind == ToleranceKind::Strght && numbers.size() == 3);
  if (per_unit) {
    if (!std::isnan(numbers[1]) && numbers[1] < 0)
      return error(p[2].span, "sema.negative-zone", "a tolerance zone must not be negative");
    for (std::size_t k = 2; k < numbers.size(); ++k)
      if (!std::isnan(numbers[k]) && !(numbers[k] > 0))
        return error(p[k + 1].span, "sema.unit-size",
                     fmt::format("the unit {} of TOL/{} must be positive",
                                 kind == ToleranceKind::Flat ? "area's side" : "length", word));
  }
  if (kind != ToleranceKind::Compos && !per_unit && numbers.size() > need.count) {
    // TOL/FLAT,0.1,0.2 (a per-unit zone, a vendor's extra): the numbers past the form's were
    // dropped unseen.
    const std::size_t extra = numbers.size() - need.count;
    warn(s.span, "sema.tolerance-arity",
         fmt::format("TOL/{} takes {} ({} number{}); the {} number{} after {} not used", word, need.meaning, need.count,
                     need.count == 1 ? "" : "s", extra, extra == 1 ? "" : "s", extra == 1 ? "it is" : "them are"));
  }
  note_definition("T", upper(s.target->name), s.span);
  m_symbols.tolerances[upper(s.target->name)] = kind;
  m_symbols.unevaluated_tolerances.erase(upper(s.target->name));
  if (std::any_of(in.operands.begin(), in.operands.end(), [](const ir::Operand& o) {
        return o.kind == ir::Operand::Kind::Label && (o.label.prefix == "DAT" || o.label.prefix == "DATT");
      }))
    m_symbols.tolerance_datums.insert(upper(s.target->name));
  else
    m_symbols.tolerance_datums.erase(upper(s.target->name));
  emit(std::move(in));
}

// DATDEF/FA(x),DAT(A)
void UnitCompiler::datdef(const grammar::Statement& s) {
  if (!expect_params(s, 2, "a feature FA(x) and a datum DAT(y)")) return;
  if (!is_label(s.params[0], {"F", "FA"}))
    return error(s.params[0].span, "sema.expected-feature", "expected FA(label) after DATDEF/");
  if (m_output_file && is_label(s.params[1], {"DAT"}) && never_defined(upper(s.params[0].label.name))) {
    // An output file echoes the program's DATDEF without restating the feature.
    note_once(m_echo_noted, s.span, "sema.echoed-line",
              "an echo of the measuring program's line: this output file does not state its feature; kept as it is");
    m_echoed_datums.insert(upper(s.params[1].label.name));
    emit(make(Op::Nop, s, "DATDEF"));
    return;
  }
  if (!check_feature(s.params[0])) return;
  if (!is_label(s.params[1], {"DAT"}))
    return error(s.params[1].span, "sema.expected-datum", "expected DAT(label) after the feature");
  if (s.params.size() > 2)
    warn(s.params[2].span, "sema.datdef-arity",
         fmt::format("DATDEF names one datum: {}({}) is DAT({}); what follows it is not used",
                     upper(s.params[0].label.prefix), s.params[0].label.name, s.params[1].label.name));
  // A second DATDEF of one datum silently replaced the first (issue 15): say so.
  note_definition("DAT", upper(s.params[1].label.name), s.span);
  m_symbols.datums.insert(upper(s.params[1].label.name));
  auto in = make(Op::DatDef, s);
  in.operands.push_back(label_op(s.params[0]));
  in.operands.push_back(label_op(s.params[1]));
  emit(std::move(in));
}

// P(l)=PATH/LINE,CART,x1,y1,z1,x2,y2,z2,i,j,k
// P(l)=PATH/ARC,CART,x,y,z,i,j,k,rad,ang1,ang2[,INNER|OUTER]
// P(l)=PATH/HELICAL,CART,x,y,z,i,j,k,rad,ang1,ang2,pitch[,INNER|OUTER]
void UnitCompiler::path(const grammar::Statement& s) {
  if (!require_target(s, {"P"}, "P(label)=PATH/...")) return;
  if (!expect_params(s, 1, "the path type (LINE, ARC, HELICAL, SECTION)")) return;
  const auto& p = s.params;
  const std::string name = upper(s.target->name);
  if (is_word(p[0], "SECTION")) return path_section(s);
  static const std::set<std::string> kinds = {"LINE", "ARC", "HELICAL"};
  if (!is_word(p[0]) || !kinds.count(p[0].text)) {
    if (is_word(p[0])) {
      warn(p[0].span, "sema.unsupported-path",
           fmt::format("PATH/{} is not supported; P({}) is skipped", p[0].text, s.target->name));
      m_symbols.skipped["P:" + name] = s.span;
      emit(make(Op::Nop, s, "PATH"));
      return;
    }
    return error(p[0].span, "sema.bad-path", "expected LINE, ARC or HELICAL after PATH/");
  }
  const std::string kind = p[0].text;
  if (p.size() < 2 || !(is_word(p[1], "CART") || is_word(p[1], "POL")))
    return error(p.size() < 2 ? p[0].span : p[1].span, "sema.expected-form",
                 fmt::format("expected CART after PATH/{}", kind));
  if (is_word(p[1], "POL"))
    return error(p[1].span, "sema.unsupported-form", "PATH with POL coordinates is not supported: use CART");
  auto in = make(Op::PathDef, s, name);
  in.operands.push_back(word_operand(p[0]));
  std::size_t end = p.size();
  std::optional<ir::Operand> side;
  if (kind != "LINE" && end > 2 && is_word(p[end - 1]) && !is_variable(p[end - 1].text)) {
    if (!is_word(p[end - 1], "INNER") && !is_word(p[end - 1], "OUTER"))
      return error(p[end - 1].span, "sema.expected-side",
                   fmt::format("expected INNER or OUTER at the end of PATH/{}", kind));
    side = word_operand(p[end - 1]);
    --end;
  }
  const std::size_t want = kind == "LINE" ? 9 : kind == "ARC" ? 9 : 10;
  const char* form = kind == "LINE"  ? "x1,y1,z1,x2,y2,z2,i,j,k"
                     : kind == "ARC" ? "x,y,z,i,j,k,rad,ang1,ang2"
                                     : "x,y,z,i,j,k,rad,ang1,ang2,pitch";
  const std::size_t n = end - 2;
  if (n != want)
    return error(end > 2 ? p[end - 1].span : p[1].span, "sema.path-arity",
                 fmt::format("PATH/{} expects {} numbers ({}), got {}", kind, want, form, n));
  if (side) in.operands.push_back(*side);
  std::vector<double> v;
  for (std::size_t i = 2; i < end; ++i) {
    auto e = numeric(p[i], "a path parameter");
    if (!e) return;
    v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
    in.operands.push_back(expr_operand(std::move(*e)));
  }
  const std::size_t vec = kind == "LINE" ? 6 : 3;
  if (v[vec] == 0 && v[vec + 1] == 0 && v[vec + 2] == 0)
    return error(p[2 + vec].span, "sema.zero-vector", "the path vector i,j,k is zero");
  if (kind != "LINE" && v[6] <= 0)
    return error(p[8].span, "sema.bad-size", fmt::format("the radius of P({}) must be positive", s.target->name));
  if (kind != "LINE" && v[7] == v[8])
    return error(p[10].span, "sema.bad-angle", "the start and end angles of the path are equal");
  if (kind == "LINE" && v[0] == v[3] && v[1] == v[4] && v[2] == v[5])
    return error(p[5].span, "sema.bad-path", "the line's end points are the same");
  m_symbols.paths.insert(name);
  m_symbols.skipped.erase("P:" + name);
  emit(std::move(in));
}

// P(l)=PATH/SECTION,'file',x,y,z,i,j,k,xs,ys,zs[,xe,ye,ze]   (metron: a plane section of a CAD model)
void UnitCompiler::path_section(const grammar::Statement& s) {
  const auto& p = s.params;
  if (p.size() < 2 || p[1].kind != ExprKind::String)
    return error(p.size() < 2 ? p[0].span : p[1].span, "sema.expected-file",
                 "expected the CAD file name as a string after PATH/SECTION, e.g. 'part.stl'");
  std::filesystem::path file(p[1].text);
  if (file.is_relative()) file = std::filesystem::path(m_module.units[m_unit].path).parent_path() / file;
  if (!std::filesystem::exists(file))
    return error(p[1].span, "sema.missing-file", fmt::format("CAD file '{}' not found", p[1].text));
  warn_if_unreadable(p[1].span, "PATH/SECTION", file.string());
  const std::size_t n = p.size() - 2;
  if (n != 9 && n != 12)
    return error(
        p.back().span, "sema.path-arity",
        fmt::format("PATH/SECTION expects the file and 9 numbers (plane point x,y,z, plane normal i,j,k, start near "
                    "xs,ys,zs) or 12 (and end near xe,ye,ze), got {}",
                    n));
  auto in = make(Op::PathDef, s, upper(s.target->name));
  in.operands.push_back(word_operand(p[0]));
  in.names.push_back(file.string());
  std::vector<double> v;
  for (std::size_t i = 2; i < p.size(); ++i) {
    auto e = numeric(p[i], "a path parameter");
    if (!e) return;
    v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
    in.operands.push_back(expr_operand(std::move(*e)));
  }
  if (v[3] == 0 && v[4] == 0 && v[5] == 0)
    return error(p[5].span, "sema.zero-vector", "the plane normal i,j,k is zero");
  m_symbols.paths.insert(upper(s.target->name));
  m_symbols.skipped.erase("P:" + upper(s.target->name));
  emit(std::move(in));
}

// DECL/[COMMON|GLOBAL|LOCAL,]INTGR|LONG|REAL|DOUBLE|BOOL|CHAR,n|VECTOR,V1,V2[10]
void UnitCompiler::decl(const grammar::Statement& s) {
  if (!expect_params(s, 2, "a type and variable names")) return;
  std::size_t i = 0;
  if (is_word(s.params[0], "COMMON") || is_word(s.params[0], "GLOBAL") || is_word(s.params[0], "LOCAL")) ++i;
  if (i >= s.params.size() || !is_word(s.params[i]))
    return error(s.params[i < s.params.size() ? i : 0].span, "sema.bad-type",
                 "expected a type (INTGR, LONG, REAL, DOUBLE, BOOL, CHAR, VECTOR) after DECL/");
  const std::optional<ValueType> type = declared_type(s.params[i].text);
  if (!type)
    return error(
        s.params[i].span, "sema.bad-type",
        fmt::format("unknown type {}: expected INTGR, LONG, REAL, DOUBLE, BOOL, CHAR or VECTOR", s.params[i].text));
  auto in = make(Op::Declare, s);
  ir::Operand type_word;
  type_word.kind = ir::Operand::Kind::Word;
  type_word.word = s.params[i].text;
  in.operands.push_back(type_word);
  ++i;
  if (*type == ValueType::String && i < s.params.size() && s.params[i].kind == ExprKind::Number) ++i;  // CHAR length
  if (i >= s.params.size())
    return error(s.params.back().span, "sema.missing-parameter", "expected variable names after the type");
  for (; i < s.params.size(); ++i) {
    const auto& p = s.params[i];
    int size = 0;
    std::vector<int> dims;
    if (p.kind == ExprKind::Index) {
      // At most max_array_size elements, whole numbers: V[1e9] would allocate gigabytes, a size
      // of 2^31 or more wrapped to 1 and V[2.5] was taken as 2 (issue 15). DMIS arrays may have
      // several dimensions (V[3,30], RationalDMIS's DECL/COMMON,DOUBLE,NUM[3,30]).
      constexpr double max_array_size = 1'000'000;
      double elements = 1;
      for (const auto& a : p.args) {
        if (a.kind != ExprKind::Number || !(a.number >= 1) || a.number != std::floor(a.number))
          return error(a.span, "sema.bad-array",
                       "an array declaration needs positive whole sizes, e.g. V1[10] or V2[3,30]");
        elements *= a.number;
        if (elements > max_array_size)
          return error(a.span, "sema.bad-array",
                       fmt::format("array {} of {:g} elements exceeds the limit of {:g} elements (docs/limits.md)",
                                   p.text, elements, max_array_size));
        dims.push_back(static_cast<int>(a.number));
      }
      if (dims.empty())
        return error(p.span, "sema.bad-array",
                     "an array declaration needs positive whole sizes, e.g. V1[10] or V2[3,30]");
      size = static_cast<int>(elements);
    } else if (p.kind != ExprKind::Word || p.text.empty()) {
      return error(p.span, "sema.expected-name", "expected a variable name");
    }
    SymbolTable::VariableInfo info{*type, size, p.span, dims};
    if (!m_repl) {
      // A second DECL of one name silently replaced the first (its type and size).
      const auto& scope = m_macro ? m_locals : m_symbols.variables;
      if (auto prior = scope.find(p.text); prior != scope.end() && prior->second.span.file == p.span.file) {
        const Location at = m_sources.locate(prior->second.span);
        warn(p.span, "sema.redeclared",
             fmt::format("variable {} is declared again (first at line {}); the later declaration replaces it", p.text,
                         at.line));
      }
    }
    if (m_macro)
      m_locals[p.text] = info;
    else
      m_symbols.variables[p.text] = info;
    in.names.push_back(p.text);
    ir::Operand sz;
    sz.kind = ir::Operand::Kind::Expr;
    sz.expr.value = Value::integer(size);
    if (dims.size() > 1)  // the run indexes V[i,j] by the dimensions (row-major, the last index fastest)
      for (int d : dims) {
        ir::Expr dim;
        dim.value = Value::integer(d);
        sz.expr.args.push_back(std::move(dim));
      }
    in.operands.push_back(sz);
  }
  emit(std::move(in));
}

}  // namespace metron::interpreter::detail
