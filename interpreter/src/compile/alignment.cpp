// SPDX-License-Identifier: GPL-3.0-or-later
// Alignment and constructions: DATSET, TRANS, ROTATE, SAVE, RECALL, CONST, OUTPUT.
#include <algorithm>
#include <cmath>

#include "compile/unit_compiler.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;
using runtime::FeatureType;
using runtime::ToleranceKind;

namespace {

/// A tolerance CMM software reports for a feature type metron does not evaluate it for: the
/// orientation of a circle (from its vector), the flatness of a circle's points, the
/// straightness of a cone's or a plane's line elements. Other mismatches (DIAM of a PLANE,
/// CYLCTY of a slot) are mistakes no machine ran.
bool reported_elsewhere(ToleranceKind kind, FeatureType type) {
  using T = FeatureType;
  switch (kind) {
    case ToleranceKind::Perp:
    case ToleranceKind::Parlel:
    case ToleranceKind::Anglr: return type == T::Circle || type == T::Arc || type == T::Ellipse;
    case ToleranceKind::Flat: return type == T::Circle;
    case ToleranceKind::Strght: return type == T::Cone || type == T::Plane;
    default: return false;
  }
}

/// The feature types metron evaluates a tolerance for, as DMIS words: "PLANE, LINE or CYLNDR".
std::string applicable_types(ToleranceKind kind) {
  std::vector<std::string> words;
  for (int t = 0; t <= static_cast<int>(FeatureType::Ellipse); ++t)
    if (runtime::tolerance_applies(kind, static_cast<FeatureType>(t)))
      words.emplace_back(ir::word_of(static_cast<FeatureType>(t)));
  std::string text;
  for (std::size_t i = 0; i < words.size(); ++i)
    text += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i];
  return text;
}

}  // namespace

void UnitCompiler::add_alignment(StatementTable& t) {
  t.insert({{"DATSET", &UnitCompiler::datset},
            {"TRANS", &UnitCompiler::trans},
            {"ROTATE", &UnitCompiler::rotate},
            {"LOCATE", &UnitCompiler::locate},
            {"ITERAT", &UnitCompiler::iterate},
            {"SAVE", &UnitCompiler::save},
            {"RECALL", &UnitCompiler::recall},
            {"CONST", &UnitCompiler::construct},
            {"OUTPUT", &UnitCompiler::output},
            {"EVAL", &UnitCompiler::evaluate}});
}

// A DAT(x), FA(x) or F(x) parameter appended to `in`, checked as DATSET, LOCATE and ITERAT need it
// (a datum DATDEF defined, a feature defined): nullopt when `p` is none of them, false when its
// check failed (reported).
std::optional<bool> UnitCompiler::push_datum_or_feature(ir::Instruction& in, const grammar::Expr& p) {
  if (is_label(p, {"DAT"})) {
    const std::string d = upper(p.label.name);
    if (!m_symbols.datums.count(d) && !named_at_run(d)) {
      error(p.span, "sema.undefined-datum",
            fmt::format("datum DAT({}) is not defined: use DATDEF/FA(x),DAT({}) first", p.label.name, p.label.name));
      return false;
    }
  } else if (is_label(p, {"FA", "F"})) {
    if (!check_feature(p)) return false;
  } else {
    return std::nullopt;
  }
  in.operands.push_back(label_op(p));
  return true;
}

// D(l)=DATSET/MCS | D(l)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XDIR,...   (-ZDIR = ZMINUS; FA(x) in
// place of DAT(A), as CAMIO and PC-DMIS write it: the feature's actual)
void UnitCompiler::datset(const grammar::Statement& s) {
  if (s.target && upper(s.target->prefix) == "DA") {
    // DA(l)=DATSET/TRMATX,...: the alignment a DMIS output file reports.
    note_once(m_reported_results_noted, s.target->span, "sema.reported-alignment",
              fmt::format("DA({})=DATSET/... is a reported alignment (a DMIS output file's line): kept as it is",
                          s.target->name));
    emit(make(Op::Nop, s, "DATSET"));
    return;
  }
  if (!require_target(s, {"D"}, "D(label)=DATSET/...")) return;
  if (!expect_params(s, 1, "MCS or datums")) return;
  if (m_output_file && std::any_of(s.params.begin(), s.params.end(), [&](const grammar::Expr& p) {
        return is_label(p, {"DAT"}) && m_echoed_datums.count(upper(p.label.name));
      })) {
    note_once(m_echo_noted, s.span, "sema.echoed-line",
              "an echo of the measuring program's line: this output file does not state its feature; kept as it is");
    emit(make(Op::Nop, s, "DATSET"));
    return;
  }
  auto in = make(Op::DatSet, s, upper(s.target->name));
  static const std::set<std::string> words = {"XDIR",   "YDIR",  "ZDIR",  "XMINUS", "YMINUS",
                                              "ZMINUS", "XORIG", "YORIG", "ZORIG"};
  if (is_word(s.params[0], "MCS")) {
    in.operands.push_back(word_operand(s.params[0]));
  } else {
    bool have_datum = false;
    for (const auto& param : s.params) {
      const grammar::Expr p = unsigned_direction(param);
      if (const auto pushed = push_datum_or_feature(in, p)) {
        if (!*pushed) return;
        have_datum = true;
      } else if (is_word(p) && words.count(p.text)) {
        if (!have_datum)
          return error(p.span, "sema.expected-datum",
                       fmt::format("expected DAT(label) or FA(label) before {}", p.text));
        in.operands.push_back(word_operand(p));
      } else {
        return error(p.span, "sema.bad-datset",
                     "expected DAT(label), FA(label) or XDIR, YDIR, ZDIR, XMINUS, ..., XORIG, YORIG, ZORIG");
      }
    }
  }
  m_symbols.alignments.insert(upper(s.target->name));
  emit(std::move(in));
}

// D(l)=TRANS/XORIG,v|FA(f),YORIG,...
void UnitCompiler::trans(const grammar::Statement& s) {
  if (!require_target(s, {"D"}, "D(label)=TRANS/...")) return;
  if (s.params.empty() || s.params.size() % 2 != 0)
    return error(s.params.empty() ? s.major_span : s.params.back().span, "sema.trans-arity",
                 "TRANS expects pairs of XORIG|YORIG|ZORIG and a value or feature");
  auto in = make(Op::Trans, s, upper(s.target->name));
  for (std::size_t i = 0; i < s.params.size(); i += 2) {
    const auto& w = s.params[i];
    if (!(is_word(w, "XORIG") || is_word(w, "YORIG") || is_word(w, "ZORIG")))
      return error(w.span, "sema.bad-trans", "expected XORIG, YORIG or ZORIG");
    in.operands.push_back(word_operand(w));
    const auto& v = s.params[i + 1];
    if (is_label(v, {"F", "FA"})) {
      if (!check_feature(v)) return;
      in.operands.push_back(label_op(v));
    } else {
      if (!push_number(in, v, "an origin coordinate")) return;
    }
  }
  m_symbols.alignments.insert(upper(s.target->name));
  emit(std::move(in));
}

// D(l)=LOCATE/[XDIR,YDIR,ZDIR,XAXIS,YAXIS,ZAXIS,]FA(f)|F(f)|DAT(d),...: the best-fit alignment
// (docs/alignments.md). The words are the motions the fit may make (along, about the current
// axes; all six when none is written); another word is not read (a warning; --strict: an error).
void UnitCompiler::locate(const grammar::Statement& s) {
  if (!require_target(s, {"D"}, "D(label)=LOCATE/...")) return;
  if (!expect_params(s, 1, "the features to fit")) return;
  auto in = make(Op::Locate, s, upper(s.target->name));
  static const std::set<std::string> freedoms = {"XDIR", "YDIR", "ZDIR", "XAXIS", "YAXIS", "ZAXIS"};
  bool have_feature = false;
  for (const auto& param : s.params) {
    const grammar::Expr p = unsigned_direction(param);
    if (const auto pushed = push_datum_or_feature(in, p)) {
      if (!*pushed) return;
      have_feature = true;
    } else if (is_word(p) && freedoms.count(p.text)) {
      in.operands.push_back(word_operand(p));
    } else if (m_strict) {
      return error(p.span, "sema.bad-locate",
                   "expected XDIR, YDIR, ZDIR, XAXIS, YAXIS, ZAXIS or a feature FA(x), F(x), DAT(x)");
    } else {
      warn(p.span, "sema.bad-locate",
           "not read: LOCATE is a least-squares fit of the features named, moving along (XDIR, YDIR, ZDIR) and "
           "about (XAXIS, YAXIS, ZAXIS) the axes written (--strict: an error)");
    }
  }
  if (!have_feature) return error(s.major_span, "sema.bad-locate", "LOCATE needs at least one feature to fit");
  m_symbols.alignments.insert(upper(s.target->name));
  emit(std::move(in));
}

// D(l)=ITERAT/[dir,]FA(a),FA(b),...,[dir,]FA(c),...,(label),accuracy,count[,ABSL|INCR]: an
// iterative alignment (docs/alignments.md). Each time it is reached the features are fitted as
// LOCATE fits them (six freedoms; the direction words that group them are not needed for it) and
// D(l) made current; while the test is not within the accuracy and fewer than `count` fits were
// made, the program goes back to (label) to measure the features again in the new alignment.
// A statement not of this form is skipped with a warning, as before metron read ITERAT.
void UnitCompiler::iterate(const grammar::Statement& s) {
  if (!require_target(s, {"D"}, "D(label)=ITERAT/...")) return;
  const auto skip = [&](Span at, const std::string& why) {
    warn(at, "sema.unknown-statement",
         fmt::format("ITERAT is skipped: {}; metron reads D(label)=ITERAT/[XDIR,...]FA(x),...,(label),accuracy,"
                     "count[,ABSL|INCR] (docs/alignments.md)",
                     why));
    m_symbols.skipped["D:" + upper(s.target->name)] = s.span;
    emit(make(Op::Nop, s, s.major));
  };
  std::size_t jump_at = s.params.size();
  for (std::size_t i = 0; i < s.params.size(); ++i)
    if (s.params[i].kind == ExprKind::Paren) {
      jump_at = i;
      break;
    }
  if (jump_at == s.params.size())
    return skip(s.major_span, "it names no jump label (label) to measure the features again from");
  const auto [label, label_span] = jump_label_name(s.params[jump_at]);
  if (label.empty()) return skip(s.params[jump_at].span, "expected a jump label (label)");
  auto in = make(Op::Iterate, s, upper(s.target->name));
  static const std::set<std::string> directions = {"XDIR",   "YDIR",   "ZDIR",  "XMINUS", "YMINUS",
                                                   "ZMINUS", "JUMPTO", "XAXIS", "YAXIS",  "ZAXIS"};
  bool have_feature = false;
  for (std::size_t i = 0; i < jump_at; ++i) {
    const grammar::Expr p = unsigned_direction(s.params[i]);
    if (const auto pushed = push_datum_or_feature(in, p)) {
      if (!*pushed) return;
      have_feature = true;
    } else if (!(is_word(p) && directions.count(p.text))) {
      return skip(p.span, "expected a direction word or a feature before the jump label");
    }
  }
  if (!have_feature) return skip(s.major_span, "it names no feature to fit");
  const std::size_t numbers = s.params.size() - jump_at - 1;
  const bool mode_word = numbers == 3 && (is_word(s.params.back(), "ABSL") || is_word(s.params.back(), "INCR"));
  if (numbers != 2 && !mode_word)
    return skip(s.params[jump_at].span, "expected an accuracy and a count after the jump label, then ABSL or INCR");
  if (!push_number(in, s.params[jump_at + 1], "the accuracy") || !push_number(in, s.params[jump_at + 2], "the count"))
    return;
  in.operands.push_back(word_operand(mode_word ? s.params.back().text : std::string("ABSL"), s.params.back().span));
  m_symbols.alignments.insert(upper(s.target->name));
  emit_jump(std::move(in), label, label_span);
}

// Signed directions (DMIS 5.x, written by PC-DMIS and CAMIO): -XDIR is the word XMINUS, +XDIR is
// XDIR; anything else is returned as it is.
grammar::Expr UnitCompiler::unsigned_direction(const grammar::Expr& e) {
  const bool is_signed = e.kind == ExprKind::Unary && e.args.size() == 1 && (e.text == "-" || e.text == "+") &&
                         (is_word(e.args[0], "XDIR") || is_word(e.args[0], "YDIR") || is_word(e.args[0], "ZDIR"));
  if (!is_signed) return e;
  grammar::Expr word = e.args[0];
  word.span = e.span;
  if (e.text == "-") word.text = std::string(1, e.args[0].text[0]) + "MINUS";
  return word;
}

// D(l)=ROTATE/XAXIS|YAXIS|ZAXIS,angle | ROTATE/ZAXIS,FA(f),XDIR|YDIR|ZDIR|-XDIR|-YDIR|-ZDIR
void UnitCompiler::rotate(const grammar::Statement& s) {
  if (!require_target(s, {"D"}, "D(label)=ROTATE/...")) return;
  if (!expect_params(s, 2, "an axis (XAXIS, YAXIS, ZAXIS) and an angle or feature")) return;
  auto in = make(Op::Rotate, s, upper(s.target->name));
  if (!(is_word(s.params[0], "XAXIS") || is_word(s.params[0], "YAXIS") || is_word(s.params[0], "ZAXIS")))
    return error(s.params[0].span, "sema.bad-rotate", "expected XAXIS, YAXIS or ZAXIS after ROTATE/");
  in.operands.push_back(word_operand(s.params[0]));
  if (is_label(s.params[1], {"F", "FA"})) {
    if (!check_feature(s.params[1])) return;
    const grammar::Expr direction = s.params.size() == 3 ? unsigned_direction(s.params[2]) : grammar::Expr{};
    static const std::set<std::string> directions = {"XDIR", "YDIR", "ZDIR", "XMINUS", "YMINUS", "ZMINUS"};
    if (s.params.size() != 3 || !is_word(direction) || !directions.count(direction.text))
      return error(s.params.back().span, "sema.bad-rotate",
                   "expected XDIR, YDIR or ZDIR (or -XDIR, -YDIR, -ZDIR) after the feature");
    if (direction.text[0] == s.params[0].text[0])
      return error(s.params[2].span, "sema.bad-rotate", "the aligned axis cannot be the rotation axis");
    in.operands.push_back(label_op(s.params[1]));
    in.operands.push_back(word_operand(direction));
  } else {
    if (s.params.size() != 2)
      return error(s.params.back().span, "sema.bad-rotate", "ROTATE/axis,angle takes one angle");
    if (!push_number(in, s.params[1], "an angle")) return;
  }
  m_symbols.alignments.insert(upper(s.target->name));
  emit(std::move(in));
}

// SAVE/DA(l); SAVE/SA(l) (a sensor: the probe library keeps it); other SAVE forms are skipped
// with a warning.
void UnitCompiler::save(const grammar::Statement& s) {
  if (!expect_params(s, 1, "a coordinate system DA(label)")) return;
  const auto& p = s.params[0];
  if (is_label(p, {"SA", "S"})) {
    note_once(
        m_sensor_saves_noted, p.span, "sema.save-sensor",
        "SAVE/SA(): the probe library keeps the qualified sensors (docs/language.md, \"Sensors\"); nothing to do");
    emit(make(Op::Nop, s, "SAVE"));
    return;
  }
  if (!is_label(p, {"DA", "D"})) {
    if (p.kind == ExprKind::Label) {
      warn(p.span, "sema.unsupported-save",
           fmt::format("SAVE of {}() is not supported and is ignored", p.label.prefix));
      emit(make(Op::Nop, s, "SAVE"));
      return;
    }
    return error(p.span, "sema.expected-alignment", "expected DA(label) after SAVE/");
  }
  const std::string name = upper(p.label.name);
  if (!m_symbols.alignments.count(name) && !named_at_run(name))
    return error(p.span, "sema.undefined-alignment",
                 fmt::format("coordinate system {}({}) is not defined", upper(p.label.prefix), p.label.name));
  m_symbols.saved.insert(name);
  auto in = make(Op::Save, s);
  in.operands.push_back(label_op(p));
  emit(std::move(in));
}

// A macro's parameter or an indirect name (DA(@V)) is known only at run. Read leniently, a name
// nothing here defines may be a system kept by the CMM's software (RationalDMIS programs recall
// D(MAC)): a warning, and the run stops at the statement.
bool UnitCompiler::known_alignment(const grammar::Expr& label, const std::string& statement) {
  const std::string name = upper(label.label.name);
  if (m_symbols.alignments.count(name) || m_symbols.saved.count(name) || name == "MCS" || named_at_run(name))
    return true;
  const std::string written = fmt::format("{}({})", upper(label.label.prefix), label.label.name);
  if (m_strict || m_repl) {
    error(label.span, "sema.undefined-alignment", fmt::format("coordinate system {} is not defined", written));
    return false;
  }
  warn(label.span, "sema.undefined-alignment",
       fmt::format("coordinate system {} is not defined in this program (one the CMM's software keeps?): a run stops "
                   "at this {} (--strict makes it an error)",
                   written, statement));
  return true;
}

// RECALL/DA(l) | RECALL/D(l) | RECALL/SA(l)   (SA: a qualified sensor of the probe library)
void UnitCompiler::recall(const grammar::Statement& s) {
  if (!expect_params(s, 1, "a coordinate system D(label) or DA(label)")) return;
  if (is_label(s.params[0], {"SA"})) {
    library_sensor(s.params[0]);
    emit(make(Op::Nop, s, "RECALL"));
    return;
  }
  if (!is_label(s.params[0], {"DA", "D"})) {
    if (s.params[0].kind == ExprKind::Label) {  // RECALL/SA(), RECALL/FA() ...: not supported
      warn(s.params[0].span, "sema.unsupported-recall",
           fmt::format("RECALL of {}() is not supported and is ignored", s.params[0].label.prefix));
      emit(make(Op::Nop, s, "RECALL"));
      return;
    }
    return error(s.params[0].span, "sema.expected-alignment", "expected D(label) or DA(label) after RECALL/");
  }
  if (m_output_file && !m_strict) {
    const std::string name = upper(s.params[0].label.name);
    if (!m_symbols.alignments.count(name) && !m_symbols.saved.count(name) && name != "MCS" && !named_at_run(name)) {
      // An output file echoes the measuring program's RECALL of a system it does not state.
      note_once(m_echo_noted, s.span, "sema.echoed-line",
                "an echo of the measuring program's line: this output file does not state its coordinate system; kept "
                "as it is");
      emit(make(Op::Nop, s, "RECALL"));
      return;
    }
  }
  if (!known_alignment(s.params[0], "RECALL")) return;
  auto in = make(Op::Recall, s);
  in.operands.push_back(label_op(s.params[0]));
  emit(std::move(in));
}

// CONST/type,F(l),BF|INTOF|MIDPT|PROJPT|PROJLN|PIERCE,FA(a),FA(b),...
// CONST/POINT,F(l),MOVEPT,FA(x),dx,dy,dz; CONST/PLANE|LINE,F(l),PARTO|PERPTO,FA(ref),THRU,FA(point)
void UnitCompiler::construct(const grammar::Statement& s) {
  if (!expect_params(s, 4, "the type, F(label), the method and the source features")) return;
  const auto& p = s.params;
  const auto const_type = type_word(p[0]);
  if (is_word(p[0], "DIST") && is_label(p[1], {"F"}) && is_word(p[2], "BF") && p.size() == 5 &&
      is_label(p[3], {"F", "FA"}) && is_label(p[4], {"F", "FA"}) && !m_strict) {
    // WinWerth holds a distance as a feature: CONST/DIST,F(d),BF,FA(a),FA(b), then
    // OUTPUT/F(d),T(t) with t a TOL/DISTB. Read as the distance between a and b.
    if (!check_feature(p[3]) || !check_feature(p[4])) return;
    note_once(m_distance_features_noted, p[0].span, "sema.distance-feature",
              fmt::format("CONST/DIST (WinWerth's): F({}) is the distance between {}({}) and {}({}); an OUTPUT of "
                          "it reports its tolerance as OUTPUT of the two features does (noted once)",
                          p[1].label.name, p[3].label.prefix, p[3].label.name, p[4].label.prefix, p[4].label.name));
    m_symbols.distance_features[upper(p[1].label.name)] = {p[3], p[4]};
    emit(make(Op::Nop, s, "CONST"));
    return;
  }
  static const std::set<std::string> location_kinds = {"PARLEL", "PERP", "CONCEN", "COAXIAL"};
  if (is_word(p[0], "LOCTOL") && is_label(p[1], {"F"}) && p.size() == 5 && is_word(p[2]) &&
      location_kinds.count(p[2].text) && is_label(p[3], {"F", "FA"}) && is_label(p[4], {"F", "FA"}) && !m_strict) {
    // WinWerth holds a location tolerance's result as a feature: CONST/LOCTOL,F(x),kind,FA(a),FA(b)
    // then OUTPUT/F(x),T(t) with T(t)=TOL/LOCTOL,zone. The first feature is the reference (so
    // its CONCEN of a line and a circle is the circle's about the line's axis): read as
    // DATDEF/FA(a),DAT(LOCTOL_x) and, at the OUTPUT, TOL/kind,zone,DAT(LOCTOL_x) of FA(b).
    if (!check_feature(p[3]) || !check_feature(p[4])) return;
    note_once(m_location_noted, p[0].span, "sema.location-feature",
              fmt::format("CONST/LOCTOL (WinWerth's): F({}) is the {} of {}({}) to {}({}), the first the reference; "
                          "an OUTPUT of it with its TOL/LOCTOL evaluates that tolerance (noted once)",
                          p[1].label.name, p[2].text, p[4].label.prefix, p[4].label.name, p[3].label.prefix,
                          p[3].label.name));
    grammar::Expr datum;
    datum.kind = ExprKind::Label;
    datum.span = p[1].span;
    datum.label.prefix = "DAT";
    datum.label.name = "LOCTOL_" + p[1].label.name;
    datum.label.span = p[1].span;
    grammar::Statement define = s;
    define.major = "DATDEF";
    define.target.reset();
    define.params = {p[3], datum};
    datdef(define);
    m_location_features[upper(p[1].label.name)] = {p[2].text, p[4], datum};
    return;
  }
  if (!const_type && is_word(p[0]) && unsupported_feature_word(p[0].text) && is_label(p[1], {"F"}) && !m_strict) {
    warn(p[0].span, "sema.unsupported-feature",
         fmt::format("feature type {} is not supported yet; CONST of F({}) is skipped", p[0].text, p[1].label.name));
    emit(make(Op::Nop, s, "CONST"));
    return;
  }
  if (!const_type) return error(p[0].span, "sema.bad-feature-type", "expected a feature type after CONST/");
  if (!is_label(p[1], {"F"}))
    return error(p[1].span, "sema.expected-feature", "expected F(label) after the feature type");
  const std::string label = upper(p[1].label.name);
  const auto type = feature_type(label);
  if (type && *type != *const_type)
    return error(p[0].span, "sema.const-type",
                 fmt::format("CONST/{} on F({}), which is FEAT/{}", p[0].text, p[1].label.name, ir::word_of(*type)));
  const auto method = is_word(p[2]) ? ir::parse_word<ir::ConstructionMethod>(p[2].text) : std::nullopt;
  if (!method) {
    if (is_word(p[2])) {
      warn(p[2].span, "sema.unsupported-construction",
           fmt::format("construction method {} is not supported; F({}) gets no actual", p[2].text, p[1].label.name));
      m_symbols.unconstructed[label] = p[2].text;
      emit(make(Op::Nop, s, "CONST"));
      return;
    }
    return error(p[2].span, "sema.bad-construction",
                 "expected a construction method (BF, INTOF, MIDPT, PROJPT, ...) after the feature");
  }
  // The methods that make one type only.
  const std::optional<FeatureType> makes = *method == ir::ConstructionMethod::Midpl    ? FeatureType::Plane
                                           : *method == ir::ConstructionMethod::Midli  ? FeatureType::Line
                                           : *method == ir::ConstructionMethod::Vertex ? FeatureType::Point
                                                                                       : std::optional<FeatureType>{};
  if (makes && *makes != *const_type)
    return error(p[0].span, "sema.const-type", fmt::format("{} constructs a {}", p[2].text, ir::word_of(*makes)));
  m_symbols.unconstructed.erase(label);
  auto in = make(Op::Construct, s, label);
  in.name_is_param = macro_param(label).has_value();
  in.payload = ir::ConstructPayload{*const_type, *method};
  if (*method == ir::ConstructionMethod::Movept) {
    // CONST/POINT,F(l),MOVEPT,FA(x),dx,dy,dz
    if (*const_type != FeatureType::Point) return error(p[0].span, "sema.const-type", "MOVEPT constructs a POINT");
    if (p.size() != 7 || !is_label(p[3], {"FA", "F"}))
      return error(p.back().span, "sema.construction-arity",
                   "MOVEPT takes a feature and an offset: MOVEPT,FA(x),dx,dy,dz");
    if (!check_feature(p[3])) return;
    in.operands.push_back(label_op(p[3]));
    for (std::size_t i = 4; i < 7; ++i)
      if (!push_number(in, p[i], "an offset")) return;
    if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {*const_type, s.span};
    emit(std::move(in));
    return;
  }
  if (*method == ir::ConstructionMethod::Extrem) return extreme_point(s, std::move(in));
  if (*method == ir::ConstructionMethod::Cone) {
    // CONST/CIRCLE,F(l),CONE,FA(cone),DIAM,d | DIST,h: a countersink's gauge circle
    if (*const_type != FeatureType::Circle) return error(p[0].span, "sema.const-type", "CONE constructs a CIRCLE");
    if (p.size() != 6 || !is_label(p[3], {"FA", "F"}) || !(is_word(p[4], "DIAM") || is_word(p[4], "DIST")))
      return error(p.back().span, "sema.construction-arity",
                   "CONE takes a cone and where to cut it: CONE,FA(cone),DIAM,diameter or CONE,FA(cone),DIST,distance");
    if (!check_feature(p[3])) return;
    in.operands.push_back(label_op(p[3]));
    ir::Operand how;
    how.kind = ir::Operand::Kind::Word;
    how.word = upper(p[4].text);
    in.operands.push_back(how);
    if (!push_number(in, p[5], how.word == "DIAM" ? "the diameter" : "the distance")) return;
    if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {*const_type, s.span};
    emit(std::move(in));
    return;
  }
  if (*method == ir::ConstructionMethod::Offset) {
    // CONST/PLANE,F(l),OFFSET,FA(plane),d
    if (*const_type != FeatureType::Plane) {
      warn(p[2].span, "sema.unsupported-construction",
           fmt::format("OFFSET constructs a PLANE here (OFFSET,FA(plane),d); an offset {} is not supported: F({}) gets "
                       "no actual",
                       p[0].text, p[1].label.name));
      m_symbols.unconstructed[label] = p[2].text;
      emit(make(Op::Nop, s, "CONST"));
      return;
    }
    if (p.size() != 5 || !is_label(p[3], {"FA", "F"}))
      return error(p.back().span, "sema.construction-arity", "OFFSET takes a plane and a distance: OFFSET,FA(plane),d");
    if (!check_feature(p[3])) return;
    in.operands.push_back(label_op(p[3]));
    if (!push_number(in, p[4], "the offset distance")) return;
    if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {*const_type, s.span};
    emit(std::move(in));
    return;
  }
  if (*method == ir::ConstructionMethod::Tanto) return tangent(s, std::move(in), *const_type, label);
  if (*method == ir::ConstructionMethod::Parto || *method == ir::ConstructionMethod::Perpto) {
    // CONST/PLANE|LINE,F(l),PARTO|PERPTO,FA(ref),[THRU,]FA(point) (shop software leaves THRU out)
    if (*const_type != FeatureType::Plane && *const_type != FeatureType::Line)
      return error(p[0].span, "sema.const-type", fmt::format("{} constructs a PLANE or a LINE", p[2].text));
    const bool thru = p.size() == 6 && is_word(p[4], "THRU");
    const std::size_t point = thru ? 5 : 4;
    if (!(thru || p.size() == 5) || !is_label(p[3], {"FA", "F"}) || !is_label(p[point], {"FA", "F"}))
      return error(p.back().span, "sema.construction-arity",
                   fmt::format("{} takes a reference and a point: {},FA(ref),THRU,FA(point)", p[2].text, p[2].text));
    for (std::size_t i : {std::size_t{3}, point}) {
      if (!check_feature(p[i])) return;
      in.operands.push_back(label_op(p[i]));
    }
    if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {*const_type, s.span};
    emit(std::move(in));
    return;
  }
  for (std::size_t i = 3; i < p.size(); ++i) {
    if (!is_label(p[i], {"FA", "F"}))
      return error(p[i].span, "sema.expected-feature", "expected FA(label) source features");
    if (!check_feature(p[i])) return;
    in.operands.push_back(label_op(p[i]));
  }
  const std::size_t sources = p.size() - 3;
  using M = ir::ConstructionMethod;
  const bool one_source = *method == M::Cast || *method == M::Copy || *method == M::Vertex;
  if (one_source && sources != 1)
    return error(p.back().span, "sema.construction-arity",
                 fmt::format("{} takes one source feature, got {}", p[2].text, sources));
  if (*method != M::Bf && !one_source && sources != 2)
    return error(p.back().span, "sema.construction-arity",
                 fmt::format("{} takes two source features, got {}", p[2].text, sources));
  if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {*const_type, s.span};
  emit(std::move(in));
}

// CONST/LINE,F(l),TANTO,FA(a),FA(b): a line tangent to two circles, or to a circle through a
// point; CONST/CIRCLE,F(l),TANTO,FA(line),FA(line),diameter | FA(line),FA(line),FA(line): a circle
// tangent to two lines with its diameter given, or to three (docs/language.md, "Tangent
// constructions"). Operands: the source labels, then the diameter. Another type: skipped with a
// warning, as an unsupported method.
void UnitCompiler::tangent(const grammar::Statement& s, ir::Instruction in, FeatureType type,
                           const std::string& label) {
  const auto& p = s.params;
  if (type != FeatureType::Line && type != FeatureType::Circle) {
    warn(p[2].span, "sema.unsupported-construction",
         fmt::format("TANTO constructs a LINE or a CIRCLE here; a tangent {} is not supported: F({}) gets no actual",
                     p[0].text, p[1].label.name));
    m_symbols.unconstructed[label] = p[2].text;
    emit(make(Op::Nop, s, "CONST"));
    return;
  }
  std::size_t labels = 0;
  while (3 + labels < p.size() && is_label(p[3 + labels], {"FA", "F"})) ++labels;
  const bool diameter = 3 + labels + 1 == p.size();
  const bool fits = type == FeatureType::Line ? labels == 2 && 3 + labels == p.size()
                                              : (labels == 2 && diameter) || (labels == 3 && 3 + labels == p.size());
  if (!fits)
    return error(p.back().span, "sema.construction-arity",
                 type == FeatureType::Line ? "TANTO takes two features for a LINE: TANTO,FA(circle),FA(circle or point)"
                                           : "TANTO takes two lines and a diameter, or three lines, for a CIRCLE: "
                                             "TANTO,FA(line),FA(line),diameter or TANTO,FA(line),FA(line),FA(line)");
  for (std::size_t i = 3; i < 3 + labels; ++i) {
    if (!check_feature(p[i])) return;
    in.operands.push_back(label_op(p[i]));
  }
  if (diameter && !push_number(in, p.back(), "the diameter")) return;
  if (m_symbols.features.find(label) == m_symbols.features.end()) m_symbols.features[label] = {type, s.span};
  emit(std::move(in));
}

// CONST/POINT,F(l),EXTREM,[MIN|MAX|MINUS|PLUS,]FA(x),XDIR|YDIR|ZDIR|-XDIR|...|VEC,i,j,k|FA(axis)|RADIAL[,MIN|MAX]
// (DMIS SIR 96-10; the directions as QIF's PointFeatureExtreme): the measured point of FA(x)
// furthest along the direction (MIN: least far). Operands: the source, a word MAX or MIN, then the
// direction: a word (XDIR, XMINUS, ...), a label (an axis feature's direction) or i, j, k.
void UnitCompiler::extreme_point(const grammar::Statement& s, ir::Instruction in) {
  const auto& p = s.params;
  if (type_word(p[0]) != FeatureType::Point) return error(p[0].span, "sema.const-type", "EXTREM constructs a POINT");
  const char* usage =
      "EXTREM takes a feature and a direction: "
      "EXTREM,[MIN|MAX,]FA(x),XDIR|YDIR|ZDIR|-XDIR|...|VEC,i,j,k|FA(axis)|RADIAL";
  std::optional<grammar::Expr> source, axis_feature, axis_word;
  std::vector<const grammar::Expr*> vec;
  bool minimum = false;
  for (std::size_t i = 3; i < p.size(); ++i) {
    const grammar::Expr& q = p[i];
    if (is_word(q, "MIN") || is_word(q, "MINUS"))
      minimum = true;
    else if (is_word(q, "MAX") || is_word(q, "PLUS"))
      minimum = false;
    else if (is_label(q, {"FA", "F"}))
      (source ? axis_feature : source) = q;
    else if (is_word(q, "XDIR") || is_word(q, "YDIR") || is_word(q, "ZDIR") || is_word(q, "XMINUS") ||
             is_word(q, "YMINUS") || is_word(q, "ZMINUS")) {
      axis_word = q;
    } else if (q.kind == ExprKind::Unary && q.args.size() == 1 && (q.text == "-" || q.text == "+") &&
               (is_word(q.args[0], "XDIR") || is_word(q.args[0], "YDIR") || is_word(q.args[0], "ZDIR"))) {
      axis_word = q.args[0];
      if (q.text == "-") axis_word->text = std::string(1, q.args[0].text[0]) + "MINUS";
      axis_word->span = q.span;
    } else if (is_word(q, "VEC") || is_word(q, "VECTOR")) {
      if (i + 3 >= p.size()) return error(q.span, "sema.construction-arity", "VEC takes i, j, k");
      for (std::size_t k = 1; k <= 3; ++k) vec.push_back(&p[i + k]);
      i += 3;
    } else if (is_word(q, "RADIAL")) {
      axis_word = q;  // from the source's own axis or centre
    } else {
      return error(q.span, "sema.construction-arity", usage);
    }
  }
  const int directions = (axis_feature ? 1 : 0) + (axis_word ? 1 : 0) + (vec.empty() ? 0 : 1);
  if (!source || directions != 1) return error(p.back().span, "sema.construction-arity", usage);
  if (!check_feature(*source)) return;
  in.operands.push_back(label_op(*source));
  in.operands.push_back(word_operand(minimum ? "MIN" : "MAX", source->span));
  if (axis_word) {
    in.operands.push_back(word_operand(axis_word->text, axis_word->span));
  } else if (axis_feature) {
    if (!check_feature(*axis_feature)) return;
    in.operands.push_back(label_op(*axis_feature));
  } else {
    for (const auto* e : vec)
      if (!push_number(in, *e, "a direction component")) return;
  }
  const std::string label = upper(p[1].label.name);
  if (m_symbols.features.find(label) == m_symbols.features.end())
    m_symbols.features[label] = {FeatureType::Point, s.span};
  emit(std::move(in));
}

// OUTPUT/FA(x),TA(t),...
void UnitCompiler::output(const grammar::Statement& s) {
  if (!expect_params(s, 1, "feature or tolerance labels")) return;
  auto in = make(Op::Output, s);
  std::size_t echoed = 0;
  if (!output_labels(s, in, echoed)) return;
  if (in.operands.empty()) {  // every item echoed a stated result or was left out
    emit(make(Op::Nop, s, "OUTPUT"));
    return;
  }
  emit(std::move(in));
}

// EVAL/FA(x)[,FA(y)],TA(t)[,TA(u)]: the tolerances evaluated against the features and kept for a
// later OUTPUT/TA(t); nothing is reported here (DMIS 5.x EVAL).
void UnitCompiler::evaluate(const grammar::Statement& s) {
  if (!expect_params(s, 1, "features and tolerances: EVAL/FA(x),TA(t)")) return;
  auto in = make(Op::Evaluate, s);
  std::size_t echoed = 0;
  if (!output_labels(s, in, echoed)) return;
  if (in.operands.empty() && (echoed > 0 || !m_strict)) {  // its features never defined: left out
    emit(make(Op::Nop, s, "EVAL"));
    return;
  }
  bool any_tolerance = false;
  for (const auto& o : in.operands) {
    if (o.label.prefix != "T" && o.label.prefix != "TA") continue;
    any_tolerance = true;
    m_symbols.evaluated_tolerances.insert(upper(o.label.name));
  }
  if (!any_tolerance) {
    // Its tolerances were all left out with a reason (read leniently): nothing to evaluate.
    const bool named = std::any_of(s.params.begin(), s.params.end(), [](const grammar::Expr& p) {
      return p.kind == ExprKind::Label && (p.label.prefix == "T" || p.label.prefix == "TA");
    });
    if (named && !m_strict) {
      emit(make(Op::Nop, s, "EVAL"));
      return;
    }
    return error(s.span, "sema.eval-without-tolerance", "EVAL evaluates tolerances: EVAL/FA(x),TA(t)");
  }
  emit(std::move(in));
}

bool UnitCompiler::output_labels(const grammar::Statement& s, ir::Instruction& in, std::size_t& echoed) {
  const auto fail = [this](Span span, const char* code, std::string message) {
    error(span, code, std::move(message));
    return false;
  };
  std::vector<std::optional<FeatureType>> types;
  bool left_out = false;  // a feature the program never defines was left out (lenient reading)
  for (const auto& p : s.params) {
    if (p.kind == ExprKind::Label && !p.label.points.empty() && (!is_label(p, {"F", "FA"}) || s.major != "OUTPUT"))
      return fail(
          p.span, "sema.point-range",
          fmt::format("a point range {}({})[...] is read only for a feature in OUTPUT", p.label.prefix, p.label.name));
    // In a DMIS output file each OUTPUT is followed by the result lines it produced: an OUTPUT of
    // a result stated below (and not defined before) echoes it.
    const bool feature_label = is_label(p, {"F", "FA"});
    const std::string key = std::string(feature_label ? "FA:" : "TA:") + upper(p.label.name);
    if ((feature_label || is_label(p, {"T", "TA"})) && m_reported_results.count(key) &&
        !(feature_label ? m_symbols.features.count(upper(p.label.name))
                        : m_symbols.tolerances.count(upper(p.label.name)))) {
      ++echoed;
      continue;
    }
    // An output file that writes each item's nominal and actual after its own OUTPUT (WENZEL
    // Quartis: OUTPUT/F(x),T(t), F(x)=FEAT, T(t)=TOL, OUTPUT/FA(x),TA(t), FA(x)=FEAT, TA(t)=TOL):
    // each OUTPUT echoes the lines stated below it.
    const auto stated_below = [&](const std::map<std::string, Span>& where, const std::string& k) {
      const auto it = where.find(k);
      return it != where.end() && it->second.file == s.span.file && it->second.begin > s.span.begin;
    };
    if (m_output_file && (feature_label || is_label(p, {"T", "TA"})) &&
        (stated_below(m_reported_results, key) ||
         stated_below(feature_label ? m_later_features : m_later_tolerances, upper(p.label.name)))) {
      ++echoed;
      continue;
    }
    if (is_label(p, {"F", "FA"}) && m_symbols.patterns.count(upper(p.label.name)) && p.label.points.empty()) {
      // A pattern: its features, in order, as if listed here.
      for (const std::string& member : m_symbols.patterns.at(upper(p.label.name))) {
        ir::Operand o = label_op(p);
        o.label.name = member;
        o.label.param.reset();
        types.push_back(feature_type(member));
        in.operands.push_back(std::move(o));
      }
      continue;
    }
    if (is_label(p, {"F", "FA"}))
      if (auto l = m_location_features.find(upper(p.label.name)); l != m_location_features.end()) {
        // WinWerth's location tolerance: its TOL/LOCTOL after it made the tolerance it is.
        for (const auto& t : s.params)
          if (auto zone = m_location_zones.find(upper(t.label.name));
              is_label(t, {"T", "TA"}) && zone != m_location_zones.end() && zone->second.params.size() == 2) {
            grammar::Statement tolerance = zone->second;
            tolerance.params[0].text = l->second.kind;
            tolerance.params.push_back(l->second.datum);
            tol(tolerance);
            break;
          }
        if (!check_feature(l->second.toleranced)) return false;
        types.push_back(feature_type(upper(l->second.toleranced.label.name)));
        in.operands.push_back(label_op(l->second.toleranced));
        continue;
      }
    if (is_label(p, {"F", "FA"}))
      if (auto d = m_symbols.distance_features.find(upper(p.label.name)); d != m_symbols.distance_features.end()) {
        for (const auto& f : d->second) {  // a distance feature: its two features, as written in its place
          if (!check_feature(f)) return false;
          types.push_back(feature_type(upper(f.label.name)));
          in.operands.push_back(label_op(f));
        }
        continue;
      }
    if (is_label(p, {"F", "FA"})) {
      // Shop software runs a program whose OUTPUT names a feature it never measured (a
      // generator's leftover): read leniently, the item is left out with a warning.
      if (!m_strict && !m_repl && never_defined(upper(p.label.name))) {
        warn(p.span, "sema.output-undefined-feature",
             fmt::format(
                 "feature {}({}) is never defined in this program: left out of this {} (--strict makes it an error)",
                 p.label.prefix, p.label.name, s.major));
        left_out = true;
        continue;
      }
      if (auto u = m_symbols.unconstructed.find(upper(p.label.name));
          !m_strict && !m_repl && u != m_symbols.unconstructed.end()) {
        warn(p.span, "sema.output-unconstructed-feature",
             fmt::format(
                 "{}({}) has no actual: its CONST method {} is not supported; left out of this {} (--strict makes it "
                 "an error)",
                 p.label.prefix, p.label.name, u->second, s.major));
        left_out = true;
        continue;
      }
      if (const std::string name = upper(p.label.name);
          !m_strict && !m_repl && m_symbols.unsupported_features.count(name) && !m_symbols.features.count(name)) {
        warn(p.span, "sema.output-skipped-feature",
             fmt::format("feature {}({}) is defined only by a statement metron skipped: left out of this {} "
                         "(--strict makes it an error)",
                         p.label.prefix, p.label.name, s.major));
        left_out = true;
        continue;
      }
      if (!check_feature(p)) return false;
      types.push_back(feature_type(upper(p.label.name)));
    } else if (is_label(p, {"T", "TA"})) {
      const std::string t = upper(p.label.name);
      if (!named_at_run(t)) {
        auto it = m_symbols.tolerances.find(t);
        if (auto u = m_symbols.unevaluated_tolerances.find(t);
            it == m_symbols.tolerances.end() && u != m_symbols.unevaluated_tolerances.end()) {
          note(p.span, "sema.unevaluated-output",
               fmt::format("T({}) (TOL/{}) is not evaluated: left out of this OUTPUT", p.label.name, u->second));
          continue;
        }
        if (it == m_symbols.tolerances.end())
          return fail(p.span,
                      m_symbols.skipped.count("T:" + t) ? "sema.skipped-definition" : "sema.undefined-tolerance",
                      m_symbols.skipped.count("T:" + t)
                          ? fmt::format("tolerance T({}) was defined by a skipped statement", p.label.name)
                          : fmt::format("tolerance T({}) is not defined", p.label.name));
        const ToleranceKind kind = it->second;
        if (types.empty() && left_out) {
          note(p.span, "sema.output-undefined-feature",
               fmt::format("T({}) is left out with the feature", p.label.name));
          continue;
        }
        if (types.empty() && in.op == Op::Output && m_symbols.evaluated_tolerances.count(t)) {
          in.operands.push_back(label_op(p));  // OUTPUT/TA(t) alone: what an EVAL of it found
          continue;
        }
        if ((kind == ToleranceKind::DistWrt || kind == ToleranceKind::AngWrt || kind == ToleranceKind::Cortol) &&
            types.empty())
          return fail(p.span, "sema.tolerance-without-feature",
                      fmt::format("T({}) is output without a feature to apply it to", p.label.name));
        if (kind == ToleranceKind::DistB && types.size() != 2)
          return fail(p.span, "sema.distb-features", "TOL/DISTB is output with two features: OUTPUT/FA(a),FA(b),TA(t)");
        if (kind == ToleranceKind::Anglb && types.size() != 2 && m_symbols.tolerance_datums.count(t) == 0)
          return fail(p.span, "sema.anglb-reference",
                      "TOL/ANGLB needs a datum DAT(x) or a second feature: OUTPUT/FA(a),FA(b),TA(t)");
        const auto mismatch = std::find_if(types.begin(), types.end(), [&](const std::optional<FeatureType>& type) {
          return type && !runtime::tolerance_applies(kind, *type);
        });
        if (mismatch != types.end()) {
          // PERP of a CIRCLE and the like: one section gives no axis. Read leniently, left out
          // with the reason.
          if (!m_strict && !m_repl && reported_elsewhere(kind, **mismatch)) {
            warn(
                p.span, "sema.tolerance-type-not-evaluated",
                fmt::format("TOL/{} of T({}) is not evaluated for a {} (metron evaluates it for {}): left out of "
                            "this {} (--strict makes it an error)",
                            ir::word_of(kind), p.label.name, ir::word_of(**mismatch), applicable_types(kind), s.major));
            m_symbols.tolerances_left_out[t] = std::string(ir::word_of(**mismatch));
            continue;
          }
          return fail(p.span, "sema.tolerance-type",
                      fmt::format("TOL/{} of T({}) does not apply to a {}", ir::word_of(kind), p.label.name,
                                  ir::word_of(**mismatch)));
        }
        if (types.empty())
          return fail(p.span, "sema.tolerance-without-feature",
                      fmt::format("T({}) is output without a feature to apply it to", p.label.name));
        m_symbols.tolerances_left_out.erase(t);
      }
    } else if (is_label(p, {"R"})) {
      // A REPORT layout (R(x)=REPORT/...) for the features beside it: metron's reports are its own.
      note_once(m_report_layout_noted, p.span, "sema.report-layout",
                "R() report layouts are not applied: metron reports every output feature and tolerance its own way");
      continue;  // not an item of the report (OUTPUT/R(ID) alone reports nothing)
    } else if (is_label(p, {"S", "SA"}) && in.op == Op::Output) {
      // A sensor: its definition (S) or its qualification (SA), as a report line. One the
      // program never defines may come from the probe library (RECALL/SA): the run tells.
      if (!m_symbols.sensors.count(upper(p.label.name)) && !m_symbols.library_sensors.count(upper(p.label.name)))
        note(p.span, "sema.output-library-sensor",
             fmt::format(
                 "{}({}) is not defined in this program: its output is what the machine's probe library holds at run",
                 p.label.prefix, p.label.name));
    } else if (is_label(p, {"D", "DA"}) && in.op == Op::Output) {
      // A coordinate system: its origin and axes in the machine's, as a report line.
      const std::string d = upper(p.label.name);
      if (!m_symbols.alignments.count(d) && d != "MCS" && !named_at_run(d))
        warn(p.span, "sema.undefined-datum-set",
             fmt::format("coordinate system D({}) is not defined in this program", p.label.name));
    } else if (p.kind == ExprKind::Label) {
      warn(p.span, "sema.unsupported-output",
           fmt::format("OUTPUT of {}() labels is not supported and is ignored", p.label.prefix));
      continue;
    } else {
      return fail(p.span, "sema.expected-label",
                  fmt::format("expected F(), FA(), T() or TA() labels after {}/", s.major));
    }
    in.operands.push_back(label_op(p));
    for (const auto& bound : p.label.points) {  // OUTPUT/FA(x)[first,last]: the numbers follow the label
      auto e = numeric(bound, "a point number");
      if (!e) return false;
      in.operands.push_back(expr_operand(std::move(*e)));
    }
  }
  return true;
}

}  // namespace metron::interpreter::detail
