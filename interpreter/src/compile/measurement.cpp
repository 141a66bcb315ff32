// SPDX-License-Identifier: GPL-3.0-or-later
// Measurement: SNSLCT, SNSET, FEDRAT, ACLRAT, SCNMOD, SCNSET, GOTO, MEAS ... ENDMES, PTMEAS, RMEAS, PAMEAS.
#include <algorithm>
#include <cmath>

#include "compile/unit_compiler.hpp"
#include "metron/runtime/measurement_plan.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;

void UnitCompiler::add_measurement(StatementTable& t) {
  t.insert({{"SNSMNT", &UnitCompiler::snsmnt},
            {"SNSLCT", &UnitCompiler::snslct},
            {"CALIB", &UnitCompiler::calib},
            {"SNSET", &UnitCompiler::snset},
            {"FEDRAT", &UnitCompiler::fedrat},
            {"ACLRAT", &UnitCompiler::aclrat},
            {"SCNMOD", &UnitCompiler::scnmod},
            {"SCNSET", &UnitCompiler::scnset},
            {"GOTO", &UnitCompiler::go_to},
            {"GOTARG", &UnitCompiler::go_target},
            {"ENDGO", &UnitCompiler::end_go},
            {"MEAS", &UnitCompiler::meas},
            {"ENDMES", &UnitCompiler::endmes},
            {"PTMEAS", &UnitCompiler::ptmeas},
            {"RMEAS", &UnitCompiler::ptmeas},
            {"RPTMEAS", &UnitCompiler::ptmeas},
            {"PAMEAS", &UnitCompiler::pameas}});
}

// SNSMNT/XVEC,i,j,k,ZVEC,i,j,k,MNTLEN,x,y,z: the probe mount; the virtual CMM's head is fixed.
void UnitCompiler::snsmnt(const grammar::Statement& s) { emit(make(Op::Nop, s, "SNSMNT")); }

// SNSLCT/S(l) | SNSLCT/SA(l)   (SA: a sensor of the machine's probe library, RECALLed or not)
void UnitCompiler::snslct(const grammar::Statement& s) {
  if (!expect_params(s, 1, "a sensor label S(...)")) return;
  if (!is_label(s.params[0], {"S", "SA"}))
    return error(s.params[0].span, "sema.expected-sensor", "expected a sensor label S(...) after SNSLCT/");
  const std::string name = upper(s.params[0].label.name);
  if (!m_symbols.sensors.count(name)) {
    if (auto it = m_symbols.skipped.find("S:" + name); it != m_symbols.skipped.end())
      return error(s.params[0].span, "sema.skipped-definition",
                   fmt::format("sensor S({}) was defined by a skipped statement", s.params[0].label.name));
    library_sensor(s.params[0]);
  }
  if (s.params.size() > 1)  // a head orientation, a vendor's option: dropped unseen before
    warn(s.params[1].span, "sema.snslct-arity",
         fmt::format("SNSLCT selects {}({}) as it is defined; the {} parameter{} after it {} not used",
                     upper(s.params[0].label.prefix), s.params[0].label.name, s.params.size() - 1,
                     s.params.size() == 2 ? "" : "s", s.params.size() == 2 ? "is" : "are"));
  emit(make(Op::SensorSelect, s, name));
}

// CALIB/SENS,S(x)[,F(artifact)][,n...]: qualifies sensor x now (again, when it was) on the
// world's reference sphere, at the current measuring feed, and selects it as a real calibration
// leaves it. Other CALIB forms (RTAB, MASTER ...) are skipped with a warning.
void UnitCompiler::calib(const grammar::Statement& s) {
  if (!expect_params(s, 1, "SENS and a sensor label S(...)")) return;
  if (!is_word(s.params[0], "SENS")) {
    warn(s.params[0].span, "sema.unsupported-calibration",
         fmt::format("CALIB/{} is not supported and is skipped",
                     is_word(s.params[0]) ? s.params[0].text : std::string("...")));
    emit(make(Op::Nop, s, "CALIB"));
    return;
  }
  if (s.params.size() < 2 || !is_label(s.params[1], {"S", "SA"}))
    return error(s.params.size() < 2 ? s.params[0].span : s.params[1].span, "sema.expected-sensor",
                 "expected a sensor label S(...) after CALIB/SENS");
  const std::string name = upper(s.params[1].label.name);
  if (!m_symbols.sensors.count(name)) {
    if (m_symbols.skipped.count("S:" + name))
      return error(s.params[1].span, "sema.skipped-definition",
                   fmt::format("sensor S({}) was defined by a skipped statement", s.params[1].label.name));
    library_sensor(s.params[1]);
  }
  if (s.params.size() > 2 && is_label(s.params[2], {"F", "FA"}))
    note_once(m_calib_artifact_noted, s.params[2].span, "sema.calibration-artifact",
              fmt::format("CALIB/SENS qualifies on the world's reference sphere; F({}) is not measured",
                          s.params[2].label.name));
  auto in = make(Op::SensorSelect, s, name);
  in.count = 1;  // qualify again
  emit(std::move(in));
}

void UnitCompiler::library_sensor(const grammar::Expr& label) {
  const std::string name = upper(label.label.name);
  if (m_symbols.sensors.count(name) || !m_symbols.library_sensors.insert(name).second) return;
  note(label.span, "sema.library-sensor",
       fmt::format("sensor {}({}) is not defined in the program: it is taken from the machine's probe library "
                   "(a 4 mm default tip, with a warning, when the library does not hold it)",
                   label.label.prefix, label.label.name));
}

// SNSET/APPRCH|RETRCT|SEARCH|CLRSRF|DEPTH,dist[, ...]; SNSET/CLRSRF,F(plane)|FA(plane),dist (a
// clearance surface: the plane moved dist along its normal)
void UnitCompiler::snset(const grammar::Statement& s) {
  static const std::set<std::string> words = {"APPRCH", "RETRCT", "SEARCH", "CLRSRF", "DEPTH"};
  // SNSET/VA(algorithm), VF(filter),value, VL(light),intensity ...: a vision or scanning sensor's
  // settings (DMIS 5.x; WinWerth writes one before each measurement). A touch probe has none: one
  // note per unit, as FILDEF and LITDEF.
  if (!s.params.empty() && is_label(s.params[0], {"VA", "VF", "VL", "VW"})) {
    if (m_noted_kinds.insert("SNSET/V").second)
      note(s.params[0].span, "sema.sensor-vision-setting",
           fmt::format("SNSET/{}(...): the settings of a vision sensor's algorithms, filters and lights have no "
                       "effect on the virtual CMM's probes (noted once)",
                       s.params[0].label.prefix));
    emit(make(Op::Nop, s, "SNSET"));
    return;
  }
  if (!expect_params(s, 2, "a setting (APPRCH, RETRCT, SEARCH, CLRSRF, DEPTH) and a distance")) return;
  for (std::size_t i = 0; i < s.params.size(); i += 2) {
    if (!is_word(s.params[i]) || !words.count(s.params[i].text)) {
      if (is_word(s.params[i])) {
        warn(s.params[i].span, "sema.unsupported-setting",
             fmt::format("SNSET/{} is not supported and is ignored", s.params[i].text));
        emit(make(Op::Nop, s, "SNSET"));
        return;
      }
      return error(s.params[i].span, "sema.bad-setting", "expected APPRCH, RETRCT, SEARCH, CLRSRF or DEPTH");
    }
    if (i + 1 >= s.params.size())
      return error(s.params[i].span, "sema.missing-parameter",
                   fmt::format("expected a distance after {}", s.params[i].text));
    if (s.params[i].text == "CLRSRF" && is_label(s.params[i + 1], {"F", "FA"})) {
      if (!check_feature(s.params[i + 1])) return;  // the run would stop here
      if (i + 2 >= s.params.size())
        return error(s.params[i + 1].span, "sema.missing-parameter",
                     "expected the clearance distance from the plane after its label");
      auto d = numeric(s.params[i + 2], "a distance");
      if (!d) return;
      auto in = make(Op::ProbeSet, s);
      in.operands.push_back(word_operand(s.params[i]));
      in.operands.push_back(label_op(s.params[i + 1]));
      in.operands.push_back(expr_operand(std::move(*d)));
      emit(std::move(in));
      ++i;  // the label; the loop steps over the distance
      continue;
    }
    std::optional<ir::Expr> e;
    if (is_word(s.params[i + 1], "OFF") && !is_variable("OFF") &&
        (s.params[i].text == "CLRSRF" || s.params[i].text == "DEPTH")) {
      // SNSET/CLRSRF,OFF: no clearance surface (AUTO moves keep metron's default clearance, 10
      // mm above the feature); SNSET/DEPTH,OFF: no depth.
      e.emplace();
      e->op = ir::ExprOp::Constant;
      e->value = Value::real(s.params[i].text == "CLRSRF" ? runtime::ProbeSettings{}.clearance_mm : 0.0);
      e->span = s.params[i + 1].span;
    } else {
      e = numeric(s.params[i + 1], "a distance");
    }
    if (!e) return;
    if (e->op == ir::ExprOp::Constant && e->value.number < 0 && s.params[i].text != "DEPTH")
      return error(s.params[i + 1].span, "sema.negative-distance",
                   fmt::format("the {} distance must not be negative", s.params[i].text));
    auto in = make(Op::ProbeSet, s);
    in.operands.push_back(word_operand(s.params[i]));
    in.operands.push_back(expr_operand(std::move(*e)));
    emit(std::move(in));
  }
}

// FEDRAT/MESVEL|POSVEL|SCNVEL,MPM|MMPS|IPM|IPS|PCENT,v   (HEDROT/HEDMVEL... skipped)
void UnitCompiler::fedrat(const grammar::Statement& s) {
  // FEDRAT/DEFALT and FEDRAT/MESVEL|POSVEL|SCNVEL,DEFALT: back to the machine's own feeds.
  const auto default_feed = [&](ir::FeedKind kind) {
    auto in = make(Op::Feed, s);
    in.payload = ir::FeedPayload{kind, ir::FeedUnit::Defalt};
    ir::Expr none;
    none.value = Value::real(0);
    in.operands.push_back(expr_operand(std::move(none)));
    emit(std::move(in));
  };
  if (s.params.size() == 1 && is_word(s.params[0], "DEFALT")) {
    for (auto kind : {ir::FeedKind::Mesvel, ir::FeedKind::Posvel, ir::FeedKind::Scnvel}) default_feed(kind);
    return;
  }
  if (s.params.size() == 2 && is_word(s.params[1], "DEFALT") && is_word(s.params[0])) {
    if (const auto kind = ir::parse_word<ir::FeedKind>(s.params[0].text)) return default_feed(*kind);
  }
  if (!expect_params(s, 3, "MESVEL|POSVEL, a unit (MPM, MMPS, IPM, IPS, PCENT) and a value")) return;
  const auto kind = is_word(s.params[0]) ? ir::parse_word<ir::FeedKind>(s.params[0].text) : std::nullopt;
  if (is_word(s.params[0], "ROTVEL")) {
    // FEDRAT/ROTVEL,RPM,n (DMIS SIR 97-63): a rotary table's speed.
    if (m_noted_kinds.insert("FEDRAT/ROTVEL").second)
      note(s.params[0].span, "sema.rotary-table",
           "FEDRAT/ROTVEL: the virtual CMM has no rotary table to turn (noted once)");
    emit(make(Op::Nop, s, "FEDRAT"));
    return;
  }
  if (is_word(s.params[0]) && !kind) {
    warn(s.params[0].span, "sema.unsupported-setting",
         fmt::format("FEDRAT/{} is not supported and is ignored", s.params[0].text));
    emit(make(Op::Nop, s, "FEDRAT"));
    return;
  }
  if (!is_word(s.params[0]))
    return error(s.params[0].span, "sema.bad-setting", "expected MESVEL, POSVEL or SCNVEL after FEDRAT/");
  const ir::FeedUnit unit = is_word(s.params[1])
                                ? ir::parse_word<ir::FeedUnit>(s.params[1].text).value_or(ir::FeedUnit::Defalt)
                                : ir::FeedUnit::Defalt;
  if (unit == ir::FeedUnit::Defalt)  // DEFALT takes no value (above)
    return error(s.params[1].span, "sema.bad-unit",
                 fmt::format("expected a feed unit (MPM, MMPS, IPM, IPS, PCENT) and a value, or DEFALT, after {}",
                             s.params[0].text));
  auto e = numeric(s.params[2], "a feed rate");
  if (!e) return;
  if (e->op == ir::ExprOp::Constant && e->value.number <= 0)
    return error(s.params[2].span, "sema.bad-feed", "a feed rate must be positive");
  if (s.params.size() > 3)  // dropped unseen before
    warn(s.params[3].span, "sema.feed-arity",
         "FEDRAT takes a kind, a unit and one value; what follows the value is not used");
  auto in = make(Op::Feed, s);
  in.payload = ir::FeedPayload{*kind, unit};
  in.operands.push_back(expr_operand(std::move(*e)));
  emit(std::move(in));
}

// ACLRAT/MESACL|POSACL,MPMM|MMPSS|IPMM|IPSS|PCENT,v
void UnitCompiler::aclrat(const grammar::Statement& s) {
  // ACLRAT/DEFALT, ACLRAT/MESACL|POSACL,DEFALT: the machine's own acceleration again.
  if ((s.params.size() == 1 && is_word(s.params[0], "DEFALT")) ||
      (s.params.size() == 2 && is_word(s.params[1], "DEFALT"))) {
    auto in = make(Op::Accel, s);
    in.operands.push_back(word_operand("DEFALT", s.params.back().span));
    emit(std::move(in));
    return;
  }
  if (!expect_params(s, 3, "MESACL|POSACL, a unit and a value")) return;
  auto e = numeric(s.params[2], "an acceleration");
  if (!e) return;
  if (s.params.size() > 3)  // dropped unseen before
    warn(s.params[3].span, "sema.feed-arity",
         "ACLRAT takes a kind, a unit and one value; what follows the value is not used");
  auto in = make(Op::Accel, s);
  in.operands.push_back(word_operand(s.params[0]));
  in.operands.push_back(word_operand(s.params[1]));
  in.operands.push_back(expr_operand(std::move(*e)));
  emit(std::move(in));
}

// SCNMOD/ON|OFF
void UnitCompiler::scnmod(const grammar::Statement& s) {
  if (!expect_params(s, 1, "ON or OFF")) return;
  if (s.params.size() != 1 || !(is_word(s.params[0], "ON") || is_word(s.params[0], "OFF")))
    return error(s.params[s.params.size() == 1 ? 0 : 1].span, "sema.bad-setting", "expected ON or OFF after SCNMOD/");
  m_scan_mode_on = is_word(s.params[0], "ON");
  auto in = make(Op::ScanMode, s);
  in.operands.push_back(word_operand(s.params[0]));
  emit(std::move(in));
}

// SCNSET/DRAG|DIST|CHORD|ACCEL|DEFLEC,value | SCNSET/LAW,VC1|VC1P|VC2 [, ...]
void UnitCompiler::scnset(const grammar::Statement& s) {
  static const std::set<std::string> values = {"DIST", "DRAG", "CHORD", "ACCEL", "DEFLEC"};
  if (!expect_params(s, 2, "a scan setting (DRAG, DIST, CHORD, ACCEL, DEFLEC, LAW) and its value")) return;
  for (std::size_t i = 0; i < s.params.size(); i += 2) {
    const auto& w = s.params[i];
    if (!is_word(w) || (!values.count(w.text) && w.text != "LAW")) {
      if (is_word(w)) {
        warn(w.span, "sema.unsupported-setting", fmt::format("SCNSET/{} is not supported and is ignored", w.text));
        emit(make(Op::Nop, s, "SCNSET"));
        return;
      }
      return error(w.span, "sema.bad-setting", "expected DRAG, DIST, CHORD, ACCEL, DEFLEC or LAW");
    }
    if (i + 1 >= s.params.size())
      return error(w.span, "sema.missing-parameter", fmt::format("expected a value after {}", w.text));
    auto in = make(Op::ScanSet, s);
    in.operands.push_back(word_operand(w));
    if (w.text == "LAW") {
      const auto& law = s.params[i + 1];
      if (!(is_word(law, "VC1") || is_word(law, "VC1P") || is_word(law, "VC2")))
        return error(law.span, "sema.bad-setting", "expected VC1, VC1P or VC2 after LAW");
      in.operands.push_back(word_operand(law));
    } else {
      auto e = numeric(s.params[i + 1], "a value");
      if (!e) return;
      if (e->op == ir::ExprOp::Constant && !(e->value.number > 0))
        return error(s.params[i + 1].span, "sema.bad-setting",
                     fmt::format("the SCNSET/{} value must be positive", w.text));
      in.operands.push_back(expr_operand(std::move(*e)));
    }
    emit(std::move(in));
  }
}

// GOTO/x,y,z | GOTO/CART,x,y,z | GOTO/INCR,dist,i,j,k | GOTO/POL,r,a,h
void UnitCompiler::go_to(const grammar::Statement& s) {
  auto in = make(Op::GoTo, s);
  ir::FormPayload form;
  std::size_t i = 0;
  if (!s.params.empty() && is_word(s.params[0])) form.form = ir::parse_word<ir::CoordinateForm>(s.params[0].text);
  if (form.form) ++i;
  in.payload = form;
  const bool incr = form.form == ir::CoordinateForm::Incr;
  const std::size_t n = s.params.size() - i;
  if (incr ? n != 4 : (n != 3 && n != 6))
    return error(n == 0 ? s.major_span : s.params.back().span, "sema.goto-arity",
                 incr ? fmt::format("GOTO/INCR expects a distance and a direction i,j,k, got {} numbers", n)
                      : fmt::format("GOTO expects x,y,z (optionally i,j,k), got {} numbers", n));
  for (; i < s.params.size(); ++i) {
    if (!push_number(in, s.params[i], "a coordinate")) return;
  }
  emit(std::move(in));
}

// GOTARG/[CART|POL,]x,y,z ... ENDGO (DMIS 5.3): a move to the target through the GOTO points
// between. The virtual CMM moves through them as it reads them and goes to the target at ENDGO.
void UnitCompiler::go_target(const grammar::Statement& s) {
  if (m_go_target) {
    const Location at = m_sources.locate(m_go_target->span);
    return error(s.major_span, "sema.nested-gotarg",
                 fmt::format("GOTARG inside the GOTARG of line {}: close it with ENDGO first", at.line));
  }
  m_go_target = point_instruction(s, Op::GoTo, "the target");
}

void UnitCompiler::end_go(const grammar::Statement& s) {
  if (!m_go_target) return error(s.major_span, "sema.endgo-without-gotarg", "ENDGO without a GOTARG");
  emit(std::move(*m_go_target));
  m_go_target.reset();
}

// MEAS/type,F(l),n
void UnitCompiler::meas(const grammar::Statement& s) {
  // Open the block first, so that a bad MEAS does not also make its ENDMES an error.
  Block placeholder = block(Block::Kind::Meas, s.span);
  placeholder.start = invalid;
  placeholder.control = true;
  m_blocks.push_back(placeholder);
  if (!expect_params(s, 3, "the feature type, F(label) and the number of points")) return;
  // A feature of a type metron skips (SYMPLN ...): read leniently, the block is skipped up to its
  // ENDMES, so that the program goes on.
  const auto unsupported = is_label(s.params[1], {"F"})
                               ? m_symbols.unsupported_features.find(upper(s.params[1].label.name))
                               : m_symbols.unsupported_features.end();
  if ((is_word(s.params[0]) && unsupported_feature_word(s.params[0].text)) ||
      unsupported != m_symbols.unsupported_features.end()) {
    const std::string what =
        fmt::format("{} of F({}): metron skips FEAT/{}", s.major, s.params[1].label.name,
                    unsupported != m_symbols.unsupported_features.end() ? unsupported->second : s.params[0].text);
    if (m_strict || m_repl) return error(s.params[0].span, "sema.skipped-measurement", what);
    warn(s.params[0].span, "sema.skipped-measurement",
         what + ", so this block is skipped up to its ENDMES, its points not taken (--strict makes it an error)");
    m_blocks.back().skipped = true;
    return;
  }
  const auto meas_type = type_word(s.params[0]);
  if (!meas_type) return error(s.params[0].span, "sema.bad-feature-type", "expected a feature type after MEAS/");
  if (!is_label(s.params[1], {"F"}))
    return error(s.params[1].span, "sema.expected-feature", "expected F(label) after the feature type");
  if (!check_feature(s.params[1])) return;
  const std::string label = upper(s.params[1].label.name);
  const auto type = feature_type(label);
  if (type && *type != *meas_type)
    return error(s.params[0].span, "sema.meas-type",
                 fmt::format("MEAS/{} on F({}), which is FEAT/{}", s.params[0].text, s.params[1].label.name,
                             ir::word_of(*type)));
  auto count = numeric(s.params[2], "the number of points");
  if (!count) return;
  if (s.params.size() > 3) {
    // RationalDMIS writes clearance surfaces on the MEAS (MEAS/POINT,F(P),1,CLRSRF,F(PL),2,...);
    // metron's clearance is SNSET/CLRSRF's. Anything else after the count is not DMIS.
    if (is_word(s.params[3], "CLRSRF"))
      note_once(m_meas_clearance_noted, s.params[3].span, "sema.meas-clearance",
                "CLRSRF on a MEAS (RationalDMIS) is not applied: the clearance is SNSET/CLRSRF's");
    else
      warn(s.params[3].span, "sema.meas-extra",
           fmt::format("MEAS takes the feature type, F(label) and the number of points; the {} parameter{} after them "
                       "{} ignored",
                       s.params.size() - 3, s.params.size() == 4 ? "" : "s", s.params.size() == 4 ? "is" : "are"));
  }
  Block b = block(Block::Kind::Meas, s.span);
  b.feature = label;
  b.scanned = b.scan_pairs = m_scan_mode_on;
  m_symbols.unconstructed.erase(label);
  b.type = *meas_type;
  if (count->op == ir::ExprOp::Constant) {
    b.declared = static_cast<int>(count->value.number);
    if (count->value.number < 0 || count->value.number != std::floor(count->value.number))
      return error(s.params[2].span, "sema.bad-count", "the number of points must be a whole number >= 0");
  }
  auto in = make(Op::MeasBegin, s, label);
  in.name_is_param = macro_param(label).has_value();
  ir::FeaturePayload payload;
  payload.type = *meas_type;
  in.payload = payload;
  in.operands.push_back(expr_operand(std::move(*count)));
  b.start = emit(std::move(in));
  m_blocks.back() = b;
}

// ENDMES
void UnitCompiler::endmes(const grammar::Statement& s) {
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Meas)
    return error(s.major_span, "sema.unmatched", "ENDMES without a matching MEAS");
  Block b = m_blocks.back();
  m_blocks.pop_back();
  if (b.start == invalid) return;
  if (!b.control && !b.scanned && b.ptmeas > 0 && b.declared > 0 && b.ptmeas != b.declared)
    // Shop software measures the PTMEAS it has and reports the difference (DMIS 5.3 leaves it to
    // the DME): a warning, and the block's points are used.
    warn(b.span, "sema.point-count",
         fmt::format("MEAS declares {} points but the block has {} PTMEAS; the {} are used", b.declared, b.ptmeas,
                     b.ptmeas));
  // A macro's body may be called in either mode: only the program's own blocks are judged here.
  if (b.scan_pairs && !m_macro && !b.control && b.ptmeas % 2 == 1)
    error(b.last_ptmeas, "sema.scan-pairs",
          fmt::format("in scan mode (SCNMOD/ON) PTMEAS come in pairs, the start and end of a scan: the block has {}, "
                      "this last one has no end",
                      b.ptmeas));
  const int n = b.ptmeas > 0 ? b.ptmeas : b.declared;
  const int minimum = runtime::minimum_points(b.type);
  if (!b.control && !b.scanned && n > 0 && n < minimum)
    error(b.span, "sema.too-few-points",
          fmt::format("a {} needs at least {} points, the block has {}", ir::word_of(b.type), minimum, n));
  const std::size_t end = emit(make(Op::MeasEnd, s));
  code()[b.start].target = static_cast<std::int64_t>(end);
}

// RMEAS/type,F(l),n,FA(ref) ... ENDMES: a MEAS whose PTMEAS are taken relative to FA(ref), each
// moved by how far the reference's actual lies from its nominal (as RMEAS/CART,...,FA(ref)).
// RMEAS/type,F(l),n,VECBLD,r,m builds the approach from m points at radius r: it is measured as a
// MEAS, with a note. RPTMEAS in it (RationalDMIS writes the m points so) probe the surface around
// the feature first; the block's points are moved as far as that surface lies from its nominal.
void UnitCompiler::rmeas_block(const grammar::Statement& s) {
  grammar::Statement as_meas = s;
  as_meas.major = "MEAS";
  as_meas.params.resize(3);
  meas(as_meas);
  if (m_blocks.empty() || m_blocks.back().kind != Block::Kind::Meas || m_blocks.back().start == invalid) return;
  for (std::size_t i = 3; i < s.params.size(); ++i) {
    if (is_label(s.params[i], {"FA", "F"})) {
      if (!check_feature(s.params[i])) return;
      m_blocks.back().reference = label_op(s.params[i]);
      return;
    }
  }
  note(s.params.size() > 3 ? s.params[3].span : s.major_span, "sema.rmeas-vecbld",
       "this RMEAS names no reference feature (VECBLD builds the approach from probed points): measured as a MEAS");
}

// PTMEAS/CART,x,y,z[,i,j,k]  |  RMEAS/CART,x,y,z,i,j,k[,FA(ref)]  |  RPTMEAS/CART,x,y,z,i,j,k
void UnitCompiler::ptmeas(const grammar::Statement& s) {
  if (s.major == "RMEAS" && s.params.size() >= 3 && is_label(s.params[1], {"F"})) return rmeas_block(s);
  if (m_blocks.empty() ||
      std::none_of(m_blocks.begin(), m_blocks.end(), [](const Block& b) { return b.kind == Block::Kind::Meas; }))
    return error(s.major_span, "sema.ptmeas-outside", fmt::format("{} outside a MEAS block", s.major));
  if (!expect_params(s, 1, "CART or POL")) return;
  if (!is_word(s.params[0], "CART") && !is_word(s.params[0], "POL"))
    return error(s.params[0].span, "sema.expected-form", fmt::format("expected CART or POL after {}/", s.major));
  const bool reference_point = s.major == "RPTMEAS";
  auto in = make(Op::PtMeas, s);
  in.payload = ir::FormPayload{ir::parse_word<ir::CoordinateForm>(s.params[0].text), reference_point};
  std::size_t end = s.params.size();
  if (s.major == "RMEAS" && end > 0 && s.params[end - 1].kind == ExprKind::Label) {
    if (!is_label(s.params[end - 1], {"FA", "F"}))
      return error(s.params[end - 1].span, "sema.expected-feature", "expected FA(label) as the RMEAS reference");
    if (!check_feature(s.params[end - 1])) return;
    --end;
  }
  if (s.major != "RMEAS" && end > 0 && s.params[end - 1].kind == ExprKind::Label)
    return error(s.params[end - 1].span, "sema.ptmeas-arity",
                 "a reference feature after the point belongs to RMEAS: RMEAS/CART,x,y,z,i,j,k,FA(ref)");
  const std::size_t n = end - 1;
  if (n != 3 && n != 6)
    return error(s.params.back().span, "sema.ptmeas-arity",
                 fmt::format("{} expects x,y,z and optionally i,j,k, got {} parameters", s.major, n));
  if (reference_point && n != 6)
    return error(s.params.back().span, "sema.ptmeas-arity",
                 "RPTMEAS expects x,y,z,i,j,k: the surface's normal says where it lies");
  std::vector<double> v;
  for (std::size_t i = 1; i < end; ++i) {
    auto e = numeric(s.params[i], "a coordinate");
    if (!e) return;
    v.push_back(e->op == ir::ExprOp::Constant ? e->value.number : NAN);
    in.operands.push_back(expr_operand(std::move(*e)));
  }
  if (n == 6 && v[3] == 0 && v[4] == 0 && v[5] == 0)
    return error(s.params[4].span, "sema.zero-vector", "the approach vector i,j,k is zero");
  if (end < s.params.size()) {
    in.operands.push_back(label_op(s.params[end]));
  } else {
    // Inside an RMEAS block a PTMEAS is relative to the block's reference.
    const auto meas =
        std::find_if(m_blocks.rbegin(), m_blocks.rend(), [](const Block& b) { return b.kind == Block::Kind::Meas; });
    if (meas != m_blocks.rend() && meas->reference) in.operands.push_back(*meas->reference);
  }
  // The reference points are not the feature's: the block's point count leaves them out.
  for (auto& b : m_blocks)
    if (b.kind == Block::Kind::Meas && !reference_point) {
      ++b.ptmeas;
      b.last_ptmeas = s.span;
    }
  emit(std::move(in));
}

// PAMEAS/P(l): scan along a path inside a MEAS block
void UnitCompiler::pameas(const grammar::Statement& s) {
  if (m_blocks.empty() ||
      std::none_of(m_blocks.begin(), m_blocks.end(), [](const Block& b) { return b.kind == Block::Kind::Meas; }))
    return error(s.major_span, "sema.ptmeas-outside", "PAMEAS outside a MEAS block");
  if (!expect_params(s, 1, "P(label)")) return;
  if (s.params.size() != 1 || !is_label(s.params[0], {"P"}))
    return error(s.params[s.params.size() == 1 ? 0 : 1].span, "sema.expected-path",
                 "expected a single P(label) after PAMEAS/");
  const std::string name = upper(s.params[0].label.name);
  if (!m_symbols.paths.count(name) && !named_at_run(name)) {
    if (auto it = m_symbols.skipped.find("P:" + name); it != m_symbols.skipped.end())
      return error(s.params[0].span, "sema.skipped-definition",
                   fmt::format("path P({}) was defined by a skipped statement", s.params[0].label.name));
    return error(s.params[0].span, "sema.undefined-path",
                 fmt::format("path P({}) is not defined: define it with P({})=PATH/...", s.params[0].label.name,
                             s.params[0].label.name));
  }
  // A GSURF or GCURVE is known only by its PTMEAS points, each its own nominal (run refused a
  // scan of one; check now says so).
  for (const auto& b : m_blocks)
    if (b.kind == Block::Kind::Meas) {
      const auto type = feature_type(b.feature);
      if (type == runtime::FeatureType::GenericSurface || type == runtime::FeatureType::GenericCurve)
        return error(s.major_span, "sema.scanned-generic",
                     fmt::format("F({}) is a {}: it is measured by PTMEAS points, each its own nominal, not by a scan",
                                 b.feature, type == runtime::FeatureType::GenericSurface ? "GSURF" : "GCURVE"));
    }
  auto in = make(Op::PaMeas, s);
  in.operands.push_back(label_op(s.params[0]));
  for (auto& b : m_blocks)
    if (b.kind == Block::Kind::Meas) b.scanned = true;
  emit(std::move(in));
}

}  // namespace metron::interpreter::detail
