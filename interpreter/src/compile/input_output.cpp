// SPDX-License-Identifier: GPL-3.0-or-later
// Input/output statements: UNITS, MODE, TEXT, DEVICE, OPEN, CLOSE (and the statements with no run-time effect).
#include <algorithm>
#include <cmath>
#include <tuple>

#include "compile/unit_compiler.hpp"
#include "metron/runtime/measurement_runtime.hpp"

namespace metron::interpreter::detail {

using grammar::ExprKind;
using ir::Op;

namespace {
// Statements metron accepts with no run-time effect (settings a virtual CMM does not need).
const char* const no_effect_words[] = {"DMISMN", "DMISMD", "FILNAM", "DISPLY", "PRCOMP", "VFORM", "DMEHW", "DMESW",
                                       "FINPOS", "CLMPID", "CLMPSN", "PREVOP", "MFGDEV", "OPERID", "PLANID", "PARTID",
                                       "PARTRV", "PARTSN", "PROCID", "QISDEF", "TECOMP", "TEMPF", "TEMPC", "CRMODE",
                                       "CRSLCT",
                                       // DMIS 5.x statements shop programs carry that change nothing on a
                                       // virtual CMM: vendor switches, fly mode.
                                       "DMESWI", "DMESWV", "FLY", "DMEID", "LOTID", "FIXTID", "FIXTSN",
                                       // Report layouts: metron's reports are its own.
                                       "REPORT",
                                       // Clearance zones and their selection: the virtual CMM's moves
                                       // keep SNSET/CLRSRF's clearance.
                                       "CZONE", "CZSLCT",
                                       // Point buffering and the carriage definitions of a one-carriage
                                       // machine: the points reach the runtime the same either way.
                                       "PTBUFF", "CRGDEF",
                                       // A reference mount (REFMNT) places sensors as SNSMNT does: the
                                       // virtual CMM's sensors are placed by their SNSDEF or library entry.
                                       "REFMNT",
                                       // XTERN ... ENDXTN frames the EXTFIL declarations, which do the work.
                                       "XTERN", "ENDXTN"};

// Statements accepted without their effect, which a reader of the results may want to know: one
// note per program and word, with the reason.
struct NotedWord {
  const char* word;
  const char* reason;
};
const NotedWord noted_words[] = {
    {"RAPID", "RAPID: the next move is made at the positioning feed (FEDRAT/POSVEL), not at a rapid rate"},
    {"DELETE", "DELETE: the labels stay defined (a virtual CMM has the memory); a later use of one is not refused"},
    {"KEYCHAR", "KEYCHAR: key characteristics are not marked in the report"},
    {"CNFRMRUL", "CNFRMRUL: tolerances are judged IN or OUT on the measured value, without an uncertainty rule"},
    {"UNCERTALG", "UNCERTALG: no measurement uncertainty is computed or reported"},
    {"UNCERTSET", "UNCERTSET: no measurement uncertainty is computed or reported"},
    {"LITDEF", "LITDEF: the virtual CMM has no vision sensor to light"},
    {"WINDEF", "WINDEF: the virtual CMM has no vision sensor to window"},
    {"FILDEF", "FILDEF: the virtual CMM has no vision sensor to filter"},
    {"ALGDEF", "ALGDEF: the vendor's algorithms it names (SNSET/VA) are not run; GEOALG chooses metron's fits"},
    // CROSCL/ON|OFF (DMIS SIR 96-5, "CrossCenterLine"): whether the sensor may pass the centre of a
    // rotary axis on a machine of two linear axes and one rotary.
    {"CROSCL", "CROSCL: the virtual CMM has no rotary axis whose centre line the sensor could cross"},
    {"BOUND", "BOUND: features are not bounded by other features; each is fitted and reported over its own points"},
    {"PSTHRU", "PSTHRU: its text is for a real controller; the virtual CMM has none to pass it to"},
    {"CUTCOM", "CUTCOM: a CMM has no cutter to compensate"},
    {"TOOLDF", "TOOLDF: machining tools are not used by a CMM"},
    {"THLDEF", "THLDEF: thread definitions are not evaluated"},
    {"MATDEF", "MATDEF: part materials are not used (TECOMP is not applied either)"},
};
}  // namespace

void UnitCompiler::add_input_output(StatementTable& t) {
  for (const char* w : no_effect_words) t.emplace(w, &UnitCompiler::no_effect);
  for (const auto& w : noted_words) t.emplace(w.word, &UnitCompiler::noted_no_effect);
  t.insert({{"UNITS", &UnitCompiler::units},
            {"MODE", &UnitCompiler::mode},
            {"TEXT", &UnitCompiler::text},
            {"DEVICE", &UnitCompiler::device},
            {"OPEN", &UnitCompiler::open},
            {"GEOM", &UnitCompiler::cad_geometry},
            {"EQUATE", &UnitCompiler::equate},
            {"CLOSE", &UnitCompiler::close},
            {"PAUSE", &UnitCompiler::pause},
            {"DECPL", &UnitCompiler::decpl},
            {"READ", &UnitCompiler::read},
            {"WRITE", &UnitCompiler::write},
            {"ERROR", &UnitCompiler::on_error},
            {"RESUME", &UnitCompiler::resume},
            {"GEOALG", &UnitCompiler::geometry_algorithm},
            {"WKPLAN", &UnitCompiler::work_plane},
            {"PUSH", &UnitCompiler::push_pop},
            {"POP", &UnitCompiler::push_pop},
            {"GOHOME", &UnitCompiler::go_home},
            {"FROM", &UnitCompiler::from},
            {"BADTST", &UnitCompiler::bad_test}});
}

// DECPL/ALL,n | DECPL/LENGTH,n[,ANGLE,m] | DECPL/n: the decimals of reports and DMIS output files
// (docs/language.md). Other words (vendor sub-kinds) are kept and count as lengths.
void UnitCompiler::decpl(const grammar::Statement& s) {
  if (!expect_params(s, 1, "ALL, LENGTH or ANGLE and the number of decimals")) return;
  auto in = make(Op::DecimalPlaces, s);
  for (const auto& p : s.params) {
    if (is_word(p) && !is_variable(p.text)) {
      in.operands.push_back(word_operand(p));
    } else if (!push_number(in, p, "a number of decimals")) {
      return;
    }
  }
  emit(std::move(in));
}

void UnitCompiler::no_effect(const grammar::Statement& s) { emit(make(Op::Nop, s, s.major)); }

void UnitCompiler::noted_no_effect(const grammar::Statement& s) {
  const auto* w = std::find_if(std::begin(noted_words), std::end(noted_words),
                               [&](const NotedWord& n) { return s.major == n.word; });
  if (w != std::end(noted_words) && m_noted_kinds.insert(s.major).second)
    note(s.span, "sema.not-applied", fmt::format("{} (noted once)", w->reason));
  emit(make(Op::Nop, s, s.major));
}

// WKPLAN/XYPLAN|YZPLAN|ZXPLAN: the plane polar coordinates are taken in (CORTOL RADIUS and ANGLE,
// the POL positions of FEAT, PTMEAS, GOTO and FROM).
// Another form (a feature's plane) is read leniently with a warning: XYPLAN stays.
void UnitCompiler::work_plane(const grammar::Statement& s) {
  if (!expect_params(s, 1, "XYPLAN, YZPLAN or ZXPLAN")) return;
  const auto& w = s.params[0];
  if (s.params.size() != 1 || !(is_word(w, "XYPLAN") || is_word(w, "YZPLAN") || is_word(w, "ZXPLAN"))) {
    if (m_strict) return error(w.span, "sema.bad-setting", "expected XYPLAN, YZPLAN or ZXPLAN after WKPLAN/");
    // Told once per form: WinWerth writes WKPLAN/NONE before every construction.
    if (m_noted_kinds.insert("WKPLAN/" + (is_word(w) ? w.text : std::string("..."))).second)
      warn(w.span, "sema.bad-setting",
           "WKPLAN takes XYPLAN, YZPLAN or ZXPLAN; this form is not applied: the working plane is unchanged (told "
           "once)");
    emit(make(Op::Nop, s, "WKPLAN"));
    return;
  }
  auto in = make(Op::WorkPlane, s);
  in.operands.push_back(word_operand(w));
  emit(std::move(in));
}

// PUSH/word,... and POP/word,...: the state each word names saved and restored, in order (ALGN,
// SNSLCT, WKPLAN, SNSET, GEOALG, FEDRAT: runtime/src/pushed_state.cpp). No public text of DMIS's PUSH was
// found: these are the words of the states metron holds; another word is read with one warning
// and saves nothing.
void UnitCompiler::push_pop(const grammar::Statement& s) {
  static constexpr const char* words = "ALGN, SNSLCT, WKPLAN, SNSET, GEOALG and FEDRAT";
  if (!expect_params(s, 1, "what to save or restore: ALGN, SNSLCT, WKPLAN, SNSET, GEOALG or FEDRAT")) return;
  auto in = make(s.major == "PUSH" ? Op::Push : Op::Pop, s);
  for (const auto& p : s.params) {
    if (!is_word(p)) return error(p.span, "sema.push-word", fmt::format("expected a word after {}/", s.major));
    if (runtime::MeasurementRuntime::pushable(p.text)) {
      in.operands.push_back(word_operand(p));
      note_push_balance(s.major == "PUSH", p);
      continue;
    }
    if (m_strict)
      return error(p.span, "sema.push-word",
                   fmt::format("{}/{}: metron saves and restores {}", s.major, p.text, words));
    if (m_push_words_warned.insert(p.text).second)
      warn(p.span, "sema.push-word",
           fmt::format("{}/{}: metron saves and restores {}; {} is neither saved nor restored (told once per word, "
                       "--strict makes it an error)",
                       s.major, p.text, words, p.text));
  }
  if (in.operands.empty()) {
    emit(make(Op::Nop, s, s.major));
    return;
  }
  emit(std::move(in));
}

// A POP whose word has no PUSH before it in the program's text stops the run there: check says so.
// A macro's POP may restore what its caller pushed, so only a program's own text is counted.
void UnitCompiler::note_push_balance(bool push, const grammar::Expr& word) {
  if (m_macro) return;
  int& open = m_pushes_open[word.text];
  if (push) {
    ++open;
    return;
  }
  if (open > 0) {
    --open;
    return;
  }
  warn(word.span, "sema.pop-without-push",
       fmt::format("POP/{} has no PUSH/{} before it in this program: the run stops here", word.text, word.text));
}

// GEOALG/type,algorithm: MAXINS, MINCIR, MINMAX and LSTSQR (DEFALT) are applied to CIRCLE, ARC,
// SPHERE and CYLNDR, MINMAX and LSTSQR to PLANE, LINE and CONE; any other type or algorithm (an
// EXTERN algorithm ...), and a FILTER or ELIMINATE after it, is accepted without its effect, which
// a program may rely on: one warning per program says so.
void UnitCompiler::geometry_algorithm(const grammar::Statement& s) {
  const auto word_at = [&](std::size_t i) {
    return i < s.params.size() && is_word(s.params[i]) ? s.params[i].text : std::string();
  };
  const std::string type = word_at(0), algorithm = word_at(1);
  const bool sized = type == "CIRCLE" || type == "ARC" || type == "SPHERE" || type == "CYLNDR";
  const bool unsized = type == "PLANE" || type == "LINE" || type == "CONE";  // no size a gauge would find
  const bool least_squares = s.params.size() < 2 || algorithm == "LSTSQR" || algorithm == "DEFALT";
  // FILTER (a cut-off, a Gaussian ...) or ELIMINATE (outliers) after the algorithm: the points are
  // fitted as measured; told once, not dropped unseen.
  if (s.params.size() > 2 && (is_word(s.params[2], "FILTER") || is_word(s.params[2], "ELIMINATE")) &&
      m_noted_kinds.insert("GEOALG-FILTER").second)
    warn(s.params[2].span, "sema.not-applied",
         fmt::format(
             "GEOALG/{},{},{}: metron does not filter or thin the points; they are fitted as measured (noted once)",
             type, algorithm, s.params[2].text));
  if ((sized || unsized) &&
      (least_squares || algorithm == "MINMAX" || (sized && (algorithm == "MAXINS" || algorithm == "MINCIR")))) {
    // MAXINS a hole's pin-gauge size, MINCIR a boss's ring-gauge size, MINMAX the minimum zone
    // reference feature; LSTSQR and DEFALT back to least squares.
    auto in = make(Op::FitAlgorithm, s);
    in.operands.push_back(word_operand(type == "ARC" ? std::string("CIRCLE") : type, s.params[0].span));
    in.operands.push_back(word_operand(least_squares ? std::string("LSTSQR") : algorithm, s.params.back().span));
    emit(std::move(in));
    return;
  }
  if (least_squares) {
    emit(make(Op::Nop, s, s.major));  // least squares: what metron does
    return;
  }
  if (m_noted_kinds.insert(s.major).second) {
    // A feature type is fitted by least squares; another word (ANGLB, a vendor's) is evaluated as
    // docs/tolerances.md describes.
    const bool feature_type = !type.empty() && ir::parse_word<runtime::FeatureType>(type).has_value();
    const std::string message =
        feature_type ? fmt::format(
                           "GEOALG/{},{}: this fitting algorithm is not applied: metron fits {} by least "
                           "squares (form tolerances by minimum zone) (noted once)",
                           type, algorithm, type)
                     : fmt::format(
                           "GEOALG/{},{}: this algorithm is not applied: metron evaluates {} as "
                           "docs/tolerances.md describes (noted once)",
                           type, algorithm, type.empty() ? std::string("it") : type);
    warn(s.span, "sema.not-applied", message);
  }
  emit(make(Op::Nop, s, s.major));
}

// BADTST/ON|OFF (DMIS 5.x): with ON, a measurement that fails (a missed or unexpected contact,
// or points no feature fits) does not stop the run; the program asks BADPT() and BADGT() about
// the last measurement and decides (docs/language.md).
void UnitCompiler::bad_test(const grammar::Statement& s) {
  if (!expect_params(s, 1, "ON or OFF")) return;
  if (!is_word(s.params[0], "ON") && !is_word(s.params[0], "OFF")) {
    error(s.params[0].span, "sema.bad-parameter", "expected ON or OFF after BADTST/");
    return;
  }
  auto in = make(Op::BadTest, s);
  in.operands.push_back(word_operand(s.params[0]));
  emit(std::move(in));
}

// ERROR/(label),cond | ERROR/AUTO,cond | ERROR/OFF (DMIS 5.x; the handler and the condition are
// read in either order, as shop software writes both): from here on, a machine fault the
// condition covers (ALL; NOTOUCH: no contact; ILLEGALTOUCH: a contact where none was expected,
// a probe over-travel; a DME error code: any) goes to the handler label, or with AUTO (IGNORE)
// goes on after the failing statement; OFF stops handling. A macro as the handler, M(x), is not
// run: a warning. docs/language.md.
void UnitCompiler::on_error(const grammar::Statement& s) {
  if (!expect_params(s, 1, "(label), AUTO or OFF, then ALL, NOTOUCH or ILLEGALTOUCH")) return;
  auto in = make(Op::OnError, s);
  const auto& p = s.params;
  if (is_word(p[0], "OFF")) {
    in.operands.push_back(word_operand(p[0]));
    emit(std::move(in));
    return;
  }
  std::optional<ir::Operand> condition, how;
  std::string jump_name;
  Span jump_span;
  for (const auto& q : p) {
    if (is_word(q, "ALL") || is_word(q, "NOTOUCH") || is_word(q, "ILLEGALTOUCH")) {
      condition = word_operand(q);
    } else if (q.kind == ExprKind::Number) {
      condition = word_operand("ALL", q.span);  // a DME's error code: metron's faults have none
    } else if (is_word(q, "AUTO") || is_word(q, "IGNORE")) {
      how = word_operand("AUTO", q.span);
    } else if (q.kind == ExprKind::Paren) {
      std::tie(jump_name, jump_span) = jump_label_name(q);
      if (jump_name.empty())
        return error(q.span, "sema.bad-error-handler", "expected the handler's label in parentheses");
      how = word_operand("JUMP", q.span);
    } else if (is_label(q, {"M"})) {
      warn(q.span, "sema.not-applied",
           fmt::format("ERROR with the macro M({}) as its handler is not run: a machine fault stops the run",
                       q.label.name));
      emit(make(Op::Nop, s, s.major));
      return;
    } else {
      return error(
          q.span, "sema.bad-error-handler",
          "expected the handler's label in parentheses, AUTO or OFF, and ALL, NOTOUCH, ILLEGALTOUCH or an error code");
    }
  }
  if (!how)
    return error(p[0].span, "sema.bad-error-handler",
                 "expected the handler's label in parentheses, AUTO or OFF after ERROR/");
  in.operands.push_back(*how);
  in.operands.push_back(condition.value_or(word_operand("ALL", p[0].span)));
  if (jump_name.empty()) {
    emit(std::move(in));
    return;
  }
  emit_jump(std::move(in), jump_name, jump_span);
}

// RESUME/(label) | NEXTLINE | NEXTMEAS | CURMEAS | END: where a handler goes on.
void UnitCompiler::resume(const grammar::Statement& s) {
  if (!expect_params(s, 1, "(label), NEXTLINE, NEXTMEAS, CURMEAS or END")) return;
  auto in = make(Op::Resume, s);
  const auto& p = s.params[0];
  if (is_word(p, "NEXTLINE") || is_word(p, "NEXTMEAS") || is_word(p, "CURMEAS") || is_word(p, "END")) {
    in.operands.push_back(word_operand(p));
    emit(std::move(in));
    return;
  }
  const auto [name, span] = jump_label_name(p);
  if (name.empty() || p.kind != ExprKind::Paren)
    return error(p.span, "sema.bad-resume", "expected (label), NEXTLINE, NEXTMEAS, CURMEAS or END after RESUME/");
  in.operands.push_back(word_operand("JUMP", p.span));
  emit_jump(std::move(in), name, span);
}

// GOHOME: the machine's home, straight at the positioning feed (a program lifts the probe
// clear first, as it would on the machine).
void UnitCompiler::go_home(const grammar::Statement& s) {
  if (!s.params.empty()) warn(s.params.front().span, "sema.extra-params", "GOHOME takes no parameters: ignored");
  emit(make(Op::GoHome, s));
}

// FROM/[CART|POL,]x,y,z (DMIS 5.3): the program's home position, in the current coordinate
// system; GOHOME goes there from here on. FROM does not move the machine.
void UnitCompiler::from(const grammar::Statement& s) {
  if (auto in = point_instruction(s, Op::SetHome, "the home position")) emit(std::move(*in));
}

// [CART|POL,]x,y,z of FROM and GOTARG: the instruction with its form and three numbers, or
// nullopt after an error that says what the point is.
std::optional<ir::Instruction> UnitCompiler::point_instruction(const grammar::Statement& s, Op op, const char* what) {
  auto in = make(op, s);
  ir::FormPayload form;
  std::size_t i = 0;
  if (!s.params.empty() && (is_word(s.params[0], "CART") || is_word(s.params[0], "POL")))
    form.form = ir::parse_word<ir::CoordinateForm>(s.params[i++].text);
  in.payload = form;
  if (s.params.size() - i != 3) {
    error(s.params.empty() ? s.major_span : s.params.back().span, "sema.point-arity",
          fmt::format("{} expects x,y,z ({}), got {} numbers", s.major, what, s.params.size() - i));
    return std::nullopt;
  }
  for (; i < s.params.size(); ++i)
    if (!push_number(in, s.params[i], "a coordinate")) return std::nullopt;
  return in;
}

// UNITS/MM|INCH|CM|M|FEET,ANGDEC|ANGRAD[,TEMPF|TEMPC][,MMPS|IPS|MPM|IPM]. RationalDMIS writes a
// velocity unit after the angle unit (`UNITS/MM, ANGDEC, MMPS` heads every program it saves); each
// FEDRAT names its own unit, so it is accepted and changes nothing.
void UnitCompiler::units(const grammar::Statement& s) {
  if (!expect_params(s, 1, "a length unit (MM, INCH, CM, M, FEET)")) return;
  auto in = make(Op::Units, s);
  ir::UnitsPayload units;
  const auto length = is_word(s.params[0]) ? ir::parse_word<ir::LengthUnit>(s.params[0].text) : std::nullopt;
  if (!length)
    return error(s.params[0].span, "sema.bad-unit",
                 fmt::format("expected a length unit ({}) after UNITS/", ir::word_list<ir::LengthUnit>()));
  units.length = *length;
  if (s.params.size() > 1) {
    units.angle = is_word(s.params[1]) ? ir::parse_word<ir::AngleUnit>(s.params[1].text) : std::nullopt;
    if (!units.angle)
      return error(s.params[1].span, "sema.bad-unit", "expected an angle unit (ANGDEC, ANGRAD) after the length unit");
    if (units.angle == ir::AngleUnit::Angdms)
      warn(s.params[1].span, "sema.angdms", "ANGDMS is read as decimal degrees");
  }
  bool velocity = false;
  for (std::size_t i = 2; i < s.params.size(); ++i) {
    const auto& p = s.params[i];
    const bool word = is_word(p);
    if (const auto t = word ? ir::parse_word<ir::TemperatureUnit>(p.text) : std::nullopt; t && !units.temperature) {
      units.temperature = t;
    } else if (const auto v = word ? ir::parse_word<ir::FeedUnit>(p.text) : std::nullopt;
               v && !velocity && *v != ir::FeedUnit::Pcent && *v != ir::FeedUnit::Defalt) {
      velocity = true;
    } else {
      return error(p.span, "sema.bad-unit",
                   "expected a temperature unit (TEMPC, TEMPF) or a velocity unit (MMPS, IPS, MPM, IPM) after the "
                   "angle unit, each once");
    }
  }
  in.payload = units;
  emit(std::move(in));
}

// MODE/AUTO | MODE/PROG,MAN | MODE/MAN | MODE/AUTO,PROG | MODE/AUTO,PROG,MAN   (DMIS 5.3 6.106: the
// words say what the DME may do; AUTO wins, PROG without AUTO is programmed-manual)
void UnitCompiler::mode(const grammar::Statement& s) {
  if (!expect_params(s, 1, "AUTO, PROG,MAN or MAN")) return;
  auto in = make(Op::Mode, s);
  bool is_auto = false, is_prog = false, is_man = false;
  for (const auto& p : s.params) {
    const std::string w = is_word(p) ? p.text : std::string();
    if (w == "AUTO")
      is_auto = true;
    else if (w == "PROG")
      is_prog = true;
    else if (w == "MAN")
      is_man = true;
    else
      return error(p.span, "sema.bad-mode", "expected AUTO, PROG,MAN or MAN after MODE/");
  }
  if (is_prog && !is_auto && !is_man) {
    // MODE/PROG alone (WinWerth's): the program drives the machine, read as AUTO.
    if (m_strict) return error(s.params[0].span, "sema.bad-mode", "expected AUTO, PROG,MAN or MAN after MODE/");
    if (m_noted_kinds.insert("MODE/PROG").second)
      warn(s.params[0].span, "sema.bad-mode",
           "MODE/PROG alone is not a DMIS mode (AUTO, PROG,MAN or MAN): read as MODE/AUTO, the program driving the "
           "machine (told once; --strict makes it an error)");
    is_auto = true;
  }
  in.payload = ir::ModePayload{is_auto ? ir::RunMode::Auto : is_prog ? ir::RunMode::ProgMan : ir::RunMode::Man};
  emit(std::move(in));
}

// PAUSE: the operator resumes the program. A virtual CMM's operator does not keep the run waiting;
// he puts the part in its next set-up if the world has one (docs/world.md, part.setups).
void UnitCompiler::pause(const grammar::Statement& s) {
  if (!m_paused) {
    note(s.span, "sema.pause",
         "PAUSE does not wait on the virtual CMM: its operator goes on at once (noted once; a world's part.setups "
         "has him move the part here)");
    m_paused = true;
  }
  emit(make(Op::Pause, s));
}

// TEXT/OPER|OUTFIL|MAN|DISPLY,'text'
void UnitCompiler::text(const grammar::Statement& s) {
  if (!expect_params(s, 2, "the text kind (OPER, OUTFIL, MAN) and the text")) return;
  if (is_word(s.params[0], "QUERY")) return text_query(s);
  auto in = make(Op::Text, s);
  in.operands.push_back(word_operand(s.params[0]));
  auto e = expression(s.params[1]);
  if (!e) return;
  if (s.params.size() > 2) {
    // TEXT/OPER,'X = ',STR(X),' mm' (as shop programs write it): the texts one after another; a
    // number is shown as STR shows it. Only the first was shown, the rest dropped unseen.
    ir::Expr joined;
    joined.op = ir::ExprOp::Call;
    joined.name = "CONCAT";
    joined.span = s.span;
    joined.type = ValueType::String;
    const auto as_text = [&](UnitCompiler::Typed t) {
      if (!t.dynamic && t.e.type == ValueType::String) return std::move(t.e);
      ir::Expr shown;
      shown.op = ir::ExprOp::Call;
      shown.name = "STR";
      shown.span = t.e.span;
      shown.type = ValueType::String;
      shown.args.push_back(std::move(t.e));
      return shown;
    };
    joined.args.push_back(as_text(std::move(*e)));
    for (std::size_t i = 2; i < s.params.size(); ++i) {
      auto more = expression(s.params[i]);
      if (!more) return;
      joined.args.push_back(as_text(std::move(*more)));
    }
    in.operands.push_back(expr_operand(std::move(joined)));
  } else {
    in.operands.push_back(expr_operand(std::move(e->e)));
  }
  emit(std::move(in));
}

// TEXT/QUERY,(V),length,AN|N|...,L|R,'question': the operator's answer into V, as V=PROMPT/'question'
// (scripted with --answers at run, else the default with a warning); the field length, kind and
// justification are a terminal's layout.
void UnitCompiler::text_query(const grammar::Statement& s) {
  const grammar::Expr* v = &s.params[1];
  if (v->kind == ExprKind::Paren && !v->args.empty()) v = &v->args[0];
  if (v->kind == ExprKind::Word && !is_variable(v->text)) {
    // The form is right, the variable was never declared (a tutorial's line on its own).
    if (m_strict)
      return error(v->span, "sema.undeclared-variable",
                   fmt::format("variable {} is not declared: add DECL/CHAR,20,{} first", v->text, v->text));
    warn(v->span, "sema.undeclared-variable",
         fmt::format("variable {} is not declared: this TEXT/QUERY declares it CHAR (--strict: an error)", v->text));
    declare_implicitly(v->text, ValueType::String, v->span, s);
  }
  if (v->kind != ExprKind::Word || !is_variable(v->text))
    return error(s.params[1].span, "sema.text-query",
                 "TEXT/QUERY takes the variable that receives the answer: TEXT/QUERY,(V),20,AN,L,'question'");
  const std::string name = v->text;
  const SymbolTable::VariableInfo* info = variable(name);
  if (info && info->size > 0)
    return error(v->span, "sema.array-without-index", fmt::format("array {} needs an index", name));
  ir::Expr value;
  value.op = ir::ExprOp::Call;
  value.name = "PROMPT";
  value.span = s.span;
  value.type = info ? info->type : ValueType::Real;
  for (std::size_t i = 2; i < s.params.size(); ++i)
    if (s.params[i].kind == ExprKind::String) {
      auto q = expression(s.params[i]);
      if (!q) return;
      value.args.push_back(std::move(q->e));
      break;
    }
  auto in = make(Op::Assign, s, name);
  in.operands.push_back(expr_operand(std::move(value)));
  emit(std::move(in));
}

// DID(l)=DEVICE/STOR|TERM|PRINT|INCR,'path'
void UnitCompiler::device(const grammar::Statement& s) {
  if (!require_target(s, {"DID"}, "DID(label)=DEVICE/STOR,'file'")) return;
  if (!expect_params(s, 1, "the device kind")) return;
  auto in = make(Op::DeviceDef, s, upper(s.target->name));
  in.operands.push_back(word_operand(s.params[0]));
  if (s.params.size() > 1) {
    auto e = expression(s.params[1]);
    if (!e) return;
    in.operands.push_back(expr_operand(std::move(e->e)));
  }
  note_definition("DID", upper(s.target->name), s.span);
  m_symbols.devices.insert(upper(s.target->name));
  emit(std::move(in));
}

// The DID(label) of OPEN and CLOSE: given and defined.
bool UnitCompiler::check_device(const grammar::Statement& s) {
  if (!expect_params(s, 1, "DID(label)")) return false;
  if (!is_label(s.params[0], {"DID"})) {
    error(s.params[0].span, "sema.expected-device", fmt::format("expected DID(label) after {}/", s.major));
    return false;
  }
  if (!m_symbols.devices.count(upper(s.params[0].label.name))) {
    error(s.params[0].span, "sema.undefined-device",
          fmt::format("device DID({}) is not defined", s.params[0].label.name));
    return false;
  }
  return true;
}

// OPEN/DID(l),FDATA|DIRECT,DMIS|V(...),OUTPUT|INPUT|APPEND|OVERWR
void UnitCompiler::open(const grammar::Statement& s) {
  if (!check_device(s)) return;
  if (s.params.size() > 1 && is_word(s.params[1], "CAD")) {
    // OPEN/DID(l),CAD,...: the part's CAD model for the CMM software's display and nominals. The
    // virtual CMM's part is the world's; the model is not read, and no file is opened or made.
    note(s.params[1].span, "sema.cad-model", "OPEN of a CAD model: the part is the world's, the model is not read");
    emit(make(Op::Nop, s, "OPEN"));
    return;
  }
  auto in = make(Op::DeviceOpen, s);
  in.operands.push_back(label_op(s.params[0]));
  bool input = false;
  for (const auto& p : s.params) {
    if (is_word(p, "INPUT") || is_word(p, "DIRECT")) in.operands.push_back(word_operand(p));
    input = input || is_word(p, "INPUT");
  }
  // A VFORM layout (V(x)=VFORM/ALL, a spreadsheet's columns) is CMM software's own: metron writes
  // the device as a DMIS output file, and says so rather than write another layout unasked.
  for (const auto& p : s.params)
    if (!input && is_label(p, {"V"}))
      note(p.span, "sema.vform",
           fmt::format("the layout V({}) (VFORM) is not applied: DID({}) gets a DMIS output file, as "
                       "OPEN/...,FDATA,DMIS writes it",
                       p.label.name, s.params[0].label.name));
  emit(std::move(in));
}

// G(l)=GEOM/DID(model),...: geometry of the CAD model, named for the CMM software's nominals. The
// virtual CMM's part is the world's and the model is not read (OPEN/CAD): noted once; G(l) is
// remembered as skipped, so a later use of it says so.
void UnitCompiler::cad_geometry(const grammar::Statement& s) {
  if (s.target) m_symbols.skipped[s.target->prefix + ":" + upper(s.target->name)] = s.span;
  if (m_noted_kinds.insert("GEOM").second)
    note(s.span, "sema.cad-model",
         "GEOM names geometry of the CAD model: the part is the world's, the model is not read (noted once)");
  emit(make(Op::Nop, s, "GEOM"));
}

// EQUATE/DA(l),CADCS,DID(model)[,'name']: ties an alignment to the CAD model's coordinate system, so
// that CMM software places the model on the part. The virtual CMM reads no model and the program's
// nominals are in the part's coordinates already: nothing to tie, a note.
// EQUATE/DA(a),DA(b): the part frame of an earlier set-up and of a later one made one; what the
// earlier set-up measured is carried into the later (runtime equate, docs/alignments.md).
void UnitCompiler::equate(const grammar::Statement& s) {
  const auto& p = s.params;
  if (p.size() >= 3 && is_label(p[0], {"DA", "D"}) && is_word(p[1], "CADCS") && is_label(p[2], {"DID"})) {
    note(p[1].span, "sema.cad-model",
         fmt::format("EQUATE of DA({}) with the CAD model's coordinate system: the model is not read and the "
                     "nominals are the part's; nothing to equate",
                     p[0].label.name));
    emit(make(Op::Nop, s, "EQUATE"));
    return;
  }
  if (p.size() == 2 && is_label(p[0], {"DA", "D"}) && is_label(p[1], {"DA", "D"})) {
    auto in = make(Op::Equate, s);
    for (const auto& label : p) {
      if (!known_alignment(label, "EQUATE")) return;
      in.operands.push_back(label_op(label));
    }
    emit(std::move(in));
    return;
  }
  unknown(s);
}

// WRITE/DID(l),e1,e2,...: one line of the values (text as it is, numbers as TEXT shows them) into
// an output file open for OUTPUT. A value may carry its layout, `e:width[:decimals]`.
constexpr double k_max_write_field = 1000;
void UnitCompiler::write(const grammar::Statement& s) {
  if (!check_device(s)) return;
  auto in = make(Op::Write, s);
  in.operands.push_back(label_op(s.params[0]));
  for (std::size_t i = 1; i < s.params.size(); ++i) {
    const grammar::Expr& p = s.params[i];
    const bool laid_out = p.kind == ExprKind::Format;
    auto e = standalone_expression(laid_out ? p.args[0] : p);
    if (!e) return;
    auto o = expr_operand(std::move(*e));
    if (laid_out) {
      // Widths beyond a line's worth are a typing error, not a layout.
      for (std::size_t k = 1; k < p.args.size(); ++k)
        if (p.args[k].number > k_max_write_field)
          return error(p.args[k].span, "sema.write-format",
                       fmt::format("a WRITE field of {} characters is more than the {} metron allows", p.args[k].number,
                                   k_max_write_field));
      o.width = static_cast<int>(p.args[1].number);
      if (p.args.size() > 2) o.decimals = static_cast<int>(p.args[2].number);
    }
    in.operands.push_back(std::move(o));
  }
  emit(std::move(in));
}

// READ/DID(l),v1,v2,...: the next values of an input file into declared variables (docs/language.md).
void UnitCompiler::read(const grammar::Statement& s) {
  if (!check_device(s)) return;
  auto in = make(Op::Read, s);
  in.operands.push_back(label_op(s.params[0]));
  if (s.params.size() < 2) return error(s.params[0].span, "sema.read", "READ/DID(x) needs the variables to read into");
  for (std::size_t i = 1; i < s.params.size(); ++i) {
    const auto& p = s.params[i];
    if (p.kind != ExprKind::Word || !(is_variable(p.text) || macro_param(p.text) || m_locals.count(p.text)))
      return error(p.span, "sema.read",
                   fmt::format("READ reads into declared scalar variables; {} is not one",
                               p.text.empty() ? std::string("this") : p.text));
    in.names.push_back(p.text);
  }
  emit(std::move(in));
}

// CLOSE/DID(l)
void UnitCompiler::close(const grammar::Statement& s) {
  if (!check_device(s)) return;
  auto in = make(Op::DeviceClose, s);
  in.operands.push_back(label_op(s.params[0]));
  emit(std::move(in));
}

}  // namespace metron::interpreter::detail
