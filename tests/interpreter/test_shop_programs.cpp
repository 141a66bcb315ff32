// SPDX-License-Identifier: GPL-3.0-or-later
// What real shop-floor DMIS programs contain (issue 14): sensors from the probe library, the
// statements PC-DMIS, CAMIO and lab generators write, a lenient reader. The programs here are
// written for these tests in the dialects' style (the public originals are not ours to copy).
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <fmt/format.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <unistd.h>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/grammar/parser.hpp"
#include "metron/interpreter/compiler.hpp"
#include "metron/interpreter/session.hpp"
#include "metron/machine/nominal_machine.hpp"
#include "metron/runtime/outputs.hpp"

namespace {

namespace fs = std::filesystem;
using metron::DiagnosticSink;
using metron::Severity;
using metron::SourceManager;
using metron::interpreter::Compiler;
using metron::interpreter::ExecStatus;
using metron::interpreter::Session;

// `metron check` on a text: every diagnostic, formatted.
struct Checked {
  std::size_t errors = 0, warnings = 0, notes = 0;
  std::string text;
  [[nodiscard]] bool has(const std::string& s) const { return text.find(s) != std::string::npos; }
};

Checked check(const std::string& program, bool strict = false) {
  SourceManager sources;
  DiagnosticSink sink;
  Compiler compiler(sources, sink);
  compiler.set_parse_options(metron::grammar::ParseOptions{strict});
  compiler.compile_text("shop.dmi", program);
  Checked c;
  for (const auto& d : sink.items()) {
    c.text += metron::format_diagnostic(d, sources);
    if (d.severity == Severity::Error)
      ++c.errors;
    else if (d.severity == Severity::Warning)
      ++c.warnings;
    else
      ++c.notes;
  }
  return c;
}

fs::path temp_dir() {
  const fs::path d = metron::test_support::scratch_root("metron_shop");
  fs::create_directories(d);
  return d;
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = temp_dir() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

const fs::path source_dir = METRON_SOURCE_DIR;

/// A world file `name`: `base` with the hidden deviations `deviations` (a JSON object keyed by
/// primitive name, docs/world.md).
fs::path deviated(const std::string& name, const fs::path& base, const std::string& deviations) {
  return write(name, "{\"extends\": \"" + base.string() + "\", \"part\": {\"deviations\": " + deviations + "}}\n");
}

struct Ran {
  ExecStatus status = ExecStatus::Error;
  std::string diagnostics;
  std::unique_ptr<Session> session;
};

Ran run(const std::string& text, const std::optional<fs::path>& world = std::nullopt,
        std::vector<std::string> answers = {}) {
  const fs::path p = write("run.dmi", text);
  auto backend =
      metron::cli::virtual_cmm_backend(world ? std::optional<std::string>(world->string()) : std::nullopt, 1);
  EXPECT_TRUE(backend.has_value()) << (backend ? "" : backend.error());
  Ran r;
  r.session = Session::create(std::move(*backend));
  r.session->interpreter().set_prompt_answers(std::move(answers));
  if (r.session->load(p.string())) r.status = r.session->interpreter().run();
  r.diagnostics = r.session->take_diagnostics();
  for (const auto& w : r.session->record().diagnostics) r.diagnostics += w + "\n";
  return r;
}

/// `text` run on the dry-run machine (every touch at its nominal) of the default world.
Ran dry_run(const std::string& text) {
  const fs::path p = write("dry_run.dmi", text);
  auto world = metron::machine::load_world_or_default(std::nullopt);
  EXPECT_TRUE(world.has_value());
  Ran r;
  r.session = Session::create(metron::interpreter::Backend{
      std::make_unique<metron::machine::NominalMachine>(world->machine), "<default> (dry run)", 0, {}, {}});
  if (r.session->load(p.string())) r.status = r.session->interpreter().run();
  r.diagnostics = r.session->take_diagnostics();
  for (const auto& w : r.session->record().diagnostics) r.diagnostics += w + "\n";
  return r;
}

const metron::runtime::FeatureReport* report(Session& s, const std::string& label) {
  const metron::runtime::FeatureReport* found = nullptr;
  for (const auto& e : s.record().events)
    if (const auto* f = std::get_if<metron::runtime::FeatureReport>(&e); f && f->label == label) found = f;
  return found;
}
// The TEXT lines a run printed, in order.
std::vector<std::string> texts_of(Session& s) {
  std::vector<std::string> texts;
  for (const auto& e : s.record().events)
    if (const auto* t = std::get_if<metron::runtime::TextReport>(&e)) texts.push_back(t->text);
  return texts;
}
const metron::runtime::ToleranceResult* tolerance(Session& s, const std::string& label) {
  const metron::runtime::ToleranceResult* found = nullptr;
  for (const auto& e : s.record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e); t && t->label == label) found = t;
  return found;
}

// The default block's BORE1 (20 mm at part 40, 50; the part corner at machine 300, 200, 0), as
// a shop program measures it with a sensor of the probe library.
std::string bore_program(const std::string& sensor_lines) {
  return "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\n" + sensor_lines +
         "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
         "GOTO/40, 50, 80\n"
         "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
         "MEAS/CIRCLE, F(BORE1), 4\n"
         "  GOTO/40, 50, 30\n"
         "  PTMEAS/CART, 50, 50, 30, -1, 0, 0\n  PTMEAS/CART, 40, 60, 30, 0, -1, 0\n"
         "  PTMEAS/CART, 30, 50, 30, 1, 0, 0\n  PTMEAS/CART, 40, 40, 30, 0, 1, 0\n"
         "  GOTO/40, 50, 80\n"
         "ENDMES\nOUTPUT/FA(BORE1)\nENDFIL\n";
}

}  // namespace

// ---- sensors defined outside the program ------------------------------------------------------

TEST(ShopPrograms, RecallAndSelectOfALibrarySensorCheckWithOneNote) {
  const auto c =
      check("DMISMN/'p', 5.1\nRECALL/SA(T1A0B0)\nSNSLCT/SA(T1A0B0)\nSNSLCT/S(TIP2)\nSNSLCT/SA(T1A0B0)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 0u) << c.text;
  EXPECT_EQ(c.notes, 2u) << c.text;  // one per name, not one per use
  EXPECT_TRUE(c.has("sensor SA(T1A0B0) is not defined in the program: it is taken from the machine's probe library"));
}

TEST(ShopPrograms, LibrarySensorRunsWithItsTipFromTheWorld) {
  const auto r =
      run(bore_program("RECALL/SA(T1A0B0)\nSNSLCT/SA(T1A0B0)\n"), source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.diagnostics.find("not in the machine's probe library"), std::string::npos) << r.diagnostics;
  const auto* f = report(*r.session, "BORE1");
  ASSERT_TRUE(f && f->actual);
  // The perfect world's bore is the design bore: 20 mm at part (40, 50).
  EXPECT_NEAR(f->actual->diameter_mm, 20.0, 2e-3);
  EXPECT_NEAR(f->actual->position.x(), 40.0, 2e-3);
}

TEST(ShopPrograms, UnknownSensorNameGetsTheDefaultTipWithAWarningNotAHalt) {
  const auto r = run(bore_program("SNSLCT/SA(NOT_IN_LIBRARY)\n"), source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("sensor NOT_IN_LIBRARY is not in the machine's probe library; using a 4 mm default tip"),
            std::string::npos)
      << r.diagnostics;
  const auto* f = report(*r.session, "BORE1");
  ASSERT_TRUE(f && f->actual);
  EXPECT_NEAR(f->actual->diameter_mm, 20.0, 2e-3);
}

// ---- statements real programs use -------------------------------------------------------------

TEST(ShopPrograms, ModeCombinationsAndSignedDirections) {
  const auto c = check(
      "DMISMN/'p', 5.1\nMODE/AUTO,PROG,MAN\nMODE/AUTO,PROG\nMODE/PROG,MAN\nMODE/MAN\nMODE/AUTO\n"
      "F(P)=FEAT/PLANE,CART,0,0,0,0,0,1\nMEAS/PLANE,F(P),3\nPTMEAS/CART,0,0,0,0,0,1\nPTMEAS/CART,10,0,0,0,0,1\n"
      "PTMEAS/CART,0,10,0,0,0,1\nENDMES\nDATDEF/FA(P),DAT(A)\nD(A1)=DATSET/DAT(A),-ZDIR,ZORIG\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  // MODE/PROG alone (WinWerth's): read as AUTO with a warning; --strict: not a DMIS mode.
  const std::string prog = "DMISMN/'p', 5.1\nMODE/PROG\nENDFIL\n";
  EXPECT_TRUE(check(prog).has("2:6: warning: MODE/PROG alone is not a DMIS mode")) << check(prog).text;
  EXPECT_TRUE(check(prog, true).has("expected AUTO, PROG,MAN or MAN after MODE/"));
}

// ROTATE/ZAXIS,FA(l),-XDIR turns the line's direction onto the minus X axis (it was refused: only
// XDIR, YDIR, ZDIR were read). The line's stated actual runs at 10 deg in the machine's XY plane:
// afterwards VPCS of that direction is (-1, 0, 0); with XDIR it is (1, 0, 0).
TEST(ShopPrograms, RotateOntoASignedDirection) {
  const std::string head =
      "DMISMN/'r', 5.1\nUNITS/MM,ANGDEC\nFA(L)=FEAT/LINE,UNBND,CART,0,0,0,0.984807753,0.173648178,0,0,0,1\n";
  const std::string show = "TEXT/OPER,STR(VDOT(VPCS(VCART(0.984807753,0.173648178,0)),VCART(1,0,0)),6)\nENDFIL\n";
  std::vector<std::string> said;
  for (const char* direction : {"-XDIR", "XDIR", "+XDIR"}) {
    const auto r = run(head + "D(R)=ROTATE/ZAXIS,FA(L)," + direction + "\n" + show);
    ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
    for (const auto& e : r.session->record().events)
      if (const auto* t = std::get_if<metron::runtime::TextReport>(&e)) said.push_back(t->text);
  }
  EXPECT_EQ(said, (std::vector<std::string>{"-1.000000", "1.000000", "1.000000"}));
  EXPECT_TRUE(
      check(head + "D(R)=ROTATE/ZAXIS,FA(L),-ZDIR\nENDFIL\n").has("the aligned axis cannot be the rotation axis"));
}

TEST(ShopPrograms, QuietStatementsAreAcceptedWithoutAWarningPerLine) {
  const auto c = check(
      "DMISMN/'p', 5.1\nDECPL/ALL,DEFALT,4\nDMESWI/'COMM/GOTOPARAMS'\nDMESWV/'NEWSPEED'\nFLY/1.0\n"
      "PAUSE\nPAUSE\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 0u) << c.text;
  EXPECT_EQ(c.notes, 1u) << c.text;  // PAUSE, once
  // Statements accepted without their effect warn once per kind: a program may rely on them.
  const auto once = check(
      "DMISMN/'p', 5.1\nMFGDEV/'M1'\nGEOALG/CIRCLE,LSTSQR\nGEOALG/CIRCLE,MINMAX\nGEOALG/CONE,MAXINS\n"
      "GEOALG/ELLIPS,MINMAX\nGEOALG/CONE,MINMAX\nGOHOME\nGOHOME\nSNSET/CLRSRF,OFF\nSNSET/DEPTH,OFF\nENDFIL\n");
  EXPECT_EQ(once.errors, 0u) << once.text;
  EXPECT_EQ(once.warnings, 1u) << once.text;
  // GEOALG/CIRCLE,MINMAX and CONE,MINMAX are applied (minimum zone reference features); a cone
  // has no size a gauge would find, so CONE,MAXINS is the first that is not.
  EXPECT_TRUE(once.has("5:1: warning: GEOALG/CONE,MAXINS: this fitting algorithm is not applied")) << once.text;
  EXPECT_FALSE(once.has("GOHOME")) << once.text;
  // A REPORT layout named in OUTPUT: one note, not a warning per OUTPUT.
  const auto layout = check(
      "DMISMN/'p', 5.1\nR(R1)=REPORT/ALGOR,DATE\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\n"
      "OUTPUT/F(P),R(R1)\nOUTPUT/F(P),R(R1)\nENDFIL\n");
  EXPECT_EQ(layout.errors + layout.warnings, 0u) << layout.text;
  EXPECT_EQ(layout.notes, 1u) << layout.text;
  // CAMIO's header: a report of a QIS label output alone. The run reports nothing for it (it took
  // R(ID) for a feature and stopped: "feature F(ID) is not defined").
  const auto alone =
      run("DMISMN/'p', 5.2\nQ(ID)=QISDEF/'Machine ID',Var_SysID\nR(ID)=REPORT/Q(ID)\nOUTPUT/R(ID)\n"
          "F(P)=FEAT/POINT,CART,0,0,0,0,0,1\nOUTPUT/F(P),R(ID)\nENDFIL\n");
  EXPECT_EQ(alone.status, ExecStatus::Finished) << alone.diagnostics;
}

// GOHOME moves the machine to its home (it was accepted without moving, so a program that lifts
// the probe home between parts of the set-up went on from where the probe was).
TEST(ShopPrograms, GoHomeMovesTheMachineHome) {
  auto world = metron::machine::load_world_or_default(std::nullopt);
  ASSERT_TRUE(world.has_value());
  const Eigen::Vector3d home = world->machine.home_mm;
  std::string text = bore_program("");
  text.insert(text.find("ENDFIL"), "GOTO/100, 20, 60\nGOHOME\n");
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_LT((r.session->machine().state().position_mm - home).norm(), 1e-9);
  const auto inside =
      run("DMISMN/'h', 5.1\nF(P)=FEAT/PLANE,CART,20,20,40,0,0,1\nMEAS/PLANE,F(P),1\nGOHOME\n"
          "PTMEAS/CART,20,20,40,0,0,1\nENDMES\nENDFIL\n");
  EXPECT_EQ(inside.status, ExecStatus::Error);
  EXPECT_NE(inside.diagnostics.find("GOHOME is not allowed inside a MEAS block"), std::string::npos)
      << inside.diagnostics;
}

// FROM sets the home GOHOME goes to, in the coordinate system current at FROM (it was skipped
// with a warning, so GOHOME went to the machine's own home).
TEST(ShopPrograms, FromSetsWhereGoHomeGoes) {
  std::string from = bore_program("");
  from.insert(from.find("ENDFIL"), "FROM/10, 20, 90\nD(MOVED) = TRANS/XORIG, -50\nGOTO/100, 20, 60\nGOHOME\n");
  std::string go_to = bore_program("");
  go_to.insert(go_to.find("ENDFIL"), "GOTO/10, 20, 90\n");
  const auto a = run(from);
  const auto b = run(go_to);
  ASSERT_EQ(a.status, ExecStatus::Finished) << a.diagnostics;
  ASSERT_EQ(b.status, ExecStatus::Finished) << b.diagnostics;
  // Part (10, 20, 90) with D(PART) at machine (300, 200, 0): GOHOME ends where GOTO/10,20,90 did.
  const auto& ended = a.session->machine().state().position_mm;
  EXPECT_LT((ended - b.session->machine().state().position_mm).norm(), 1e-9);
  EXPECT_LT((ended - Eigen::Vector3d(310, 220, 90)).norm(), 1e-9) << ended.transpose();
  const auto bad = check("DMISMN/'f', 5.1\nFROM/1,2\nENDFIL\n");
  EXPECT_TRUE(bad.has("2:8: error: FROM expects x,y,z (the home position), got 2 numbers")) << bad.text;
}

// Statements with nothing to do on a virtual CMM that a reader may want to know of: one note
// per word, with the reason, and no warning; point buffering and carriage definitions quietly.
TEST(ShopPrograms, StatementsWithoutEffectAreNotedOnceEach) {
  const auto c = check(
      "DMISMN/'n', 5.1\nPTBUFF/ON\nRAPID/50\nRAPID/20\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\n"
      "DELETE/F(P)\nDELETE/F(P)\nPTBUFF/OFF\nKEYCHAR/'k'\nBOUND/F(P),F(P)\n"
      "XTERN\nENDXTN\nPSTHRU/PAUSE,'x'\nCZ(Z1)=CZONE\nCZSLCT/CZ(Z1),ON\n"
      "REFMNT/XVEC,1,0,0,ZVEC,0,0,1,MNTLEN,0,0,0\nENDFIL\n");
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;  // clearance zones and reference mounts quietly
  EXPECT_EQ(c.notes, 5u) << c.text;
  EXPECT_TRUE(c.has("10:1: note: BOUND: features are not bounded")) << c.text;
  EXPECT_TRUE(c.has("3:1: note: RAPID: the next move is made at the positioning feed")) << c.text;
  EXPECT_TRUE(c.has("6:1: note: DELETE: the labels stay defined")) << c.text;
  EXPECT_TRUE(c.has("9:1: note: KEYCHAR")) << c.text;
}

// GOTARG/x,y,z ... ENDGO: through the GOTO points between to the target (both words were skipped
// with a warning, so the machine stayed at the last intermediate point).
TEST(ShopPrograms, GoTargetMovesThroughItsPointsToTheTarget) {
  std::string text = bore_program("");
  text.insert(text.find("ENDFIL"), "GOTARG/10, 20, 90\nGOTO/60, 50, 80\nGOTO/60, 20, 80\nENDGO\n");
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  // D(PART) puts the part origin at machine (300, 200, 0).
  EXPECT_LT((r.session->machine().state().position_mm - Eigen::Vector3d(310, 220, 90)).norm(), 1e-9);
  const auto bad = check("DMISMN/'g', 5.1\nENDGO\nGOTARG/1,2,3\nGOTARG/1,2,3\nGOTARG/1\nENDFIL\n");
  EXPECT_TRUE(bad.has("2:1: error: ENDGO without a GOTARG")) << bad.text;
  EXPECT_TRUE(bad.has("4:1: error: GOTARG inside the GOTARG of line 3: close it with ENDGO first")) << bad.text;
  EXPECT_TRUE(bad.has("3:1: error: GOTARG is never closed: expected ENDGO before the end of the file")) << bad.text;
}

// SELECT/CASE (DMIS 5.x): it was skipped as an unknown statement, so every case ran.
TEST(ShopPrograms, SelectRunsTheOneMatchingCase) {
  const std::string text =
      "DMISMN/'select', 5.1\nDECL/INTGR,I\nDECL/CHAR,20,W\nDO/I,1,4\nSELECT/I\n"
      "CASE/1\nTEXT/OPER,'one'\nENDCAS\nCASE/2,3\nTEXT/OPER,CONCAT('two or three:',STR(I))\nENDCAS\n"
      "DFTCAS\nTEXT/OPER,'other'\nENDCAS\nENDSEL\nENDDO\n"
      "W=ASSIGN/'B'\nSELECT/W\nCASE/'A'\nTEXT/OPER,'a'\nENDCAS\nCASE/'B'\nTEXT/OPER,'b'\nENDCAS\nENDSEL\n"
      "SELECT/I\nCASE/1\nTEXT/OPER,'none runs'\nENDCAS\nENDSEL\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> said = texts_of(*r.session);
  const std::vector<std::string> expected = {"one", "two or three:2", "two or three:3", "other", "b"};
  EXPECT_EQ(said, expected);
  const auto bad = check(
      "DMISMN/'s', 5.1\nDECL/INTGR,I\nCASE/1\nSELECT/I\nCASE/1\nENDSEL\nSELECT/I\nDFTCAS\nENDCAS\n"
      "CASE/2\nENDCAS\nENDSEL\nSELECT/I\nENDFIL\n");
  EXPECT_TRUE(bad.has("3:1: error: CASE without a matching SELECT")) << bad.text;
  EXPECT_TRUE(bad.has("6:1: error: ENDSEL before the ENDCAS of the last case")) << bad.text;
  EXPECT_TRUE(bad.has("10:1: error: CASE after DFTCAS: the default case comes last")) << bad.text;
  EXPECT_TRUE(bad.has("SELECT is never closed: expected ENDSEL before the end of the file")) << bad.text;
}

/// The TEXT/OPER lines a run said, in order.
std::vector<std::string> operator_texts(const Ran& r) {
  const std::vector<std::string> said = texts_of(*r.session);
  return said;
}

// What a macro library as MODUS writes it needs (B. Capuana's public CommonMacros, GPL-3.0): a
// macro's label parameter naming a coordinate system, EXTFIL and CALL/EXTERN,DMIS,M(name),
// EXIST and DMESYS, a module that starts with FILNAM then DMISMD.
TEST(ShopPrograms, MacroLibrariesAsModusWritesThem) {
  // RECALL/DA(param) and SAVE/DA(param): "coordinate system D(ALN) is not defined" at check.
  const auto frames =
      run("DMISMN/'t', 05.2\nM(TOFRAME)=MACRO/'ALN'\nRECALL/DA(ALN)\nENDMAC\n"
          "M(KEEP)=MACRO/'ALN'\nSAVE/DA(ALN)\nENDMAC\nD(D1)=TRANS/XORIG,5\nCALL/M(KEEP),DA(D1)\n"
          "D(D2)=TRANS/XORIG,50\nCALL/M(TOFRAME),DA(D1)\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nOUTPUT/F(P)\n"
          "ENDFIL\n");
  ASSERT_EQ(frames.status, ExecStatus::Finished) << frames.diagnostics;
  const auto* p = report(*frames.session, "P");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->frame, "D1");
  // A system nothing in the program defines may be the CMM software's (RationalDMIS recalls
  // D(MAC)): a warning leniently, the run stopping at it; --strict: an error.
  const std::string recall_unknown = "DMISMN/'t', 05.2\nTEXT/OPER,'before'\nRECALL/D(MAC)\nTEXT/OPER,'after'\nENDFIL\n";
  EXPECT_TRUE(check(recall_unknown).has("3:8: warning: coordinate system D(MAC) is not defined in this program"));
  EXPECT_TRUE(check(recall_unknown, true).has("3:8: error: coordinate system D(MAC) is not defined"));
  const auto stopped = run(recall_unknown);
  EXPECT_NE(stopped.status, ExecStatus::Finished);
  EXPECT_EQ(operator_texts(stopped), (std::vector<std::string>{"before"}));
  EXPECT_NE(stopped.diagnostics.find("run.dmi:3:"), std::string::npos) << stopped.diagnostics;

  // A library file (FILNAM then DMISMD: no "does not start with DMISMN") declared by EXTFIL, its
  // macro called both ways; the file named in the call itself also works.
  write("modus_lib.dmi",
        "FILNAM/'modus_lib',05.2\nDMISMD/'modus_lib'\nM(GREET)=MACRO/'WHO'\n"
        "TEXT/OPER,CONCAT('hello ',WHO)\nENDMAC\nENDFIL\n");
  const auto lib = check("FILNAM/'modus_lib',05.2\nDMISMD/'modus_lib'\nM(GREET)=MACRO/'WHO'\nENDMAC\nENDFIL\n");
  EXPECT_EQ(lib.errors + lib.warnings, 0U) << lib.text;
  const auto called =
      run("DMISMN/'t', 05.2\nEXTFIL/DMIS,'modus_lib.dmi'\nCALL/EXTERN,DMIS,M(GREET),'world'\n"
          "CALL/M(GREET),'again'\nENDFIL\n");
  ASSERT_EQ(called.status, ExecStatus::Finished) << called.diagnostics;
  EXPECT_EQ(operator_texts(called), (std::vector<std::string>{"hello world", "hello again"}));
  const auto named = run("DMISMN/'t', 05.2\nCALL/EXTERN,DMIS,M(GREET),'modus_lib.dmi','there'\nENDFIL\n");
  ASSERT_EQ(named.status, ExecStatus::Finished) << named.diagnostics;
  EXPECT_EQ(operator_texts(named), (std::vector<std::string>{"hello there"}));
  // Not declared: the error says how (it took 'a', an argument, for the file before).
  const auto undeclared = check("DMISMN/'t', 05.2\nCALL/EXTERN,DMIS,M(HELLO),1,'a'\nENDFIL\n");
  EXPECT_TRUE(
      undeclared.has("2:18: error: macro M(HELLO) is not defined: declare the file that holds it with "
                     "EXTFIL/DMIS,'file'"))
      << undeclared.text;

  // EXIST of labels of every kind; DMESYS: the running file's folder, an unknown key ''.
  const auto exist =
      run("DMISMN/'t', 05.2\nDECL/CHAR,200,P\nDECL/CHAR,20,Q\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\n"
          "IF/(EXIST(F(P)) .AND. .NOT. EXIST(FA(P)) .AND. .NOT. EXIST(F(NONE)) .AND. EXIST(D(MCS)))\n"
          "TEXT/OPER,'exist'\nENDIF\nP=ASSIGN/DMESYS('CURRENT_DMIS_MODULE_PATH')\nTEXT/OPER,P\n"
          "Q=ASSIGN/DMESYS('COLOUR')\nTEXT/OPER,CONCAT('[',Q,']')\nENDFIL\n");
  ASSERT_EQ(exist.status, ExecStatus::Finished) << exist.diagnostics;
  EXPECT_EQ(operator_texts(exist), (std::vector<std::string>{"exist", temp_dir().string() + "/", "[]"}));
  EXPECT_NE(exist.diagnostics.find("DMESYS('COLOUR'): metron does not know this key"), std::string::npos)
      << exist.diagnostics;
  EXPECT_TRUE(check("DMISMN/'t', 05.2\nDECL/BOOL,B\nB=ASSIGN/EXIST(3)\nENDFIL\n").has("EXIST takes a label"));

  // SAVE/SA: a note; other SAVE forms: a warning, skipped (an error before).
  const auto saves = check(
      "DMISMN/'t', 05.2\nS(P1)=SNSDEF/PROBE,INDEX,POL,0,0,0,0,-1,100,4\nSAVE/SA(P1)\n"
      "F(P)=FEAT/POINT,CART,0,0,0,0,0,1\nSAVE/F(P)\nENDFIL\n");
  EXPECT_EQ(saves.errors, 0U) << saves.text;
  EXPECT_EQ(saves.notes, 1U) << saves.text;
  EXPECT_TRUE(saves.has("5:6: warning: SAVE of F() is not supported and is ignored")) << saves.text;
}

// Two public MODUS macro libraries (programs/real/modus, third-party, GPL-3.0): no error; each
// warning is one the README names.
TEST(ShopPrograms, PublicModusMacroLibrariesCheck) {
  const auto check_file = [](const fs::path& path) {
    SourceManager sources;
    DiagnosticSink sink;
    Compiler compiler(sources, sink);
    compiler.compile_file(path.string());
    Checked c;
    for (const auto& d : sink.items()) {
      c.text += metron::format_diagnostic(d, sources);
      if (d.severity == Severity::Error)
        ++c.errors;
      else if (d.severity == Severity::Warning)
        ++c.warnings;
      else
        ++c.notes;
    }
    return c;
  };
  const auto backup = check_file(source_dir / "programs/real/modus/ModusDatabaseBackup_CommonMacros.dmi");
  EXPECT_EQ(backup.errors + backup.warnings, 0U) << backup.text;
  EXPECT_TRUE(backup.has("47:17: note: CALL/EXTERN,SYS is for the CMM's own software")) << backup.text;
  const auto points = check_file(source_dir / "programs/real/modus/OutputModusActualPoints_CommonMacros.dmi");
  EXPECT_EQ(points.errors, 0U) << points.text;
  EXPECT_EQ(points.warnings, 0U) << points.text;  // its OUTPUT/FA(@featureName)[1,n] lists the points
  EXPECT_TRUE(points.has("121:15: note: FA(featureName): featureName is a CHAR variable and no feature has its name"))
      << points.text;
  // FA(V), V a CHAR variable naming no feature: the value names the feature, as FA(@V).
  const auto named =
      run("DMISMN/'t', 05.2\nDECL/CHAR,20,N\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nN=ASSIGN/'P'\n"
          "IF/(EXIST(F(N)))\nOUTPUT/F(N)\nENDIF\nENDFIL\n");
  ASSERT_EQ(named.status, ExecStatus::Finished) << named.diagnostics;
  ASSERT_TRUE(report(*named.session, "P"));
  // A feature of that name keeps its own: no rewriting.
  const auto own = check("DMISMN/'t', 05.2\nDECL/CHAR,20,N\nF(N)=FEAT/POINT,CART,0,0,0,0,0,1\nOUTPUT/F(N)\nENDFIL\n");
  EXPECT_EQ(own.errors + own.warnings + own.notes, 0U) << own.text;
  // A point range is OUTPUT's only.
  EXPECT_TRUE(
      check("DMISMN/'t', 05.2\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nCONST/POINT,F(Q),MOVEPT,FA(P)[1,2],0,0,1\nENDFIL\n")
          .has("3:25: error: a point range FA(P)[...] is read only in OUTPUT"));
}

// A function metron does not know is a vendor's: read leniently it stops a run only where it is
// evaluated (it stopped the whole check before); --strict keeps the error.
TEST(ShopPrograms, AnUnknownFunctionStopsOnlyTheRunThatEvaluatesIt) {
  const std::string text =
      "DMISMN/'t', 05.2\nDECL/REAL,X\nDECL/BOOL,B\nB=ASSIGN/.FALSE.\nIF/(B)\n"
      "X=ASSIGN/VENDORFN(1)\nENDIF\nTEXT/OPER,'after'\nX=ASSIGN/VENDORFN(2)\nTEXT/OPER,'never'\nENDFIL\n";
  const auto lenient = check(text);
  EXPECT_EQ(lenient.errors, 0U) << lenient.text;
  EXPECT_TRUE(lenient.has("6:10: warning: unknown function VENDORFN: a run that evaluates it stops there"))
      << lenient.text;
  EXPECT_TRUE(check(text, true).has("6:10: error: unknown function VENDORFN")) << check(text, true).text;
  // One letter off an intrinsic is a typo: an error either way.
  EXPECT_TRUE(check("DMISMN/'t', 05.2\nDECL/REAL,X\nX=ASSIGN/CONCT('a','b')\nENDFIL\n")
                  .has("3:10: error: unknown function CONCT (did you mean CONCAT?)"));
  const auto r = run(text);
  EXPECT_NE(r.status, ExecStatus::Finished);
  EXPECT_EQ(operator_texts(r), (std::vector<std::string>{"after"}));
  EXPECT_NE(r.diagnostics.find("run.dmi:9:"), std::string::npos) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("unknown function VENDORFN"), std::string::npos) << r.diagnostics;
}

// A FEAT that was rejected is named as such where the feature is used (it was "used before its
// definition at line N", the use being after line N).
TEST(ShopPrograms, AUseOfARejectedDefinitionSaysSo) {
  const auto c = check(
      "DMISMN/'t', 05.2\nF(L)=FEAT/LINE,CART,50,0,15,1,0,0,0,-1,0\nMEAS/LINE,F(L),2\nENDMES\n"
      "MEAS/CIRCLE,F(C),4\nENDMES\nF(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nENDFIL\n");
  EXPECT_TRUE(c.has("2:16: error: expected BND or UNBND after LINE")) << c.text;
  EXPECT_TRUE(c.has("3:11: error: feature F(L) has no definition: its FEAT at line 2 was rejected")) << c.text;
  EXPECT_TRUE(c.has("5:13: error: feature F(C) is used before its definition at line 7")) << c.text;
}

// Labels compare in upper case, accented letters included: F(Alésage) is FA(ALÉSAGE) (French
// exports write both).
TEST(ShopPrograms, AccentedLabelsCompareWithoutCase) {
  const auto c = check(
      "DMISMN/'p', 5.1\nF(Alésage_Ø)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(ALÉSAGE_Ø)=FEAT/POINT,CART,0,0,0.001,0,0,1\n"
      "OUTPUT/FA(alésage_ø)\nF(Œil)=FEAT/POINT,CART,0,0,0,0,0,1\nF(Łódź)=FEAT/POINT,CART,0,0,0,0,0,1\n"
      "OUTPUT/F(œil),F(ŁÓDŹ)\nENDFIL\n");
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
}

TEST(ShopPrograms, MeasPointCountMismatchIsAWarning) {
  const auto c = check(
      "DMISMN/'p', 5.1\nF(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nMEAS/CIRCLE,F(C1),4\n"
      "PTMEAS/CART,5,0,0,-1,0,0\nPTMEAS/CART,0,5,0,0,-1,0\nPTMEAS/CART,-5,0,0,1,0,0\nENDMES\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("warning: MEAS declares 4 points but the block has 3 PTMEAS; the 3 are used")) << c.text;
}

TEST(ShopPrograms, UnevaluatedToleranceTypesWarnAndTheirOutputIsLeftOut) {
  const auto c = check(
      "DMISMN/'p', 5.1\nF(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nT(PT)=TOL/PROFT,0.05,DAT(A)\n"
      "T(PL)=TOL/PROFL,-0.02,0.02\nOUTPUT/FA(C1),TA(PT)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("tolerance type PROFT is not evaluated by metron")) << c.text;
  EXPECT_TRUE(c.has("T(PT) (TOL/PROFT) is not evaluated: left out of this OUTPUT")) << c.text;
  // A type metron does not know at all (a vendor's) is left out alike: it stopped the whole
  // program before. DMIS's spellings ANGLWRT and COAXL are ANGWRT and COAXIAL.
  const auto unknown = check(
      "DMISMN/'p', 5.1\nF(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nT(AR)=TOL/VENDORTOL,0.05,90,DAT(A)\n"
      "OUTPUT/FA(C1),TA(AR)\nENDFIL\n");
  EXPECT_EQ(unknown.errors, 0u) << unknown.text;
  EXPECT_TRUE(unknown.has("tolerance type VENDORTOL is not one metron knows; the OUTPUT of T(AR) will be left out"))
      << unknown.text;
  EXPECT_TRUE(unknown.has("T(AR) (TOL/VENDORTOL) is not evaluated: left out of this OUTPUT")) << unknown.text;
  const auto spelled = check(
      "DMISMN/'p', 5.1\nF(P)=FEAT/PLANE,CART,0,0,0,0,0,1\nF(C1)=FEAT/CYLNDR,INNER,CART,0,0,0,0,0,1,10,5\n"
      "DATDEF/F(C1),DAT(D)\nT(AW)=TOL/ANGLWRT,90,-0.1,0.1,F(P)\nT(CX)=TOL/COAXL,0.05,DAT(D)\n"
      "OUTPUT/F(C1),TA(AW),TA(CX)\nENDFIL\n");
  EXPECT_EQ(spelled.errors + spelled.warnings, 0u) << spelled.text;
}

TEST(ShopPrograms, CoaxialityAndRunoutTolerancesAreCheckedAndNeedADatum) {
  const auto c = check(
      "DMISMN/'p', 5.1\nF(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nDATDEF/F(C1),DAT(A)\n"
      "T(CONC)=TOL/CONCEN,0.05,DAT(A)\nT(COAX)=TOL/COAXIAL,0.05,DAT(A)\n"
      "T(RUN)=TOL/RUNOUT,0.02,DAT(A)\nT(CR)=TOL/CRNOUT,0.02,DAT(A)\n"
      "T(TR)=TOL/TOTRUN,0.02,DAT(A)\nT(TR2)=TOL/TRNOUT,0.02,DAT(A)\n"
      "OUTPUT/FA(C1),TA(CONC),TA(RUN)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_FALSE(c.has("not evaluated")) << c.text;
  const auto bad = check("DMISMN/'p', 5.1\nT(CONC)=TOL/CONCEN,0.05\nENDFIL\n");
  EXPECT_TRUE(bad.has("TOL/CONCEN needs a datum DAT(x)")) << bad.text;
}

// DISTWRT, CORTOL and MOVEPT against analytic answers on the perfect world (the bore is the design
// bore at part (40, 50)): the moved point is 5 mm along X from the bore, at y = 47.
TEST(ShopPrograms, DistwrtCortolMoveptOnThePerfectWorld) {
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
      "MEAS/CIRCLE, F(BORE1), 4\n  GOTO/40, 50, 30\n"
      "  PTMEAS/CART, 50, 50, 30, -1, 0, 0\n  PTMEAS/CART, 40, 60, 30, 0, -1, 0\n"
      "  PTMEAS/CART, 30, 50, 30, 1, 0, 0\n  PTMEAS/CART, 40, 40, 30, 0, 1, 0\n  GOTO/40, 50, 80\nENDMES\n"
      "F(PNT_MOVED) = FEAT/POINT, CART, 45, 47, 30, 0, 0, 1\n"
      "CONST/POINT, F(PNT_MOVED), MOVEPT, FA(BORE1), 5, -3, 0\n"
      "T(DX) = TOL/DISTWRT, NOMINL, 5, -0.01, 0.01, FA(BORE1), XAXIS, AVG\n"
      "T(CY) = TOL/CORTOL, YAXIS, -0.01, 0.01\n"
      // With respect to a datum: DAT(B)'s feature is the reference (before: an error at check).
      "DATDEF/FA(BORE1), DAT(B)\nT(DB) = TOL/DISTWRT, NOMINL, 5, -0.01, 0.01, DAT(B), XAXIS, AVG\n"
      "OUTPUT/FA(PNT_MOVED), TA(DX), TA(CY), TA(DB)\n"
      // A datum is the feature as DATDEF found it: a point made the datum, then constructed 1 mm
      // further along X, leaves DAT(R) where it was (5 mm from the moved point) and FA(REF) 4 mm.
      "F(REF) = FEAT/POINT, CART, 40, 47, 30, 0, 0, 1\nCONST/POINT, F(REF), MOVEPT, FA(BORE1), 0, -3, 0\n"
      "DATDEF/FA(REF), DAT(R)\nCONST/POINT, F(REF), MOVEPT, FA(BORE1), 1, -3, 0\n"
      "T(DR) = TOL/DISTWRT, NOMINL, 5, -0.01, 0.01, DAT(R), XAXIS, AVG\n"
      "T(DF) = TOL/DISTWRT, NOMINL, 4, -0.01, 0.01, FA(REF), XAXIS, AVG\n"
      "OUTPUT/FA(PNT_MOVED), TA(DR), TA(DF)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* p = report(*r.session, "PNT_MOVED");
  ASSERT_TRUE(p && p->actual);
  EXPECT_NEAR(p->actual->position.x(), 45.0, 2e-3);
  EXPECT_NEAR(p->actual->position.y(), 47.0, 2e-3);
  const auto* dx = tolerance(*r.session, "DX");
  ASSERT_TRUE(dx);
  EXPECT_NEAR(dx->actual, 5.0, 1e-6);  // exactly the MOVEPT offset along X
  EXPECT_TRUE(dx->in_tolerance);
  const auto* cy = tolerance(*r.session, "CY");
  ASSERT_TRUE(cy);
  EXPECT_NEAR(cy->actual, 47.0, 2e-3);
  EXPECT_NEAR(cy->value, 0.0, 2e-3);
  const auto* db = tolerance(*r.session, "DB");
  ASSERT_TRUE(db);
  EXPECT_NEAR(db->actual, 5.0, 1e-6);
  const auto* dr = tolerance(*r.session, "DR");
  const auto* df = tolerance(*r.session, "DF");
  ASSERT_TRUE(dr && df);
  EXPECT_NEAR(dr->actual, 5.0, 1e-6);
  EXPECT_NEAR(df->actual, 4.0, 1e-6);
}

// SNSET/CLRSRF,F(plane),d: a clearance surface for AUTO moves. Planned from low down (z = 10),
// the y pair's move between its faces rises only to its own points plus the clearance distance
// (about z = 45) and hits what stands on the block's top (the world's truth: SPHERE1 reaches
// z = 58, BOSS1 z = 55). With the clearance surface 25 mm over F(TOP) (z = 65) it goes over the
// part and measures the moved faces (block_width.json: width 100.015).
TEST(ShopPrograms, ClearanceSurfaceLiftsAutoMovesOverThePart) {
  const auto program = [](const std::string& clearance) {
    return "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
           "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nSNSET/CLRSRF, 10\n"
           "F(TOP) = FEAT/PLANE, CART, 80, 50, 40, 0, 0, 1\n" +
           clearance +
           "GOTO/80, -15, 80\nGOTO/80, -15, 10\nMODE/AUTO\n"
           "F(YPAIR) = FEAT/PARPLN, OUTER, CART, 80, 50, 20, 0, 1, 0, 100\nMEAS/PARPLN, F(YPAIR), 6\nENDMES\n"
           "OUTPUT/FA(YPAIR)\nENDFIL\n";
  };
  const auto world = source_dir / "programs/worlds/block_width.json";
  const auto low = run(program(""), world);
  EXPECT_EQ(low.status, ExecStatus::Faulted) << low.diagnostics;
  const auto collided = [](const Ran& r) {
    for (const auto& e : r.session->record().events)
      if (const auto* f = std::get_if<metron::runtime::FaultReport>(&e))
        return f->message.find("collision") != std::string::npos;
    return false;
  };
  EXPECT_TRUE(collided(low));
  const auto lifted = run(program("SNSET/CLRSRF, F(TOP), 25\n"), world);
  ASSERT_EQ(lifted.status, ExecStatus::Finished) << lifted.diagnostics;
  const auto* y = report(*lifted.session, "YPAIR");
  ASSERT_TRUE(y && y->actual);
  EXPECT_NEAR(y->actual->width_mm, 100.015, 1e-3);
  // A later distance alone removes the surface again: the same collision.
  const auto removed = run(program("SNSET/CLRSRF, F(TOP), 25\nSNSET/CLRSRF, 10\n"), world);
  EXPECT_EQ(removed.status, ExecStatus::Faulted) << removed.diagnostics;
  EXPECT_TRUE(collided(removed));
  // Only a plane facing up is a clearance surface; the distance is required.
  const auto bore =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nF(B) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
          "SNSET/CLRSRF, F(B), 5\nENDFIL\n");
  EXPECT_EQ(bore.status, ExecStatus::Error);
  EXPECT_NE(bore.diagnostics.find("a clearance surface is a plane"), std::string::npos) << bore.diagnostics;
  const auto side =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nF(S) = FEAT/PLANE, CART, 0, 50, 20, -1, 0, 0\n"
          "SNSET/CLRSRF, F(S), 5\nENDFIL\n");
  EXPECT_EQ(side.status, ExecStatus::Error);
  EXPECT_NE(side.diagnostics.find("steeper than 60 degrees"), std::string::npos) << side.diagnostics;
  const auto no_distance =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nF(T) = FEAT/PLANE, CART, 80, 50, 40, 0, 0, 1\n"
          "SNSET/CLRSRF, F(T)\nENDFIL\n");
  EXPECT_NE(no_distance.diagnostics.find("expected the clearance distance"), std::string::npos)
      << no_distance.diagnostics;
}

// FEAT/PARPLN with TOL/WIDTH on a block whose side faces were moved (programs/worlds/
// block_width.json states the truth): the x pair measured with PTMEAS, the y pair planned by
// metron (MODE/AUTO, no PTMEAS), which must go over the part between the faces.
TEST(ShopPrograms, ParallelPlanesWidthAgainstTheMovedFaces) {
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/175, 50, 80\n"
      "F(XPAIR) = FEAT/PARPLN, OUTER, CART, 80, 50, 20, 1, 0, 0, 160\n"
      "MEAS/PARPLN, F(XPAIR), 7\n  GOTO/175, 50, 20\n"
      "  PTMEAS/CART, 160, 30, 20, 1, 0, 0\n  PTMEAS/CART, 160, 70, 20, 1, 0, 0\n"
      "  PTMEAS/CART, 160, 50, 30, 1, 0, 0\n  PTMEAS/CART, 160, 50, 10, 1, 0, 0\n"
      "  GOTO/175, 50, 80\n  GOTO/-15, 50, 80\n  GOTO/-15, 50, 20\n"
      "  PTMEAS/CART, 0, 30, 20, -1, 0, 0\n  PTMEAS/CART, 0, 70, 25, -1, 0, 0\n  PTMEAS/CART, 0, 50, 10, -1, 0, 0\n"
      "  GOTO/-15, 50, 80\nENDMES\n"
      "MODE/AUTO\nF(YPAIR) = FEAT/PARPLN, OUTER, CART, 80, 50, 20, 0, 1, 0, 100\nMEAS/PARPLN, F(YPAIR), 6\nENDMES\n"
      "T(WX) = TOL/WIDTH, -0.01, 0.01\nT(WY) = TOL/WIDTH, -0.01, 0.01\n"
      "OUTPUT/FA(XPAIR), TA(WX)\nOUTPUT/FA(YPAIR), TA(WY)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_width.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* x = report(*r.session, "XPAIR");
  ASSERT_TRUE(x && x->actual);
  EXPECT_NEAR(x->actual->width_mm, 160.02, 1e-3);
  EXPECT_NEAR(x->actual->position.x(), 80.02, 1e-3);
  EXPECT_NEAR(x->actual->direction.x(), 1.0, 1e-7);
  const auto* wx = tolerance(*r.session, "WX");
  ASSERT_TRUE(wx);
  EXPECT_NEAR(wx->value, 0.02, 1e-3);
  EXPECT_FALSE(wx->in_tolerance);
  // Reported like a DIAM: the nominal, the actual and the deviation against its limits.
  const std::string line = metron::runtime::format_tolerance_result(*wx);
  EXPECT_NE(line.find("nominal 160.0000  actual 160.0"), std::string::npos) << line;
  EXPECT_NE(line.find("limits [-0.0100, +0.0100]  OUT"), std::string::npos) << line;
  const auto* y = report(*r.session, "YPAIR");
  ASSERT_TRUE(y && y->actual);
  EXPECT_EQ(y->point_count, 6U);
  EXPECT_NEAR(y->actual->width_mm, 100.015, 1e-3);
  EXPECT_NEAR(y->actual->position.y(), 50.0075, 1e-3);
  const auto* wy = tolerance(*r.session, "WY");
  ASSERT_TRUE(wy);
  EXPECT_NEAR(wy->value, 0.015, 1e-3);
  EXPECT_FALSE(wy->in_tolerance);

  // POS of a width (ASME Y14.5): its median plane, 0.02 mm off in X (LEFT 0.01 in, RIGHT 0.03
  // out): a zone of 0.04. At LMC the tab, 0.02 over its nominal (MMC) width, gains 0.02.
  const std::string positions =
      text.substr(0, text.find("OUTPUT/")) +
      "T(PX) = TOL/POS, 2D, 0.05\nT(PXS) = TOL/POS, 2D, 0.03\nT(PXL) = TOL/POS, 2D, 0.03, LMC\n"
      "T(PXM) = TOL/POS, 2D, 0.03, MMC\nOUTPUT/FA(XPAIR), TA(PX), TA(PXS), TA(PXL), TA(PXM)\nENDFIL\n";
  EXPECT_EQ(check(positions).errors, 0U) << check(positions).text;
  const auto placed = run(positions, source_dir / "programs/worlds/block_width.json");
  ASSERT_EQ(placed.status, ExecStatus::Finished) << placed.diagnostics;
  for (const char* label : {"PX", "PXS", "PXL", "PXM"}) ASSERT_NE(tolerance(*placed.session, label), nullptr) << label;
  EXPECT_NEAR(tolerance(*placed.session, "PX")->value, 0.04, 2e-3);
  EXPECT_TRUE(tolerance(*placed.session, "PX")->in_tolerance);
  EXPECT_FALSE(tolerance(*placed.session, "PXS")->in_tolerance);
  EXPECT_NEAR(tolerance(*placed.session, "PXL")->upper, 0.05, 2e-3);
  EXPECT_TRUE(tolerance(*placed.session, "PXL")->in_tolerance) << tolerance(*placed.session, "PXL")->note;
  EXPECT_NEAR(tolerance(*placed.session, "PXM")->upper, 0.03, 1e-9);  // beyond its MMC width: no bonus
  EXPECT_FALSE(tolerance(*placed.session, "PXM")->in_tolerance);

  // PERP and POS of a width: its derived median plane, the middles of opposite points (ISO
  // 14660-2). The RIGHT face leaned 0.1 deg about Y about its middle (z 20; hidden, on
  // probe_library.json), LEFT upright: the median plane leans half as much, so over the touches'
  // 20 mm of height it spans 10 tan 0.1 deg = 0.01745 across the top face's normal (PERP), and its
  // ends lie 5 tan 0.1 deg = 0.00873 either side of x 80 (POS: twice that, 0.01745); upright, 0.
  // Each face's points moved half the width inward would lean the median the whole 0.1 deg.
  const std::string leaning_text =
      text.substr(0, text.find("GOTO/175, 50, 80\n")) +
      "GOTO/100, 50, 60\nF(TOP) = FEAT/PLANE, CART, 100, 50, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 3\n"
      "  PTMEAS/CART, 100, 50, 40, 0, 0, 1\n  PTMEAS/CART, 150, 10, 40, 0, 0, 1\n  PTMEAS/CART, 100, 10, 40, 0, 0, 1\n"
      "ENDMES\nDATDEF/FA(TOP), DAT(A)\n" +
      text.substr(text.find("GOTO/175, 50, 80\n"), text.find("MODE/AUTO") - text.find("GOTO/175, 50, 80\n")) +
      "T(PP) = TOL/PERP, 0.02, DAT(A)\nT(PO) = TOL/POS, 2D, 0.01\nOUTPUT/FA(XPAIR), TA(PP), TA(PO)\nENDFIL\n";
  EXPECT_EQ(check(leaning_text).errors, 0U) << check(leaning_text).text;
  const fs::path library = source_dir / "programs/worlds/probe_library.json";
  const fs::path leaned = deviated("right_leaned.json", library, "{\"RIGHT\": {\"tilt_deg\": [0.1, 0]}}");
  const auto leaning = run(leaning_text, leaned);
  ASSERT_EQ(leaning.status, ExecStatus::Finished) << leaning.diagnostics;
  const auto* perp = tolerance(*leaning.session, "PP");
  ASSERT_NE(perp, nullptr) << leaning.diagnostics;
  // To second order the pairs are joined along the pair's normal, itself leaning 0.05 deg, not
  // along X: the far face is met 0.14 mm higher, which moves a median end by 0.1 um more.
  const double lean = std::tan(0.1 * std::numbers::pi / 180);
  EXPECT_NEAR(perp->value, 10 * lean, 3e-4) << perp->note;
  EXPECT_TRUE(perp->in_tolerance);
  const auto* pos = tolerance(*leaning.session, "PO");
  ASSERT_NE(pos, nullptr) << leaning.diagnostics;
  EXPECT_NEAR(pos->value, 10 * lean, 4e-4) << pos->note;
  EXPECT_FALSE(pos->in_tolerance) << pos->note;
  const auto upright = run(leaning_text, library);
  ASSERT_EQ(upright.status, ExecStatus::Finished) << upright.diagnostics;
  ASSERT_NE(tolerance(*upright.session, "PP"), nullptr);
  EXPECT_LT(tolerance(*upright.session, "PP")->value, 1e-5);

  // Points on one face only, or a PARPLN where a circle is toleranced: positioned errors.
  const auto one_side =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "GOTO/175, 50, 80\nF(XPAIR) = FEAT/PARPLN, OUTER, CART, 80, 50, 20, 1, 0, 0, 160\n"
          "MEAS/PARPLN, F(XPAIR), 4\n  GOTO/175, 50, 20\n"
          "  PTMEAS/CART, 160, 30, 20, 1, 0, 0\n  PTMEAS/CART, 160, 70, 20, 1, 0, 0\n"
          "  PTMEAS/CART, 160, 50, 30, 1, 0, 0\n  PTMEAS/CART, 160, 50, 10, 1, 0, 0\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/block_width.json");
  EXPECT_NE(one_side.diagnostics.find("it needs points on both faces (4 on the +normal side, 0 on the other)"),
            std::string::npos)
      << one_side.diagnostics;
  const auto bad = check("DMISMN/'p', 5.0\nF(S) = FEAT/PARPLN, INNER, CART, 0, 0, 0, 1, 0, 0, -2\nENDFIL\n");
  EXPECT_TRUE(bad.has("shop.dmi:2:") && bad.has("the width of F(S) must be positive")) << bad.text;
}

// ---- FEAT/CPARLN: closed slots -----------------------------------------------------------------

/// The hidden truth of a slot of programs/worlds/block_slot.json, read from the file's design
/// and deviations (not from a run): the side and end planes where the deviations put them, the
/// end circles likewise. PART coordinates.
struct SlotTruth {
  double centre_x = 0, centre_y = 0, length_mm = 0, width_mm = 0;
};

/// Every primitive of a CSG node, depth first.
void primitives(const nlohmann::json& node, std::vector<nlohmann::json>& out) {
  if (node.contains("type")) return out.push_back(node);
  for (const auto& item : node.items())
    for (const auto& child : item.value()) primitives(child, out);
}

SlotTruth slot_truth(const std::string& slot) {
  std::ifstream in(source_dir / "programs/worlds/block_slot.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto world = nlohmann::json::parse(text, nullptr, true, /*ignore_comments=*/true);
  const auto& deviations = world["part"]["deviations"];
  std::vector<nlohmann::json> all;
  primitives(world["part"]["design"], all);
  const auto deviation = [&](const std::string& name, const char* key, std::size_t i) {
    if (!deviations.contains(name) || !deviations[name].contains(key)) return 0.0;
    const auto& v = deviations[name][key];
    return v.is_array() ? v[i].get<double>() : v.get<double>();
  };
  // Extent of the slot toward +x, -x, +y, -y: a half-space's plane n.p + size + n.offset along
  // its normal; a cylinder's centre (with its offset) plus or minus its radius (with its size).
  double extent[4] = {-1e9, -1e9, -1e9, -1e9};
  for (const auto& p : all) {
    const std::string name = p.value("name", "");
    if (name.rfind(slot + "_", 0) != 0 || name.find("FLOOR") != std::string::npos) continue;
    const Eigen::Vector3d offset(deviation(name, "offset_mm", 0), deviation(name, "offset_mm", 1),
                                 deviation(name, "offset_mm", 2));
    if (p["type"] == "half_space") {
      const auto vec = [&](const char* key) {
        return Eigen::Vector3d(p[key][0].get<double>(), p[key][1].get<double>(), p[key][2].get<double>());
      };
      const Eigen::Vector3d point = vec("point"), n = vec("normal");
      if (name.find("CAP") != std::string::npos) continue;  // inside the end circles
      const double along = n.dot(point + offset) + deviation(name, "size_mm", 0);
      extent[n.x() > 0.5 ? 0 : n.x() < -0.5 ? 1 : n.y() > 0.5 ? 2 : 3] = along;
    } else {
      const double r = 0.5 * (p["diameter_mm"].get<double>() + deviation(name, "diameter_mm", 0));
      const double x = p["point"][0].get<double>() + offset.x();
      extent[0] = std::max(extent[0], x + r);
      extent[1] = std::max(extent[1], -(x - r));
    }
  }
  const bool along_x = slot == "SLOT1";
  SlotTruth t;
  t.centre_x = 0.5 * (extent[0] - extent[1]);
  t.centre_y = 0.5 * (extent[2] - extent[3]);
  t.length_mm = along_x ? extent[0] + extent[1] : extent[2] + extent[3];
  t.width_mm = along_x ? extent[2] + extent[3] : extent[0] + extent[1];
  return t;
}

// FEAT/CPARLN on the slots of programs/worlds/block_slot.json: the ROUND slot measured once with
// PTMEAS (on both sides and around both ends) and once planned by metron (MODE/AUTO), the FLAT
// one planned; WIDTH (SHORT: the width, LONG: the length) and POS against the world's truth.
TEST(ShopPrograms, ClosedSlotsAgainstTheMachinedSlots) {
  const SlotTruth round = slot_truth("SLOT1"), flat = slot_truth("SLOT2");
  // The truth as the world file's comment states it, so a misread file does not pass unseen.
  EXPECT_NEAR(round.width_mm, 10.03, 1e-12);
  EXPECT_NEAR(round.length_mm, 30.05, 1e-12);
  EXPECT_NEAR(flat.length_mm, 30.03, 1e-12);
  EXPECT_NEAR(flat.centre_y, 49.995, 1e-12);
  const std::string slot1 = "F(SLOT1) = FEAT/CPARLN, INNER, ROUND, CART, 80, 25, 35, 0, 0, 1, 1, 0, 0, 30, 10\n";
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/80, 25, 80\n" +
      slot1 +
      "MEAS/CPARLN, F(SLOT1), 8\n  GOTO/80, 25, 35\n"
      "  PTMEAS/CART, 73, 20, 35, 0, 1, 0\n  PTMEAS/CART, 87, 20, 35, 0, 1, 0\n"
      "  PTMEAS/CART, 95, 25, 35, -1, 0, 0\n  PTMEAS/CART, 93.53553, 28.53553, 35, -0.70711, -0.70711, 0\n"
      "  PTMEAS/CART, 87, 30, 35, 0, -1, 0\n  PTMEAS/CART, 73, 30, 35, 0, -1, 0\n"
      "  PTMEAS/CART, 65, 25, 35, 1, 0, 0\n  PTMEAS/CART, 66.46447, 21.46447, 35, 0.70711, 0.70711, 0\n"
      "  GOTO/80, 25, 35\n  GOTO/80, 25, 80\nENDMES\n"
      "MODE/AUTO\nF(SLOT1A) = FEAT/CPARLN, INNER, ROUND, CART, 80, 25, 35, 0, 0, 1, 1, 0, 0, 30, 10\n"
      "MEAS/CPARLN, F(SLOT1A), 10\nENDMES\n"
      "F(SLOT2) = FEAT/CPARLN, INNER, FLAT, CART, 145, 50, 35, 0, 0, 1, 0, 1, 0, 30, 10\nMEAS/CPARLN, F(SLOT2), "
      "8\nENDMES\n"
      "T(W) = TOL/WIDTH, -0.01, 0.01\nT(L) = TOL/WIDTH, -0.02, 0.02, LONG\nT(P2) = TOL/POS, 2D, 0.05\n"
      "T(P3) = TOL/POS, 3D, 0.05\n"
      "OUTPUT/FA(SLOT1), TA(W), TA(L), TA(P2), TA(P3)\nOUTPUT/FA(SLOT1A), TA(W), TA(L), TA(P2)\n"
      "OUTPUT/FA(SLOT2), TA(W), TA(L), TA(P2)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_slot.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  // The probe's noise and pre-travel left after qualification: a micrometre.
  constexpr double tol_mm = 1e-3;
  // One OUTPUT's tolerance results in order (the labels repeat over the OUTPUTs).
  std::vector<const metron::runtime::ToleranceResult*> results;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) results.push_back(t);
  ASSERT_EQ(results.size(), 10U);
  const struct {
    const char* label;
    SlotTruth truth;
    double nominal_x, nominal_y;
    std::size_t first_result;
    std::size_t points;
  } cases[] = {{"SLOT1", round, 80, 25, 0, 8}, {"SLOT1A", round, 80, 25, 4, 10}, {"SLOT2", flat, 145, 50, 7, 8}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.label);
    const auto* f = report(*r.session, c.label);
    ASSERT_TRUE(f && f->actual);
    EXPECT_EQ(f->point_count, c.points);
    EXPECT_NEAR(f->actual->position.x(), c.truth.centre_x, tol_mm);
    EXPECT_NEAR(f->actual->position.y(), c.truth.centre_y, tol_mm);
    EXPECT_NEAR(f->actual->width_mm, c.truth.width_mm, tol_mm);
    EXPECT_NEAR(f->actual->length_mm, c.truth.length_mm, tol_mm);
    EXPECT_LT(f->fit->form_mm, tol_mm);
    const auto& width = *results[c.first_result];
    const auto& length = *results[c.first_result + 1];
    const auto& pos = *results[c.first_result + 2];
    EXPECT_NEAR(width.value, c.truth.width_mm - 10, tol_mm);
    EXPECT_NEAR(length.value, c.truth.length_mm - 30, tol_mm);
    EXPECT_NEAR(pos.value, 2 * std::hypot(c.truth.centre_x - c.nominal_x, c.truth.centre_y - c.nominal_y), 2 * tol_mm);
    EXPECT_FALSE(width.in_tolerance);
    EXPECT_FALSE(length.in_tolerance);
    EXPECT_TRUE(pos.in_tolerance);
  }
  EXPECT_NEAR(results[3]->value, results[2]->value, 1e-9);  // 3D: the centre stays in the nominal's plane

  // Points on the sides only: an error that says which parts have none.
  const auto sides_only =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "GOTO/80, 25, 80\n" +
              slot1 +
              "MEAS/CPARLN, F(SLOT1), 6\n  GOTO/80, 25, 35\n"
              "  PTMEAS/CART, 73, 20, 35, 0, 1, 0\n  PTMEAS/CART, 80, 20, 35, 0, 1, 0\n"
              "  PTMEAS/CART, 87, 20, 35, 0, 1, 0\n  PTMEAS/CART, 87, 30, 35, 0, -1, 0\n"
              "  PTMEAS/CART, 80, 30, 35, 0, -1, 0\n  PTMEAS/CART, 73, 30, 35, 0, -1, 0\n"
              "  GOTO/80, 25, 80\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/block_slot.json");
  EXPECT_NE(sides_only.diagnostics.find("run.dmi:6:"), std::string::npos) << sides_only.diagnostics;
  EXPECT_NE(
      sides_only.diagnostics.find("cannot fit a CPARLN to 6 points: it needs 5, with points on both sides (3 and 3) "
                                  "and both ends (0 toward +axis, 0 toward -axis)"),
      std::string::npos)
      << sides_only.diagnostics;
}

// SYMMTY of a closed slot: the median points of its sides (the ends' points have no opposite side)
// about a datum plane. block_slot.json's FLAT slot (sides at x 140 and 150, each 0.01 in) moved
// 0.02 in +X (hidden, written here): its median plane at x 145.02, so 2 x 0.02 = 0.04 about the
// plane 15 mm inside the RIGHT face (x 145); not moved, 0.
TEST(ShopPrograms, SymmetryOfAClosedSlotAboutADatumPlane) {
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/175, 50, 80\n"
      "F(RIGHT) = FEAT/PLANE, CART, 160, 50, 20, 1, 0, 0\nMEAS/PLANE, F(RIGHT), 3\n  GOTO/175, 50, 20\n"
      "  PTMEAS/CART, 160, 30, 20, 1, 0, 0\n  PTMEAS/CART, 160, 70, 20, 1, 0, 0\n  PTMEAS/CART, 160, 50, 10, 1, 0, 0\n"
      "  GOTO/175, 50, 80\nENDMES\n"
      "F(MID) = FEAT/PLANE, CART, 145, 50, 20, 1, 0, 0\nCONST/PLANE, F(MID), OFFSET, FA(RIGHT), -15\n"
      "DATDEF/FA(MID), DAT(B)\nGOTO/145, 50, 80\nMODE/AUTO\n"
      "F(SLOT2) = FEAT/CPARLN, INNER, FLAT, CART, 145, 50, 35, 0, 0, 1, 0, 1, 0, 30, 10\nMEAS/CPARLN, F(SLOT2), 8\n"
      "ENDMES\nT(SY) = TOL/SYMMTY, 0.03, DAT(B)\nOUTPUT/FA(SLOT2), TA(SY)\nENDFIL\n";
  const auto checked = check(text);
  EXPECT_EQ(checked.errors, 0U) << checked.text;
  const fs::path slots = source_dir / "programs/worlds/block_slot.json";
  const auto moved = run(
      text, deviated("slot_moved.json", slots, "{\"SLOT2_SIDES\": {\"size_mm\": -0.01, \"offset_mm\": [0.02, 0, 0]}}"));
  ASSERT_EQ(moved.status, ExecStatus::Finished) << moved.diagnostics;
  const auto* symmetry = tolerance(*moved.session, "SY");
  ASSERT_NE(symmetry, nullptr) << moved.diagnostics;
  // The default probe's scatter and pre-travel, doubled as SYMMTY doubles the worst point: 3 um.
  EXPECT_NEAR(symmetry->value, 0.04, 3e-3) << symmetry->note;
  EXPECT_FALSE(symmetry->in_tolerance) << symmetry->note;
  EXPECT_NE(symmetry->note.find("end points left out"), std::string::npos) << symmetry->note;
  const auto centred = run(text, slots);
  ASSERT_EQ(centred.status, ExecStatus::Finished) << centred.diagnostics;
  ASSERT_NE(tolerance(*centred.session, "SY"), nullptr) << centred.diagnostics;
  EXPECT_LT(tolerance(*centred.session, "SY")->value, 3e-3) << tolerance(*centred.session, "SY")->note;
  std::printf("slot symmetry: moved 0.02: %.5f (%s); centred: %.5f\n", symmetry->value, symmetry->note.c_str(),
              tolerance(*centred.session, "SY")->value);
}

// A FEAT with more numbers than its form takes (a cone with two distances, a plane with a size,
// as longer DMIS 5.3 forms and vendors write them): read leniently with the form's numbers and a
// warning naming what is ignored; --strict: an error. Fewer numbers stay an error.
TEST(ShopPrograms, FeaturesWithMoreNumbersThanTheirFormAreReadWithAWarning) {
  const std::string text =
      "DMISMN/'p', 5.0\nF(C) = FEAT/CONE, INNER, CART, 10, 20, 0, 0, 0, 1, 60, 5, 10\n"
      "F(P) = FEAT/PLANE, CART, 0, 0, 5, 0, 0, 1, 10, 20\nENDFIL\n";
  const auto lenient = check(text);
  EXPECT_EQ(lenient.errors, 0u) << lenient.text;
  EXPECT_EQ(lenient.warnings, 2u) << lenient.text;
  EXPECT_TRUE(
      lenient.has("shop.dmi:2:59: warning: FEAT/CONE takes at most 8 numbers (x,y,z,i,j,k,angle[,len]); the 1 "
                  "after them is ignored"))
      << lenient.text;
  EXPECT_TRUE(
      lenient.has("shop.dmi:3:44: warning: FEAT/PLANE takes at most 6 numbers (x,y,z,i,j,k); the 2 after them are "
                  "ignored"))
      << lenient.text;
  const auto strict = check(text, true);
  EXPECT_EQ(strict.errors, 2u) << strict.text;
  EXPECT_TRUE(strict.has("FEAT/CONE expects 7 to 8 numbers")) << strict.text;
  // The numbers the form takes are the nominal: the cone's axis point, direction, angle and length.
  const auto r = run(text.substr(0, text.find("ENDFIL")) + "OUTPUT/F(C)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* cone = r.session->runtime().find_feature("C");
  ASSERT_TRUE(cone);
  EXPECT_NEAR(cone->nominal.apex_angle_deg, 60, 1e-12);
  EXPECT_NEAR(cone->nominal.position.x(), 10, 1e-12);
  EXPECT_NEAR(cone->nominal.length_mm, 5, 1e-12);
}

// A LINE written without the normal of its plane, as a public web generator of DMIS writes
// UNBND lines (x,y,z,i,j,k) and others BND lines (two ends): read with one warning, the normal the
// axis the line is most perpendicular to. The generator's own PTMEAS vector for the line along X,
// probed on its front face, is 0,-1,0: the face a line is probed on is direction x normal, so the
// normal taken must be +Z for the touches to agree with it.
TEST(ShopPrograms, ALineWithoutItsPlanesNormalIsReadWithOneWarning) {
  const std::string text =
      "DMISMN/'generated',05.2\nUNITS/MM,ANGDEC\n"
      "F(FRONT)=FEAT/LINE,UNBND,CART,10.0000,0.0000,-5.0000,1.0000,0.0000,0.0000\n"
      "MEAS/LINE,F(FRONT),2\n  PTMEAS/CART,10.0000,0.0000,-5.0000,0.0000,-1.0000,0.0000\n"
      "  PTMEAS/CART,90.0000,0.0000,-5.0000,0.0000,-1.0000,0.0000\nENDMES\n"
      "F(RISE)=FEAT/LINE,BND,CART,0,0,0,0,0,-20\n"
      "F(SLANT)=FEAT/LINE,UNBND,CART,0,0,0,0,0.8,0.6\nF(DIAG)=FEAT/LINE,UNBND,CART,0,0,0,1,1,1\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 1u) << c.text;
  EXPECT_TRUE(c.has("shop.dmi:3:") && c.has("FEAT/LINE of F(FRONT) has 6 numbers, without the normal of the plane it "
                                            "lies in (x,y,z,i,j,k,i2,j2,k2): metron takes 0,0,1"))
      << c.text;
  const auto strict = check(text, true);
  EXPECT_TRUE(strict.has("shop.dmi:3:") && strict.has("FEAT/LINE expects 9 numbers (x,y,z,i,j,k,i2,j2,k2), got 6"))
      << strict.text;
  const auto computed =
      check("DMISMN/'g',05.2\nDECL/DOUBLE,I\nI=ASSIGN/1\nF(L)=FEAT/LINE,UNBND,CART,0,0,0,I,0,0\nENDFIL\n");
  EXPECT_TRUE(computed.has("shop.dmi:4:") && computed.has("can be left out only where the line's direction is written"))
      << computed.text;
  const auto degenerate = check(
      "DMISMN/'g',05.2\nF(L)=FEAT/LINE,UNBND,CART,0,0,0,0,0,0\n"
      "F(M)=FEAT/LINE,BND,CART,1,2,3,1,2,3\nF(N)=FEAT/LINE,BND,POL,1,2,3,4,5,6\nENDFIL\n");
  EXPECT_TRUE(
      degenerate.has("shop.dmi:2:37: error: FEAT/LINE expects 9 numbers (x,y,z,i,j,k,i2,j2,k2), got 6: its "
                     "direction is the zero vector"))
      << degenerate.text;
  EXPECT_TRUE(
      degenerate.has("shop.dmi:3:35: error: FEAT/LINE expects 9 numbers (x1,y1,z1,x2,y2,z2,i,j,k), got 6: its "
                     "two ends are one point"))
      << degenerate.text;
  EXPECT_TRUE(
      degenerate.has("shop.dmi:4:34: error: FEAT/LINE expects 9 numbers (x1,y1,z1,x2,y2,z2,i,j,k), got 6: the "
                     "normal of its plane can be left out only where a BND line's ends are in CART"))
      << degenerate.text;

  const auto r = dry_run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* front = r.session->runtime().find_feature("FRONT");
  const auto* rise = r.session->runtime().find_feature("RISE");
  const auto* slant = r.session->runtime().find_feature("SLANT");
  const auto* diagonal = r.session->runtime().find_feature("DIAG");
  ASSERT_TRUE(front && rise && slant && diagonal);
  const metron::Vec3 probed_face = front->nominal.direction.cross(front->nominal.normal2);
  EXPECT_LT((probed_face - metron::Vec3(0, -1, 0)).norm(), 1e-12) << probed_face.transpose();
  ASSERT_TRUE(front->actual);
  EXPECT_NEAR(front->actual->position.z(), -5, 1e-9);
  // A vertical line: Z is along it, Y (next in the order) is perpendicular.
  EXPECT_LT((rise->nominal.normal2 - metron::Vec3::UnitY()).norm(), 1e-12) << rise->nominal.normal2.transpose();
  // Along 0,0.8,0.6: X is the axis it is most perpendicular to, taken as it is.
  EXPECT_LT((slant->nominal.normal2 - metron::Vec3::UnitX()).norm(), 1e-12) << slant->nominal.normal2.transpose();
  // Along 1,1,1 (equally far from every axis): Z less its part along the line, by hand
  // (0,0,1) - (1/3)(1,1,1) = (-1,-1,2)/3, of length sqrt(6)/3.
  EXPECT_LT((diagonal->nominal.normal2 - metron::Vec3(-1, -1, 2) / std::sqrt(6.0)).norm(), 1e-12)
      << diagonal->nominal.normal2.transpose();
}

// TOL/POS,DIAM,t (a public GD&T-to-DMIS exporter writes the drawing's diameter sign so): read
// as 2D with one warning. A hole stated 0.03, 0.04 off its nominal in its plane and 0.02 along its
// axis, 2D and DIAM alike: 2 x 0.05 (3D would count the 0.02 too: 2 x sqrt(0.0029) = 0.1077).
TEST(ShopPrograms, APositionWithADiametralZoneWordIsRead2D) {
  const auto program = [](const std::string& form) {
    return "DMISMN/'STEPPED_FLANGE'\nUNITS/MM,ANGDEC\nF(H)=FEAT/CIRCLE,INNER,CART,550,480,0,0,0,1,20\n"
           "FA(H)=FEAT/CIRCLE,INNER,CART,550.03,480.04,0.02,0,0,1,20\nT(P)=TOL/POS," +
           form + ",0.0680,MMC\nOUTPUT/FA(H),TA(P)\nENDFIL\n";
  };
  const auto c = check(program("DIAM"));
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("shop.dmi:5:14: warning: TOL/POS takes 2D or 3D; DIAM (a diametral zone) is read as 2D")) << c.text;
  EXPECT_TRUE(check(program("DIAM"), true).has("shop.dmi:5:14: error: expected 2D or 3D after TOL/POS"));
  for (const std::string form : {"2D", "DIAM"}) {
    const auto r = dry_run(program(form));
    ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
    const auto* pos = tolerance(*r.session, "P");
    ASSERT_TRUE(pos) << form;
    EXPECT_NEAR(pos->value, 0.1, 1e-9) << form;
    EXPECT_FALSE(pos->in_tolerance) << form;  // 0.1 > 0.068 (the hole at its nominal size: no bonus)
  }
}

// Bad CPARLN statements: positioned errors that say what is wrong.
TEST(ShopPrograms, BadClosedSlotStatementsArePositionedErrors) {
  const auto feat = [](const std::string& rest) {
    return check("DMISMN/'p', 5.0\nF(S) = FEAT/CPARLN, " + rest + "\nENDFIL\n");
  };
  const auto arity = feat("INNER, ROUND, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30");
  EXPECT_TRUE(arity.has("shop.dmi:2:") && arity.has("FEAT/CPARLN expects 11 numbers (x,y,z,i1,j1,k1,i2,j2,k2,len,wid"))
      << arity.text;
  const auto ends = feat("INNER, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30, 10");
  EXPECT_TRUE(ends.has("shop.dmi:2:28: error: expected ROUND or FLAT after CPARLN,INNER|OUTER")) << ends.text;
  const auto zero = feat("INNER, ROUND, CART, 0, 0, 0, 0, 0, 1, 0, 0, 0, 30, 10");
  EXPECT_TRUE(zero.has("shop.dmi:2:") && zero.has("the long axis i2,j2,k2 is zero")) << zero.text;
  const auto slanted = feat("INNER, ROUND, CART, 0, 0, 0, 0, 0, 1, 1, 0, 1, 30, 10");
  EXPECT_TRUE(slanted.has("shop.dmi:2:") && slanted.has("the long axis i2,j2,k2 of F(S) is not perpendicular to the "
                                                        "normal i1,j1,k1 of its plane (at 45.000 deg to it, not 90)"))
      << slanted.text;
  const auto wide = feat("INNER, ROUND, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 10, 12");
  EXPECT_TRUE(wide.has("shop.dmi:2:") && wide.has("the width 12 of F(S) is not less than its length 10")) << wide.text;
  EXPECT_EQ(feat("INNER, FLAT, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 10, 12").errors, 0U);  // a FLAT slot may be square-ish
  const auto negative = feat("OUTER, FLAT, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30, -1");
  EXPECT_TRUE(negative.has("the width of F(S) must be positive")) << negative.text;
  // WIDTH (and SYMMTY) apply to a CPARLN; CYLCTY does not.
  const auto symmetry = check(
      "DMISMN/'p', 5.0\nF(S) = FEAT/CPARLN, INNER, ROUND, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30, 10\n"
      "F(P) = FEAT/PLANE, CART, 0, 0, 0, 0, 0, 1\nDATDEF/FA(P), DAT(A)\n"
      "T(W) = TOL/WIDTH, -0.1, 0.1, LONG\nT(S) = TOL/CYLCTY, 0.1\nOUTPUT/FA(S), TA(W)\n"
      "OUTPUT/FA(S), TA(S)\nENDFIL\n");
  EXPECT_EQ(symmetry.errors, 1U) << symmetry.text;
  EXPECT_TRUE(symmetry.has("shop.dmi:8:")) << symmetry.text;
}

// TOL/DIAM,lo,up,AVG|MAX|MIN: the elliptic pocket of block_ellipse.json (30.03 x 16.03 as
// machined, centre 95.025, 29.985, major axis at 20.3 deg) probed as a CIRCLE at the ends of its
// axes (PTMEAS along them from the machined centre). The four points are symmetric about both axes, so the
// least-squares circle is centred on the ellipse's centre with the mean radius, (15.015 + 8.015) / 2: AVG 23.03; the
// largest and smallest distances from that centre give MAX 30.03 and MIN 16.03.
TEST(ShopPrograms, DiameterTolerancesAtMaxAndMin) {
  const std::string text =
      "DMISMN/'diam', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
      "S(P1) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nSNSLCT/S(P1)\nGOTO/95, 30, 60\n"
      "F(C) = FEAT/CIRCLE, INNER, CART, 95, 30, 35, 0, 0, 1, 23\nMEAS/CIRCLE, F(C), 4\n"
      "  PTMEAS/CART, 109.0933340, 35.1890348, 35, -0.9378889, -0.3469357, 0\n"
      "  PTMEAS/CART, 92.2495148, 37.4881115, 35, 0.3469357, -0.9378889, 0\n"
      "  PTMEAS/CART, 80.9566660, 24.7809652, 35, 0.9378889, 0.3469357, 0\n"
      "  PTMEAS/CART, 97.8004852, 22.4818885, 35, -0.3469357, 0.9378889, 0\nENDMES\n"
      "T(AV) = TOL/DIAM, -0.1, 0.1, AVG\nT(MX) = TOL/DIAM, -0.1, 0.1, MAX\nT(MN) = TOL/DIAM, -0.1, 0.1, MIN\n"
      "T(RX) = TOL/RAD, -0.1, 0.1, MAX\nT(LP) = TOL/DIAM, -0.1, 0.1, DIAMLP\n"
      "OUTPUT/FA(C), TA(AV), TA(MX), TA(MN), TA(RX), TA(LP)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_ellipse.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  constexpr double tol_mm = 1e-3;
  EXPECT_NEAR(tolerance(*r.session, "AV")->actual, 23.03, tol_mm);
  EXPECT_NEAR(tolerance(*r.session, "MX")->actual, 30.03, tol_mm);
  EXPECT_FALSE(tolerance(*r.session, "MX")->in_tolerance);
  EXPECT_NEAR(tolerance(*r.session, "MN")->actual, 16.03, tol_mm);
  EXPECT_NEAR(tolerance(*r.session, "RX")->actual, 15.015, tol_mm);
  // DIAMLP, the two-point sizes: the four points lie on the ellipse's axes, each opposite another,
  // so the sizes are its two axes, 30.03 and 16.03; the major axis is the farther beyond its limit.
  EXPECT_NEAR(tolerance(*r.session, "LP")->actual, 30.03, tol_mm);
  EXPECT_NE(tolerance(*r.session, "LP")
                ->note.find("two-point sizes (ISO 14405-1 LP) at 4 of the 4 measured points "
                            "run from 16.03"),
            std::string::npos)
      << tolerance(*r.session, "LP")->note;
  EXPECT_NE(tolerance(*r.session, "MN")->note.find("MIN: the smallest diameter of the 4 measured points"),
            std::string::npos)
      << tolerance(*r.session, "MN")->note;
}

namespace {

// A touch of the boss of scan_lobed_circle.json (d 50 at machine (200, 300)) at `deg` round it and
// height z, from 15 mm outside and over it.
std::string boss_touch(double deg, double z) {
  const double t = deg * std::numbers::pi / 180, c = std::cos(t), s = std::sin(t);
  return fmt::format(
      "  GOTO/{0:.6f},{1:.6f},60\n  GOTO/{0:.6f},{1:.6f},{5}\n  PTMEAS/CART,{2:.6f},{3:.6f},{5},{4:.6f},{6:.6f},0\n"
      "  GOTO/{0:.6f},{1:.6f},60\n",
      200 + 40 * c, 300 + 40 * s, 200 + 25 * c, 300 + 25 * s, c, z, s);
}

// Touches of the default block's countersink (apex at (40, 20, 32), 90 deg) in two rings 4 and 6 mm
// above its apex, 6 points 60 deg apart in each, the ball moving across the axis.
std::string countersink_rings() {
  std::string out;
  for (const double h : {4.0, 6.0}) {
    out += fmt::format("  GOTO/40,20,{}\n", 32 + h);
    for (int k = 0; k < 6; ++k) {
      const double t = k * std::numbers::pi / 3, c = std::cos(t), s = std::sin(t);
      out += fmt::format("  PTMEAS/CART,{:.6f},{:.6f},{},{:.6f},{:.6f},0\n  GOTO/40,20,{}\n", 40 + h * c, 20 + h * s,
                         32 + h, -c, -s, 32 + h);
    }
  }
  return out;
}

}  // namespace

// DIAMLP: ISO 14405-1's two-point size, against the hidden form of scan_lobed_circle.json's boss
// (d 50, lobes of 2.5 um amplitude at 20 deg), touched at 12 points 30 deg apart, each opposite
// another. With 3 lobes r(t) + r(t + 180) = 2R: odd lobing cancels in every two-point size (why a
// two-point gauge cannot see it), while the least-squares circle sees none either and MAX sees
// the lobes. With 2 lobes (an oval) the sizes are 2R + 2a cos 2(t - 20 deg): at t = 30 k deg at
// most 2 x 2.5 cos 20 deg = 4.70 um from 50, beyond a +-3 um tolerance the least-squares
// diameter meets.
TEST(ShopPrograms, TwoPointSizeSeesAnOvalAndNotOddLobes) {
  std::string text =
      "DMISMN/'lp', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,3\nSNSET/RETRCT,3\nSNSET/SEARCH,3\n"
      "F(BOSS)=FEAT/CIRCLE,OUTER,CART,200,300,15,0,0,1,50\nMEAS/CIRCLE,F(BOSS),12\n";
  for (int k = 0; k < 12; ++k) text += boss_touch(30.0 * k, 15);
  text +=
      "ENDMES\nT(LP)=TOL/DIAM,-0.003,0.003,DIAMLP\nT(LS)=TOL/DIAM,-0.003,0.003\nT(MX)=TOL/DIAM,-0.003,0.003,MAX\n"
      "OUTPUT/FA(BOSS),TA(LP),TA(LS),TA(MX)\nENDFIL\n";
  const fs::path lobed = source_dir / "programs/worlds/scan_lobed_circle.json";
  const auto three = run(text, lobed);
  ASSERT_EQ(three.status, ExecStatus::Finished) << three.diagnostics;
  ASSERT_NE(tolerance(*three.session, "LP"), nullptr) << three.diagnostics;
  EXPECT_NEAR(tolerance(*three.session, "LP")->actual, 50.0, 1e-3);
  EXPECT_TRUE(tolerance(*three.session, "LP")->in_tolerance);
  EXPECT_GT(tolerance(*three.session, "MX")->actual, 50.004);  // 2 x 2.5 cos 30 deg = 4.33 um and more
  const fs::path oval = deviated("oval.json", lobed,
                                 "{\"BOSS\": {\"form\": {\"lobes\": 2, \"amplitude_mm\": 0.0025, \"phase_deg\": 20}}}");
  const auto two = run(text, oval);
  ASSERT_EQ(two.status, ExecStatus::Finished) << two.diagnostics;
  const auto* lp = tolerance(*two.session, "LP");
  ASSERT_NE(lp, nullptr) << two.diagnostics;
  EXPECT_NEAR(std::abs(lp->actual - 50.0), 2 * 0.0025 * std::cos(20 * std::numbers::pi / 180), 5e-4);
  EXPECT_FALSE(lp->in_tolerance);
  EXPECT_TRUE(tolerance(*two.session, "LS")->in_tolerance);
  EXPECT_NEAR(tolerance(*two.session, "LS")->actual, 50.0, 5e-4);

  // The oval boss as a CYLNDR touched in two sections 14 mm apart, 6 points 60 deg apart in each:
  // each section its own two-point sizes, at most 2 x 2.5 cos(2 (120 - 20) deg) = 4.70 um off.
  std::string cylinder =
      "DMISMN/'lp', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,3\nSNSET/RETRCT,3\nSNSET/SEARCH,3\n"
      "F(BOSS)=FEAT/CYLNDR,OUTER,CART,200,300,8,0,0,1,50,14\nMEAS/CYLNDR,F(BOSS),12\n";
  for (const double z : {8.0, 22.0})
    for (int k = 0; k < 6; ++k) cylinder += boss_touch(60.0 * k, z);
  cylinder += "ENDMES\nT(LP)=TOL/DIAM,-0.003,0.003,DIAMLP\nOUTPUT/FA(BOSS),TA(LP)\nENDFIL\n";
  const auto sections = run(cylinder, oval);
  ASSERT_EQ(sections.status, ExecStatus::Finished) << sections.diagnostics;
  const auto* lp_cylinder = tolerance(*sections.session, "LP");
  ASSERT_NE(lp_cylinder, nullptr) << sections.diagnostics;
  EXPECT_NEAR(std::abs(lp_cylinder->actual - 50.0), 2 * 0.0025 * std::cos(20 * std::numbers::pi / 180), 5e-4);
  EXPECT_NE(lp_cylinder->note.find("at 12 of the 12 measured points"), std::string::npos) << lp_cylinder->note;

  // Five touches 72 deg apart have no opposite touch: each point's opposite radius is interpolated
  // midway between the touches 36 deg either side of it. On the oval, r(t) = R + a cos 2(t - 20),
  // the pair of neighbours averages to R + a cos 2(t + 180 - 20) cos 72 deg, so the sizes are
  // 2R + a (1 + cos 72 deg) cos 2(t - 20): the method's own reading of five points (the true
  // two-point sizes, 2R + 2a cos 2(t - 20), are underestimated by the factor (1 + cos 72) / 2 =
  // 0.65; docs/tolerances.md). At t = 72 k: the largest at t = 216, the smallest at t = 288.
  std::string five = text.substr(0, text.find("MEAS/CIRCLE")) + "MEAS/CIRCLE,F(BOSS),5\n";
  for (int k = 0; k < 5; ++k) five += boss_touch(72.0 * k, 15);
  five += "ENDMES\nT(LP)=TOL/DIAM,-0.01,0.01,DIAMLP\nOUTPUT/FA(BOSS),TA(LP)\nENDFIL\n";
  const auto odd = run(five, oval);
  ASSERT_EQ(odd.status, ExecStatus::Finished) << odd.diagnostics;
  const auto* lp_odd = tolerance(*odd.session, "LP");
  ASSERT_NE(lp_odd, nullptr) << odd.diagnostics;
  const auto size_at = [](double deg) {
    const double rad = std::numbers::pi / 180;
    return 50 + 0.0025 * (1 + std::cos(72 * rad)) * std::cos(2 * (deg - 20) * rad);
  };
  double from = 0, to = 0;
  const auto at = lp_odd->note.find("run from ");
  ASSERT_NE(at, std::string::npos) << lp_odd->note;
  ASSERT_EQ(std::sscanf(lp_odd->note.c_str() + at, "run from %lf to %lf", &from, &to), 2) << lp_odd->note;
  EXPECT_NEAR(from, size_at(288), 5e-4) << lp_odd->note;
  EXPECT_NEAR(to, size_at(216), 5e-4) << lp_odd->note;

  // A cylinder's sections each give their own sizes: the default block's 90 deg countersink (apex
  // 8 mm below the top) read as a CYLNDR touched at 4 and 6 mm above its apex by a 2 mm ball moving
  // across the axis, 6 points 60 deg apart in each (the points of the two sections at the same
  // angles keep the least-squares cylinder's axis on the cone's). A ball of radius b touching a 45 deg wall with
  // its centre h above the apex is h - b sqrt(2) from the axis, its surface point h - b (sqrt(2) - 1): the sections'
  // two-point sizes are 2 (4 - (sqrt(2) - 1)) = 7.1716 and 2 (6 - (sqrt(2) - 1)) = 11.1716 (perfect world).
  std::string countersink =
      "DMISMN/'csk', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,2\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,1\nSNSET/RETRCT,1\nSNSET/SEARCH,2\nD(PART)=TRANS/XORIG,300,YORIG,200,ZORIG,0\n"
      "GOTO/40,20,60\nF(CSK)=FEAT/CYLNDR,INNER,CART,40,20,36,0,0,1,10,2\nMEAS/CYLNDR,F(CSK),12\n";
  countersink += countersink_rings();
  countersink += "  GOTO/40,20,60\nENDMES\nT(LP)=TOL/DIAM,-0.01,0.01,DIAMLP\nOUTPUT/FA(CSK),TA(LP)\nENDFIL\n";
  const auto cone = run(countersink, source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(cone.status, ExecStatus::Finished) << cone.diagnostics;
  const auto* lp_sections = tolerance(*cone.session, "LP");
  ASSERT_NE(lp_sections, nullptr) << cone.diagnostics;
  const double lift = std::sqrt(2.0) - 1;
  EXPECT_NEAR(lp_sections->actual, 2 * (4 - lift), 1e-4);
  EXPECT_NE(lp_sections->note.find(fmt::format("run from {:.4f} to {:.4f}", 2 * (4 - lift), 2 * (6 - lift))),
            std::string::npos)
      << lp_sections->note;
}

// CIRLTY of a CYLNDR is the roundness of its sections (ISO 1101: every section normal to the axis):
// scan_lobed_circle.json's boss, 3 lobes of 2.5 um at 20 deg (hidden), touched at 12 points 30 deg
// apart at z 8 and z 22. At those angles the lobes read a cos 3(30 k - 20) = a cos(90 k - 60), from
// -a cos 30 to +a cos 30: a minimum zone of 2a cos 30 deg = 4.330 um in each section (a centre
// moved adds a first harmonic, which cannot narrow a third); 6 points 60 deg apart at z 15 read
// +-a/2, 2.5 um. The worst section is the roundness. check no longer calls it wrong.
TEST(ShopPrograms, RoundnessOfACylinderIsItsWorstSection) {
  std::string text =
      "DMISMN/'round', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,3\nSNSET/RETRCT,3\nSNSET/SEARCH,3\n"
      "F(BOSS)=FEAT/CYLNDR,OUTER,CART,200,300,8,0,0,1,50,14\nMEAS/CYLNDR,F(BOSS),30\n";
  for (const double z : {8.0, 22.0})
    for (int k = 0; k < 12; ++k) text += boss_touch(30.0 * k, z);
  for (int k = 0; k < 6; ++k) text += boss_touch(60.0 * k, 15);
  text += "ENDMES\nT(RND)=TOL/CIRLTY,0.004\nOUTPUT/FA(BOSS),TA(RND)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0U) << check(text).text;
  const auto ran = run(text, source_dir / "programs/worlds/scan_lobed_circle.json");
  ASSERT_EQ(ran.status, ExecStatus::Finished) << ran.diagnostics;
  const auto* round = tolerance(*ran.session, "RND");
  ASSERT_NE(round, nullptr) << ran.diagnostics;
  EXPECT_NEAR(round->value, 2 * 0.0025 * std::cos(std::numbers::pi / 6), 5e-4) << round->note;
  EXPECT_FALSE(round->in_tolerance) << round->note;
  EXPECT_NE(round->note.find("of 3 sections normal to the axis"), std::string::npos) << round->note;
}

// PERP of a CONE: its axis. The default block's countersink CONE1 (90 deg, apex 8 mm below the
// top) tilted 0.5 deg about X about its apex (hidden, a world written here on perfect.json),
// touched in two rings 4 and 6 mm above the apex by a 2 mm ball: its axis leans 0.5 deg from the
// top face's normal over the rings' extent along it, 2 mm and a little more (a ring on a tilted
// cone is not at one height along its axis: up to 2 x 5 sin 0.5 deg more), so PERP to the top is
// between 2 sin 0.5 and 2.09 sin 0.5 deg; untilted, 0.
TEST(ShopPrograms, PerpendicularityOfAConesAxis) {
  std::string text =
      "DMISMN/'csk', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,2\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,1\nSNSET/RETRCT,1\nSNSET/SEARCH,2\nD(PART)=TRANS/XORIG,300,YORIG,200,ZORIG,0\nGOTO/100,50,60\n"
      "F(TOP)=FEAT/PLANE,CART,100,50,40,0,0,1\nMEAS/PLANE,F(TOP),3\n  PTMEAS/CART,100,50,40,0,0,1\n"
      "  PTMEAS/CART,150,10,40,0,0,1\n  PTMEAS/CART,100,10,40,0,0,1\nENDMES\nDATDEF/FA(TOP),DAT(A)\n"
      "GOTO/40,20,60\nF(CSK)=FEAT/CONE,INNER,CART,40,20,32,0,0,1,90\nMEAS/CONE,F(CSK),12\n";
  text += countersink_rings();
  text += "  GOTO/40,20,60\nENDMES\nT(PP)=TOL/PERP,0.01,DAT(A)\nOUTPUT/FA(CSK),TA(PP)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0U) << check(text).text;
  const fs::path perfect = source_dir / "programs/worlds/perfect.json";
  const fs::path tilted = deviated("cone_tilted.json", perfect, "{\"CONE1\": {\"tilt_deg\": [0.5, 0]}}");
  const double lean = std::sin(0.5 * std::numbers::pi / 180);
  const auto leaning = run(text, tilted);
  ASSERT_EQ(leaning.status, ExecStatus::Finished) << leaning.diagnostics;
  const auto* perp = tolerance(*leaning.session, "PP");
  ASSERT_NE(perp, nullptr) << leaning.diagnostics;
  EXPECT_GE(perp->value, 2 * lean * 0.999) << perp->note;
  EXPECT_LE(perp->value, 2.09 * lean) << perp->note;
  EXPECT_FALSE(perp->in_tolerance) << perp->note;
  EXPECT_NE(perp->note.find("axis of CSK at 0.5000 deg to datum A"), std::string::npos) << perp->note;
  const auto upright = run(text, perfect);
  ASSERT_EQ(upright.status, ExecStatus::Finished) << upright.diagnostics;
  ASSERT_NE(tolerance(*upright.session, "PP"), nullptr);
  EXPECT_LT(tolerance(*upright.session, "PP")->value, 1e-5) << tolerance(*upright.session, "PP")->note;
}

// TOL/ANGLR (angularity): programs/worlds/block_chamfer.json, a block whose top-right edge is
// chamfered at 30 deg to the top face, the chamfer turned a further 0.2 deg about Y (hidden). Its touches 6 mm
// apart in X, 6 / cos 30 deg down its slope, spread that times sin 0.2 deg across the zone at a
// basic 30 deg to datum A: 0.024184 (the geometry of the world, not metron's); untilted, 0.
TEST(ShopPrograms, AngularityOfAChamferToTheTopFace) {
  const double slope = std::tan(30 * std::numbers::pi / 180);
  const fs::path turned_world = source_dir / "programs/worlds/block_chamfer.json";
  const fs::path square_world = deviated("chamfer_square.json", turned_world, "{\"CHAMFER\": null}");
  std::string text =
      "DMISMN/'chamfer', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,2\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,1\nSNSET/RETRCT,1\nSNSET/SEARCH,2\nD(PART)=TRANS/XORIG,300,YORIG,200,ZORIG,0\nGOTO/100,50,60\n"
      "F(TOP)=FEAT/PLANE,CART,100,50,40,0,0,1\nMEAS/PLANE,F(TOP),3\n  PTMEAS/CART,100,50,40,0,0,1\n"
      "  PTMEAS/CART,140,10,40,0,0,1\n  PTMEAS/CART,100,10,40,0,0,1\nENDMES\nDATDEF/FA(TOP),DAT(A)\n"
      "GOTO/175,50,60\nF(CH)=FEAT/PLANE,CART,155,50," +
      fmt::format("{:.6f}", 40 - 5 * slope) + ",0.5,0,0.866025\nMEAS/PLANE,F(CH),4\n";
  for (const double x : {152.0, 158.0})
    for (const double y : {20.0, 80.0})
      text += fmt::format("  PTMEAS/CART,{},{},{:.6f},0.5,0,0.866025\n", x, y, 40 - (x - 150) * slope);
  text +=
      "ENDMES\nT(AN)=TOL/ANGLR,0.02,30,DAT(A)\nT(AW)=TOL/ANGLR,30,0.03,DAT(A)\nT(AM)=TOL/ANGLR,0.03,-30,DAT(A)\n"
      "OUTPUT/FA(CH),TA(AN),TA(AW),TA(AM)\nENDFIL\n";
  const auto checked = check(text);
  EXPECT_EQ(checked.errors + checked.warnings, 0U) << checked.text;
  const double truth = 6 / std::cos(30 * std::numbers::pi / 180) * std::sin(0.2 * std::numbers::pi / 180);
  const auto turned = run(text, turned_world);
  ASSERT_EQ(turned.status, ExecStatus::Finished) << turned.diagnostics;
  const auto* an = tolerance(*turned.session, "AN");
  const auto* aw = tolerance(*turned.session, "AW");
  ASSERT_NE(an, nullptr) << turned.diagnostics;
  ASSERT_NE(aw, nullptr) << turned.diagnostics;
  EXPECT_NEAR(an->value, truth, 2e-6) << an->note;
  EXPECT_FALSE(an->in_tolerance) << an->note;
  EXPECT_NEAR(aw->value, truth, 2e-6) << aw->note;    // the angle first: the larger number is the angle
  const auto* am = tolerance(*turned.session, "AM");  // a negative angle: the same lines
  ASSERT_NE(am, nullptr) << turned.diagnostics;
  EXPECT_NEAR(am->value, truth, 2e-6) << am->note;
  EXPECT_TRUE(aw->in_tolerance) << aw->note;
  EXPECT_NE(an->note.find("basic 30 deg"), std::string::npos) << an->note;
  const auto square = run(text, square_world);
  ASSERT_EQ(square.status, ExecStatus::Finished) << square.diagnostics;
  ASSERT_NE(tolerance(*square.session, "AN"), nullptr);
  EXPECT_LT(tolerance(*square.session, "AN")->value, 1e-5) << tolerance(*square.session, "AN")->note;
  // A datum is required, and a negative zone is refused, at check.
  const auto no_datum = check("DMISMN/'p', 5.0\nT(A1)=TOL/ANGLR,0.02,30\nENDFIL\n");
  EXPECT_TRUE(no_datum.has("TOL/ANGLR needs a datum DAT(x)")) << no_datum.text;
  const auto negative = check("DMISMN/'p', 5.0\nT(A1)=TOL/ANGLR,-0.02,30,DAT(A)\nENDFIL\n");
  EXPECT_TRUE(negative.has("a tolerance zone must not be negative")) << negative.text;
}

/// A boss tapering 0.2 deg (a cone whose apex lies 7 m above; its diameter 50 at z 15, 30 high):
/// scan_lobed_circle.json's boss with the taper and without its lobes (hidden truth written here).
fs::path taper_world() {
  const fs::path lobed = source_dir / "programs/worlds/scan_lobed_circle.json";
  const double tan_taper = std::tan(0.2 * std::numbers::pi / 180);
  const double apex_height = 15 + 25 / tan_taper;  // the diameter is 50 at z 15
  return write("taper.json",
               fmt::format("{{\"extends\": \"{}\", \"part\": {{\"design\": {{\"intersection\": ["
                           "{{\"type\": \"cone\", \"name\": \"BOSS\", \"apex\": [0, 0, {:.9f}], \"axis\": [0, 0, "
                           "-1], \"half_angle_deg\": 0.2}},"
                           "{{\"type\": \"half_space\", \"point\": [0, 0, 30], \"normal\": [0, 0, 1]}},"
                           "{{\"type\": \"half_space\", \"point\": [0, 0, 0], \"normal\": [0, 0, -1]}}]}},"
                           "\"deviations\": {{\"BOSS\": {{\"form\": {{\"lobes\": 3, \"amplitude_mm\": 0, "
                           "\"phase_deg\": 0}}}}}}}}}}\n",
                           lobed.string(), apex_height));
}

// A cylinder's two-point sizes are taken section by section: a boss tapering 0.2 deg (a cone whose
// apex lies 7 m above, hidden truth of the world written here) touched at 5 points 72 deg apart at
// z 8, 15 and 22, turned 0, 18 and 36 deg, so a point's opposite at z 8 lies at z 22 only. Per
// section (a circle: the opposite radius interpolated between equal radii) the sizes are the
// section's diameters, 50 +- 2 x 7 tan 0.2 deg = 50 +- 0.04887 at the ends; taken as one section
// those of z 8 and 22 would all be their mean, 50.
TEST(ShopPrograms, TwoPointSizesOfATaperAreTakenPerSection) {
  const double tan_taper = std::tan(0.2 * std::numbers::pi / 180);
  const fs::path taper = taper_world();
  std::string text =
      "DMISMN/'taper', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,3\nSNSET/RETRCT,3\nSNSET/SEARCH,3\n"
      "F(BOSS)=FEAT/CYLNDR,OUTER,CART,200,300,8,0,0,1,50,14\nMEAS/CYLNDR,F(BOSS),15\n";
  for (const auto& [z, turn] : {std::pair{8.0, 0.0}, std::pair{15.0, 18.0}, std::pair{22.0, 36.0}})
    for (int k = 0; k < 5; ++k) text += boss_touch(72.0 * k + turn, z);
  text += "ENDMES\nT(LP)=TOL/DIAM,-0.1,0.1,DIAMLP\nT(ST)=TOL/STRGHT,0.002\nOUTPUT/FA(BOSS),TA(LP),TA(ST)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0U) << check(text).text;  // STRGHT of a CYLNDR: its axis
  const auto ran = run(text, taper);
  ASSERT_EQ(ran.status, ExecStatus::Finished) << ran.diagnostics;
  const auto* lp = tolerance(*ran.session, "LP");
  ASSERT_NE(lp, nullptr) << ran.diagnostics;
  // The default probe's scatter (a few tenths of a micrometre) is on every size.
  const double bottom = 50 + 2 * 7 * tan_taper, top = 50 - 2 * 7 * tan_taper;
  EXPECT_NEAR(lp->actual, bottom, 5e-4) << lp->note;  // 0.0511 from 50.1, nearer than the top's 0.0489 from 49.9
  double from = 0, to = 0;
  const auto at = lp->note.find("run from ");
  ASSERT_NE(at, std::string::npos) << lp->note;
  ASSERT_EQ(std::sscanf(lp->note.c_str() + at, "run from %lf to %lf", &from, &to), 2) << lp->note;
  EXPECT_NEAR(from, top, 5e-4) << lp->note;
  EXPECT_NEAR(to, bottom, 5e-4) << lp->note;
  // The taper's axis is straight (a cone's): the three sections' centres lie on a line, but for
  // the probe's scatter.
  const auto* straight = tolerance(*ran.session, "ST");
  ASSERT_NE(straight, nullptr) << ran.diagnostics;
  EXPECT_LT(straight->value, 1e-3) << straight->note;
  EXPECT_TRUE(straight->in_tolerance) << straight->note;
  EXPECT_NE(straight->note.find("the centres of 3 sections"), std::string::npos) << straight->note;
}

// A helical scan has no sections by height: its turns are its sections. The tapered boss of
// taper_world() scanned along four turns of pitch 4 mm from z 24 down to 8: its axis is straight
// (the four turns' centres on a line but for the probe and the scan's own error); each turn's
// roundness is the taper over one pitch, 4 tan 0.2 deg = 0.0140: no more (the zone about the true
// axis holds the turn) and no less (the turn's first and last points lie at one angle, that far
// apart radially, whatever the centre). All the points as one section would span 16 mm of taper,
// 0.0559.
TEST(ShopPrograms, AHelicalScanIsSectionedByItsTurns) {
  const double tan_taper = std::tan(0.2 * std::numbers::pi / 180);
  const std::string text =
      "DMISMN/'helix', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,3\nSNSET/RETRCT,3\nSNSET/SEARCH,3\nGOTO/240,300,40\n"
      "P(H)=PATH/HELICAL,CART,200,300,24,0,0,-1,25,0,1440,4,OUTER\n"
      "F(BOSS)=FEAT/CYLNDR,OUTER,CART,200,300,8,0,0,1,50,16\nSCNMOD/ON\nMEAS/CYLNDR,F(BOSS),0\n  PAMEAS/P(H)\n"
      "ENDMES\nSCNMOD/OFF\nT(ST)=TOL/STRGHT,0.002\nT(RN)=TOL/CIRLTY,0.02\nOUTPUT/FA(BOSS),TA(ST),TA(RN)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0U) << check(text).text;
  const auto ran = run(text, taper_world());
  ASSERT_EQ(ran.status, ExecStatus::Finished) << ran.diagnostics;
  const auto* straight = tolerance(*ran.session, "ST");
  ASSERT_NE(straight, nullptr) << ran.diagnostics;
  EXPECT_LT(straight->value, 1e-3) << straight->note;
  EXPECT_NE(straight->note.find("the centres of 4 sections"), std::string::npos) << straight->note;
  const auto* round = tolerance(*ran.session, "RN");
  ASSERT_NE(round, nullptr) << ran.diagnostics;
  EXPECT_NEAR(round->value, 4 * tan_taper, 1e-3) << round->note;
  EXPECT_NE(round->note.find("of 4 sections"), std::string::npos) << round->note;
  std::printf("helix on a 0.2 deg taper: axis straightness %.6f, worst turn's roundness %.6f (4 tan 0.2 deg = %.6f)\n",
              straight->value, round->value, 4 * tan_taper);
}

// TOL/FLAT,t,tu,a[,b] and TOL/STRGHT,t,tu,l (DMIS 5.x; ASME Y14.5 form per unit area or length)
// against the hidden waviness of a world written here: the default block's top face waved
// a cos(2 pi x / 40) with a = 2 um (the perfect probe), touched on a 5 mm grid over x 10..90 in
// three rows, and along one row as a LINE. Analytic truth: the whole face's minimum zone is 2a
// (the grid holds the crests and troughs); the largest minimum zone of a cosine over a stretch
// w <= half its wavelength is a (1 - cos(pi w / 40)), on a stretch centred on a crest (a brute-force
// search over placements agrees): a for 20 mm, 0.2929 a for 10 mm.
TEST(ShopPrograms, FormPerUnitAreaAndLengthAgainstAWavyFace) {
  const fs::path wavy =
      deviated("wavy.json", (source_dir / "programs/worlds/perfect.json"),
               "{\"TOP\": {\"form\": {\"amplitude_mm\": 0.002, \"wavelength_mm\": 40, \"phase_deg\": 0}}}");
  std::string text =
      "DMISMN/'per unit', 5.0\nUNITS/MM, ANGDEC\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P)\n"
      "SNSET/APPRCH,2\nSNSET/RETRCT,2\nD(PART)=TRANS/XORIG,300,YORIG,200,ZORIG,0\nGOTO/10,3,60\n"
      "F(TOP)=FEAT/PLANE,CART,80,50,40,0,0,1\nMEAS/PLANE,F(TOP),51\n";
  for (const int y : {3, 6, 9})
    for (int x = 10; x <= 90; x += 5) text += fmt::format("  PTMEAS/CART,{},{},40,0,0,1\n", x, y);
  text +=
      "ENDMES\nT(FL)=TOL/FLAT,0.005\nT(FLU)=TOL/FLAT,0.005,0.0015,20,20\nT(FLU2)=TOL/FLAT,0.005,0.0025,20,20\n"
      "T(FLS)=TOL/FLAT,0.005,0.001,10\nT(FL25)=TOL/FLAT,0.005,0.003,25,25\nT(FLN)=TOL/"
      "FLAT,0.005,0.0001,3,3\nF(ROW)=FEAT/"
      "LINE,BND,CART,10,6,40,90,6,40,0,-1,0\nMEAS/LINE,F(ROW),17\n";
  for (int x = 10; x <= 90; x += 5) text += fmt::format("  PTMEAS/CART,{},6,40,0,0,1\n", x);
  text +=
      "ENDMES\nT(STU)=TOL/STRGHT,0.005,0.0015,20\nOUTPUT/FA(TOP),TA(FL),TA(FLU),TA(FLU2),TA(FLS),TA(FL25),TA(FLN)\n"
      "OUTPUT/FA(ROW),TA(STU)\nENDFIL\n";
  ASSERT_EQ(check(text).errors, 0U) << check(text).text;
  EXPECT_EQ(check(text).warnings, 0U) << check(text).text;
  const auto ran = run(text, wavy);
  ASSERT_EQ(ran.status, ExecStatus::Finished) << ran.diagnostics;
  const double a = 0.002;
  const auto per_unit = [](const metron::runtime::ToleranceResult& t) {
    const auto at = t.note.find("the largest minimum zone ");
    double v = -1;
    if (at != std::string::npos) std::sscanf(t.note.c_str() + at, "the largest minimum zone %lf", &v);
    return v;
  };
  for (const char* label : {"FL", "FLU", "FLU2", "FLS", "FL25", "FLN", "STU"})
    ASSERT_NE(tolerance(*ran.session, label), nullptr) << label;
  const auto& whole = *tolerance(*ran.session, "FL");
  EXPECT_NEAR(whole.value, 2 * a, 1e-6);
  EXPECT_TRUE(whole.in_tolerance);
  EXPECT_EQ(whole.note.find("per unit"), std::string::npos) << whole.note;
  const auto& over = *tolerance(*ran.session, "FLU");
  EXPECT_NEAR(over.value, 2 * a, 1e-6);  // the whole face's form, within its zone
  EXPECT_NEAR(per_unit(over), a, 1e-6) << over.note;
  EXPECT_FALSE(over.in_tolerance) << over.note;  // a unit's zone exceeded
  const auto& within = *tolerance(*ran.session, "FLU2");
  EXPECT_NEAR(per_unit(within), a, 1e-6) << within.note;
  EXPECT_TRUE(within.in_tolerance) << within.note;
  const auto& square = *tolerance(*ran.session, "FLS");  // three numbers: a square of 10
  EXPECT_NEAR(per_unit(square), a * (1 - std::cos(std::numbers::pi / 4)), 1e-6) << square.note;
  EXPECT_NE(square.note.find("per unit area 10.0000 x 10.0000"), std::string::npos) << square.note;
  // 25 x 25 holds six touches of a row, never placed symmetrically about a crest: the truth is
  // the largest Chebyshev (minimum-zone) line of the sampled profile over the windows, found here
  // by a ternary search on the slope (the rows are alike, so the zone's plane does not tilt across
  // them); the least-squares form of the worst window is 0.06 a more (1.34 a against 1.2828 a).
  const auto chebyshev = [&](int x0) {
    const auto width = [&](double slope) {
      double lo = 1e9, hi = -1e9;
      for (int x = x0; x <= x0 + 25; x += 5) {
        const double r = a * std::cos(2 * std::numbers::pi * x / 40) - slope * x;
        lo = std::min(lo, r);
        hi = std::max(hi, r);
      }
      return hi - lo;
    };
    double lo = -1, hi = 1;
    for (int i = 0; i < 200; ++i) {
      const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
      if (width(m1) < width(m2))
        hi = m2;
      else
        lo = m1;
    }
    return width((lo + hi) / 2);
  };
  double worst = 0;
  for (int x0 = 10; x0 + 25 <= 90; x0 += 5) worst = std::max(worst, chebyshev(x0));
  EXPECT_NEAR(worst, 1.2828 * a, 1e-4 * a);
  EXPECT_NEAR(per_unit(*tolerance(*ran.session, "FL25")), worst, 1e-6) << tolerance(*ran.session, "FL25")->note;
  // Units of 3 x 3 between touches 5 mm apart hold at most one: nothing to judge, and said so.
  const auto& sparse = *tolerance(*ran.session, "FLN");
  EXPECT_TRUE(sparse.in_tolerance) << sparse.note;
  EXPECT_NE(sparse.note.find("per unit area 3.0000 x 3.0000: not evaluated, no unit holds four of the measured points"),
            std::string::npos)
      << sparse.note;
  const auto& row = *tolerance(*ran.session, "STU");
  EXPECT_NEAR(row.value, 2 * a, 1e-6);
  EXPECT_NEAR(per_unit(row), a, 1e-6) << row.note;
  EXPECT_FALSE(row.in_tolerance) << row.note;

  // The unit's sides must be positive; two numbers are not a per-unit form (the second is told unused).
  const std::string head = "DMISMN/'u', 5.0\nF(P)=FEAT/PLANE,CART,0,0,0,0,0,1\n";
  EXPECT_TRUE(
      check(head + "T(A)=TOL/FLAT,0.01,0.005,-10\nENDFIL\n").has("the unit area's side of TOL/FLAT must be positive"));
  EXPECT_TRUE(check(head + "T(A)=TOL/FLAT,0.01,0.005\nENDFIL\n").has("the 1 number after it is not used"));
  EXPECT_TRUE(check(head + "T(A)=TOL/STRGHT,0.01,-0.005,10\nENDFIL\n").has("a tolerance zone must not be negative"));
}

// F(p)=FEAT/PATERN,F(a),F(b),...: a pattern of features. OUTPUT/FA(p) is the OUTPUT of its
// features, in order (a composite position judges them together); elsewhere it is an error.
TEST(ShopPrograms, APatternIsOutputAsItsFeatures) {
  const std::string head =
      "DMISMN/'pattern', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\n"
      "F(B1) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, 20\nMEAS/CIRCLE, F(B1), 4\nENDMES\n"
      "F(B2) = FEAT/CIRCLE, INNER, CART, 120, 30, 35, 0, 0, 1, 12\nMEAS/CIRCLE, F(B2), 4\nENDMES\n"
      "T(C) = TOL/COMPOS, PATERN, 0.2, FEATUR, 0.05\n";
  const auto events = [](const Ran& r) {
    std::vector<std::string> out;
    for (const auto& e : r.session->record().events) {
      if (const auto* f = std::get_if<metron::runtime::FeatureReport>(&e)) out.push_back("F " + f->label);
      if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e))
        out.push_back(fmt::format("T {} {:.6f} {}", t->label, t->value, t->in_tolerance));
    }
    return out;
  };
  const auto listed =
      run(head + "OUTPUT/FA(B1), FA(B2), TA(C)\nENDFIL\n", source_dir / "programs/worlds/block_deviations.json");
  const auto pattern = run(head + "F(HOLES) = FEAT/PATERN, F(B1), F(B2)\nOUTPUT/FA(HOLES), TA(C)\nENDFIL\n",
                           source_dir / "programs/worlds/block_deviations.json");
  ASSERT_EQ(listed.status, ExecStatus::Finished) << listed.diagnostics;
  ASSERT_EQ(pattern.status, ExecStatus::Finished) << pattern.diagnostics;
  EXPECT_EQ(events(pattern), events(listed));
  EXPECT_EQ(events(pattern).size(), 4U);  // two features, two tiers
  EXPECT_NE(pattern.diagnostics.find("F(HOLES) is a pattern of 2 features"), std::string::npos) << pattern.diagnostics;
  // Elsewhere a pattern is not a feature; its members must be features defined before.
  const auto c = check(
      "DMISMN/'p', 5.0\nF(A) = FEAT/POINT, CART, 0, 0, 0, 0, 0, 1\nF(P) = FEAT/PATERN, F(A), F(NOPE)\n"
      "F(B) = FEAT/POINT, CART, 1, 0, 0, 0, 0, 1\nF(Q) = FEAT/PATERN, F(A), F(B)\nDATDEF/FA(Q), DAT(A)\nF(R) = "
      "FEAT/PATERN, F(A), 3\nENDFIL\n");
  EXPECT_TRUE(c.has("3:27: error: feature F(NOPE) is not defined")) << c.text;
  EXPECT_TRUE(c.has("6:8: error: FA(Q) is a pattern (FEAT/PATERN): OUTPUT takes it")) << c.text;
  EXPECT_TRUE(c.has("7:27: error: FEAT/PATERN lists the pattern's features")) << c.text;
}

// RationalDMIS's "fitting coordinate system" pages (365seal.com, laitimes.com) show the beginning
// of the programs they export around EQUATE: a library sensor whose label has a '-', PTMEAS over
// two lines with '$', MODE/PROG, MAN then MODE/MAN. Written out here with the page's scenario (the
// part moved by accident: the same plane measured again, the system built again, EQUATE): it
// checks clean and runs to its end; two systems built in the same set-up are told as such.
TEST(ShopPrograms, RationalDmisEquateProgramChecksAndRuns) {
  const std::string text =
      "DMISMN/'Created by [x] on 2018', 4.0\nUNITS/MM, ANGDEC\nWKPLAN/XYPLAN\nPRCOMP/ON\nTECOMP/ON\nFLY/1.0\n"
      "MODE/PROG, MAN\nSNSET/APPRCH, 3.000000\nSNSET/SEARCH, 10.000000\nSNSET/CLRSRF, 50.000000\nRECALL/D(MCS)\n"
      "SNSLCT/S(20-30X2)\nGEOALG/PLANE, LSTSQR\n$$\nMODE/MAN\n"
      "F(PLN1) = FEAT/PLANE,CART, 80.0, 50.0, 40.0, 0.000000,$\n0.000000, 1.000000\n"
      "MEAS/PLANE, F(PLN1), 3\nPTMEAS/CART,  10.000000, 10.000000, 40.000000,  0.000000, 0.000000,$\n1.000000\n"
      "PTMEAS/CART,  150.000000, 10.000000, 40.000000,  0.000000, 0.000000,$\n1.000000\n"
      "PTMEAS/CART,  80.000000, 90.000000, 40.000000,  0.000000, 0.000000,$\n1.000000\nENDMES\n"
      "D(CRD1) = DATSET/FA(PLN1), ZDIR, ZORIG\nD(CRD2) = DATSET/FA(PLN1), ZDIR, ZORIG\nEQUATE/DA(CRD1), DA(CRD2)\n"
      "OUTPUT/FA(PLN1)\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0U) << c.text;
  EXPECT_EQ(c.warnings, 0U) << c.text;
  const auto r = dry_run(text);
  EXPECT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("warning: EQUATE: DA(CRD1) rests on no feature measured before DA(CRD2)'s first point"),
            std::string::npos)
      << r.diagnostics;
}

// A CAMIO program (a public lab's scale-bar program) ties its alignment to the CAD model's
// coordinate system and names the model's geometry: EQUATE/DA(x),CADCS,DID(m),'cs' and
// G(x)=GEOM/DID(m). The virtual CMM reads no model: a note each, where both were warnings saying
// the statement "is not supported". EQUATE of two alignments is carried out (PartSetups.* in
// tests/e2e/test_run.cpp); of one the program does not define, a warning read leniently.
TEST(ShopPrograms, CadModelStatementsAreNoted) {
  const auto c = check(
      "DMISMN/'cad', 5.0\nDID(LADDER) = DEVICE/STOR, 'ladder.igs'\nOPEN/DID(LADDER), CAD, IGES\n"
      "D(REF) = DATSET/MCS\nG(ALL) = GEOM/DID(LADDER)\nG(TOP) = GEOM/DID(LADDER)\n"
      "EQUATE/DA(REF), CADCS, DID(LADDER), '_Origin'\nEQUATE/DA(REF), DA(OTHER)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0U) << c.text;
  EXPECT_EQ(c.warnings, 1U) << c.text;
  EXPECT_TRUE(c.has("5:1: note: GEOM names geometry of the CAD model: the part is the world's")) << c.text;
  EXPECT_EQ(c.text.find("GEOM names geometry", c.text.find("GEOM names geometry") + 1), std::string::npos)
      << c.text;  // once
  EXPECT_TRUE(c.has("7:17: note: EQUATE of DA(REF) with the CAD model's coordinate system: the model is not read"))
      << c.text;
  EXPECT_TRUE(c.has("8:17: warning: coordinate system DA(OTHER) is not defined in this program")) << c.text;
  // The dry run goes past them.
  const auto r = dry_run(
      "DMISMN/'cad', 5.0\nDID(LADDER) = DEVICE/STOR, 'ladder.igs'\nOPEN/DID(LADDER), CAD, IGES\n"
      "D(REF) = DATSET/MCS\nG(ALL) = GEOM/DID(LADDER)\nEQUATE/DA(REF), CADCS, DID(LADDER), '_Origin'\n"
      "F(P) = FEAT/POINT, CART, 10, 10, 40, 0, 0, 1\nMEAS/POINT, F(P), 1\nENDMES\nOUTPUT/FA(P)\nENDFIL\n");
  EXPECT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
}

// The header RationalDMIS saves every program with (a public RationalDMIS 2024 program, its Quick
// 3-2-1 alignment block): `UNITS/MM, ANGDEC, MMPS` (a velocity unit after the angle unit) and
// `KNPTC1 = VALUE/MODE` with no DECL of KNPTC1. Both were errors, so no RationalDMIS program
// checked. Now the unit is read (each FEDRAT names its own), VALUE/MODE answers the mode as SMODE()
// does, and the VALUE declares its variable with a warning (`--strict`: the error).
TEST(ShopPrograms, RationalDmisHeaderIsRead) {
  const std::string text =
      "DMISMN/'Created by [RationalDMIS]', 4.0\nUNITS/MM, ANGDEC, MMPS\nWKPLAN/XYPLAN\nPRCOMP/ON\nTECOMP/ON\n"
      "FLY/1.0000\nMODE/PROG, MAN\nSNSET/APPRCH, 2.0000\nRECALL/D(MCS)\nSNSLCT/S(D3-L20)\nGEOALG/BF, LSTSQR\n"
      "GEOALG/CIRCLE, LSTSQR\nMODE/MAN\nDECL/COMMON, DOUBLE, DPROBEX, DPROBEY, DPROBEZ\nPRCOMP/OFF\n"
      "KNPTC1 = VALUE/MODE\nMODE/PROG, MAN\nKNPTC2 = VALUE/MODE\nTEXT/OPER, CONCAT(KNPTC1, ' ', KNPTC2)\n"
      "F(PT1)=FEAT/POINT,POL,53.2994,32.5276,40.0000,0.0000,0.0000,1.0000\nGEOALG/ANGLB, COMPLM\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0U) << c.text;
  EXPECT_TRUE(
      c.has("21:1: warning: GEOALG/ANGLB,COMPLM: this algorithm is not applied: metron evaluates ANGLB as "
            "docs/tolerances.md describes"))
      << c.text;
  EXPECT_TRUE(c.has("16:1: warning: variable KNPTC1 is not declared: this VALUE declares it CHAR (--strict: an error)"))
      << c.text;
  const auto strict = check(text, true);
  EXPECT_TRUE(strict.has("16:1: error: variable KNPTC1 is not declared")) << strict.text;
  const auto r = dry_run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  EXPECT_EQ(texts, (std::vector<std::string>{"MAN PROG,MAN"}));
  // Units the velocity word does not excuse.
  const auto units = check(
      "DMISMN/'u', 4.0\nUNITS/INCH, ANGRAD, TEMPF, IPS\nUNITS/MM, ANGDEC, MMPS, IPS\nUNITS/MM, ANGDEC, PCENT\n"
      "UNITS/MM, ANGDEC, TEMPC, TEMPF\nENDFIL\n");
  EXPECT_EQ(units.errors, 3U) << units.text;
  EXPECT_TRUE(units.has("3:25: error: expected a temperature unit (TEMPC, TEMPF) or a velocity unit")) << units.text;
  EXPECT_TRUE(units.has("4:19: error:")) << units.text;
  EXPECT_TRUE(units.has("5:26: error:")) << units.text;
  // An undeclared variable of a VALUE form metron does not answer is not declared by it.
  const auto unanswered = check("DMISMN/'v', 4.0\nK = VALUE/GEOALG, CIRCLE\nENDFIL\n");
  EXPECT_EQ(unanswered.errors, 0U) << unanswered.text;
  EXPECT_TRUE(unanswered.has("this VALUE form is not answered")) << unanswered.text;
}

// Forms found in public programs (RationalDMIS exports, CAMIO lab programs, web tutorials) that
// metron read without a word or with a misleading one: each is now told for what it is.
TEST(ShopPrograms, ShopSoftwareFormsAreToldNotDropped) {
  const auto c = check(
      "DMISMN/'t', 5.0\nF(P1) = FEAT/POINT, CART, 0, 0, 0, 0, 0, 1\nF(PL) = FEAT/PLANE, CART, 0, 0, 0, 0, 0, 1\n"
      "MEAS/POINT, F(P1), 1, CLRSRF, F(PL), 2.00, CLRSRF, F(PL), 20.00\nENDMES\n"
      "MEAS/POINT, F(P1), 1, BOGUS, 3\nENDMES\n"
      "F(P1) = FEAT/POINT, CART, 1, 0, 0, 0, 0, 1\nEQUATE/DA(MCS), DA(MCS), DA(MCS)\n"
      "GEOALG/CIRCLE, LSTSQR, FILTER, LAMBDAC, 0.8\nGEOALG/PLANE, LSTSQR, ELIMINATE, STDDEV, 3\nENDFIL\n");
  EXPECT_EQ(c.errors, 0U) << c.text;
  // A fitting filter was dropped unseen: told once.
  EXPECT_TRUE(c.has("10:24: warning: GEOALG/CIRCLE,LSTSQR,FILTER: metron does not filter or thin the points"))
      << c.text;
  const auto told = c.text.find("metron does not filter or thin the points");
  EXPECT_EQ(c.text.find("metron does not filter or thin the points", told + 1), std::string::npos) << c.text;  // once
  // So were a tolerance's numbers past its form's, and DATDEF's second datum.
  const auto extra = check(
      "DMISMN/'t', 5.0\nF(P) = FEAT/PLANE, CART, 0, 0, 0, 0, 0, 1\nT(A) = TOL/FLAT, 0.1, 0.2\n"
      "T(B) = TOL/DIAM, -0.1, 0.1, 0.3, 4\nT(C) = TOL/DIAM, -0.1, 0.1\nDATDEF/FA(P), DAT(A), DAT(B)\nENDFIL\n");
  EXPECT_EQ(extra.errors, 0u) << extra.text;
  EXPECT_EQ(extra.warnings, 4u) << extra.text;  // and P is never measured:
  EXPECT_TRUE(extra.has("6:8: warning: FA(P) is read here, but nothing in this program measures")) << extra.text;
  EXPECT_TRUE(
      extra.has("3:1: warning: TOL/FLAT takes the tolerance zone (1 number); the 1 number after it is not used"))
      << extra.text;
  EXPECT_TRUE(extra.has(
      "4:1: warning: TOL/DIAM takes lower and upper tolerance (2 numbers); the 2 numbers after them are not used"))
      << extra.text;
  EXPECT_TRUE(extra.has("6:23: warning: DATDEF names one datum: FA(P) is DAT(A); what follows it is not used"))
      << extra.text;
  const auto select =
      check("DMISMN/'t', 5.0\nS(P)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,4\nSNSLCT/S(P), 0, 90\nENDFIL\n");
  EXPECT_TRUE(select.has("3:14: warning: SNSLCT selects S(P) as it is defined; the 2 parameters after it are not used"))
      << select.text;
  const auto feeds = check(
      "DMISMN/'t', 5.0\nFEDRAT/MESVEL, MMPS, 3, 4\nACLRAT/POSACL, MMPSS, 100, 5\n"
      "F(P)=FEAT/POINT,CART,0,0,0,0,0,1\nMEAS/POINT,F(P),1\nPTMEAS/CART,0,0,0,0,0,1,FA(P)\nENDMES\nENDFIL\n");
  EXPECT_TRUE(feeds.has("2:25: warning: FEDRAT takes a kind, a unit and one value; what follows the value is not used"))
      << feeds.text;
  EXPECT_TRUE(feeds.has("3:28: warning: ACLRAT takes a kind, a unit and one value")) << feeds.text;
  // A reference feature after a PTMEAS is RMEAS's (the message said "got 7 numbers").
  EXPECT_TRUE(feeds.has("6:25: error: a reference feature after the point belongs to RMEAS")) << feeds.text;
  EXPECT_TRUE(c.has("4:23: note: CLRSRF on a MEAS (RationalDMIS) is not applied")) << c.text;
  EXPECT_TRUE(
      c.has("6:23: warning: MEAS takes the feature type, F(label) and the number of points; the 2 parameters after "
            "them are ignored"))
      << c.text;
  // DMIS lets a nominal feature label be defined again: a note, not a warning.
  EXPECT_TRUE(c.has("8:1: note: F(P1) is defined again (first at line 2)")) << c.text;
  EXPECT_TRUE(
      c.has("9:1: warning: the DMIS statement EQUATE is not supported by metron and is skipped: the coordinate "
            "systems are not equated"))
      << c.text;
  EXPECT_EQ(c.warnings, 3U) << c.text;
  // A typographic quote copied from a document is named.
  const auto quote = check("DMISMN/\u2019EXAMPLE\u2019, 4.0\nENDFIL\n");
  EXPECT_TRUE(
      quote.has("1:8: error: expected a parameter after '/': \u2019 is a typographic quote; a DMIS string is "
                "quoted with ' (an apostrophe)"))
      << quote.text;
  // A size from a variable never assigned stops the run at the FEAT (it measured a 0 mm circle).
  const auto unassigned =
      run("DMISMN/'t', 5.0\nDECL/REAL, DD\nMODE/AUTO\nF(C1) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, DD\n"
          "MEAS/CIRCLE, F(C1), 4\nENDMES\nENDFIL\n");
  EXPECT_NE(unassigned.status, ExecStatus::Finished);
  EXPECT_NE(unassigned.diagnostics.find("4:1: error: the diameter of F(C1) is 0: it must be positive"),
            std::string::npos)
      << unassigned.diagnostics;
  // A hole the ball cannot enter is told before it is probed.
  const auto small =
      run("DMISMN/'t', 5.0\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
          "GOTO/40, 50, 60\nF(H) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, 3\n"
          "MEAS/CIRCLE, F(H), 3\n  PTMEAS/CART, 41.5, 50, 35, -1, 0, 0\n  PTMEAS/CART, 40, 51.5, 35, 0, -1, 0\n"
          "  PTMEAS/CART, 38.5, 50, 35, 1, 0, 0\nENDMES\nENDFIL\n");
  EXPECT_NE(small.diagnostics.find("6:1: warning: the ball of P4 (4.000 mm) is not smaller than F(H) (3.000 mm)"),
            std::string::npos)
      << small.diagnostics;
  // So is one whose ball is selected inside the block (the first sensor's was the only one judged).
  const auto switched = dry_run(
      "DMISMN/'t', 5.0\nS(P1) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 1.0\n"
      "S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P1)\n"
      "GOTO/40, 50, 60\nF(H) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, 3\n"
      "MEAS/CIRCLE, F(H), 3\n  PTMEAS/CART, 41.5, 50, 35, -1, 0, 0\n  SNSLCT/S(P4)\n"
      "  PTMEAS/CART, 40, 51.5, 35, 0, -1, 0\n  PTMEAS/CART, 38.5, 50, 35, 1, 0, 0\nENDMES\nENDFIL\n");
  ASSERT_EQ(switched.status, ExecStatus::Finished) << switched.diagnostics;
  EXPECT_NE(switched.diagnostics.find("the ball of P4 (4.000 mm) is not smaller than F(H) (3.000 mm)"),
            std::string::npos)
      << switched.diagnostics;
  EXPECT_EQ(switched.diagnostics.find("the ball of P1"), std::string::npos) << switched.diagnostics;
}

// OUTPUT/FA(x)[first,last] (MODUS): the feature is reported with its points first..last listed
// (compensated surface point, approach, distance from the fit) in the current frame. On
// perfect.json's BORE1 (20 mm at part 40, 50) the points are where the PTMEAS put them.
TEST(ShopPrograms, OutputListsAFeaturesPointRange) {
  const std::string head =
      "DMISMN/'points', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 60\n"
      "F(C) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, 20\nMEAS/CIRCLE, F(C), 4\n"
      "  PTMEAS/CART, 50, 50, 35, -1, 0, 0\n  PTMEAS/CART, 40, 60, 35, 0, -1, 0\n"
      "  PTMEAS/CART, 30, 50, 35, 1, 0, 0\n  PTMEAS/CART, 40, 40, 35, 0, 1, 0\nENDMES\n";
  const auto r = run(head +
                         "DECL/INTGR, N\nN = ASSIGN/3\nOUTPUT/FA(C)[2,N]\nOUTPUT/FA(C)[4]\nOUTPUT/FA(C)[3,9]\n"
                         "OUTPUT/FA(C)[3,2]\nOUTPUT/FA(C)[6,7]\nENDFIL\n",
                     source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::vector<const metron::runtime::FeatureReport*> reports;
  for (const auto& e : r.session->record().events)
    if (const auto* f = std::get_if<metron::runtime::FeatureReport>(&e)) reports.push_back(f);
  ASSERT_EQ(reports.size(), 5U);
  ASSERT_EQ(reports[0]->points.size(), 2U);
  EXPECT_EQ(reports[0]->points[0].index, 2);
  EXPECT_NEAR((reports[0]->points[0].surface_mm - metron::Vec3(40, 60, 35)).norm(), 0, 2e-3);
  EXPECT_NEAR((reports[0]->points[0].approach - metron::Vec3(0, -1, 0)).norm(), 0, 1e-6);
  EXPECT_NEAR((reports[0]->points[1].surface_mm - metron::Vec3(30, 50, 35)).norm(), 0, 2e-3);
  ASSERT_TRUE(reports[0]->points[1].residual_mm);
  EXPECT_NEAR(*reports[0]->points[1].residual_mm, 0, 2e-3);
  ASSERT_EQ(reports[1]->points.size(), 1U);
  EXPECT_EQ(reports[1]->points[0].index, 4);
  EXPECT_NEAR((reports[1]->points[0].surface_mm - metron::Vec3(40, 40, 35)).norm(), 0, 2e-3);
  // Beyond the points it has: listed as far as it goes, with a warning.
  ASSERT_EQ(reports[2]->points.size(), 2U);
  EXPECT_NE(r.diagnostics.find("FA(C)[3,9] asks for points 3 to 9; it has 4: points 3 to 4 are listed"),
            std::string::npos)
      << r.diagnostics;
  // A range backwards, or past the last point: nothing is listed, and the warning says so.
  EXPECT_TRUE(reports[3]->points.empty());
  EXPECT_TRUE(reports[4]->points.empty());
  EXPECT_NE(r.diagnostics.find("FA(C)[3,2] asks for points 3 to 2; it has 4: none is listed"), std::string::npos)
      << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("FA(C)[6,7] asks for points 6 to 7; it has 4: none is listed"), std::string::npos)
      << r.diagnostics;
  const std::string text = metron::runtime::format_feature_report(*reports[1]);
  EXPECT_NE(text.find("[4]"), std::string::npos) << text;
  // A point range on a tolerance, or outside OUTPUT, is an error.
  const auto bad = check(head + "T(D) = TOL/DIAM, -0.1, 0.1\nOUTPUT/FA(C), TA(D)[1,2]\nENDFIL\n");
  EXPECT_TRUE(bad.has("shop.dmi:13:") && bad.has("a point range TA(D)[...] is read only for a feature in OUTPUT"))
      << bad.text;
}

// An ARC measured in MODE/AUTO: its points lie within its span (they went round the whole circle,
// into the air beside a real arc). perfect.json's BORE1 (20 mm at part 40, 50) holds the arc, so
// each touched point shows where it was planned: angles from the part's X axis.
TEST(ShopPrograms, AnArcIsProbedWithinItsSpan) {
  const auto r =
      run("DMISMN/'arc', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "GOTO/40, 50, 60\nMODE/AUTO\nF(A) = FEAT/ARC, INNER, CART, 40, 50, 40, 0, 0, 1, 10, 30, 90\n"
          "MEAS/ARC, F(A), 4\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* f = r.session->runtime().find_feature("A");
  ASSERT_TRUE(f && f->actual);
  ASSERT_EQ(f->points.size(), 4U);
  std::vector<double> angles;
  for (const auto& p : f->points) {
    const metron::Vec3 s = p.surface_mm() - metron::Vec3(340, 250, 0);  // machine to part: the TRANS above
    angles.push_back(std::atan2(s.y(), s.x()) * 180 / std::numbers::pi);
  }
  const std::vector<double> expected = {41.25, 63.75, 86.25, 108.75};  // 30 + 90 (i + 0.5) / 4
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(angles[i], expected[i], 0.01) << i;
  EXPECT_NEAR(f->actual->diameter_mm, 20, 0.002);

  // RationalDMIS writes the direction the angles count from after them (12 numbers): here the
  // part's Y, so every point turns 90 deg on.
  const auto y =
      run("DMISMN/'arc', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "GOTO/40, 50, 60\nMODE/AUTO\nF(A) = FEAT/ARC, INNER, CART, 40, 50, 40, 0, 0, 1, 10, 30, 90, 0, 1, 0\n"
          "MEAS/ARC, F(A), 4\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(y.status, ExecStatus::Finished) << y.diagnostics;
  const auto* g = y.session->runtime().find_feature("A");
  ASSERT_TRUE(g && g->actual && g->points.size() == 4U);
  for (std::size_t i = 0; i < 4; ++i) {
    const metron::Vec3 s = g->points[i].surface_mm() - metron::Vec3(340, 250, 0);
    const double turned = std::remainder(std::atan2(s.y(), s.x()) * 180 / std::numbers::pi - (expected[i] + 90), 360.0);
    EXPECT_NEAR(turned, 0, 0.01) << i;
  }
  const auto bad =
      check("DMISMN/'arc', 5.0\nF(A) = FEAT/ARC, INNER, CART, 0, 0, 0, 0, 0, 1, 10, 30, 90, 1, 0\nENDFIL\n");
  EXPECT_TRUE(bad.has("FEAT/ARC expects 9 or 12 numbers (x,y,z,i,j,k,rad,ang1,ang2[,i2,j2,k2]), got 11")) << bad.text;
}

// FEAT/TORUS on programs/worlds/block_torus.json, planned by metron (MODE/AUTO): a ring standing
// on the top face and a round-bottomed groove cut into it, each machined off its nominal (the
// world's hidden deviations). The fit must find the machined torus; POS and PROFS are checked
// against values derived from the deviations by hand (for a torus moved by o and its tube grown
// by s, a surface point at tube direction n lies s/2 + o.n off the nominal surface, + out of the
// tube).
TEST(ShopPrograms, ToriAgainstTheMachinedRingAndGroove) {
  const std::string text =
      "DMISMN/'torus', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
      "S(P1) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 1.0\nSNSLCT/S(P1)\nMODE/AUTO\n"
      "F(RING) = FEAT/TORUS, OUTER, CART, 80, 30, 43, 0, 0, 1, 30, 6\nMEAS/TORUS, F(RING), 12\nENDMES\n"
      "F(GROOVE) = FEAT/TORUS, INNER, CART, 140, 18, 40, 0, 0, 1, 24, 8\nMEAS/TORUS, F(GROOVE), 12\nENDMES\n"
      "T(P) = TOL/POS, 3D, 0.05\nT(S) = TOL/PROFS, -0.02, 0.02\n"
      "OUTPUT/FA(RING), TA(P), TA(S)\nOUTPUT/FA(GROOVE), TA(P), TA(S)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_torus.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  constexpr double tol_mm = 1e-3;  // the probe's noise and pre-travel left after qualification
  const auto* ring = report(*r.session, "RING");
  ASSERT_TRUE(ring && ring->actual);
  EXPECT_EQ(ring->point_count, 12U);
  EXPECT_NEAR(ring->actual->position.x(), 80.03, tol_mm);
  EXPECT_NEAR(ring->actual->position.y(), 29.98, tol_mm);
  EXPECT_NEAR(ring->actual->position.z(), 43, tol_mm);
  EXPECT_NEAR(ring->actual->diameter_mm, 30, tol_mm);
  EXPECT_NEAR(ring->actual->minor_diameter_mm, 6.04, tol_mm);
  EXPECT_GT(ring->actual->direction.z(), 1 - 1e-6);
  const auto* groove = report(*r.session, "GROOVE");
  ASSERT_TRUE(groove && groove->actual);
  EXPECT_NEAR(groove->actual->position.x(), 140, tol_mm);
  EXPECT_NEAR(groove->actual->position.y(), 18, tol_mm);
  EXPECT_NEAR(groove->actual->position.z(), 39.98, tol_mm);
  EXPECT_NEAR(groove->actual->diameter_mm, 24, tol_mm);
  EXPECT_NEAR(groove->actual->minor_diameter_mm, 7.97, tol_mm);
  std::vector<const metron::runtime::ToleranceResult*> results;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) results.push_back(t);
  ASSERT_EQ(results.size(), 4U);
  EXPECT_NEAR(results[0]->value, 2 * std::hypot(0.03, 0.02), 2 * tol_mm);  // POS 3D of the ring
  EXPECT_FALSE(results[0]->in_tolerance);
  // The ring: 0.02 + 0.036 cos(v) cos(azimuth - that of the offset); its four equator points lie
  // 90 deg apart, so the largest is at least 0.02 + 0.036 cos 45 and at most 0.02 + 0.036.
  EXPECT_GT(results[1]->value, 0.02 + std::hypot(0.03, 0.02) * std::cos(std::numbers::pi / 4) - tol_mm);
  EXPECT_LT(results[1]->value, 0.02 + std::hypot(0.03, 0.02) + tol_mm);
  EXPECT_FALSE(results[1]->in_tolerance);
  EXPECT_NEAR(results[2]->value, 2 * 0.02, 2 * tol_mm);  // POS 3D of the groove
  EXPECT_TRUE(results[2]->in_tolerance);
  // The groove (+ toward the tube's centre): 0.015 + 0.02 sin v at the tube angles 200, 270 and
  // 340 deg; the largest is at 200 and 340 deg.
  EXPECT_NEAR(results[3]->value, 0.015 + 0.02 * std::sin(200 * std::numbers::pi / 180), tol_mm);
  EXPECT_TRUE(results[3]->in_tolerance);

  // A torus needs seven points; its tube must be thinner than its centre circle.
  const auto few =
      run("DMISMN/'torus', 5.0\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\n"
          "F(RING) = FEAT/TORUS, OUTER, CART, 80, 30, 43, 0, 0, 1, 30, 6\nMEAS/TORUS, F(RING), 6\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/block_torus.json");
  EXPECT_NE(few.diagnostics.find("run.dmi:5:"), std::string::npos) << few.diagnostics;
  const auto feat = [](const std::string& rest) {
    return check("DMISMN/'p', 5.0\nF(T) = FEAT/TORUS, " + rest + "\nENDFIL\n");
  };
  EXPECT_EQ(feat("OUTER, CART, 0, 0, 0, 0, 0, 1, 30, 6").errors, 0U);
  const auto fat = feat("OUTER, CART, 0, 0, 0, 0, 0, 1, 30, 30");
  EXPECT_TRUE(fat.has("shop.dmi:2:") &&
              fat.has("the tube's diameter 30 of F(T) is not less than its major diameter 30"))
      << fat.text;
  const auto arity = feat("INNER, CART, 0, 0, 0, 0, 0, 1, 30");
  EXPECT_TRUE(arity.has("FEAT/TORUS expects 8 numbers (x,y,z,i,j,k,majdiam,mindiam")) << arity.text;
  EXPECT_TRUE(feat("CART, 0, 0, 0, 0, 0, 1, 30, 6").has("expected INNER or OUTER after the feature type TORUS"));
}

// FEAT/ELLIPS and FEAT/RCTNGL on programs/worlds/block_ellipse.json, planned by metron (MODE/AUTO):
// an elliptic pocket, an elliptic boss and a rectangular pocket, each machined off its nominal
// (the world's hidden deviations). The fits must find the machined shapes; POS and PROFL are
// checked against values derived by hand: an ellipse moved by o, turned by w and with both
// semi-axes grown by d moves the point of parameter t (x = a cos t, y = b sin t) by
// d (cos t, sin t) + o + w (-y, x), whose part along the outward normal (b cos t, a sin t) / N is
// d (b cos^2 t + a sin^2 t) / N + o . n + w (a^2 - b^2) sin t cos t / N, to first order (+ out of
// the material: negated in a pocket).
double ellipse_profile_extreme(double a, double b, double grow, Eigen::Vector2d offset, double turn_deg,
                               double angle_deg, int points, bool inner) {
  const double angle = angle_deg * std::numbers::pi / 180;
  const Eigen::Vector2d u(std::cos(angle), std::sin(angle)), v(-u.y(), u.x());
  double extreme = 0;
  for (int i = 0; i < points; ++i) {
    const double t = 2 * std::numbers::pi * (i + 0.5) / points;  // where the plan probes (docs/language.md)
    const double norm = std::hypot(b * std::cos(t), a * std::sin(t));
    const Eigen::Vector2d n = (b * std::cos(t) * u + a * std::sin(t) * v) / norm;
    // A turn w about the centre moves the point by w (-y, x): along the normal w (a^2 - b^2) sin t cos t / N.
    const double turn = turn_deg * std::numbers::pi / 180 * (a * a - b * b) * std::sin(t) * std::cos(t) / norm;
    const double out =
        grow * (b * std::cos(t) * std::cos(t) + a * std::sin(t) * std::sin(t)) / norm + offset.dot(n) + turn;
    const double deviation = inner ? -out : out;
    if (std::abs(deviation) > std::abs(extreme)) extreme = deviation;
  }
  return extreme;
}

TEST(ShopPrograms, EllipsesAndRectanglesAgainstTheMachinedPocketsAndBoss) {
  const std::string text =
      "DMISMN/'ellipse', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
      "S(P1) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nSNSLCT/S(P1)\nMODE/AUTO\n"
      "F(POCKET) = FEAT/ELLIPS, INNER, CART, 95, 30, 40, 0, 0, 1, 0.9396926, 0.3420201, 0, 30, 16\n"
      "MEAS/ELLIPS, F(POCKET), 8\nENDMES\n"
      "F(EBOSS) = FEAT/ELLIPS, OUTER, CART, 30, 82, 52, 0, 0, 1, 1, 0, 0, 24, 14\nMEAS/ELLIPS, F(EBOSS), 10\nENDMES\n"
      "F(RECT) = FEAT/RCTNGL, INNER, CART, 145, 50, 40, 0, 0, 1, 0, 1, 0, 20, 12, 10\nMEAS/RCTNGL, F(RECT), 8\nENDMES\n"
      "T(P) = TOL/POS, 2D, 0.05\nT(L) = TOL/PROFL, -0.02, 0.02\n"
      "DECL/REAL, V1\nV1 = VALUE/FA(POCKET), SIZE, 2\n"
      "OUTPUT/FA(POCKET), TA(P), TA(L)\nOUTPUT/FA(EBOSS), TA(P), TA(L)\nOUTPUT/FA(RECT), TA(P)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_ellipse.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  constexpr double tol_mm = 1e-3;  // the probe's noise and pre-travel left after qualification
  const auto* pocket = report(*r.session, "POCKET");
  ASSERT_TRUE(pocket && pocket->actual);
  EXPECT_EQ(pocket->point_count, 8U);
  EXPECT_NEAR(pocket->actual->position.x(), 95.025, tol_mm);
  EXPECT_NEAR(pocket->actual->position.y(), 29.985, tol_mm);
  EXPECT_NEAR(pocket->actual->diameter_mm, 30.03, tol_mm);
  EXPECT_NEAR(pocket->actual->minor_diameter_mm, 16.03, tol_mm);
  EXPECT_NEAR(std::atan2(pocket->actual->slot_axis.y(), pocket->actual->slot_axis.x()) * 180 / std::numbers::pi, 20.3,
              0.01);
  const auto* boss = report(*r.session, "EBOSS");
  ASSERT_TRUE(boss && boss->actual);
  EXPECT_NEAR(boss->actual->position.x(), 29.98, tol_mm);
  EXPECT_NEAR(boss->actual->position.y(), 82.01, tol_mm);
  EXPECT_NEAR(boss->actual->diameter_mm, 23.98, tol_mm);
  EXPECT_NEAR(boss->actual->minor_diameter_mm, 13.98, tol_mm);
  // RCTNGL: a CPARLN with FLAT ends, its east wall 0.02 out.
  const auto* rect = report(*r.session, "RECT");
  ASSERT_TRUE(rect && rect->actual);
  EXPECT_EQ(rect->actual->type, metron::runtime::FeatureType::ClosedSlot);
  EXPECT_EQ(rect->actual->slot_ends, metron::runtime::SlotEnds::Flat);
  EXPECT_NEAR(rect->actual->position.x(), 145.01, tol_mm);
  EXPECT_NEAR(rect->actual->position.y(), 50, tol_mm);
  EXPECT_NEAR(rect->actual->width_mm, 12.02, tol_mm);
  EXPECT_NEAR(rect->actual->length_mm, 20, tol_mm);
  std::vector<const metron::runtime::ToleranceResult*> results;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) results.push_back(t);
  ASSERT_EQ(results.size(), 5U);
  EXPECT_NEAR(results[0]->value, 2 * std::hypot(0.025, 0.015), 2 * tol_mm);  // POS 2D of the pocket
  EXPECT_FALSE(results[0]->in_tolerance);
  EXPECT_NEAR(results[1]->value, ellipse_profile_extreme(15, 8, 0.015, {0.025, -0.015}, 0.3, 20, 8, true), tol_mm);
  EXPECT_NEAR(results[2]->value, 2 * std::hypot(0.02, 0.01), 2 * tol_mm);  // POS 2D of the boss
  EXPECT_TRUE(results[2]->in_tolerance);
  EXPECT_NEAR(results[3]->value, ellipse_profile_extreme(12, 7, -0.01, {-0.02, 0.01}, 0, 0, 10, false), tol_mm);
  EXPECT_NEAR(results[4]->value, 2 * 0.01, 2 * tol_mm);  // POS 2D of the rectangle
  EXPECT_NE(r.diagnostics.find("FEAT/RCTNGL is measured and reported as a CPARLN with FLAT ends"), std::string::npos)
      << r.diagnostics;

  // An ellipse needs five points.
  const auto few =
      run("DMISMN/'e', 5.0\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\n"
          "F(E) = FEAT/ELLIPS, INNER, CART, 95, 30, 40, 0, 0, 1, 0.9396926, 0.3420201, 0, 30, 16\n"
          "MEAS/ELLIPS, F(E), 4\nENDMES\nENDFIL\n",
          source_dir / "programs/worlds/block_ellipse.json");
  EXPECT_NE(few.status, ExecStatus::Finished);
  EXPECT_NE(few.diagnostics.find("run.dmi:5:"), std::string::npos) << few.diagnostics;
  // check: the numbers of ELLIPS and RCTNGL.
  const auto feat = [](const std::string& rest) {
    return check("DMISMN/'p', 5.0\nF(E) = FEAT/" + rest + "\nENDFIL\n");
  };
  EXPECT_EQ(feat("ELLIPS, OUTER, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30, 16").errors, 0U);
  const auto swapped = feat("ELLIPS, OUTER, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 16, 30");
  EXPECT_TRUE(swapped.has("shop.dmi:2:") &&
              swapped.has("the minor diameter 30 of F(E) is more than its major diameter 16"))
      << swapped.text;
  const auto slanted = feat("ELLIPS, INNER, CART, 0, 0, 0, 0, 0, 1, 1, 0, 1, 30, 16");
  EXPECT_TRUE(slanted.has("the major axis i2,j2,k2 of F(E) is not perpendicular")) << slanted.text;
  EXPECT_TRUE(feat("ELLIPS, INNER, CART, 0, 0, 0, 0, 0, 1, 30, 16").has("FEAT/ELLIPS expects 11 numbers")) << "arity";
  EXPECT_EQ(feat("RCTNGL, INNER, CART, 0, 0, 0, 0, 0, 1, 0, 1, 0, 20, 12").errors, 0U);
  EXPECT_TRUE(feat("RCTNGL, INNER, CART, 0, 0, 0, 0, 0, 1, 20, 12")
                  .has("FEAT/RCTNGL expects INNER or OUTER, CART or POL and 11 or 12"));
  const auto mismatch = check(
      "DMISMN/'p', 5.0\nF(E) = FEAT/ELLIPS, INNER, CART, 0, 0, 0, 0, 0, 1, 1, 0, 0, 30, 16\n"
      "MEAS/CIRCLE, F(E), 8\nENDMES\nENDFIL\n");
  EXPECT_TRUE(mismatch.has("MEAS/CIRCLE on F(E), which is FEAT/ELLIPS")) << mismatch.text;
}

// FEAT/GSURF and GCURVE: features known only by the points a program probes on them (CAMIO and
// PC-DMIS export free-form and edge inspections so). Each point is judged along its own PTMEAS
// normal. The truth (programs/worlds/block_width.json): TOP is where it was designed, RIGHT
// lies 0.03 mm and BACK 0.015 mm out of the material.
TEST(ShopPrograms, GenericSurfacePointsAreJudgedAlongTheirOwnNormals) {
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/100, 50, 60\n"
      "F(SKIN) = FEAT/GSURF\nMEAS/GSURF, F(SKIN), 5\n"
      "  PTMEAS/CART, 100, 50, 40, 0, 0, 1\n  PTMEAS/CART, 100, 20, 40, 0, 0, 1\n"
      "  GOTO/175, 50, 60\n  GOTO/175, 50, 20\n  PTMEAS/CART, 160, 50, 20, 1, 0, 0\n  PTMEAS/CART, 160, 80, 30, 1, 0, "
      "0\n"
      "  GOTO/175, 80, 60\n  GOTO/120, 115, 60\n  GOTO/120, 115, 20\n  PTMEAS/CART, 120, 100, 20, 0, 1, 0\n"
      "  GOTO/120, 115, 60\nENDMES\n"
      "F(EDGE) = FEAT/GCURVE, CART, 60, 50, 40, 0, 1, 0\nMEAS/GCURVE, F(EDGE), 3\n"
      "  PTMEAS/CART, 60, 20, 40, 0, 0, 1\n  PTMEAS/CART, 60, 50, 40, 0, 0, 1\n  PTMEAS/CART, 60, 80, 40, 0, 0, "
      "1\nENDMES\n"
      "T(SURF) = TOL/PROFS, -0.02, 0.02\nT(LINE) = TOL/PROFL, -0.005, 0.005\nT(ZONE) = TOL/PROFS, 0.04\n"
      "OUTPUT/FA(SKIN), TA(SURF), TA(ZONE)\nOUTPUT/FA(EDGE), TA(LINE)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_width.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* skin = report(*r.session, "SKIN");
  ASSERT_TRUE(skin && skin->actual);
  EXPECT_EQ(skin->point_count, 5U);
  const auto* surf = tolerance(*r.session, "SURF");
  ASSERT_TRUE(surf);
  EXPECT_NEAR(surf->value, 0.03, 1e-3);  // RIGHT, the farthest out
  EXPECT_FALSE(surf->in_tolerance);
  // TOP, where it was designed: its points deviate by the probe's noise only.
  EXPECT_TRUE(surf->note.find("min +0.000") != std::string::npos || surf->note.find("min -0.000") != std::string::npos)
      << surf->note;
  // One number (a shop's short form) is a zone of that width centred on the profile, told once.
  const auto* zone = tolerance(*r.session, "ZONE");
  ASSERT_TRUE(zone);
  EXPECT_DOUBLE_EQ(zone->value, surf->value);
  EXPECT_DOUBLE_EQ(zone->lower, surf->lower);
  EXPECT_DOUBLE_EQ(zone->upper, surf->upper);
  EXPECT_NEAR(zone->upper, 0.02, 1e-12);
  EXPECT_TRUE(check(text).has("the one number is read as a zone of that width centred on the nominal profile"))
      << check(text).text;
  EXPECT_TRUE(check("DMISMN/'p', 5.0\nF(S)=FEAT/GSURF\nT(Z)=TOL/PROFS,-0.04\nENDFIL\n")
                  .has("a tolerance zone must not be negative"));
  const auto* line = tolerance(*r.session, "LINE");
  ASSERT_TRUE(line);
  EXPECT_NEAR(line->value, 0.0, 1e-3);
  EXPECT_TRUE(line->in_tolerance);

  // An EDGEPT is measured as a point on its surface: the TOP face beside the RIGHT edge, where
  // it was designed.
  const auto edge =
      run("DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "GOTO/155, 50, 60\nF(E1) = FEAT/EDGEPT, CART, 155, 50, 40, 0, 0, 1, 1, 0, 0\n"
          "MEAS/EDGEPT, F(E1), 1\n  PTMEAS/CART, 155, 50, 40, 0, 0, 1\nENDMES\nOUTPUT/FA(E1)\nENDFIL\n",
          source_dir / "programs/worlds/block_width.json");
  ASSERT_EQ(edge.status, ExecStatus::Finished) << edge.diagnostics;
  const auto* e1 = report(*edge.session, "E1");
  ASSERT_TRUE(e1 && e1->actual);
  EXPECT_NEAR(e1->actual->position.z(), 40.0, 1e-3);
  EXPECT_NE(edge.diagnostics.find("FEAT/EDGEPT is measured as a POINT"), std::string::npos) << edge.diagnostics;

  // check: a GSURF takes no numbers or six; PROFS is its tolerance, DIAM is not.
  const auto c = check("DMISMN/'p', 5.0\nF(S1) = FEAT/GSURF\nF(S2) = FEAT/GSURF, CART, 1, 2, 3\nENDFIL\n");
  EXPECT_EQ(c.errors, 1U) << c.text;
  EXPECT_TRUE(c.has("shop.dmi:3:") && c.has("FEAT/GSURF expects")) << c.text;
}

// DATSET/FA(x),... (CAMIO and PC-DMIS write the feature in place of a datum label): the same frame
// as DATDEF + DATSET/DAT. Truth: TOP is the plane z = 40 of the part, so after the alignment the
// bottom of BORE1 (z = 15) is at z = -25.
TEST(ShopPrograms, DatsetWithAFeatureInPlaceOfADatum) {
  const auto program = [](const std::string& datset) {
    return "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
           "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/100, 50, 60\n"
           "F(TOPPL) = FEAT/PLANE, CART, 100, 40, 40, 0, 0, 1\nMEAS/PLANE, F(TOPPL), 3\n"
           "  PTMEAS/CART, 100, 50, 40, 0, 0, 1\n  PTMEAS/CART, 100, 20, 40, 0, 0, 1\n  PTMEAS/CART, 60, 40, 40, 0, 0, "
           "1\n"
           "  GOTO/60, 40, 60\nENDMES\nDATDEF/FA(TOPPL), DAT(A)\n" +
           datset +
           "GOTO/40, 50, 20\nF(FLOOR) = FEAT/POINT, CART, 40, 50, -25, 0, 0, 1\nMEAS/POINT, F(FLOOR), 1\n"
           "  PTMEAS/CART, 40, 50, -25, 0, 0, 1\nENDMES\nGOTO/40, 50, 20\nOUTPUT/FA(FLOOR)\nENDFIL\n";
  };
  // TOP of block_deviations is tilted 0.05 deg about x through its point (80, 50, 40): its actual,
  // not its nominal, must set the frame (the nominal moves FLOOR by about 0.6 um: caught below).
  const fs::path world = source_dir / "programs/worlds/block_deviations.json";
  const auto by_feature = run(program("D(A1) = DATSET/FA(TOPPL), ZDIR, ZORIG\n"), world);
  const auto by_datum = run(program("D(A1) = DATSET/DAT(A), ZDIR, ZORIG\n"), world);
  ASSERT_EQ(by_feature.status, ExecStatus::Finished) << by_feature.diagnostics;
  ASSERT_EQ(by_datum.status, ExecStatus::Finished) << by_datum.diagnostics;
  const auto* f = report(*by_feature.session, "FLOOR");
  const auto* d = report(*by_datum.session, "FLOOR");
  ASSERT_TRUE(f && f->actual && d && d->actual);
  EXPECT_NEAR(f->actual->position.z(), -25.0, 2e-3);
  EXPECT_NEAR(f->actual->position.z(), d->actual->position.z(), 1e-9);
  const auto before = check("DMISMN/'p', 5.0\nD(A1) = DATSET/ZDIR, FA(X)\nENDFIL\n");
  EXPECT_TRUE(before.has("expected DAT(label) or FA(label) before ZDIR")) << before.text;
}

// UNITS/INCH and DECPL: the report and the DMIS output statement are in the program's units with
// the decimals DECPL asks for; the truth is the world's 20 mm bore at part (40, 50, 30) mm.
// EVAL/FA(x),TA(t) evaluates a tolerance and keeps the result without reporting it; a later
// OUTPUT/TA(t) alone reports what it found (DMIS 5.x EVAL). block_deviations machines BORE1
// 20.012 (its hidden truth): the kept DIAM value is +0.012, OUT of +-0.005, reported once.
// The lengths in a tolerance's note are in the program's units too: block_deviations machines
// BORE1 20.012 mm; its MMC bonus note, output under UNITS/INCH, gives the nominal 20 mm as
// 0.78740 (20 / 25.4, INCH's 5 decimals) and the actual as 0.78787.
TEST(ShopPrograms, ToleranceNotesAreInTheProgramsUnits) {
  const std::string text =
      "DMISMN/'inch', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 8\nENDMES\n"
      "T(P) = TOL/POS, 2D, 0.05, MMC\nUNITS/INCH, ANGDEC\nOUTPUT/FA(BORE1), TA(P)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/block_deviations.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* p = tolerance(*r.session, "P");
  ASSERT_NE(p, nullptr);
  EXPECT_NE(p->note.find("nominal diameter 0.78740"), std::string::npos) << p->note;
  EXPECT_NE(p->note.find("actual diameter 0.7878"), std::string::npos) << p->note;
}

TEST(ShopPrograms, EvalKeepsAToleranceResultForALaterOutput) {
  const std::string head =
      "DMISMN/'eval', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 8\nENDMES\n"
      "T(D) = TOL/DIAM, -0.005, 0.005\n";
  const auto r = run(head + "EVAL/FA(BORE1), TA(D)\nTEXT/OPER, 'between'\nOUTPUT/TA(D)\nENDFIL\n",
                     source_dir / "programs/worlds/block_deviations.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::size_t results = 0, text_at = 0, result_at = 0, k = 0;
  for (const auto& e : r.session->record().events) {
    ++k;
    if (std::holds_alternative<metron::runtime::ToleranceResult>(e)) ++results, result_at = k;
    if (std::holds_alternative<metron::runtime::TextReport>(e)) text_at = k;
  }
  EXPECT_EQ(results, 1u);         // EVAL reports nothing, OUTPUT/TA(D) once
  EXPECT_GT(result_at, text_at);  // ... and the report comes with the OUTPUT
  const auto* d = tolerance(*r.session, "D");
  ASSERT_NE(d, nullptr);
  EXPECT_NEAR(d->value, 0.012, 0.002);
  EXPECT_FALSE(d->in_tolerance);
  // A tolerance alone that nothing evaluated, and an EVAL without a tolerance, are errors.
  const Checked alone = check(head + "OUTPUT/TA(D)\nENDFIL\n");
  EXPECT_TRUE(alone.has("shop.dmi:12:8: error: T(D) is output without a feature")) << alone.text;
  const Checked no_tol = check(head + "EVAL/FA(BORE1)\nENDFIL\n");
  EXPECT_TRUE(no_tol.has("shop.dmi:12:1: error: EVAL evaluates tolerances")) << no_tol.text;
  const Checked ok = check(head + "EVAL/FA(BORE1), TA(D)\nOUTPUT/TA(D)\nENDFIL\n");
  EXPECT_EQ(ok.errors + ok.warnings, 0u) << ok.text;
}

// VALUE/FA(x),SIZE and VALUE/TA(t),ACT|DEV|AMT|INTOL|OUTOL: what a program reads back to decide
// (DMIS 5 VALUE; SIR 97-8 for the tolerance words). block_deviations.json hides BORE1 0.012 mm
// oversize: the expected values are that truth, not metron's output.
TEST(ShopPrograms, ValueReadsAFeaturesSizeAndAToleranceResult) {
  const std::string head =
      "DMISMN/'value', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, "
      "4.0\nSNSLCT/S(P4)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 8\nENDMES\n"
      "T(D) = TOL/DIAM, -0.005, 0.005\nDECL/REAL, SZ, NOM, ACTV, DEVV, AMTV\nDECL/BOOL, IN, OUT\n";
  const std::string reads =
      "SZ = VALUE/FA(BORE1), SIZE\nNOM = VALUE/F(BORE1), SIZE, 1\nOUTPUT/FA(BORE1), TA(D)\n"
      "ACTV = VALUE/TA(D), ACT\nDEVV = VALUE/TA(D), DEV\nAMTV = VALUE/TA(D), AMT\n"
      "IN = VALUE/TA(D), INTOL\nOUT = VALUE/TA(D), OUTOL\n";
  const auto r = run(head + reads + "UNITS/INCH, ANGDEC\nSZ = VALUE/FA(BORE1), SIZE\nENDFIL\n",
                     source_dir / "programs/worlds/block_deviations.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  auto& vm = r.session->interpreter();
  const auto num = [&](const char* v) { return vm.variable(v).value().number; };
  EXPECT_NEAR(num("NOM"), 20.0, 1e-12);
  EXPECT_NEAR(num("ACTV"), 20.012, 0.002);
  EXPECT_NEAR(num("DEVV"), 0.012, 0.002);
  EXPECT_NEAR(num("AMTV"), 0.012 - 0.005, 0.002);
  EXPECT_NEAR(num("DEVV") - num("AMTV"), 0.005, 1e-12);  // beyond the upper limit by AMT
  EXPECT_FALSE(vm.variable("IN").value().boolean);
  EXPECT_TRUE(vm.variable("OUT").value().boolean);
  EXPECT_NEAR(num("SZ"), num("ACTV") / 25.4, 1e-12);  // in the program's units at the VALUE
  // Forms and order: a size a feature has not, a tolerance read before any evaluation, a word
  // that is no VALUE word, a VALUE form metron does not answer.
  const auto no_length =
      run(head + "SZ = VALUE/FA(BORE1), SIZE, 2\nENDFIL\n", source_dir / "programs/worlds/block_deviations.json");
  EXPECT_TRUE(no_length.diagnostics.find("VALUE/FA(BORE1),SIZE,2: a CIRCLE has no size 2") != std::string::npos)
      << no_length.diagnostics;
  const auto early =
      run(head + "ACTV = VALUE/TA(D), ACT\nENDFIL\n", source_dir / "programs/worlds/block_deviations.json");
  EXPECT_TRUE(early.diagnostics.find("VALUE/TA(D) before T(D) was evaluated") != std::string::npos)
      << early.diagnostics;
  // Another word of a feature may be a vendor's or a later DMIS's: a warning read leniently, an
  // error strictly; a tolerance's words are DMIS's own.
  const std::string words =
      head + "SZ = VALUE/FA(BORE1), DIAM\nACTV = VALUE/TA(NONE), ACT\nSZ = VALUE/TA(D), DIAM\nENDFIL\n";
  const Checked bad = check(words);
  EXPECT_TRUE(bad.has("warning: VALUE/FA(x),DIAM is not answered")) << bad.text;
  EXPECT_TRUE(bad.has("tolerance T(NONE) is not defined")) << bad.text;
  EXPECT_TRUE(bad.has("VALUE/TA(t),DIAM: expected ACT, DEV, AMT, INTOL or OUTOL")) << bad.text;
  EXPECT_EQ(bad.errors, 2u) << bad.text;
  EXPECT_TRUE(check(words, true).has("error: VALUE/FA(x),DIAM: expected SIZE"));
  const Checked other = check(head + "SZ = VALUE/GEOALG, CIRCLE\nENDFIL\n");
  EXPECT_EQ(other.errors, 0u) << other.text;
  EXPECT_TRUE(other.has("this VALUE form is not answered")) << other.text;
}

// TOL/ANGL,lo,up: a cone's included angle against its nominal (it was left out of OUTPUT). A
// stated actual of 91.2 deg against 90 makes the deviation analytic; the default world's
// countersink is a true 90 deg cone (CONE1, half angle 45), measured.
TEST(ShopPrograms, AnglJudgesAConesIncludedAngle) {
  const auto stated =
      run("DMISMN/'angl', 5.0\nF(C)=FEAT/CONE,INNER,CART,0,0,0,0,0,1,90\n"
          "FA(C)=FEAT/CONE,INNER,CART,0,0,0,0,0,1,91.2\nT(A)=TOL/ANGL,-0.5,0.5\n"
          "UNITS/MM,ANGRAD\nT(R)=TOL/ANGL,-0.05,0.05\nDECL/REAL,DEV\n"
          "OUTPUT/FA(C),TA(A),TA(R)\nDEV=VALUE/TA(R),DEV\nENDFIL\n");
  ASSERT_EQ(stated.status, ExecStatus::Finished) << stated.diagnostics;
  const auto* a = tolerance(*stated.session, "A");
  ASSERT_NE(a, nullptr);
  EXPECT_NEAR(a->value, 1.2, 1e-9);
  EXPECT_FALSE(a->in_tolerance);
  const auto* r = tolerance(*stated.session, "R");  // +-0.05 rad is +-2.86 deg: in
  ASSERT_NE(r, nullptr);
  EXPECT_NEAR(r->upper, 0.05 * 180 / M_PI, 1e-9);
  EXPECT_TRUE(r->in_tolerance);
  EXPECT_NEAR(stated.session->interpreter().variable("DEV")->number, 1.2 * M_PI / 180, 1e-12);  // in ANGRAD
  const auto measured =
      run("DMISMN/'angl', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
          "SNSLCT/S(P4)\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\nGOTO/40, 20, 80\n"
          "F(CSINK) = FEAT/CONE, INNER, CART, 40, 20, 32, 0, 0, 1, 90, 8\nMEAS/CONE, F(CSINK), 8\nENDMES\n"
          "T(A)=TOL/ANGL,-0.05,0.05\nOUTPUT/FA(CSINK),TA(A)\nENDFIL\n");
  ASSERT_EQ(measured.status, ExecStatus::Finished) << measured.diagnostics;
  const auto* m = tolerance(*measured.session, "A");
  ASSERT_NE(m, nullptr);
  EXPECT_NEAR(m->value, 0.0, 0.01);
  EXPECT_TRUE(m->in_tolerance);
  const auto circle = check(
      "DMISMN/'angl', 5.0\nF(B)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nT(A)=TOL/ANGL,-0.5,0.5\n"
      "OUTPUT/FA(B),TA(A)\nT(W)=TOL/ANGL,0.5,-0.5\nENDFIL\n");
  EXPECT_TRUE(circle.has("TOL/ANGL of T(A) does not apply to a CIRCLE")) << circle.text;
  EXPECT_TRUE(circle.has("the lower tolerance 0.5 is above the upper tolerance -0.5")) << circle.text;
}

// TOL/COMPOS: a pattern of four holes 40 mm apart, moved as a group by (0.2, 0.1) mm and turned
// 0.002 rad about its centre, two holes off by (+-0.01, +-0.01) along their diagonal. The
// expected zones are analytic: PATERN (datums A, B, C locate) sees every motion; FEATUR with
// only A may translate and turn the pattern, and the individual offsets have no mean and no
// moment, so they remain exactly: 2 |(0.01, 0.01)|; FEATUR with A and B may not turn it, so the
// turn remains (translation only: the turn's displacements have no mean on this square).
TEST(ShopPrograms, CompositePositionJudgesThePatternAndItsFeatures) {
  const std::string text =
      "DMISMN/'compos', 5.0\n"
      "F(A)=FEAT/PLANE,CART,0,0,0,0,0,1\nFA(A)=FEAT/PLANE,CART,0,0,0,0,0,1\nDATDEF/FA(A),DAT(A)\n"
      "F(B)=FEAT/PLANE,CART,-50,0,0,-1,0,0\nFA(B)=FEAT/PLANE,CART,-50,0,0,-1,0,0\nDATDEF/FA(B),DAT(B)\n"
      "F(C)=FEAT/PLANE,CART,0,-50,0,0,-1,0\nFA(C)=FEAT/PLANE,CART,0,-50,0,0,-1,0\nDATDEF/FA(C),DAT(C)\n"
      "F(H1)=FEAT/CIRCLE,INNER,CART,20,20,0,0,0,1,10\nFA(H1)=FEAT/"
      "CIRCLE,INNER,CART,20.169960026680,20.149959973347,0,0,0,1,10\n"
      "F(H2)=FEAT/CIRCLE,INNER,CART,-20,20,0,0,0,1,10\nFA(H2)=FEAT/"
      "CIRCLE,INNER,CART,-19.839959973347,20.059960026680,0,0,0,1,10\n"
      "F(H3)=FEAT/CIRCLE,INNER,CART,-20,-20,0,0,0,1,10\nFA(H3)=FEAT/"
      "CIRCLE,INNER,CART,-19.769960026680,-19.949959973347,0,0,0,1,10\n"
      "F(H4)=FEAT/CIRCLE,INNER,CART,20,-20,0,0,0,1,10\nFA(H4)=FEAT/"
      "CIRCLE,INNER,CART,20.239959973347,-19.859960026680,0,0,0,1,10\n"
      "T(CP)=TOL/COMPOS,PATERN,0.5,DAT(A),DAT(B),DAT(C),FEATUR,0.05,DAT(A)\n"
      "T(CQ)=TOL/COMPOS,2D,PATERN,0.5,MMC,DAT(A),DAT(B),DAT(C),FEATUR,0.05,DAT(A),DAT(B)\n"
      "DECL/REAL,PAT,FEA\n"
      "OUTPUT/FA(H1),FA(H2),FA(H3),FA(H4),TA(CP),TA(CQ)\nPAT=VALUE/TA(CP),ACT,1\nFEA=VALUE/TA(CP),ACT,2\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::vector<const metron::runtime::ToleranceResult*> tiers;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) tiers.push_back(t);
  ASSERT_EQ(tiers.size(), 4u);
  const Eigen::Vector2d shift(0.2, 0.1);
  const double turn = 0.002;
  const Eigen::Vector2d p[4] = {Eigen::Vector2d(20, 20), Eigen::Vector2d(-20, 20), Eigen::Vector2d(-20, -20),
                                Eigen::Vector2d(20, -20)};
  const Eigen::Vector2d e[4] = {Eigen::Vector2d(0.01, 0.01), Eigen::Vector2d(0, 0), Eigen::Vector2d(-0.01, -0.01),
                                Eigen::Vector2d(0, 0)};
  double pattern = 0, turned = 0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d rotated = Eigen::Rotation2Dd(turn) * p[i] - p[i];
    pattern = std::max(pattern, 2 * (shift + rotated + e[i]).norm());
    turned = std::max(turned, 2 * (rotated + e[i]).norm());
  }
  EXPECT_EQ(tiers[0]->tier, "PATERN");
  EXPECT_NEAR(tiers[0]->value, pattern, 1e-9);
  EXPECT_FALSE(tiers[0]->in_tolerance);  // about 0.55 against 0.5
  // FEATUR with A: the closed-form 2-D Procrustes fit (rotation angle atan2 of the summed cross
  // and dot products of the centred point sets) of the actual centres onto the nominal ones.
  Eigen::Vector2d q[4], qc(0, 0);
  for (int i = 0; i < 4; ++i) qc += (q[i] = shift + Eigen::Rotation2Dd(turn) * p[i] + e[i]) / 4;
  double cross = 0, dot = 0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d a = q[i] - qc;
    cross += a.x() * p[i].y() - a.y() * p[i].x();
    dot += a.dot(p[i]);
  }
  double procrustes = 0;
  for (int i = 0; i < 4; ++i)
    procrustes = std::max(procrustes, 2 * (Eigen::Rotation2Dd(std::atan2(cross, dot)) * (q[i] - qc) - p[i]).norm());
  EXPECT_NEAR(procrustes, 2 * std::hypot(0.01, 0.01), 1e-7);  // the offsets remain, to second order
  EXPECT_EQ(tiers[1]->tier, "FEATUR");
  EXPECT_NEAR(tiers[1]->value, procrustes, 1e-12);
  EXPECT_TRUE(tiers[1]->in_tolerance);
  EXPECT_EQ(tiers[3]->tier, "FEATUR");
  EXPECT_NEAR(tiers[3]->value, turned, 1e-9);
  EXPECT_FALSE(tiers[3]->in_tolerance);
  EXPECT_NEAR(r.session->interpreter().variable("PAT")->number, pattern, 1e-9);
  EXPECT_NEAR(r.session->interpreter().variable("FEA")->number, procrustes, 1e-12);
  // Forms: a tier without exactly one zone is an error; another layout is left out with a warning.
  const auto two = check("DMISMN/'c', 5.0\nT(X)=TOL/COMPOS,PATERN,0.5,0.2,FEATUR,0.05\nENDFIL\n");
  EXPECT_TRUE(two.has("each tier of TOL/COMPOS takes one zone, got 2 in the PATERN tier")) << two.text;
  const auto other = check("DMISMN/'c', 5.0\nT(X)=TOL/COMPOS,POS,0.5,0.05\nENDFIL\n");
  EXPECT_EQ(other.errors, 0u) << other.text;
  EXPECT_TRUE(other.has("tolerance type COMPOS is not evaluated")) << other.text;
}

TEST(ShopPrograms, ReportsAreInTheProgramsUnitsWithDecpl) {
  const auto inch = [](double mm) { return fmt::format("{:.6f}", mm / 25.4); };
  const std::string text =
      "DMISMN/'inch', 5.0\nUNITS/INCH, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, " +
      inch(300) + ", YORIG, " + inch(200) + ", ZORIG, 0\nGOTO/" + inch(40) + ", " + inch(50) + ", " + inch(80) +
      "\nF(BORE1) = FEAT/CIRCLE, INNER, CART, " + inch(40) + ", " + inch(50) + ", " + inch(30) + ", 0, 0, 1, " +
      inch(20) +
      "\nT(D1) = TOL/DIAM, -0.0005, 0.0005\nMEAS/CIRCLE, F(BORE1), 4\nENDMES\n"
      "OUTPUT/FA(BORE1), TA(D1)\nDECPL/ALL, 3\nOUTPUT/FA(BORE1), TA(D1)\nENDFIL\n";
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::vector<metron::runtime::FeatureReport> reports;
  std::vector<metron::runtime::ToleranceResult> results;
  for (const auto& e : r.session->record().events) {
    if (const auto* f = std::get_if<metron::runtime::FeatureReport>(&e)) reports.push_back(*f);
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) results.push_back(*t);
  }
  ASSERT_EQ(reports.size(), 2u);
  ASSERT_EQ(results.size(), 2u);
  // The record stays in mm (results.json's unit); the report converts.
  ASSERT_TRUE(reports[0].actual);
  EXPECT_NEAR(reports[0].actual->diameter_mm, 20.0, 2e-3);
  const std::string first = metron::runtime::format_feature_report(reports[0]);
  EXPECT_NE(first.find("frame PART, INCH, ANGDEC"), std::string::npos) << first;
  EXPECT_NE(first.find("  D            0.78740"), std::string::npos) << first;  // 20 mm, 5 decimals in inch
  EXPECT_NE(first.find("  X            1.57480"), std::string::npos) << first;
  const std::string second = metron::runtime::format_feature_report(reports[1]);
  EXPECT_NE(second.find("  D              0.787"), std::string::npos) << second;  // DECPL/ALL,3
  const std::string line = metron::runtime::dmis_feature_line(reports[1]);
  // Direction cosines keep their 5 decimals (DECPL is for lengths and angles).
  EXPECT_NE(line.find("1.575, 1.969, 1.181, 0.00000, 0.00000, 1.00000, 0.787"), std::string::npos) << line;
  EXPECT_TRUE(results[0].in_tolerance);
  const std::string tol = metron::runtime::format_tolerance_result(results[0]);
  EXPECT_NE(tol.find("limits [-0.00050, +0.00050]"), std::string::npos) << tol;
  EXPECT_NE(tol.find("(INCH, ANGDEC)"), std::string::npos) << tol;
}

// OPEN ... INPUT, READ and EOF read a data file beside the program; the date and time come from
// the run's clock (SOURCE_DATE_EPOCH fixes its start), SELAPSETIME from the simulated machine.
TEST(ShopPrograms, InputFilesAndTheIntrinsicsOfTheRun) {
  write("offsets.txt", "P1, 1.5, 2.5\nP2 3 4\n'A B',5,6\n");
  const std::string text =
      "DMISMN/'p', 5.0\nDECL/CHAR,20,NAME\nDECL/REAL,X,Y,ET\nDECL/INTGR,K\nDECL/CHAR,30,WHEN\n"
      "DID(IN1)=DEVICE/STOR,'offsets.txt'\nOPEN/DID(IN1),DIRECT,INPUT\nK=ASSIGN/0\n"
      "(NEXT)\nIF/(.NOT.EOF(DID(IN1)))\n  READ/DID(IN1),NAME,X,Y\n  TEXT/OPER,CONCAT(NAME,'=',STR(X+Y,1))\n"
      "  K=ASSIGN/K+1\n  JUMPTO/(NEXT)\nENDIF\nCLOSE/DID(IN1)\nTEXT/OPER,STR(K)\n"
      "WHEN=ASSIGN/SDATETIME()\nTEXT/OPER,WHEN\nTEXT/OPER,CONCAT(SDATE(),'|',STIME())\n"
      "ET=ASSIGN/SELAPSETIME()\nTEXT/OPER,STR(ET,3)\n"
      "TEXT/OPER,STR(VAL(' 12.5 ')*2,2)\nTEXT/OPER,ELEMNT(2,',','a,b,c')\nENDFIL\n";
  ::setenv("SOURCE_DATE_EPOCH", "31622400", 1);  // 1971-01-02 00:00:00 UTC
  const auto r = run(text);
  ::unsetenv("SOURCE_DATE_EPOCH");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  const std::vector<std::string> expected = {
      "P1=4.0", "P2=7.0", "A B=11.0", "3", "1971/01/02 00:00:00", "1971/01/02|00:00:00", "0.000", "25.00", "b"};
  EXPECT_EQ(texts, expected);

  // Reading past the end, a number that is not one, a file that is not there: positioned errors.
  const auto past =
      run("DMISMN/'p', 5.0\nDECL/REAL,X\nDID(IN1)=DEVICE/STOR,'offsets.txt'\n"
          "OPEN/DID(IN1),DIRECT,INPUT\nREAD/DID(IN1),X\nENDFIL\n");
  EXPECT_NE(past.diagnostics.find("READ/DID(IN1): 'P1' is not a number for X (field 1 of the file)"), std::string::npos)
      << past.diagnostics;
  const auto missing = run("DMISMN/'p', 5.0\nDID(IN1)=DEVICE/STOR,'nowhere.txt'\nOPEN/DID(IN1),DIRECT,INPUT\nENDFIL\n");
  EXPECT_NE(missing.diagnostics.find("OPEN/DID(IN1),INPUT: the file 'nowhere.txt' is not there"), std::string::npos)
      << missing.diagnostics;
  EXPECT_NE(missing.diagnostics.find("run.dmi:3:1: error"), std::string::npos) << missing.diagnostics;
}

// DECL/VECTOR and the vector intrinsics (DMIS 5.3 6.5). Expected values by hand: the cross
// product of x and y is z; |(3,4,12)| = 13; VPOL(2,30,5) = (2 cos 30, 2 sin 30, 5); after a
// 90 deg turn about z, part x is machine y (VMCS) and machine x is part -y (VPCS); VECX, VECY,
// VECZ the components read from the file.
TEST(ShopPrograms, VectorVariablesAndTheirIntrinsics) {
  write("vectors.txt", "1.5, -2, 0.25\n");
  const std::string text =
      "DMISMN/'p', 5.0\nUNITS/MM, ANGDEC\nDECL/COMMON,VECTOR,U,V,W\nDECL/VECTOR,ARR[2]\nDECL/REAL,D\n"
      "U=ASSIGN/VCART(1,0,0)\nV=ASSIGN/VCART(0,1,0)\nW=ASSIGN/VCROSS(U,V)\nTEXT/OPER,STR(VDOT(W,VCART(0,0,1)))\n"
      "D=ASSIGN/VMAG(VCART(3,4,12))\nTEXT/OPER,STR(D)\nW=ASSIGN/VUNIT(VCART(0,0,-7))\nTEXT/OPER,STR(W)\n"
      "W=ASSIGN/2*U-V/4+(-U)\nTEXT/OPER,STR(VDOT(W,VCART(1,10,100)))\n"
      "ARR[2]=ASSIGN/VPOL(2,30,5)\nTEXT/OPER,STR(VDOT(ARR[2],VCART(1,0,0)),6)\nTEXT/"
      "OPER,STR(VDOT(ARR[2],VCART(0,1,1)),6)\n"
      "IF/(VCROSS(U,V).EQ.VCART(0,0,1))\n  TEXT/OPER,'cross ok'\nENDIF\n"
      "D(R) = ROTATE/ZAXIS, "
      "90\nTEXT/OPER,STR(VDOT(VMCS(U),VCART(0,1,0)),6)\nTEXT/OPER,STR(VDOT(VPCS(U),VCART(0,-1,0)),6)\n"
      "DID(IN1)=DEVICE/STOR,'vectors.txt'\nOPEN/DID(IN1),DIRECT,INPUT\nREAD/DID(IN1),U\n"
      "TEXT/OPER,STR(VDOT(U,VCART(100,10,1)),3)\n"
      "TEXT/OPER,CONCAT(STR(VECX(U)),' ',STR(VECY(U)),' ',STR(VECZ(U)))\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  const std::vector<std::string> expected = {"1",        "13",       "0,0,-1",   "-1.5",    "1.732051",   "6.000000",
                                             "cross ok", "1.000000", "1.000000", "130.250", "1.5 -2 0.25"};
  EXPECT_EQ(texts, expected);

  // Type errors are found by check, with the place.
  const auto wrong = check(
      "DMISMN/'p', 5.0\nDECL/VECTOR,U\nDECL/REAL,X\nX=ASSIGN/VCART(1,2,3)\nU=ASSIGN/U*U\n"
      "X=ASSIGN/SQRT(U)\nX=ASSIGN/VMAG(X)\nENDFIL\n");
  EXPECT_EQ(wrong.errors, 4U) << wrong.text;
  EXPECT_TRUE(wrong.has("shop.dmi:4:")) << wrong.text;
  EXPECT_TRUE(wrong.has("cannot assign a VECTOR to X, which is declared REAL")) << wrong.text;
  EXPECT_TRUE(wrong.has("'*' does not apply to a VECTOR and a VECTOR")) << wrong.text;
  EXPECT_TRUE(wrong.has("SQRT does not take a VECTOR argument")) << wrong.text;
  EXPECT_TRUE(wrong.has("VMAG takes VECTOR arguments, got a REAL")) << wrong.text;
  const auto zero = run("DMISMN/'p', 5.0\nDECL/VECTOR,U\nU=ASSIGN/VUNIT(VCART(0,0,0))\nENDFIL\n");
  EXPECT_NE(zero.diagnostics.find("run.dmi:3:"), std::string::npos) << zero.diagnostics;
  EXPECT_NE(zero.diagnostics.find("VUNIT of a zero vector"), std::string::npos) << zero.diagnostics;
}

// A DMIS output file (NIST's, for the simple part) is DMIS too: each OUTPUT is followed by the
// result lines it produced, FA(x)=FEAT and TA(x)=TOL. metron checks it without error, and a
// stated actual can be judged against a tolerance again.
// An output file as WENZEL Quartis writes it (written for metron in its manner): report values
// after OUTPUT/R(x) (`DATE = ...`, `PN(x)= '...'`), a RECALL of a system the measuring program
// had, and each item's nominal and actual stated after its own OUTPUT. It had 2 errors ("expected a
// major word after '='"), and its run output F(P1) before its FEAT.
TEST(ShopPrograms, OutputFilesWithReportValuesAndEachItemAfterItsOutput) {
  const std::string text =
      "FILNAM/'SAMPLE'\nOUTPUT/R(DAY)\nDATE = 2026/01/01\nOUTPUT/R(P1)\nPN(TEIL_NR)= '123'\n"
      "RECALL/DA(FIXTURE)\nOUTPUT/F(P1),T(P1_X)\nF(P1)=FEAT/POINT,CART,10,20,30,0,0,1\n"
      "T(P1_X)=TOL/CORTOL,XAXIS,-0.5,0.5\nOUTPUT/FA(P1),TA(P1_X)\nFA(P1)=FEAT/POINT,CART,10.006,20,30,0,0,1\n"
      "TA(P1_X)=TOL/CORTOL,XAXIS,0.006,INTOL\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  EXPECT_TRUE(c.has("3:1: note: a report's value, as a DMIS output file writes it")) << c.text;
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.diagnostics.find("warning"), std::string::npos) << r.diagnostics;
  const auto* p1 = r.session->runtime().find_feature("P1");
  ASSERT_TRUE(p1 && p1->actual);
  EXPECT_NEAR(p1->actual->position.x(), 10.006, 1e-12);
  EXPECT_TRUE(check(text, true).has("3:8: error: expected a major word after '='"));
  // Not a report's value: a variable set without ASSIGN stays an error.
  EXPECT_TRUE(check("DMISMN/'p', 5.1\nDECL/REAL,X\nX = 5\nENDFIL\n").has("expected a major word after '='"));
}

TEST(ShopPrograms, DmisOutputFilesCheckAndTheirActualsCanBeJudged) {
  const fs::path nist = source_dir.parent_path() / "shared" / "data" / "nist-simple-part" / "output.dms";
  if (fs::exists(nist)) {
    std::ifstream in(nist);
    std::stringstream text;
    text << in.rdbuf();
    const auto c = check(text.str());
    EXPECT_EQ(c.errors, 0u) << c.text;
    EXPECT_TRUE(c.has("FA(A_CIRCLE)=FEAT/... states a measured actual")) << c.text;
  }
  const auto results = check(
      "DMISMN/'out', 5.0\nOUTPUT/FA(C1),TA(D1)\nFA(C1)=FEAT/CIRCLE,INNER,CART,1,2,3,0,0,1,10.01\n"
      "TA(D1)=TOL/DIAM,0.01000,INTOL\nENDFIL\n");
  EXPECT_EQ(results.errors, 0u) << results.text;
  // A CAMIO output file echoes the program's DATDEF and DATSET without restating their features,
  // and reports the alignment as DA(l)=DATSET/TRMATX,...: notes, not errors.
  const auto camio = check(
      "$$ Version Camio 8.6\nUNITS/MM,ANGDEC\nDATDEF/FA(PLN_Décalé),DAT(A)\n"
      "D(Réf)=DATSET/DAT(A),-YDIR,YORIG\n"
      "DA(Réf)=DATSET/TRMATX,-1,0,0,0,1,0,0,0,-1,1251.254,155.056,-0.034\n"
      "OUTPUT/FA(P1),TA(A1)\nFA(P1)=FEAT/POINT,CART,1062.026,-7.805,373.053,0,-1,0\n"
      "TA(A1)=TOL/DISTWRT,OUTOL,NOMINL,7.805,7.805,7.805,FA(PLN_Décalé),YAXIS,AVG\n");
  EXPECT_EQ(camio.errors, 0u) << camio.text;
  EXPECT_TRUE(camio.has("3:1: note: an echo of the measuring program's line")) << camio.text;
  EXPECT_TRUE(camio.has("5:1: note: DA(Réf)=DATSET/... is a reported alignment")) << camio.text;
  // In a program that measures, the same DATDEF leans on an actual from an earlier run: a warning
  // read leniently, an error under --strict.
  const std::string measuring =
      "DMISMN/'p', 5.0\nDATDEF/FA(PLN_Décalé),DAT(A)\nFA(P1)=FEAT/POINT,CART,0,0,0,0,0,1\n"
      "GOTO/0,0,10\nENDFIL\n";
  const auto program = check(measuring);
  EXPECT_TRUE(program.has("2:8: warning: feature FA(PLN_Décalé) is not defined in this program")) << program.text;
  EXPECT_TRUE(check(measuring, true).has("2:8: error: feature FA(PLN_Décalé) is not defined"));
  const auto r =
      run("DMISMN/'judge', 5.0\nF(C1)=FEAT/CIRCLE,INNER,CART,50,50,40,0,0,1,50\n"
          "FA(C1)=FEAT/CIRCLE,INNER,CART,50.01,50,40,0,0,1,50.02\nT(D)=TOL/DIAM,-0.01,0.01\n"
          "OUTPUT/FA(C1),TA(D)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* d = tolerance(*r.session, "D");
  ASSERT_TRUE(d);
  EXPECT_NEAR(d->value, 0.02, 1e-9);
  EXPECT_FALSE(d->in_tolerance);
  const auto* c1 = report(*r.session, "C1");
  ASSERT_TRUE(c1 && c1->actual);
  EXPECT_NEAR(c1->actual->position.x(), 50.01, 1e-9);
  EXPECT_NEAR(c1->nominal.position.x(), 50.0, 1e-9);
}

// A CAMIO program opens its CAD model (DID(l)=DEVICE/STOR,'...sab' then OPEN/DID(l),CAD,...): the
// model is not read, and no file is made for it (an empty Ladder.sab was written into --out).
TEST(ShopPrograms, OpenOfACadModelMakesNoFile) {
  const fs::path out = temp_dir() / "cad_out";
  fs::create_directories(out);
  const std::string text =
      "DMISMN/'cad', 5.2\nDID(Ladder)=DEVICE/STOR,'C:\\LK\\CAO\\Ladder_model.sab'\n"
      "OPEN/DID(Ladder),CAD,VENDOR,'ACIS'\nTEXT/OPER,'after'\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  EXPECT_TRUE(c.has("3:18: note: OPEN of a CAD model: the part is the world's, the model is not read")) << c.text;
  const fs::path p = write("cad.dmi", text);
  auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
  ASSERT_TRUE(backend.has_value());
  auto session = Session::create(std::move(*backend));
  session->runtime().set_output_directory(out.string());
  ASSERT_TRUE(session->load(p.string()));
  EXPECT_EQ(session->interpreter().run(), ExecStatus::Finished) << session->take_diagnostics();
  EXPECT_TRUE(fs::is_empty(out)) << fs::directory_iterator(out)->path();
}

// `metron run --dry-run`: a program written for another machine's coordinates and a part the
// world does not hold (here a bore at machine x = -1063, outside the default travel) runs to its
// end, every touch on its nominal and every scan on its path. The expected values are the
// nominals themselves: the points lie exactly on them, so the fits give them back.
TEST(ShopPrograms, DryRunTakesEveryPointAtItsNominal) {
  const std::string text =
      "DMISMN/'dry', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
      "F(TOP) = FEAT/PLANE, CART, -1063, -20, 200, 0, 0.6, 0.8\nMEAS/PLANE, F(TOP), 3\n"
      "PTMEAS/CART, -1063, -20, 200, 0, 0.6, 0.8\nPTMEAS/CART, -1053, -20, 200, 0, 0.6, 0.8\n"
      "PTMEAS/CART, -1063, -28, 206, 0, 0.6, 0.8\nENDMES\n"
      "F(B1) = FEAT/CIRCLE, INNER, CART, -1063, -20, 150, 0, 0, 1, 12\nMEAS/CIRCLE, F(B1), 4\n"
      "PTMEAS/CART, -1057, -20, 150, -1, 0, 0\nPTMEAS/CART, -1063, -14, 150, 0, -1, 0\n"
      "PTMEAS/CART, -1069, -20, 150, 1, 0, 0\nPTMEAS/CART, -1063, -26, 150, 0, 1, 0\nENDMES\n"
      "FEDRAT/SCNVEL, MMPS, 10\nSCNSET/DRAG, 0.1, DEFLEC, 0.3, LAW, VC2\n"
      "F(B2) = FEAT/CIRCLE, INNER, CART, -1063, -20, 140, 0, 0, 1, 12\nSCNMOD/ON\nMEAS/CIRCLE, F(B2), "
      "0\nENDMES\nSCNMOD/OFF\n"
      "T(D) = TOL/DIAM, -0.001, 0.001\nT(F) = TOL/FLAT, 0.001\nOUTPUT/FA(TOP), TA(F)\nOUTPUT/FA(B1), "
      "TA(D)\nOUTPUT/FA(B2), TA(D)\nENDFIL\n";
  const Ran dry = dry_run(text);
  ASSERT_EQ(dry.status, ExecStatus::Finished) << dry.diagnostics;
  Session* session = dry.session.get();
  const auto* top = report(*session, "TOP");
  ASSERT_TRUE(top && top->actual);
  EXPECT_NEAR(top->actual->direction.dot(Eigen::Vector3d(0, 0.6, 0.8)), 1.0, 1e-12);
  EXPECT_NEAR((top->actual->position - Eigen::Vector3d(-1063, -20, 200)).dot(Eigen::Vector3d(0, 0.6, 0.8)), 0.0, 1e-9);
  // Touches exactly; a scan within the chord error of its PCC path (cubic segments between
  // points of the exact offset contour, docs/scanning-paths.md), here under a micrometre.
  for (const auto& [bore, within] : {std::pair{"B1", 1e-9}, std::pair{"B2", 1e-3}}) {
    const auto* b = report(*session, bore);
    ASSERT_TRUE(b && b->actual) << bore;
    EXPECT_NEAR(b->actual->diameter_mm, 12.0, within) << bore;
    EXPECT_NEAR(b->actual->position.x(), -1063.0, within) << bore;
    EXPECT_NEAR(b->actual->position.y(), -20.0, within) << bore;
  }
  // A scan: the ball centres' circle, radius 6 - (2 - 0.3) mm, every 0.1 mm.
  EXPECT_GT(report(*session, "B2")->point_count, static_cast<std::size_t>(2 * M_PI * 4.3 / 0.1) - 5);
  std::size_t in = 0;
  for (const auto& e : session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) in += t->in_tolerance;
  EXPECT_EQ(in, 3u);
  // On the virtual CMM the same program stops at the first move: x = -1063 is outside its travel.
  const auto real = run(text);
  EXPECT_EQ(real.status, ExecStatus::Faulted);
  const auto& events = real.session->record().events;
  ASSERT_FALSE(events.empty());
  const auto* fault = std::get_if<metron::runtime::FaultReport>(&events.back());
  ASSERT_NE(fault, nullptr);
  EXPECT_NE(fault->message.find("outside the x travel"), std::string::npos) << fault->message;
}

// A DIRECT file (a CSV a program WRITEs) receives its WRITE lines only; OUTPUT and TEXT/OUTFIL
// lines go to the FDATA (DMIS output) files. Every OUTPUT went into every open file before.
TEST(ShopPrograms, DirectFilesGetOnlyTheirWriteLines) {
  const fs::path out = temp_dir() / "direct_out";
  fs::remove_all(out);
  fs::create_directories(out);
  const std::string text =
      "DMISMN/'direct', 5.1\nDID(CSV)=DEVICE/STOR,'table.csv'\nDID(DMO)=DEVICE/STOR,'part.dmo'\n"
      "OPEN/DID(CSV),DIRECT,OUTPUT,OVERWR\nOPEN/DID(DMO),FDATA,V(1),OUTPUT,OVERWR\n"
      "F(P1)=FEAT/POINT,CART,1,2,3,0,0,1\nFA(P1)=FEAT/POINT,CART,1,2,3.5,0,0,1\n"
      "WRITE/DID(CSV),'x,y,z'\nOUTPUT/FA(P1)\nTEXT/OUTFIL,'note'\nCLOSE/DID(CSV)\nCLOSE/DID(DMO)\nENDFIL\n";
  const fs::path p = write("direct.dmi", text);
  auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
  ASSERT_TRUE(backend.has_value());
  auto session = Session::create(std::move(*backend));
  session->runtime().set_output_directory(out.string());
  ASSERT_TRUE(session->load(p.string()));
  ASSERT_EQ(session->interpreter().run(), ExecStatus::Finished) << session->take_diagnostics();
  const auto read = [](const fs::path& f) {
    std::ifstream in(f, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  EXPECT_EQ(read(out / "table.csv"), "x,y,z\n");
  const std::string dmo = read(out / "part.dmo");
  EXPECT_NE(dmo.find("FA(P1) = FEAT/POINT"), std::string::npos) << dmo;
  EXPECT_NE(dmo.find("note"), std::string::npos) << dmo;
  EXPECT_EQ(dmo.find("x,y,z"), std::string::npos) << dmo;
  // Framed as a DMIS output file (NIST's output.dms): name and units first, each OUTPUT echoed
  // before its results, ENDFIL last; metron reads it back without an error or a warning.
  EXPECT_EQ(dmo.rfind("FILNAM/'part'\nUNITS/MM, ANGDEC\n", 0), 0u) << dmo;
  EXPECT_LT(dmo.find("OUTPUT/FA(P1)\n"), dmo.find("FA(P1) = FEAT/POINT")) << dmo;
  EXPECT_EQ(dmo.substr(dmo.size() - 7), "ENDFIL\n") << dmo;
  const auto reread = check(dmo);
  EXPECT_EQ(reread.errors + reread.warnings, 0u) << reread.text;
}

// CONST/...,TANTO (docs/language.md, "Tangent constructions"), each against its analytic solution:
// the outer tangents of circles of radius 5 and 10 with centres 30 apart turn by asin(5/30) and
// touch the first at 5 (-sin, cos); the inner ones turn by asin(15/30); from a point 20 from a
// circle of radius 5 a tangent turns by asin(5/20); a circle of diameter 10 in a corner of two
// perpendicular lines has its centre 5 from each; the 30-40-50 triangle's incircle has radius
// (30 + 40 - 50) / 2 = 10 at (10, 10), its excircle across the hypotenuse the radius s = 60 at
// (60, 60). Of each construction's solutions the one nearest its nominal is taken; without a
// nominal, the documented one with a warning.
TEST(ShopPrograms, TangentConstructionsTakeTheSolutionNearestTheNominal) {
  const std::string stated =
      "DMISMN/'t', 5.1\nFA(C1)=FEAT/CIRCLE,OUTER,CART,0,0,0,0,0,1,10\nFA(C2)=FEAT/CIRCLE,OUTER,CART,30,0,0,0,0,1,20\n"
      "FA(Q)=FEAT/POINT,CART,-20,0,0,0,0,1\nFA(LX)=FEAT/LINE,UNBND,CART,0,0,0,1,0,0,0,0,1\n"
      "FA(LY)=FEAT/LINE,UNBND,CART,0,0,0,0,1,0,0,0,1\nFA(LH)=FEAT/LINE,UNBND,CART,40,0,0,-0.8,0.6,0,0,0,1\n";
  const auto r =
      run(stated +
          "F(UP)=FEAT/LINE,UNBND,CART,0,5,0,1,0,0,0,0,1\nCONST/LINE,F(UP),TANTO,FA(C1),FA(C2)\n"
          "F(DOWN)=FEAT/LINE,UNBND,CART,0,-5,0,1,0,0,0,0,1\nCONST/LINE,F(DOWN),TANTO,FA(C1),FA(C2)\n"
          "F(CROSS)=FEAT/LINE,UNBND,CART,0,-5,0,1,0.5,0,0,0,1\nCONST/LINE,F(CROSS),TANTO,FA(C1),FA(C2)\n"
          "CONST/LINE,F(FREE),TANTO,FA(C1),FA(C2)\n"
          "F(FROMQ)=FEAT/LINE,UNBND,CART,-20,0,0,1,-0.2,0,0,0,1\nCONST/LINE,F(FROMQ),TANTO,FA(Q),FA(C1)\n"
          "F(K1)=FEAT/CIRCLE,OUTER,CART,4,6,0,0,0,1,10\nCONST/CIRCLE,F(K1),TANTO,FA(LX),FA(LY),10\n"
          "F(K2)=FEAT/CIRCLE,OUTER,CART,-6,-4,0,0,0,1,10\nCONST/CIRCLE,F(K2),TANTO,FA(LX),FA(LY),10\n"
          "F(IN)=FEAT/CIRCLE,INNER,CART,11,9,0,0,0,1,18\nCONST/CIRCLE,F(IN),TANTO,FA(LX),FA(LY),FA(LH)\n"
          "F(EX)=FEAT/CIRCLE,INNER,CART,55,58,0,0,0,1,100\nCONST/CIRCLE,F(EX),TANTO,FA(LX),FA(LY),FA(LH)\n"
          "CONST/CIRCLE,F(FREEC),TANTO,FA(LX),FA(LY),FA(LH)\n"
          "OUTPUT/FA(UP),FA(DOWN),FA(CROSS),FA(FREE),FA(FROMQ),FA(K1),FA(K2),FA(IN),FA(EX),FA(FREEC)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  using metron::runtime::Geometry;
  const auto actual = [&](const char* label) {
    const auto* f = report(*r.session, label);
    EXPECT_TRUE(f != nullptr && f->actual) << label;
    return f != nullptr && f->actual ? *f->actual : Geometry{};
  };
  const auto distance = [](const Geometry& line, const Eigen::Vector3d& c) {
    return (c - line.position).cross(line.direction.normalized()).norm();
  };
  const auto angle = [](const Geometry& line) { return std::atan2(line.direction.y(), line.direction.x()); };
  const double outer = std::asin(5.0 / 30), inner = std::asin(15.0 / 30);
  const Geometry up = actual("UP"), down = actual("DOWN"), cross = actual("CROSS"), free = actual("FREE");
  for (const Geometry* l : {&up, &down, &cross, &free}) {
    EXPECT_NEAR(distance(*l, Eigen::Vector3d(0, 0, 0)), 5, 1e-9);
    EXPECT_NEAR(distance(*l, Eigen::Vector3d(30, 0, 0)), 10, 1e-9);
  }
  EXPECT_NEAR(angle(up), outer, 1e-9);
  EXPECT_LT((up.position - Eigen::Vector3d(-5 * std::sin(outer), 5 * std::cos(outer), 0)).norm(), 1e-9);
  EXPECT_NEAR(angle(down), -outer, 1e-9);
  EXPECT_NEAR(angle(cross), inner, 1e-9);
  EXPECT_LT((free.position - up.position).norm() + (free.direction - up.direction).norm(), 1e-9);
  const Geometry from_q = actual("FROMQ");
  EXPECT_NEAR(distance(from_q, Eigen::Vector3d(0, 0, 0)), 5, 1e-9);
  EXPECT_LT((from_q.position - Eigen::Vector3d(-20, 0, 0)).norm(), 1e-9);
  EXPECT_NEAR(angle(from_q), -std::asin(5.0 / 20), 1e-9);
  const auto circle = [&](const char* label, const Eigen::Vector3d& centre, double diameter) {
    const Geometry c = actual(label);
    EXPECT_LT((c.position - centre).norm(), 1e-9) << label;
    EXPECT_NEAR(c.diameter_mm, diameter, 1e-9) << label;
  };
  circle("K1", {5, 5, 0}, 10);
  circle("K2", {-5, -5, 0}, 10);
  circle("IN", {10, 10, 0}, 20);
  circle("EX", {60, 60, 0}, 120);
  circle("FREEC", {10, 10, 0}, 20);
  EXPECT_NE(r.diagnostics.find("warning: CONST of F(FREE) without a FEAT nominal: of TANTO's solutions, the outer "
                               "tangent left of the way from the first to the second"),
            std::string::npos)
      << r.diagnostics;

  // What has no tangent: a warning at check for a type TANTO does not make here, an error at run
  // for lines that do not cross and for a circle inside another.
  const auto plane = check(stated + "CONST/PLANE,F(P),TANTO,FA(C1),FA(C2)\nENDFIL\n");
  EXPECT_NE(plane.text.find("warning: TANTO constructs a LINE or a CIRCLE here; a tangent PLANE is not supported"),
            std::string::npos)
      << plane.text;
  const auto parallel = run(stated +
                            "FA(LX2)=FEAT/LINE,UNBND,CART,0,8,0,1,0,0,0,0,1\n"
                            "CONST/CIRCLE,F(K),TANTO,FA(LX),FA(LX2),8\nENDFIL\n");
  EXPECT_NE(parallel.diagnostics.find("cannot construct CIRCLE F(K) by TANTO: the two lines are parallel"),
            std::string::npos)
      << parallel.diagnostics;
  const auto inside =
      run(stated + "FA(C3)=FEAT/CIRCLE,OUTER,CART,31,0,0,0,0,1,4\nCONST/LINE,F(T),TANTO,FA(C2),FA(C3)\nENDFIL\n");
  EXPECT_NE(inside.diagnostics.find("cannot construct LINE F(T) by TANTO: FA(C3) lies inside FA(C2)"),
            std::string::npos)
      << inside.diagnostics;
}

// A constructed feature keeps how far the points it rests on spread (RMS about their centroid), the
// lever LOCATE weighs its direction by: a plane through three stated points (positions only)
// their RMS distance from their centroid; a plane offset from it, the same (one source, its
// spread); a line through the plane's centre and a point, the two clouds together by the
// parallel-axis theorem.
TEST(ShopPrograms, ConstructedFeaturesKeepTheSpreadOfTheirSources) {
  const auto r =
      run("DMISMN/'s', 5.1\nFA(P1)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(P2)=FEAT/POINT,CART,30,0,0,0,0,1\n"
          "FA(P3)=FEAT/POINT,CART,0,40,0,0,0,1\nF(PL)=FEAT/PLANE,CART,10,13,0,0,0,1\n"
          "CONST/PLANE,F(PL),BF,FA(P1),FA(P2),FA(P3)\nF(OFF)=FEAT/PLANE,CART,10,13,5,0,0,1\n"
          "CONST/PLANE,F(OFF),OFFSET,FA(PL),5\nFA(Q)=FEAT/POINT,CART,10,13.3333333333,20,0,0,1\n"
          "F(L)=FEAT/LINE,UNBND,CART,10,13,0,0,0,1,1,0,0\nCONST/LINE,F(L),BF,FA(PL),FA(Q)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const Eigen::Vector3d p1(0, 0, 0), p2(30, 0, 0), p3(0, 40, 0), c = (p1 + p2 + p3) / 3;
  const double plane = std::sqrt(((p1 - c).squaredNorm() + (p2 - c).squaredNorm() + (p3 - c).squaredNorm()) / 3);
  const auto spread = [&](const char* label) {
    const auto* f = r.session->runtime().find_feature(label);
    EXPECT_NE(f, nullptr) << label;
    return f ? f->construction_spread_mm : -1.0;
  };
  EXPECT_NEAR(spread("PL"), plane, 1e-9);
  EXPECT_NEAR(spread("OFF"), plane, 1e-9);
  // The plane's cloud (its centre c, spread `plane`) and Q 20 above c, weighted one each.
  EXPECT_NEAR(spread("L"), std::sqrt((2 * 10.0 * 10.0 + plane * plane) / 2), 1e-6);
}

// CONST/POINT,INTOF of a line and a circle (CAMIO's "Intersection: line - arc"): the line
// projected onto the circle's plane, the crossing nearest F()'s nominal. By hand: a 20 mm circle
// at the origin crossed along X at y = 0 gives x = +-10, at y = 6 x = +-sqrt(100 - 36) = +-8; at
// y = 12 the line passes 2 mm outside.
TEST(ShopPrograms, PointWhereALineCrossesACircle) {
  const std::string stated =
      "DMISMN/'x', 5.2\nFA(C)=FEAT/CIRCLE,OUTER,CART,0,0,0,0,0,1,20\n"
      "FA(L)=FEAT/LINE,UNBND,CART,3,0,5,1,0,0,0,0,1\nFA(L6)=FEAT/LINE,UNBND,CART,3,6,0,-1,0,0,0,0,1\n"
      "FA(L12)=FEAT/LINE,UNBND,CART,3,12,0,1,0,0,0,0,1\n";
  const auto r = run(stated +
                     "F(A)=FEAT/POINT,CART,10,0,0,0,0,1\nCONST/POINT,F(A),INTOF,FA(L),FA(C)\n"
                     "F(B)=FEAT/POINT,CART,-9,1,0,0,0,1\nCONST/POINT,F(B),INTOF,FA(C),FA(L)\n"
                     "F(E)=FEAT/POINT,CART,7,6,0,0,0,1\nCONST/POINT,F(E),INTOF,FA(L6),FA(C)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto at = [&](const char* label) {
    const auto* f = r.session->runtime().find_feature(label);
    return f && f->actual ? f->actual->position : Eigen::Vector3d::Constant(NAN);
  };
  EXPECT_NEAR((at("A") - Eigen::Vector3d(10, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((at("B") - Eigen::Vector3d(-10, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((at("E") - Eigen::Vector3d(8, 6, 0)).norm(), 0.0, 1e-12);
  const auto missed = run(stated + "F(M)=FEAT/POINT,CART,0,12,0,0,0,1\nCONST/POINT,F(M),INTOF,FA(L12),FA(C)\nENDFIL\n");
  EXPECT_EQ(missed.status, ExecStatus::Error);
  EXPECT_NE(missed.diagnostics.find("the line passes 2.0000 mm outside the circle"), std::string::npos)
      << missed.diagnostics;
}

// Constructions vendor exports write: a countersink's gauge circle (CONST/CIRCLE,INTOF of a cone
// and a plane) and a bore's cylinder from two measured sections (CONST/CYLNDR,BF,FA(C1),FA(C2)).
TEST(ShopPrograms, CircleOfAConeAndAPlaneAndACylinderFromSections) {
  const std::string stated =
      "DMISMN/'k', 5.1\nFA(CN)=FEAT/CONE,INNER,CART,1,2,10,0,0,1,90\nFA(CY)=FEAT/CYLNDR,INNER,CART,1,2,0,0,0,1,12,20\n"
      "FA(PL)=FEAT/PLANE,CART,0,0,14,0,0,1\nFA(TL)=FEAT/PLANE,CART,0,0,14,0,0.0872,0.9962\n";
  const auto r =
      run(stated +
          "CONST/CIRCLE,F(K),INTOF,FA(CN),FA(PL)\nCONST/CIRCLE,F(L),INTOF,FA(PL),FA(CY)\nOUTPUT/FA(K),FA(L)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* k = report(*r.session, "K");
  ASSERT_TRUE(k && k->actual);
  EXPECT_NEAR(k->actual->diameter_mm, 2 * 4 * std::tan(M_PI / 4), 1e-9);  // 4 mm above a 90 deg apex
  EXPECT_NEAR((k->actual->position - Eigen::Vector3d(1, 2, 14)).norm(), 0.0, 1e-9);
  const auto* l = report(*r.session, "L");
  ASSERT_TRUE(l && l->actual);
  EXPECT_NEAR(l->actual->diameter_mm, 12.0, 1e-12);
  const auto tilted = run(stated + "CONST/CIRCLE,F(K),INTOF,FA(CN),FA(TL)\nENDFIL\n");
  EXPECT_NE(tilted.diagnostics.find("deg off normal to the axis: the section is an ellipse"), std::string::npos)
      << tilted.diagnostics;
  // The default block's BORE1 (a 20 mm bore, its axis along Z) from two measured sections.
  const auto bore =
      run("DMISMN/'sections', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
          "SNSLCT/S(P4)\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nMODE/AUTO\nGOTO/40, 50, 80\n"
          "F(C1) = FEAT/CIRCLE, INNER, CART, 40, 50, 35, 0, 0, 1, 20\nMEAS/CIRCLE, F(C1), 8\nENDMES\n"
          "F(C2) = FEAT/CIRCLE, INNER, CART, 40, 50, 25, 0, 0, 1, 20\nMEAS/CIRCLE, F(C2), 8\nENDMES\n"
          "GOTO/40, 50, 80\nF(CY) = FEAT/CYLNDR, INNER, CART, 40, 50, 30, 0, 0, 1, 20, 10\n"
          "CONST/CYLNDR, F(CY), BF, FA(C1), FA(C2)\nOUTPUT/FA(CY)\nENDFIL\n");
  ASSERT_EQ(bore.status, ExecStatus::Finished) << bore.diagnostics;
  const auto* cy = report(*bore.session, "CY");
  ASSERT_TRUE(cy && cy->actual);
  EXPECT_NEAR(cy->actual->diameter_mm, 20.0, 0.002);
  EXPECT_GT(std::abs(cy->actual->direction.z()), 1 - 1e-6);
}

// A probing feed other than the qualification's moves every point along its normal by the
// trigger delay times the feed difference, which the effective radius does not hold: told once.
// The block's -X face is at machine x = 300 exactly (the world's truth).
TEST(ShopPrograms, ProbingAtAnotherFeedThanTheQualificationsIsToldOnce) {
  const auto program = [](const std::string& before, const std::string& after) {
    return "DMISMN/'feed', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n" +
           before + "SNSLCT/S(P4)\n" + after +
           "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nF(P1) = FEAT/POINT, CART, 0, 50, 30, -1, 0, 0\n"
           "F(P2) = FEAT/POINT, CART, 0, 60, 30, -1, 0, 0\nGOTO/-10, 50, 80\nGOTO/-10, 50, 30\n"
           "MEAS/POINT, F(P1), 1\nPTMEAS/CART, 0, 50, 30, -1, 0, 0\nENDMES\n"
           "MEAS/POINT, F(P2), 1\nPTMEAS/CART, 0, 60, 30, -1, 0, 0\nENDMES\nOUTPUT/FA(P1)\nENDFIL\n";
  };
  const std::string slow = "FEDRAT/MESVEL, PCENT, 20\n";
  const auto after = run(program("", slow));
  ASSERT_EQ(after.status, ExecStatus::Finished) << after.diagnostics;
  EXPECT_NE(after.diagnostics.find("12:1: warning: probing at 0.600 mm/s, but the probe was qualified at 3.000 mm/s"),
            std::string::npos)
      << after.diagnostics;
  EXPECT_EQ(after.diagnostics.find("probing at", after.diagnostics.find("probing at") + 1), std::string::npos);  // once
  const auto* off = report(*after.session, "P1");
  ASSERT_TRUE(off && off->actual);
  EXPECT_GT(std::abs(off->actual->position.x()), 0.005);  // the delay's displacement, part frame
  const auto before = run(program(slow, ""));
  ASSERT_EQ(before.status, ExecStatus::Finished) << before.diagnostics;
  EXPECT_EQ(before.diagnostics.find("probing at"), std::string::npos) << before.diagnostics;
  const auto* on = report(*before.session, "P1");
  ASSERT_TRUE(on && on->actual);
  EXPECT_LT(std::abs(on->actual->position.x()), 0.001);
  // CALIB/SENS after the change of feed qualifies the probe again at it: no warning, no offset.
  const auto calibrated = run(program("", slow + "CALIB/SENS,S(P4),F(REFSPH),9\n"));
  ASSERT_EQ(calibrated.status, ExecStatus::Finished) << calibrated.diagnostics;
  EXPECT_EQ(calibrated.diagnostics.find("probing at"), std::string::npos) << calibrated.diagnostics;
  const auto* again = report(*calibrated.session, "P1");
  ASSERT_TRUE(again && again->actual);
  EXPECT_LT(std::abs(again->actual->position.x()), 0.001);
  EXPECT_TRUE(check(program("", slow + "CALIB/SENS,S(P4),F(REFSPH),9\n")).has("F(REFSPH) is not measured"));
}

// A system built on measured features carries the nominals written before it onto the part: its
// nominal frame (the same statement on the features' nominals) goes with its actual frame. With
// the circle's origin taken from its actual, the circle's nominal is at the origin too, and each
// CORTOL deviation is 0 (the reading TotalDMIS publishes for this example; one frame gave the
// actual's offset, 0.03, -0.02 and 0.4, as the deviations). RECALL of the earlier system takes the
// nominal back.
TEST(ShopPrograms, ASystemOnMeasuredFeaturesCarriesTheEarlierNominals) {
  const std::string text =
      "DMISMN/'frames', 5.0\nUNITS/MM, ANGDEC\nD(C1)=ROTATE/XAXIS,45\n"
      "F(CIR)=FEAT/CIRCLE,INNER,CART,10,20,30,0,0,1,8\nFA(CIR)=FEAT/CIRCLE,INNER,CART,10.03,19.98,30.4,0,0,1,8\n"
      "D(C2)=TRANS/XORIG,FA(CIR),YORIG,FA(CIR),ZORIG,FA(CIR)\nT(X)=TOL/CORTOL,XAXIS,-0.1,0.1\n"
      "T(Y)=TOL/CORTOL,YAXIS,-0.1,0.1\nT(Z)=TOL/CORTOL,ZAXIS,-0.1,0.1\nOUTPUT/FA(CIR),TA(X),TA(Y),TA(Z)\n"
      "RECALL/D(C1)\nOUTPUT/FA(CIR),TA(Z)\nENDFIL\n";
  const auto r = dry_run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::vector<const metron::runtime::ToleranceResult*> z;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) {
      if (t->label == "Z") z.push_back(t);
      if (z.size() < 2 || t->label != "Z") {
        EXPECT_NEAR(t->actual, 0.0, 1e-9) << t->label;
        EXPECT_NEAR(t->nominal, 0.0, 1e-9) << t->label;
      }
    }
  ASSERT_EQ(z.size(), 2u);
  // Back in C1, where both were written: the nominal 30, the actual 30.4.
  EXPECT_NEAR(z[1]->nominal, 30.0, 1e-9);
  EXPECT_NEAR(z[1]->actual, 30.4, 1e-9);
}

// The hidden truth of the simulated world: the default block is exact, but it lies 0.3 mm along X
// and -0.2 mm along Y from where the program expects it. The program writes its features in
// machine coordinates first, measures them, then builds its part system on the measured left,
// front and top faces. BORE1 lies exactly 40, 50 from those faces: reported in that system its
// deviations are 0 (they were the misplacement, +0.3 and -0.2, with one frame).
TEST(ShopPrograms, FeaturesWrittenBeforeTheAlignmentAreReportedRelativeToItsFaces) {
  const fs::path world =
      write("misplaced_block.json", "{\"extends\": \"" + (source_dir / "programs/worlds/default.json").string() +
                                        "\", \"part\": {\"pose\": {\"translation_mm\": [300.3, "
                                        "199.8, 0], \"rotation_deg\": [0, 0, 0]}}}\n");
  const std::string text =
      "DMISMN/'misplaced', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "SNSLCT/S(P4)\nF(TOP)=FEAT/PLANE,CART,380,250,40,0,0,1\nF(FRONT)=FEAT/PLANE,CART,380,200,20,0,-1,0\n"
      "F(LEFT)=FEAT/PLANE,CART,300,250,20,-1,0,0\nF(BORE1)=FEAT/CIRCLE,INNER,CART,340,250,30,0,0,1,20\n"
      "GOTO/320,220,60\nMEAS/PLANE,F(TOP),3\nPTMEAS/CART,320,220,40,0,0,1\nPTMEAS/CART,440,220,40,0,0,1\n"
      "GOTO/440,220,60\nGOTO/310,290,60\nPTMEAS/CART,310,290,40,0,0,1\nGOTO/310,290,60\nENDMES\nGOTO/320,180,60\nGOTO/"
      "320,180,30\n"
      "MEAS/PLANE,F(FRONT),3\nPTMEAS/CART,320,200,30,0,-1,0\nPTMEAS/CART,440,200,30,0,-1,0\n"
      "PTMEAS/CART,380,200,15,0,-1,0\nGOTO/280,180,30\nENDMES\nMEAS/PLANE,F(LEFT),3\n"
      "PTMEAS/CART,300,220,30,-1,0,0\nPTMEAS/CART,300,280,30,-1,0,0\nPTMEAS/CART,300,250,15,-1,0,0\n"
      "GOTO/280,250,60\nENDMES\nGOTO/340,250,60\nMEAS/CIRCLE,F(BORE1),4\nGOTO/340,250,30\n"
      "PTMEAS/CART,350,250,30,-1,0,0\nPTMEAS/CART,340,260,30,0,-1,0\nPTMEAS/CART,330,250,30,1,0,0\n"
      "PTMEAS/CART,340,240,30,0,1,0\nGOTO/340,250,60\nENDMES\n"
      "D(PART)=TRANS/XORIG,FA(LEFT),YORIG,FA(FRONT),ZORIG,FA(TOP)\n"
      "T(X)=TOL/CORTOL,XAXIS,-0.01,0.01\nT(Y)=TOL/CORTOL,YAXIS,-0.01,0.01\nOUTPUT/FA(BORE1),TA(X),TA(Y)\nENDFIL\n";
  const auto r = run(text, world);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* x = tolerance(*r.session, "X");
  const auto* y = tolerance(*r.session, "Y");
  ASSERT_TRUE(x && y);
  EXPECT_NEAR(x->nominal, 40.0, 1e-3);
  EXPECT_NEAR(y->nominal, 50.0, 1e-3);
  EXPECT_NEAR(x->value, 0.0, 0.005);
  EXPECT_NEAR(y->value, 0.0, 0.005);
  EXPECT_TRUE(x->in_tolerance && y->in_tolerance);
}

// RationalDMIS writes RMEAS/CIRCLE,F(x),n,VECBLD,r,m with the m points of the surface around the
// hole as RPTMEAS before the hole's PTMEAS. The program below expects the default block's top face
// at z = 40.5; the world's face is at 40 (the drawing). The three RPTMEAS, 3 mm from the edge of
// BORE1 (diameter 20, centre 340,250 on the table), find the face 0.5 mm low, and the hole's points,
// written 3 mm below the expected face (37.5), are taken 3 mm below the actual one: 37.0. Taken as
// plain PTMEAS they would be at 37.5. The reference points are not the circle's: 4 points, no
// count warning.
TEST(ShopPrograms, RationalDmisReferencePointsMeasureTheHoleRelativeToTheFace) {
  const std::string header =
      "DMISMN/'rptmeas', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "SNSLCT/S(P4)\nF(C)=FEAT/CIRCLE,INNER,CART,340,250,40.5,0,0,1,20\n";
  const std::string block =
      "RMEAS/CIRCLE, F(C), 4, VECBLD, 3.0000, 3\n"
      "RPTMEAS/CART, 353, 250, 40.5, 0, 0, 1\nRPTMEAS/CART, 333.5, 261.2583, 40.5, 0, 0, 1\n"
      "RPTMEAS/CART, 333.5, 238.7417, 40.5, 0, 0, 1\nGOTO/CART, 340, 250, 45\n"
      "PTMEAS/CART, 350, 250, 37.5, -1, 0, 0\nPTMEAS/CART, 340, 260, 37.5, 0, -1, 0\n"
      "PTMEAS/CART, 330, 250, 37.5, 1, 0, 0\nPTMEAS/CART, 340, 240, 37.5, 0, 1, 0\nENDMES\n";
  const std::string text = header + block + "OUTPUT/FA(C)\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_FALSE(c.has("PTMEAS")) << c.text;  // no count warning: the RPTMEAS are not the circle's points
  const Ran r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::string told = "3 reference points (RPTMEAS) probed around F(C): the surface lies ";
  const auto at = r.diagnostics.find(told);
  ASSERT_NE(at, std::string::npos) << r.diagnostics;
  EXPECT_NEAR(std::stod(r.diagnostics.substr(at + told.size())), -0.5, 0.01) << r.diagnostics;
  const auto* hole = report(*r.session, "C");
  ASSERT_TRUE(hole && hole->actual);
  EXPECT_NEAR(hole->actual->position.z(), 37.0, 0.01);
  EXPECT_NEAR(hole->actual->diameter_mm, 20.0, 0.01);
  // RPTMEAS needs the surface's normal; outside a block it is a PTMEAS outside one.
  EXPECT_TRUE(check(header + "RMEAS/CIRCLE,F(C),4,VECBLD,3,3\nRPTMEAS/CART,353,250,40.5\n" +
                    "PTMEAS/CART,350,250,37.5,-1,0,0\nPTMEAS/CART,340,260,37.5,0,-1,0\n" +
                    "PTMEAS/CART,330,250,37.5,1,0,0\nENDMES\nENDFIL\n")
                  .has("RPTMEAS expects x,y,z,i,j,k"));
  EXPECT_TRUE(check(header + "RPTMEAS/CART,353,250,40.5,0,0,1\nENDFIL\n").has("error: RPTMEAS outside a MEAS block"));
}

// What RationalDMIS users' programs and tutorials hold (CSDN and fangzhenxiu.com pages): a statement
// metron does not know inside a MEAS block is skipped as it is outside one (told once), read
// leniently; a macro the program never defines (RationalDMIS's own EASI_ macros) is a call skipped
// with a warning, one defined after its call is still an error naming where; and the forms below.
// --strict refuses each.
TEST(ShopPrograms, RationalDmisShopFormsAreReadLeniently) {
  const std::string text =
      "DMISMN/'vendor', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "SNSLCT/S(P4)\nF(T)=FEAT/PLANE,CART,340,250,40,0,0,1\n"
      "CALL/M(EASI_CLEARPLN_GOTO), 1, 64.0000, 55.0000, 35.0000\n"
      "MEAS/PLANE,F(T),3\nSETMACREF/INIT\nPTMEAS/CART,320,230,40,0,0,1\nPTMEAS/CART,360,230,40,0,0,1\n"
      "PTMEAS/CART,340,270,40,0,0,1\nENDMES\nOUTPUT/FA(T)\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("8:1: warning: unknown statement SETMACREF is skipped")) << c.text;
  EXPECT_TRUE(c.has("6:6: warning: macro M(EASI_CLEARPLN_GOTO) is not defined in this program")) << c.text;
  const Ran r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* top = report(*r.session, "T");
  ASSERT_TRUE(top && top->actual);
  EXPECT_NEAR(top->actual->position.z(), 40.0, 0.01);
  const Checked strict = check(text, true);
  EXPECT_TRUE(strict.has("error: SETMACREF is not allowed inside a MEAS block")) << strict.text;
  EXPECT_TRUE(strict.has("error: macro M(EASI_CLEARPLN_GOTO) is not defined before this call")) << strict.text;
  // A clearance plane the program never defines is told at check, where the run would stop.
  EXPECT_TRUE(check("DMISMN/'c', 5.0\nSNSET/CLRSRF, FA(PLN2), 20.0000\nENDFIL\n")
                  .has("2:15: warning: feature FA(PLN2) is not defined in this program"));
  // A VFORM layout of an output device is CMM software's own: noted, the file is DMIS output.
  EXPECT_TRUE(check("DMISMN/'v', 5.0\nV(F)=VFORM/ALL\nDID(X)=DEVICE/STOR,'x.xls'\n"
                    "OPEN/DID(X),FDATA,V(F),OUTPUT,APPEND\nCLOSE/DID(X)\nENDFIL\n")
                  .has("note: the layout V(F) (VFORM) is not applied: DID(X) gets a DMIS output file"));
  // A definition the parser could not read is one error: the uses of its label after it are notes
  // that point at it (before, each was an error of its own: 3 for one fault).
  const Checked unread = check(
      "DMISMN/'u', 5.0\nDID(xls) = DEVICE/STOR,\u2018d:\\aaa.xls\u2019\nOPEN/DID(xls),FDATA,DMIS,OUTPUT\n"
      "CLOSE/DID(XLS)\nF(C)=FEAT/CIRCLE,INNER,CART,1,2,\nOUTPUT/FA(C)\nENDFIL\n");
  EXPECT_EQ(unread.errors, 2u) << unread.text;
  EXPECT_TRUE(unread.has("3:6: note: device DID(xls) is not defined: its definition at line 2 could not be read"))
      << unread.text;
  EXPECT_TRUE(unread.has("4:7: note: device DID(XLS) is not defined: its definition at line 2")) << unread.text;
  EXPECT_TRUE(unread.has("its definition at line 5 could not be read")) << unread.text;
  // A loop counter never declared is declared by its DO; a rotary table's speed is noted.
  const std::string loop = "DMISMN/'d', 5.0\nFEDRAT/ROTVEL,RPM,2\nDO/II,1,3\nTEXT/OPER,STR(II)\nENDDO\nENDFIL\n";
  const Checked looped = check(loop);
  EXPECT_EQ(looped.errors, 0u) << looped.text;
  EXPECT_TRUE(looped.has("warning: the DO variable II is not declared: this DO declares it INTGR")) << looped.text;
  EXPECT_TRUE(looped.has("note: FEDRAT/ROTVEL: the virtual CMM has no rotary table")) << looped.text;
  const auto counted = run(loop);
  ASSERT_EQ(counted.status, ExecStatus::Finished) << counted.diagnostics;
  EXPECT_EQ(texts_of(*counted.session), (std::vector<std::string>{"1", "2", "3"}));
  EXPECT_TRUE(check(loop, true).has("error: the DO variable II is not declared"));
  // A typographic quote inside a function's arguments is named (text copied from a web page).
  EXPECT_TRUE(check("DMISMN/'q', 5.0\nDECL/CHAR,20,S\nS = ASSIGN/CONCAT(\u2018ARC\u2019,'1')\nENDFIL\n")
                  .has("\u2018 is a typographic quote"));
}

// RMEAS/type,F(l),n,FA(ref) ... ENDMES (the block form Modus writes): each PTMEAS of the block is
// moved by the reference's deviation, as RMEAS/CART,...,FA(ref) is. In a dry run the touch lands
// where it is commanded, so the point shows the shift: the stated reference lies (0.5, -0.2, 0)
// off its nominal. CAST reads a cylinder's axis as a LINE and its centre as a POINT.
TEST(ShopPrograms, RmeasBlockAndCastConstructions) {
  const std::string text =
      "DMISMN/'rmeas', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, "
      "4.0\nSNSLCT/S(P4)\n"
      "F(REF)=FEAT/CIRCLE,INNER,CART,10,20,0,0,0,1,8\nFA(REF)=FEAT/CIRCLE,INNER,CART,10.5,19.8,0,0,0,1,8\n"
      "F(P)=FEAT/POINT,CART,30,20,-5,0,0,1\nRMEAS/POINT,F(P),1,FA(REF)\nPTMEAS/CART,30,20,-5,0,0,1\nENDMES\n"
      "F(Q)=FEAT/POINT,CART,40,20,-5,0,0,1\nRMEAS/POINT,F(Q),1,VECBLD,2,3\nPTMEAS/CART,40,20,-5,0,0,1\nENDMES\n"
      "FA(CY)=FEAT/CYLNDR,INNER,CART,5,6,7,0,0.6,0.8,12,20\nCONST/LINE,F(AX),CAST,FA(CY)\nCONST/"
      "POINT,F(CT),CAST,FA(CY)\n"
      "CONST/CIRCLE,F(SEC),CAST,FA(CY)\nOUTPUT/FA(P),FA(Q),FA(AX),FA(CT),FA(SEC)\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("this RMEAS names no reference feature")) << c.text;
  const Ran dry = dry_run(text);
  ASSERT_EQ(dry.status, ExecStatus::Finished) << dry.diagnostics;
  Session* session = dry.session.get();
  const auto* pt = report(*session, "P");
  ASSERT_TRUE(pt && pt->actual);
  EXPECT_NEAR((pt->actual->position - Eigen::Vector3d(30.5, 19.8, -5)).norm(), 0.0, 1e-9);
  const auto* q = report(*session, "Q");
  ASSERT_TRUE(q && q->actual);
  EXPECT_NEAR((q->actual->position - Eigen::Vector3d(40, 20, -5)).norm(), 0.0, 1e-9);
  const auto* ax = report(*session, "AX");
  ASSERT_TRUE(ax && ax->actual);
  EXPECT_NEAR(std::abs(ax->actual->direction.dot(Eigen::Vector3d(0, 0.6, 0.8))), 1.0, 1e-12);
  EXPECT_NEAR((ax->actual->position - Eigen::Vector3d(5, 6, 7)).cross(Eigen::Vector3d(0, 0.6, 0.8)).norm(), 0.0, 1e-9);
  const auto* ct = report(*session, "CT");
  ASSERT_TRUE(ct && ct->actual);
  EXPECT_NEAR((ct->actual->position - Eigen::Vector3d(5, 6, 7)).norm(), 0.0, 1e-9);
  const auto* sec = report(*session, "SEC");
  ASSERT_TRUE(sec && sec->actual);
  EXPECT_NEAR(sec->actual->diameter_mm, 12.0, 1e-12);
  const Checked bad = check(
      "DMISMN/'c', 5.0\nFA(A)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(B)=FEAT/POINT,CART,1,0,0,0,0,1\n"
      "CONST/LINE,F(L),CAST,FA(A),FA(B)\nENDFIL\n");
  EXPECT_TRUE(bad.has("CAST takes one source feature, got 2")) << bad.text;
}

// A line built through features runs from the first toward the last, as CMM software builds it:
// a CAMIO program aligns X on CONST/LINE,F(LINE001),BF,FA(PNT002),FA(PNT003) whose placeholder
// nominal says (1, 0, 0) while PNT002 lies at the larger X. Its real CMM reported the alignment
// with X along -X of the machine (DA(..)=DATSET/TRMATX,-1,...). The nominal's sense made metron's
// X the opposite, and every distance along X to a point then came out 1680 mm off the machine's.
TEST(ShopPrograms, ALineThroughFeaturesRunsFromTheFirstToTheLast) {
  const auto r = run(
      "DMISMN/'line', 5.0\nFA(P2)=FEAT/POINT,CART,1257,145,-514,0,0,-1\nFA(P3)=FEAT/POINT,CART,408,146,-514,0,0,-1\n"
      "F(L)=FEAT/LINE,UNBND,CART,0,0,0,1,0,0,0,1,0\nCONST/LINE,F(L),BF,FA(P2),FA(P3)\nOUTPUT/FA(L)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* l = report(*r.session, "L");
  ASSERT_TRUE(l && l->actual);
  const Eigen::Vector3d run_dir = Eigen::Vector3d(408 - 1257, 1, 0).normalized();
  EXPECT_NEAR(l->actual->direction.dot(run_dir), 1.0, 1e-9);
  EXPECT_NE(r.diagnostics.find("F(L) runs from FA(P2) to FA(P3), against its nominal direction"), std::string::npos)
      << r.diagnostics;
}

TEST(ShopPrograms, PromptTakesScriptedAnswersThenTheDefault) {
  const std::string text =
      "DMISMN/'p', 5.0\nDECL/COMMON,CHAR,40,PARTNO\nDECL/COMMON,REAL,LIM\nDECL/COMMON,REAL,LIM2\n"
      "PARTNO=PROMPT/'Part number ?'\nLIM=PROMPT/'Limit ?'\nLIM2=PROMPT/'Second limit ?'\n"
      "TEXT/OPER,PARTNO\nTEXT/OPER,STR(LIM)\nTEXT/OPER,STR(LIM2)\nENDFIL\n";
  const auto r = run(text, std::nullopt, {"SN-0042", "2.5"});
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  ASSERT_EQ(texts.size(), 3u);
  EXPECT_EQ(texts[0], "SN-0042");
  EXPECT_EQ(std::stod(texts[1]), 2.5);
  EXPECT_EQ(std::stod(texts[2]), 0.0);
  EXPECT_NE(r.diagnostics.find("PROMPT 'Second limit ?': no operator on the virtual CMM, answered 0"),
            std::string::npos)
      << r.diagnostics;  // The dialog CAMIO writes: its title, text and buttons make the question (it said PROMPT '').
  const auto dialog =
      run("DMISMN/'p', 5.2\nDECL/COMMON,LONG,VX\nVX=PROMPT/0,0,165,100,TITLE,'Calibrare',BUTTON,14,48,51,28,'DA',1,"
          "BUTTON,105,48,49,27,'NU',0,TEXT,24,16,133,16,'Vrei sa calibrezi ?'\nENDFIL\n");
  ASSERT_EQ(dialog.status, ExecStatus::Finished) << dialog.diagnostics;
  EXPECT_NE(dialog.diagnostics.find("PROMPT 'Calibrare: Vrei sa calibrezi ? [DA = 1, NU = 0]': no operator"),
            std::string::npos)
      << dialog.diagnostics;
}

// TEXT/QUERY,(V),len,AN|N,L|R,'question' (older and MCOSMOS-style programs ask the serial number
// so) is a PROMPT into V: it displayed V and dropped the question and the answer.
TEST(ShopPrograms, TextQueryReadsTheAnswerIntoItsVariable) {
  const std::string text =
      "DMISMN/'q', 5.0\nDECL/CHAR,20,AA\nDECL/REAL,X\nAA=ASSIGN/'none'\n"
      "TEXT/QUERY,(AA),20,AN,L,'Enter serial number'\nTEXT/QUERY,(X),8,N,R,'Temperature?'\n"
      "TEXT/OPER,CONCAT('SN=',AA)\nTEXT/OPER,STR(X*2)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0u);
  const auto r = run(text, std::nullopt, {"SN123", "21.5"});
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  ASSERT_EQ(texts.size(), 2u);
  EXPECT_EQ(texts[0], "SN=SN123");
  EXPECT_EQ(std::stod(texts[1]), 43.0);
  // A variable never declared (a tutorial's line on its own) is declared CHAR by the query, read
  // leniently; --strict names the DECL to add. Another first parameter is not a variable at all.
  const std::string undeclared =
      "DMISMN/'q', 5.0\nTEXT/QUERY,(NMVAR),20,A,L,'Write your name'\nTEXT/OPER,NMVAR\nENDFIL\n";
  const Checked lenient = check(undeclared);
  EXPECT_EQ(lenient.errors, 0u) << lenient.text;
  EXPECT_TRUE(lenient.has("warning: variable NMVAR is not declared: this TEXT/QUERY declares it CHAR")) << lenient.text;
  const auto named = run(undeclared, std::nullopt, {"Ada"});
  ASSERT_EQ(named.status, ExecStatus::Finished) << named.diagnostics;
  EXPECT_EQ(texts_of(*named.session), std::vector<std::string>{"Ada"});
  EXPECT_TRUE(check(undeclared, true).has("error: variable NMVAR is not declared: add DECL/CHAR,20,NMVAR first"));
  const Checked bad = check("DMISMN/'q', 5.0\nTEXT/QUERY,('x'),20,AN,L,'x'\nENDFIL\n");
  EXPECT_TRUE(bad.has("TEXT/QUERY takes the variable that receives the answer")) << bad.text;
}

// ---- the lenient reader -----------------------------------------------------------------------

TEST(ShopPrograms, LabelsWithAccentsPlusAndPlusMinusInEveryEncoding) {
  // The same program in UTF-8 and in Windows-1252 (è = 0xE8, ± = 0xB1): both check clean and
  // the label is the same UTF-8 text.
  const std::string utf8 =
      "DMISMN/'p', 5.1\nF(PLN_Sph\xC3\xA8res+\xC2\xB1)=FEAT/PLANE,CART,0,0,0,0,0,1\n"
      "T(F1)=TOL/FLAT,0.1\nOUTPUT/FA(PLN_Sph\xC3\xA8res+\xC2\xB1),TA(F1)\nENDFIL\n";
  const std::string latin =
      "DMISMN/'p', 5.1\nF(PLN_Sph\xE8res+\xB1)=FEAT/PLANE,CART,0,0,0,0,0,1\n"
      "T(F1)=TOL/FLAT,0.1\nOUTPUT/FA(PLN_Sph\xE8res+\xB1),TA(F1)\nENDFIL\n";
  for (const auto* t : {&utf8, &latin}) {
    const auto c = check(*t);
    EXPECT_EQ(c.errors, 0u) << c.text;
  }
  SourceManager sources;
  const auto id = sources.add("latin.dmi", latin);
  EXPECT_EQ(sources.file(id).encoding, metron::TextEncoding::Windows1252);
  EXPECT_EQ(sources.file(id).text, utf8);
  // Windows-1252's own characters (0x80-0x9F): the euro sign and a curly quote.
  EXPECT_EQ(metron::to_utf8("\x80\x93"), "\xE2\x82\xAC\xE2\x80\x9C");  // U+20AC, U+201C (WHATWG table)
  // Both in one file (a lab's generator pasted UTF-8 names into a Windows-1252 template): each line
  // is read in its own, and the label is one (it was two, the OUTPUT's never defined).
  const std::string mixed =
      "DMISMN/'p', 5.1\nF(PLN_Sph\xE8res+\xB1)=FEAT/PLANE,CART,0,0,0,0,0,1\n"
      "T(F1)=TOL/FLAT,0.1\nOUTPUT/FA(PLN_Sph\xC3\xA8res+\xC2\xB1),TA(F1)\nENDFIL\n";
  const auto both = check(mixed);
  EXPECT_EQ(both.errors, 0u) << both.text;
  EXPECT_FALSE(both.has("never defined")) << both.text;
  EXPECT_EQ(metron::to_utf8(mixed), utf8);
}

TEST(ShopPrograms, ProgramsSavedAsUtf16AreRead) {
  // Windows editors save "Unicode" text as UTF-16 (with or without a byte-order mark): before,
  // "expected a major word" at 1:1 with a NUL after every letter.
  const std::string text =
      "DMISMN/'p', 5.1\r\nF(PLN_Sph\xC3\xA8res)=FEAT/PLANE,CART,0,0,0,0,0,1\r\n"
      "TEXT/OPER,'\xF0\x9D\x9C\x8B ok'\r\nFEAT PLANE\r\nENDFIL\r\n";  // a 4-byte character: a surrogate pair
  // UTF-16 from UTF-8, by hand (the test's own encoder: code points, then units).
  const auto utf16 = [&](bool little, bool bom) {
    std::u32string cps;
    for (std::size_t i = 0; i < text.size();) {
      const auto c = static_cast<unsigned char>(text[i]);
      const std::size_t n = c < 0x80 ? 1 : c < 0xE0 ? 2 : c < 0xF0 ? 3 : 4;
      char32_t cp = n == 1 ? c : n == 2 ? (c & 0x1F) : n == 3 ? (c & 0x0F) : (c & 0x07);
      for (std::size_t k = 1; k < n; ++k) cp = (cp << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3F);
      cps.push_back(cp);
      i += n;
    }
    std::string out;
    const auto put = [&](unsigned u) {
      out += static_cast<char>(little ? u & 0xFF : u >> 8);
      out += static_cast<char>(little ? u >> 8 : u & 0xFF);
    };
    if (bom) put(0xFEFF);
    for (char32_t cp : cps) {
      if (cp >= 0x10000) {
        put(0xD800 + ((cp - 0x10000) >> 10));
        put(0xDC00 + ((cp - 0x10000) & 0x3FF));
      } else {
        put(cp);
      }
    }
    return out;
  };
  for (const bool little : {true, false})
    for (const bool bom : {true, false}) {
      SourceManager sources;
      const auto id = sources.add("u16.dmi", utf16(little, bom));
      EXPECT_EQ(sources.file(id).encoding, little ? metron::TextEncoding::Utf16Le : metron::TextEncoding::Utf16Be);
      EXPECT_EQ(sources.file(id).text, text) << little << bom;
      const auto c = check(utf16(little, bom));
      EXPECT_EQ(c.errors, 1u) << c.text;  // FEAT PLANE, at its own line and column
      EXPECT_TRUE(c.has("shop.dmi:4:6: error: expected '/' after the major word 'FEAT'")) << c.text;
    }
  // A lone surrogate and a lone last byte are U+FFFD, not a crash.
  EXPECT_EQ(metron::to_utf8(std::string("\xFF\xFE"
                                        "A\0\x00\xD8"
                                        "B",
                                        7)),
            "A\xEF\xBF\xBD\xEF\xBF\xBD");
}

TEST(ShopPrograms, ContinuationInsideALabelSkipsTheLeadingBlanks) {
  const auto c = check(
      "DMISMN/'p', 5.1\nF(CIR_1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\n"
      "T(D1)=TOL/DIAM,-0.1,0.1\nOUTPUT/FA(CIR_$\n    1),TA(D1)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
}

TEST(ShopPrograms, NonStatementLinesAreOneWarningEachLenientAndErrorsStrict) {
  const std::string text =
      "DMISMN/'p', 5.1\n-------------------------\nOperator: turn the part over\nFEAT PLANE\n"
      "//////////////////////////////////////\nENDFIL\n";
  const auto lenient = check(text);
  EXPECT_EQ(lenient.warnings, 3u) << lenient.text;
  // CAMIO writes separators of slashes around operator notes: a line of symbols only is a note.
  EXPECT_TRUE(lenient.has("5:1: warning: this line is not a DMIS statement")) << lenient.text;
  EXPECT_TRUE(lenient.has("2:1: warning: this line is not a DMIS statement and is skipped")) << lenient.text;
  EXPECT_TRUE(lenient.has("3:1: warning: this line is not a DMIS statement")) << lenient.text;
  EXPECT_EQ(lenient.errors, 1u) << lenient.text;  // FEAT PLANE is a statement with an error
  EXPECT_TRUE(lenient.has("4:6: error: expected '/' after the major word 'FEAT'")) << lenient.text;
  const auto strict = check(text, true);
  EXPECT_EQ(strict.errors, 4u) << strict.text;
}

TEST(ShopPrograms, TextAfterEndfilIsReportedOnceAsASecondProgram) {
  const auto c =
      check("DMISMN/'one', 5.1\nENDFIL\nDMISMN/'two', 5.1\nF(X)=FEAT/POINT,CART,0,0,0,0,0,1\nGARBAGE !!\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 1u) << c.text;
  EXPECT_TRUE(c.has("3 statements after ENDFIL are ignored: the file holds a second program (DMISMN after ENDFIL)"))
      << c.text;
}

// ---- defects found as a new user --------------------------------------------------------------

// CMM software keeps the actuals of its last run; a CAMIO program that ran on a real machine
// defines its datums from FA(x) measured only further down (CMMPyAna, proto3-corr.dmi). Read
// leniently that is a warning, and a run stops at the use when x has no actual by then.
TEST(ShopPrograms, ActualsFromAnEarlierRunAreReadLeniently) {
  const std::string text =
      "DMISMN/'p', 5.1\nDATDEF/FA(PL),DAT(A)\nD(R)=DATSET/DAT(A),ZDIR,ZORIG\n"
      "CONST/POINT,F(M),MIDPT,FA(OLD1),FA(OLD2)\n"
      "F(PL)=FEAT/PLANE,CART,0,0,0,0,0,1\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0U) << c.text;
  EXPECT_TRUE(
      c.has("2:8: warning: feature FA(PL) is used before its definition at line 5: CMM software may keep its "
            "actual from an earlier run, metron does not"))
      << c.text;
  EXPECT_TRUE(c.has("4:24: warning: feature FA(OLD1) is not defined in this program: CMM software may keep its actual"))
      << c.text;
  EXPECT_GE(check(text, true).errors, 3U);  // --strict: errors
  const auto r = run(text);
  EXPECT_NE(r.status, ExecStatus::Finished);
  EXPECT_NE(r.diagnostics.find("run.dmi:2:1: error: FA(PL) is not defined yet: it has no actual"), std::string::npos)
      << r.diagnostics;
  // A nominal used before its FEAT stays an error.
  EXPECT_TRUE(check("DMISMN/'p', 5.1\nMEAS/POINT,F(P),1\nENDMES\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n")
                  .has("2:12: error: feature F(P) is used before its definition at line 4"));
}

TEST(ShopPrograms, NeverDefinedFeatureIsNotDefinedNotUsedBeforeItsDefinition) {
  EXPECT_TRUE(check("DMISMN/'p', 5.1\nDATDEF/FA(NOWHERE),DAT(A)\nENDFIL\n", true)
                  .has("feature FA(NOWHERE) is not defined: define it with F(NOWHERE)=FEAT/..."));
  EXPECT_TRUE(check("DMISMN/'p', 5.1\nDATDEF/FA(NOWHERE),DAT(A)\nENDFIL\n")
                  .has("feature FA(NOWHERE) is not defined in this program"));
  EXPECT_TRUE(check("DMISMN/'p', 5.1\nOUTPUT/FA(LATER)\nF(LATER)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n")
                  .has("feature FA(LATER) is used before its definition at line 3"));
}

// A feature the program defines and reads as FA(x) but never measures, constructs or states: check
// says so where it is read (the run has no actual there: a CONST stops it), once per feature. A
// feature measured anywhere (in a macro, as an indexed family) is not told; when a measured name
// is known only at run (a macro parameter), check cannot tell and says nothing.
TEST(ShopPrograms, AFeatureNeverMeasuredIsToldWhereItIsRead) {
  const std::string head = "DMISMN/'p', 5.1\nUNITS/MM,ANGDEC\nF(P1)=FEAT/POINT,CART,0,0,40,0,0,1\n";
  const std::string never = head + "F(P2)=FEAT/POINT,CART,10,0,40,0,0,1\nMEAS/POINT,F(P2),1\nENDMES\n" +
                            "CONST/LINE,F(L),BF,FA(P1),FA(P2)\nOUTPUT/FA(P1)\nENDFIL\n";
  const auto c = check(never);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 1u) << c.text;  // once, at the first read
  EXPECT_TRUE(c.has("7:20: warning: FA(P1) is read here, but nothing in this program measures or constructs P1"))
      << c.text;
  EXPECT_TRUE(check(never, true).has("warning: FA(P1) is read here")) << "strict: still valid DMIS, a warning";
  // The run agrees: it stops at the CONST for want of P1's actual.
  const auto r = dry_run(never);
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find("FA(P1) has no actual"), std::string::npos) << r.diagnostics;

  const std::string measured_in_a_macro =
      head + "M(TOUCH)=MACRO\nMEAS/POINT,F(P1),1\nENDMES\nENDMAC\nCALL/M(TOUCH)\nOUTPUT/FA(P1)\nENDFIL\n";
  const auto m = check(measured_in_a_macro);
  EXPECT_EQ(m.errors, 0u) << m.text;
  EXPECT_FALSE(m.has("nothing in this program measures")) << m.text;
  const std::string indexed =
      "DMISMN/'p', 5.1\nDECL/INTGR,I\nDO/I,1,2\nF(H[I])=FEAT/POINT,CART,I,0,40,0,0,1\n"
      "MEAS/POINT,F(H[I]),1\nENDMES\nENDDO\nOUTPUT/FA(H[1])\nENDFIL\n";
  const auto x = check(indexed);
  // The same family defined and never measured is told at its read.
  std::string unmeasured = indexed;
  unmeasured.replace(unmeasured.find("MEAS/POINT,F(H[I]),1\nENDMES\n"), 29, "");
  EXPECT_TRUE(check(unmeasured).has("FA(H[1]) is read here, but nothing in this program measures")) << unmeasured;
  EXPECT_EQ(x.errors, 0u) << x.text;
  EXPECT_FALSE(x.has("nothing in this program measures")) << x.text;
  const std::string by_parameter = head +
                                   "M(TOUCH)=MACRO/'X'\nMEAS/POINT,F(X),1\nENDMES\nENDMAC\nCALL/M(TOUCH),F(P1)\n"
                                   "OUTPUT/FA(P1)\nENDFIL\n";
  const auto b = check(by_parameter);
  EXPECT_EQ(b.errors, 0u) << b.text;
  EXPECT_FALSE(b.has("nothing in this program measures")) << b.text;
}

// FA(x) read after its FEAT but before the MEAS further down, in a program that runs straight
// through: told at the read with the line of the MEAS; the run stops there as told. A loop or a
// jump back could make the order right, a macro or a called file could measure it first, and an
// FA(x) read before its FEAT is told by the compiler already: no word from this check then.
TEST(ShopPrograms, AFeatureReadBeforeItIsMeasuredIsTold) {
  const std::string head = "DMISMN/'p', 5.1\nUNITS/MM,ANGDEC\nF(P1)=FEAT/POINT,CART,0,0,40,0,0,1\n";
  const std::string measure = "MEAS/POINT,F(P1),1\nENDMES\n";
  const std::string early = head + "DATDEF/FA(P1),DAT(A)\n" + measure + "OUTPUT/FA(P1)\nENDFIL\n";
  const auto c = check(early);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 1u) << c.text;
  EXPECT_TRUE(c.has("4:8: warning: FA(P1) is read here, before P1 is measured or constructed (first at line 5)"))
      << c.text;
  const auto r = dry_run(early);
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find("FA(P1) has no actual"), std::string::npos) << r.diagnostics;

  const std::string in_order = head + measure + "DATDEF/FA(P1),DAT(A)\nENDFIL\n";
  EXPECT_EQ(check(in_order).warnings, 0u) << check(in_order).text;
  // A second pass of a loop reads the actual the first pass measured.
  const std::string looped =
      "DMISMN/'p', 5.1\nDECL/INTGR,I\nF(P1)=FEAT/POINT,CART,0,0,40,0,0,1\nDO/I,1,2\n"
      "IF/(I.EQ.2)\nOUTPUT/FA(P1)\nENDIF\n" +
      measure + "ENDDO\nENDFIL\n";
  EXPECT_FALSE(check(looped).has("before P1 is measured")) << check(looped).text;
  const std::string jumped_back = head + "(AGAIN)\nOUTPUT/FA(P1)\n" + measure + "JUMPTO/(AGAIN)\nENDFIL\n";
  EXPECT_FALSE(check(jumped_back).has("before P1 is measured")) << check(jumped_back).text;
  const std::string by_macro =
      head + "M(TOUCH)=MACRO\n" + measure + "ENDMAC\nCALL/M(TOUCH)\nOUTPUT/FA(P1)\n" + measure + "ENDFIL\n";
  EXPECT_FALSE(check(by_macro).has("before P1 is measured")) << check(by_macro).text;
  // Before its FEAT: the compiler's warning alone.
  const std::string before_feat =
      "DMISMN/'p', 5.1\nOUTPUT/FA(P1)\nF(P1)=FEAT/POINT,CART,0,0,40,0,0,1\n" + measure + "ENDFIL\n";
  const auto f = check(before_feat);
  EXPECT_EQ(f.warnings, 1u) << f.text;
  EXPECT_TRUE(f.has("FA(P1) is used before its definition")) << f.text;
}

// A CAMIO program generated for a ladder of modules outputs the features of inserts it never
// measured (OUTPUT/FA(PNTC06F1),TA(C06F1) with no F(PNTC06F1) anywhere), and ran on the machine.
// Read leniently, such an item is left out with a warning, and a tolerance left without a
// feature goes with it; --strict keeps the error. A feature defined later stays an error.
TEST(ShopPrograms, OutputOfAFeatureTheProgramNeverDefinesIsLeftOutLeniently) {
  const std::string text =
      "DMISMN/'p', 5.1\nF(P1)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(P1)=FEAT/POINT,CART,0,0,0.004,0,0,1\n"
      "T(Z)=TOL/CORTOL,ZAXIS,-0.01,0.01\nOUTPUT/FA(NEVER),TA(Z)\nOUTPUT/FA(P1),FA(NEVER2),TA(Z)\nENDFIL\n";
  const auto lenient = check(text);
  EXPECT_EQ(lenient.errors, 0u) << lenient.text;
  EXPECT_TRUE(lenient.has("5:8: warning: feature FA(NEVER) is never defined in this program: left out of this OUTPUT"))
      << lenient.text;
  EXPECT_TRUE(lenient.has("5:18: note: T(Z) is left out with the feature")) << lenient.text;
  EXPECT_TRUE(lenient.has("6:15: warning: feature FA(NEVER2) is never defined")) << lenient.text;
  const auto strict = check(text, true);
  EXPECT_TRUE(strict.has("5:8: error: feature FA(NEVER) is not defined")) << strict.text;
  // The run reports the defined feature's tolerance, and only it.
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::size_t results = 0;
  for (const auto& e : r.session->record().events)
    results += std::holds_alternative<metron::runtime::ToleranceResult>(e);
  EXPECT_EQ(results, 1u);
  const auto* z = tolerance(*r.session, "Z");
  ASSERT_NE(z, nullptr);
  EXPECT_NEAR(z->value, 0.004, 1e-12);
}

// CONST PARTO/PERPTO (a CAMIO lab program builds its datum plane with
// CONST/PLANE,F(..),PARTO,FA(plane),THRU,FA(point)). Stated actuals make the expected geometry
// analytic: a plane with normal (0, 0.6, 0.8) and the point (10, 20, 30).
TEST(ShopPrograms, PartoAndPerptoConstructThroughAPoint) {
  const std::string head =
      "DMISMN/'p', 5.1\nF(A)=FEAT/PLANE,CART,0,0,0,0,0.6,0.8\nFA(A)=FEAT/PLANE,CART,1,2,-1.25,0,0.6,0.8\n"
      "F(P)=FEAT/POINT,CART,10,20,30,0,0,1\nFA(P)=FEAT/POINT,CART,10,20,30,0,0,1\n"
      "F(L)=FEAT/LINE,UNBND,CART,0,0,0,1,0,0,0,0,1\nFA(L)=FEAT/LINE,UNBND,CART,5,5,5,-1,0,0,0,0,1\n"
      "F(B)=FEAT/PLANE,CART,0,0,0,0,0,1\nF(N)=FEAT/LINE,UNBND,CART,0,0,0,0,0,1,1,0,0\nF(Q)=FEAT/"
      "PLANE,CART,0,0,0,1,0,0\n";
  const std::string text = head +
                           "CONST/PLANE,F(B),PARTO,FA(A),THRU,FA(P)\nCONST/LINE,F(N),PERPTO,FA(A),THRU,FA(P)\n"
                           "CONST/PLANE,F(Q),PERPTO,FA(L),THRU,FA(P)\nCONST/LINE,F(M),PARTO,FA(L),THRU,FA(P)\n"
                           "OUTPUT/FA(B),FA(N),FA(Q),FA(M)\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const Eigen::Vector3d p(10, 20, 30), n(0, 0.6, 0.8), x(1, 0, 0);
  const auto expect = [&](const char* label, const Eigen::Vector3d& dir) {
    const auto* f = report(*r.session, label);
    ASSERT_NE(f, nullptr) << label;
    ASSERT_TRUE(f->actual.has_value()) << label;
    // Through the point: for a plane the point lies in it, for a line on it.
    const Eigen::Vector3d d = f->actual->position - p;
    if (f->actual->type == metron::runtime::FeatureType::Plane)
      EXPECT_NEAR(d.dot(dir), 0.0, 1e-12) << label;
    else
      EXPECT_NEAR(d.cross(dir).norm(), 0.0, 1e-12) << label;
    EXPECT_NEAR(f->actual->direction.dot(dir), 1.0, 1e-12) << label;  // the nominal's sense
  };
  expect("B", n);   // parallel to A
  expect("N", n);   // along A's normal
  expect("Q", x);   // normal to L (L runs along -x; Q's nominal says +x)
  expect("M", -x);  // parallel to L; M has no nominal, so L's actual sense (-x) stays
  // Wrong references and forms are positioned errors.
  const auto bad_ref = run(head + "CONST/PLANE,F(B),PARTO,FA(L),THRU,FA(P)\nENDFIL\n");
  EXPECT_NE(bad_ref.diagnostics.find("PARTO a PLANE needs a PLANE as its reference, got a LINE"), std::string::npos)
      << bad_ref.diagnostics;
  // THRU may be left out, as shop software (Creo CMM) writes it: the same plane.
  const auto no_thru = run(head + "CONST/PLANE,F(B),PARTO,FA(A),FA(P)\nOUTPUT/FA(B)\nENDFIL\n");
  ASSERT_EQ(no_thru.status, ExecStatus::Finished) << no_thru.diagnostics;
  const auto* b = report(*no_thru.session, "B");
  ASSERT_TRUE(b != nullptr && b->actual.has_value());
  EXPECT_NEAR((b->actual->position - p).dot(n), 0.0, 1e-12);
  EXPECT_NEAR(b->actual->direction.dot(n), 1.0, 1e-12);
  const auto no_point = check(head + "CONST/PLANE,F(B),PARTO,FA(A),THRU\nENDFIL\n");
  EXPECT_TRUE(no_point.has("PARTO takes a reference and a point: PARTO,FA(ref),THRU,FA(point)")) << no_point.text;
  const auto circle =
      check(head + "F(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,5\nCONST/CIRCLE,F(C),PERPTO,FA(A),THRU,FA(P)\nENDFIL\n");
  EXPECT_TRUE(circle.has("PERPTO constructs a PLANE or a LINE")) << circle.text;
}

// PROJPT, PROJLN (PROJLI, Creo CMM's word) and PROJCT onto a tilted plane, from stated actuals:
// the foot of the point, the line's direction less its normal part (0,0,1) - 0.8 n, normalised
// to (0, -0.8, 0.6), the circle's centre with its diameter.
TEST(ShopPrograms, ProjectionsOntoAPlane) {
  const std::string text =
      "DMISMN/'proj', 5.1\nFA(A)=FEAT/PLANE,CART,1,2,-1.25,0,0.6,0.8\n"
      "FA(P)=FEAT/POINT,CART,10,20,30,0,0,1\nFA(L)=FEAT/LINE,UNBND,CART,5,5,5,0,0,1,1,0,0\n"
      "FA(C)=FEAT/CIRCLE,INNER,CART,3,4,9,0,0,1,12\n"
      "F(PP)=FEAT/POINT,CART,0,0,0,0,0.6,0.8\nF(PL)=FEAT/LINE,UNBND,CART,0,0,0,0,-0.8,0.6,1,0,0\n"
      "F(PI)=FEAT/LINE,UNBND,CART,0,0,0,0,-0.8,0.6,1,0,0\nF(PC)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0.6,0.8,12\n"
      "CONST/POINT,F(PP),PROJPT,FA(P),FA(A)\nCONST/LINE,F(PL),PROJLN,FA(L),FA(A)\n"
      "CONST/LINE,F(PI),PROJLI,FA(L),FA(A)\nCONST/CIRCLE,F(PC),PROJCT,FA(C),FA(A)\n"
      "OUTPUT/FA(PP),FA(PL),FA(PI),FA(PC)\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const Eigen::Vector3d a(1, 2, -1.25), n(0, 0.6, 0.8);
  const auto actual = [&](const char* label) {
    const auto* f = report(*r.session, label);
    EXPECT_TRUE(f != nullptr && f->actual.has_value()) << label;
    return f != nullptr && f->actual ? *f->actual : metron::runtime::Geometry{};
  };
  // (P - a).n = 35.8: the foot is P - 35.8 n.
  EXPECT_LT((actual("PP").position - Eigen::Vector3d(10, 20 - 21.48, 30 - 28.64)).norm(), 1e-12);
  for (const char* line : {"PL", "PI"}) {
    const auto g = actual(line);
    EXPECT_NEAR((g.position - a).dot(n), 0.0, 1e-12) << line;
    EXPECT_LT((g.position - Eigen::Vector3d(5, 5, 5)).cross(n).norm(), 1e-12) << line;  // the foot of L's point
    EXPECT_NEAR(g.direction.dot(Eigen::Vector3d(0, -0.8, 0.6)), 1.0, 1e-12) << line;
  }
  const auto c = actual("PC");
  EXPECT_NEAR((c.position - a).dot(n), 0.0, 1e-12);
  EXPECT_LT((c.position - Eigen::Vector3d(3, 4, 9)).cross(n).norm(), 1e-12);
  EXPECT_NEAR(c.diameter_mm, 12.0, 1e-12);
}

// MIDPL, MIDLI, COPY and VERTEX: hand-computed answers from stated actuals.
TEST(ShopPrograms, MidPlaneMidLineCopyAndVertexConstructions) {
  const std::string head =
      "DMISMN/'mid', 5.1\nFA(P1)=FEAT/PLANE,CART,0,0,0,0,0,1\nFA(P2)=FEAT/PLANE,CART,5,5,10,0,0.6,-0.8\n"
      "FA(L1)=FEAT/LINE,UNBND,CART,0,0,0,1,0,0,0,0,1\nFA(L2)=FEAT/LINE,UNBND,CART,7,10,0,-1,0,0,0,0,1\n"
      "FA(C)=FEAT/CIRCLE,INNER,CART,1,2,3,0,0,1,8\nFA(K)=FEAT/CONE,INNER,CART,4,5,6,0,0,1,60\n";
  const auto r = run(head +
                     "CONST/PLANE,F(MP),MIDPL,FA(P1),FA(P2)\nCONST/LINE,F(ML),MIDLI,FA(L1),FA(L2)\n"
                     "CONST/CIRCLE,F(CC),COPY,FA(C)\nCONST/POINT,F(V),VERTEX,FA(K)\n"
                     "OUTPUT/FA(MP),FA(ML),FA(CC),FA(V)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto actual = [&](const char* label) {
    const auto* f = report(*r.session, label);
    EXPECT_TRUE(f && f->actual) << label;
    return f && f->actual ? *f->actual : metron::runtime::Geometry{};
  };
  // The mid-plane bisects the normals (0,0,1) and (0,-0.6,0.8), P2's turned to P1's sense, and
  // passes midway between the planes' points.
  const auto mp = actual("MP");
  const Eigen::Vector3d bisector = Eigen::Vector3d(0, -0.6, 1.8).normalized();
  EXPECT_NEAR(mp.direction.dot(bisector), 1.0, 1e-12);
  EXPECT_NEAR((mp.position - Eigen::Vector3d(2.5, 2.5, 5)).dot(bisector), 0.0, 1e-12);
  // The mid-line of y = 0 and y = 10 (opposite senses) is y = 5 along +x.
  const auto ml = actual("ML");
  EXPECT_NEAR(ml.direction.dot(Eigen::Vector3d::UnitX()), 1.0, 1e-12);
  // Its point is midway between L1's point and the nearest point of L2 (not the points' midpoint
  // (3.5, 5, 0), which slides along the line with where each line's point happened to be).
  EXPECT_NEAR((ml.position - Eigen::Vector3d(0, 5, 0)).norm(), 0.0, 1e-12);
  const auto cc = actual("CC");
  EXPECT_EQ(cc.type, metron::runtime::FeatureType::Circle);
  EXPECT_NEAR((cc.position - Eigen::Vector3d(1, 2, 3)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(cc.diameter_mm, 8.0, 1e-12);
  EXPECT_NEAR((actual("V").position - Eigen::Vector3d(4, 5, 6)).norm(), 0.0, 1e-12);  // the apex
  // Wrong types are errors: at check where the words say so, at run where the sources do.
  const Checked wrong = check(head + "CONST/LINE,F(X),MIDPL,FA(P1),FA(P2)\nENDFIL\n");
  EXPECT_TRUE(wrong.has("MIDPL constructs a PLANE")) << wrong.text;
  const auto not_cone = run(head + "CONST/POINT,F(V),VERTEX,FA(C)\nENDFIL\n");
  EXPECT_NE(not_cone.diagnostics.find("VERTEX is the apex of a CONE, got a CIRCLE"), std::string::npos)
      << not_cone.diagnostics;
  const auto retype = run(head + "CONST/POINT,F(X),COPY,FA(C)\nENDFIL\n");
  EXPECT_NE(retype.diagnostics.find("COPY keeps the type"), std::string::npos) << retype.diagnostics;
  const auto lines = run(head + "CONST/LINE,F(X),MIDLI,FA(L1),FA(P1)\nENDFIL\n");
  EXPECT_NE(lines.diagnostics.find("the mid line of two LINEs (or axes), got a PLANE"), std::string::npos)
      << lines.diagnostics;
}

// TOL/DISTB and DISTWRT with MINIM and MAXIM: between the near or far sides of features of size.
// Forms metron does not evaluate (a CORTOL coordinate other than XAXIS, YAXIS, ZAXIS, RADIUS,
// ANGLE) are left out with a warning, as an unknown tolerance type is, instead of stopping check.
// CORTOL,ANGLE and DISTB,LIMIT were such forms; they are evaluated now
// (ShopPrograms.PolarCoordinatesAndDistanceLimitsAreEvaluated).
TEST(ShopPrograms, UnevaluatedToleranceFormsAreLeftOut) {
  const Checked c = check(
      "DMISMN/'f', 5.0\nF(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nFA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\n"
      "T(CA)=TOL/CORTOL,ANGLE,-1,1\nT(DB)=TOL/DISTB,LIMIT,39.9,40.1\nT(CQ)=TOL/CORTOL,PHI,-1,1\n"
      "OUTPUT/FA(C),TA(CA),TA(CQ)\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_FALSE(c.has("TOL/CORTOL,ANGLE is not evaluated by metron")) << c.text;
  EXPECT_FALSE(c.has("TOL/DISTB,LIMIT is not evaluated by metron")) << c.text;
  EXPECT_TRUE(c.has("TOL/CORTOL,PHI is not evaluated by metron")) << c.text;
  // A scanned GCURVE: run refused it, check now does.
  const Checked scan = check(
      "DMISMN/'g', 5.0\nP(PTH1)=PATH/LINE,CART,10,50,0,90,50,0,0,-1,0\nF(GC1)=FEAT/GCURVE,CART,10,50,0,0,-1,0\n"
      "MEAS/GCURVE,F(GC1),20\nPAMEAS/P(PTH1)\nENDMES\nENDFIL\n");
  EXPECT_TRUE(scan.has("F(GC1) is a GCURVE: it is measured by PTMEAS points, each its own nominal, not by a scan"))
      << scan.text;
  // A feature constructed by a method metron does not evaluate: its OUTPUT is left out with its
  // tolerance (the run stopped at "OUTPUT of FA(TANP) before it was measured").
  const std::string tangent =
      "DMISMN/'o', 5.0\nFA(PA)=FEAT/PLANE,CART,0,0,0,0,0,1\nF(TANP)=FEAT/PLANE,CART,0,0,5,0,0,1\n"
      "CONST/PLANE,F(TANP),TANTO,FA(PA),FA(PA)\nT(FL)=TOL/FLAT,0.01\nOUTPUT/FA(TANP),TA(FL)\nOUTPUT/FA(PA)\nENDFIL\n";
  const Checked o = check(tangent);
  EXPECT_EQ(o.errors, 0u) << o.text;
  EXPECT_TRUE(o.has("FA(TANP) has no actual: its CONST method TANTO is not supported; left out of this OUTPUT"))
      << o.text;
  const auto r = run(tangent);
  EXPECT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
}

TEST(ShopPrograms, DistanceBetweenTheSidesOfHoles) {
  const std::string text =
      "DMISMN/'sides', 5.1\nDECL/REAL,WALL,SPAN,AXIAL\n"
      "F(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nFA(C1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\n"
      "F(C2)=FEAT/CIRCLE,INNER,CART,50,0,0,0,0,1,6\nFA(C2)=FEAT/CIRCLE,INNER,CART,50.02,0,0,0,0,1,6.04\n"
      "T(WALL)=TOL/DISTB,NOMINL,42,-0.1,0.1,MINIM\nT(SPAN)=TOL/DISTB,NOMINL,58,-0.1,0.1,XAXIS,MAXIM\n"
      "T(REF)=TOL/DISTWRT,NOMINL,58,-0.1,0.1,FA(C1),XAXIS,MAXIM\n"
      "OUTPUT/FA(C1),FA(C2),TA(WALL)\nOUTPUT/FA(C1),FA(C2),TA(SPAN)\nOUTPUT/FA(C2),TA(REF)\n"
      "WALL=VALUE/TA(WALL),ACT\nSPAN=VALUE/TA(SPAN),ACT\nAXIAL=VALUE/TA(REF),ACT\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0u);
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  // 50.02 - 5 - 3.02 and 50.02 + 5 + 3.02.
  EXPECT_NEAR(r.session->interpreter().variable("WALL")->number, 42.0, 1e-9);
  EXPECT_NEAR(r.session->interpreter().variable("SPAN")->number, 58.04, 1e-9);
  EXPECT_NEAR(r.session->interpreter().variable("AXIAL")->number, 58.04, 1e-9);
}

// WRITE/DID(x),V:w:d lays a value out Fortran-like: a number with d decimals right-aligned in w
// characters, a text left-aligned; a value wider than its field is written whole.
TEST(ShopPrograms, WriteLaysOutValuesInTheirFields) {
  const fs::path out = temp_dir() / "write_format_out";
  fs::remove_all(out);
  fs::create_directories(out);
  const std::string text =
      "DMISMN/'fmt', 5.1\nDECL/REAL,X\nDECL/INTGR,N\nX=ASSIGN/-12.34567\nN=ASSIGN/42\n"
      "DID(T)=DEVICE/STOR,'table.txt'\nOPEN/DID(T),DIRECT,OUTPUT,OVERWR\n"
      "WRITE/DID(T),'D':4,X:10:3,N:5,'|',X:3:1,N:6:2,' ',-0.0004:5:3\nCLOSE/DID(T)\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0u);
  const fs::path p = write("write_format.dmi", text);
  auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
  ASSERT_TRUE(backend.has_value());
  auto session = Session::create(std::move(*backend));
  session->runtime().set_output_directory(out.string());
  ASSERT_TRUE(session->load(p.string()));
  ASSERT_EQ(session->interpreter().run(), ExecStatus::Finished) << session->take_diagnostics();
  std::ifstream in(out / "table.txt", std::ios::binary);
  const std::string written((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(written, "D      -12.346   42|-12.3 42.00 0.000\n");
  // A layout outside WRITE, and a field without its width, are positioned errors.
  const Checked outside = check("DMISMN/'fmt', 5.1\nDECL/REAL,X\nX=ASSIGN/1:3\nENDFIL\n");
  EXPECT_TRUE(outside.has("a layout ':width:decimals' belongs to the values of WRITE only")) << outside.text;
  const Checked no_width = check("DMISMN/'fmt', 5.1\nDECL/REAL,X\nDID(T)=DEVICE/STOR,'t'\nWRITE/DID(T),X:\nENDFIL\n");
  EXPECT_TRUE(no_width.has("expected a field width after ':'")) << no_width.text;
}

namespace {
// The holes a DO loop stated (FA(...)=FEAT): hole i at x = 100 + 20 i, 10 + i/100 mm across.
void expect_stated_holes(Session& s, const std::vector<std::string>& labels, const std::vector<int>& indices) {
  for (std::size_t k = 0; k < labels.size(); ++k) {
    const auto* h = report(s, labels[k]);
    ASSERT_TRUE(h && h->actual) << labels[k];
    EXPECT_NEAR(h->actual->position.x(), 100 + 20 * indices[k], 1e-12);
    EXPECT_NEAR(h->actual->diameter_mm, 10 + indices[k] / 100.0, 1e-12);
  }
}
}  // namespace

// Indexed labels (DMIS 5.x): F(H[I]) in a loop defines H[1], H[2], H[3]; FA(H[2]) and FA(H[I-1])
// name them afterwards. check reads the family H[] as one feature.
TEST(ShopPrograms, IndexedLabelsNameOneFeaturePerIndex) {
  const std::string text =
      "DMISMN/'indexed', 5.0\nUNITS/MM,ANGDEC\nDECL/INTGR,I\nDECL/REAL,D\nT(DIA)=TOL/DIAM,-0.05,0.05\n"
      "DO/I,1,3\n  F(H[I])=FEAT/CIRCLE,INNER,CART,100+20*I,100,-5,0,0,1,10\n"
      "  FA(H[ I ])=FEAT/CIRCLE,INNER,CART,100+20*I,100,-5,0,0,1,10+I/100\n  OUTPUT/FA(H[I]),TA(DIA)\nENDDO\n"
      "D=VALUE/FA(H[2]),SIZE\nCONST/POINT,F(M),MIDPT,FA(H[1]),FA(H[I-1])\nOUTPUT/FA(M)\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  expect_stated_holes(*r.session, {"H[1]", "H[2]", "H[3]"}, {1, 2, 3});
  EXPECT_NEAR(r.session->interpreter().variable("D")->number, 10.02, 1e-12);
  const auto* m = report(*r.session, "M");  // after the loop I is 4: between H[1] and H[3]
  ASSERT_TRUE(m && m->actual);
  EXPECT_NEAR(m->actual->position.x(), 140.0, 1e-12);
  // An index that is no number, a family never defined and a missing ']' are positioned errors.
  const Checked bad = check(
      "DMISMN/'i', 5.0\nDECL/CHAR,8,S\nF(H[S])=FEAT/POINT,CART,0,0,0,0,0,1\nOUTPUT/FA(G[1])\n"
      "F(K[1)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n");
  EXPECT_TRUE(bad.has("a label's index")) << bad.text;
  EXPECT_TRUE(bad.has("G[1]")) << bad.text;
  EXPECT_TRUE(bad.has("expected ']' after the label's index")) << bad.text;
}

// Indirect labels (DMIS 5.x 5.1.2.4): F(@V) names the feature whose label the CHAR variable V
// holds, at the moment of use, one level deep. check cannot know the name and accepts it.
TEST(ShopPrograms, IndirectLabelsNameTheFeatureTheVariableHolds) {
  const std::string text =
      "DMISMN/'indirect', 5.0\nUNITS/MM,ANGDEC\nDECL/INTGR,I\nDECL/CHAR,20,NAME\nT(DIA)=TOL/DIAM,-0.05,0.05\n"
      "DO/I,1,3\n  NAME=ASSIGN/CONCAT('h',STR(I))\n"
      "  F(@NAME)=FEAT/CIRCLE,INNER,CART,100+20*I,100,-5,0,0,1,10\n"
      "  FA(@NAME)=FEAT/CIRCLE,INNER,CART,100+20*I,100,-5,0,0,1,10+I/100\nENDDO\n"
      "NAME=ASSIGN/' H2 '\nOUTPUT/FA(@NAME),TA(DIA)\nOUTPUT/FA(H3)\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  expect_stated_holes(*r.session, {"H2", "H3"}, {2, 3});
  EXPECT_FALSE(report(*r.session, "H1"));  // defined, not output
  // A variable holding a name that no statement defined fails at run, naming that feature.
  const auto bad = run("DMISMN/'i', 5.0\nDECL/CHAR,8,V\nV=ASSIGN/'NOPE'\nOUTPUT/FA(@V)\nENDFIL\n");
  EXPECT_NE(bad.diagnostics.find("NOPE"), std::string::npos) << bad.diagnostics;
}

// CONST/POINT,EXTREM picks the measured point furthest along a direction of the current
// coordinate system (or least far), CONST/PLANE,OFFSET moves a plane along its normal. Expected
// values: the design of perfect.json's block (BORE1 20 mm at part 40, 50; the top at z = 40),
// which an ideal probe measures exactly.
TEST(ShopPrograms, ExtremePointsAndOffsetPlanes) {
  std::string text = bore_program("");
  const std::string more =
      "F(E1)=FEAT/POINT,CART,50,50,30,1,0,0\nCONST/POINT,F(E1),EXTREM,FA(BORE1),XDIR\n"
      "CONST/POINT,F(E2),EXTREM,MIN,FA(BORE1),YDIR\nCONST/POINT,F(E3),EXTREM,FA(BORE1),-XDIR\n"
      "CONST/POINT,F(E4),EXTREM,MAX,FA(BORE1),VEC,1,2,0\n"
      "F(TOP)=FEAT/PLANE,CART,80,50,40,0,0,1\nMEAS/PLANE,F(TOP),3\nGOTO/80,50,60\n"
      "PTMEAS/CART,20,20,40,0,0,1\nPTMEAS/CART,140,20,40,0,0,1\nPTMEAS/CART,80,90,40,0,0,1\nENDMES\n"
      "F(LOW)=FEAT/PLANE,CART,80,50,35,0,0,1\nCONST/PLANE,F(LOW),OFFSET,FA(TOP),-5\n"
      "OUTPUT/FA(E1),FA(E2),FA(E3),FA(E4),FA(LOW)\n"
      "D(TURNED)=ROTATE/ZAXIS,90\nCONST/POINT,F(E5),EXTREM,FA(BORE1),XDIR\nOUTPUT/FA(E5)\n";
  text.insert(text.find("OUTPUT/FA(BORE1)"), more);
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  const auto r = run(text, source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto at = [&](const char* label) {
    const auto* f = report(*r.session, label);
    EXPECT_TRUE(f && f->actual) << label;
    return f && f->actual ? f->actual->position : Eigen::Vector3d(NAN, NAN, NAN);
  };
  EXPECT_LT((at("E1") - Eigen::Vector3d(50, 50, 30)).norm(), 1e-4);
  EXPECT_LT((at("E2") - Eigen::Vector3d(40, 40, 30)).norm(), 1e-4);
  EXPECT_LT((at("E3") - Eigen::Vector3d(30, 50, 30)).norm(), 1e-4);
  EXPECT_LT((at("E4") - Eigen::Vector3d(40, 60, 30)).norm(), 1e-4);  // 40 + 2*60 beats 50 + 2*50
  EXPECT_NEAR(at("LOW").z(), 35, 1e-4);
  // After ROTATE/ZAXIS,90 the current X is the part's Y: the extreme is part (40, 60), reported
  // in the rotated frame (x' = y).
  const Eigen::Vector3d e5 = at("E5");
  EXPECT_NEAR(e5.x(), 60, 1e-4);
  EXPECT_NEAR(std::abs(e5.y()), 40, 1e-4);
  // A construction with no measured points, and OFFSET of what is not a plane, are errors at run.
  const auto none =
      run("DMISMN/'e', 5.0\nF(A)=FEAT/POINT,CART,0,0,0,0,0,1\nFA(A)=FEAT/POINT,CART,1,2,3,0,0,1\n"
          "CONST/POINT,F(B),EXTREM,FA(A),ZDIR\nENDFIL\n");
  EXPECT_NE(none.diagnostics.find("EXTREM picks one of the measured points of FA(A), which has none"),
            std::string::npos)
      << none.diagnostics;
  EXPECT_TRUE(check("DMISMN/'e', 5.0\nF(A)=FEAT/POINT,CART,0,0,0,0,0,1\nCONST/POINT,F(B),EXTREM,FA(A)\nENDFIL\n")
                  .has("EXTREM takes a feature and a direction"));
}

// BADTST/ON: a measurement that fails does not stop the run; BADPT() tells of a machine fault
// (a point in the air misses), BADGT() of points no feature fits (a circle probed twice at one
// point and once across: two distinct points), and the
// next MEAS clears both. With OFF the missed point stops the run as before.
TEST(ShopPrograms, BadTestTakesAFailedMeasurementAndTellsWhichKind) {
  const std::string failing =
      "DECL/BOOL,P1,G1,P2,G2,P3,G3\nDECL/CHAR,20,E0,E1\nE0=ASSIGN/SERROR()\n"
      "F(AIR)=FEAT/POINT,CART,200,50,20,1,0,0\nMEAS/POINT,F(AIR),1\nGOTO/220,50,60\nGOTO/220,50,20\n"
      "PTMEAS/CART,200,50,20,1,0,0\nGOTO/220,50,60\nENDMES\nP1=ASSIGN/BADPT()\nG1=ASSIGN/BADGT()\nE1=ASSIGN/SERROR()\n"
      "GOTO/220,50,60\nGOTO/40,50,80\n"
      "F(TWO)=FEAT/CIRCLE,INNER,CART,40,50,30,0,0,1,20\nMEAS/CIRCLE,F(TWO),3\nGOTO/40,50,30\n"
      "PTMEAS/CART,50,50,30,-1,0,0\nPTMEAS/CART,50,50,30,-1,0,0\nPTMEAS/CART,30,50,30,1,0,0\nGOTO/40,50,80\nENDMES\n"
      "P2=ASSIGN/BADPT()\nG2=ASSIGN/BADGT()\n";
  const auto program = [&](const std::string& switch_word) {
    std::string text = bore_program("");
    text.insert(text.find("F(BORE1)"), "BADTST/" + switch_word + "\n" + failing);
    text.insert(text.find("ENDFIL"), "P3=ASSIGN/BADPT()\nG3=ASSIGN/BADGT()\n");
    return text;
  };
  const Checked c = check(program("ON"));
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  const auto r = run(program("ON"));
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto value = [&](const char* name) { return r.session->interpreter().variable(name)->boolean; };
  EXPECT_TRUE(value("P1"));
  EXPECT_FALSE(value("G1"));
  EXPECT_FALSE(value("P2"));
  EXPECT_TRUE(value("G2"));
  EXPECT_FALSE(value("P3"));  // BORE1 measured well
  EXPECT_FALSE(value("G3"));
  // SERROR(): the last fault the run went on after, by ERROR's condition word ('' before any).
  EXPECT_EQ(r.session->interpreter().variable("E0")->text, "");
  EXPECT_EQ(r.session->interpreter().variable("E1")->text, "NOTOUCH");
  EXPECT_NE(r.diagnostics.find("is taken by BADTST/ON: BADPT() is .TRUE."), std::string::npos) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("cannot fit a CIRCLE to 3 points: degenerate point set: taken by BADTST/ON"),
            std::string::npos)
      << r.diagnostics;
  const auto* two = report(*r.session, "TWO");
  EXPECT_TRUE(!two || !two->actual);  // no actual for a failed measurement
  const auto* bore = report(*r.session, "BORE1");
  ASSERT_TRUE(bore && bore->actual);
  EXPECT_NEAR(bore->actual->diameter_mm, 20.0, 2e-3);
  EXPECT_EQ(run(program("OFF")).status, ExecStatus::Faulted);
  EXPECT_TRUE(check("DMISMN/'r', 5.0\nBADTST/MAYBE\nENDFIL\n").has("expected ON or OFF after BADTST/"));
}

// QTEMP(sensor): the machine's thermometer, the world's scale temperature (cmm_errors_at_22c.json:
// air 22 C, the scales following it without lag); a world with no temperature answers 20 C and
// says so once.
TEST(ShopPrograms, QtempReadsTheMachinesThermometer) {
  const std::string text = "DMISMN/'t', 5.0\nDECL/REAL,T1,T2\nT1=ASSIGN/QTEMP(1)\nT2=ASSIGN/QTEMP('X')\nENDFIL\n";
  EXPECT_EQ(check(text).errors + check(text).warnings, 0u) << check(text).text;
  const auto warm = run(text, source_dir / "programs/worlds/cmm_errors_at_22c.json");
  ASSERT_EQ(warm.status, ExecStatus::Finished) << warm.diagnostics;
  EXPECT_NEAR(warm.session->interpreter().variable("T1")->number, 22.0, 0.005);
  EXPECT_NEAR(warm.session->interpreter().variable("T2")->number, 22.0, 0.005);
  EXPECT_EQ(warm.diagnostics.find("no thermometer"), std::string::npos) << warm.diagnostics;
  const auto plain = run(text);
  ASSERT_EQ(plain.status, ExecStatus::Finished) << plain.diagnostics;
  EXPECT_EQ(plain.session->interpreter().variable("T1")->number, 20.0);
  const auto told = plain.diagnostics.find("QTEMP: this machine has no thermometer");
  EXPECT_NE(told, std::string::npos) << plain.diagnostics;
  EXPECT_EQ(plain.diagnostics.find("QTEMP: this machine has no thermometer", told + 1), std::string::npos)
      << plain.diagnostics;
  // UNITS/...,TEMPF: QTEMP answers in degrees Fahrenheit (22 C = 71.6 F); TEMPC back to Celsius.
  // Before, the third word of UNITS was dropped unseen.
  const std::string fahrenheit =
      "DMISMN/'t', 5.0\nUNITS/MM,ANGDEC,TEMPF\nDECL/REAL,T1,T2\nT1=ASSIGN/QTEMP(1)\n"
      "UNITS/MM,ANGDEC,TEMPC\nT2=ASSIGN/QTEMP(1)\nENDFIL\n";
  const auto f = run(fahrenheit, source_dir / "programs/worlds/cmm_errors_at_22c.json");
  ASSERT_EQ(f.status, ExecStatus::Finished) << f.diagnostics;
  EXPECT_NEAR(f.session->interpreter().variable("T1")->number, 71.6, 0.01);
  EXPECT_NEAR(f.session->interpreter().variable("T2")->number, 22.0, 0.005);
  EXPECT_TRUE(
      check("DMISMN/'t', 5.0\nUNITS/MM,ANGDEC,KELVIN\nENDFIL\n").has("expected a temperature unit (TEMPC, TEMPF)"));
}

// ERROR/(label),cond: a machine fault the condition covers goes to the handler, which goes on
// with RESUME; ERROR/AUTO goes on after the failing statement; a fault the condition does not
// cover stops the run, as without ERROR. The air point: nothing of the block (x 0..160) is
// within the probing move at x = 200.
TEST(ShopPrograms, ErrorHandlersGoOnAfterAMachineFault) {
  const std::string air =
      "F(AIR)=FEAT/POINT,CART,200,50,20,1,0,0\nMEAS/POINT,F(AIR),1\nGOTO/220,50,60\nGOTO/220,50,20\n"
      "PTMEAS/CART,200,50,20,1,0,0\nGOTO/220,50,60\nENDMES\nGOTO/220,50,60\nGOTO/40,50,80\n";
  const auto program = [&](const std::string& handling, const std::string& handler) {
    std::string text = bore_program("");
    text.insert(text.find("F(BORE1)"), "DECL/INTGR,N\n" + handling + air);
    text.insert(text.find("ENDFIL"), "JUMPTO/(DONE)\n(EH)\n" + handler + "(DONE)\n");
    return text;
  };
  // The handler lifts the probe clear (it stopped at the end of its search, beside the block),
  // counts, retries the measurement once (CURMEAS), then goes on after it.
  const std::string retry = program(
      "ERROR/(EH),ALL\n", "GOTO/220,50,60\nN=ASSIGN/N+1\nIF/(N.LT.2)\nRESUME/CURMEAS\nENDIF\nRESUME/NEXTMEAS\n");
  const Checked c = check(retry);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  const auto r = run(retry);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.session->interpreter().variable("N")->number, 2);  // the air point failed twice
  EXPECT_NE(r.diagnostics.find("is handled by ERROR/(label): the run goes on at the handler"), std::string::npos)
      << r.diagnostics;
  const auto* bore = report(*r.session, "BORE1");
  ASSERT_TRUE(bore && bore->actual);
  EXPECT_NEAR(bore->actual->diameter_mm, 20.0, 2e-3);
  // AUTO: on after the failing measurement from where the machine stopped (the program lifts the
  // probe), no handler.
  const auto automatic = run(program("ERROR/AUTO,NOTOUCH\n", ""));
  ASSERT_EQ(automatic.status, ExecStatus::Finished) << automatic.diagnostics;
  EXPECT_EQ(automatic.session->interpreter().variable("N")->number, 0);
  EXPECT_TRUE(report(*automatic.session, "BORE1"));
  // NOTOUCH does not cover a collision, ILLEGALTOUCH does not cover a missed contact; OFF ends
  // the handling.
  std::string crash = program("ERROR/(EH),NOTOUCH\nGOTO/80,50,20\n", "GOTO/220,50,60\nRESUME/NEXTLINE\n");
  const auto not_covered = run(crash);
  EXPECT_EQ(not_covered.status, ExecStatus::Faulted);
  EXPECT_EQ(not_covered.diagnostics.find("(collision"), std::string::npos) << not_covered.diagnostics;
  crash.replace(crash.find("NOTOUCH"), 7, "ILLEGALTOUCH");
  const auto covered = run(crash);  // the collision handled; then the air point's missed contact stops it
  EXPECT_NE(covered.diagnostics.find("(collision with TOP"), std::string::npos) << covered.diagnostics;
  EXPECT_EQ(covered.status, ExecStatus::Faulted);
  EXPECT_EQ(run(program("ERROR/(EH),ILLEGALTOUCH\n", "RESUME/NEXTLINE\n")).status, ExecStatus::Faulted);
  EXPECT_EQ(run(program("ERROR/(EH),ALL\nERROR/OFF\n", "RESUME/NEXTLINE\n")).status, ExecStatus::Faulted);
  // RESUME with no fault being handled is an error; ERROR needs its label in parentheses.
  const auto stray = run("DMISMN/'r', 5.0\nRESUME/NEXTLINE\nENDFIL\n");
  EXPECT_NE(stray.diagnostics.find("RESUME outside an error handler"), std::string::npos) << stray.diagnostics;
  EXPECT_TRUE(check("DMISMN/'r', 5.0\nERROR/EH,ALL\nENDFIL\n").has("expected the handler's label in parentheses"));
  // The condition first, IGNORE for AUTO, a macro handler (not run: one warning).
  const Checked orders =
      check("DMISMN/'r', 5.0\nERROR/ALL,IGNORE\nERROR/NOTOUCH,(EH)\nERROR/ILLEGALTOUCH,M(EH)\n(EH)\nENDFIL\n");
  EXPECT_EQ(orders.errors, 0u) << orders.text;
  EXPECT_EQ(orders.warnings, 1u) << orders.text;
  EXPECT_TRUE(orders.has("ERROR with the macro M(EH) as its handler is not run")) << orders.text;
  EXPECT_TRUE(check("DMISMN/'r', 5.0\nERROR/(NOWHERE),ALL\nENDFIL\n").has("(NOWHERE) is not defined"));
}

// A tolerance that cannot be evaluated (here: its feature was never measured) is left out
// of its OUTPUT with a warning, and the run goes on to report the rest, as shop software does;
// --strict (Runtime::set_strict) keeps it an error that stops the run.
TEST(ShopPrograms, AToleranceThatCannotBeEvaluatedIsLeftOutLeniently) {
  std::string text = bore_program("");
  text.insert(text.find("OUTPUT/FA(BORE1)"),
              "F(SIDE)=FEAT/PLANE,CART,0,50,20,-1,0,0\nT(PAR)=TOL/FLAT,0.05\n"
              "F(TOP)=FEAT/PLANE,CART,80,50,40,0,0,1\nMEAS/PLANE,F(TOP),3\nGOTO/80,50,60\n"
              "PTMEAS/CART,20,20,40,0,0,1\nPTMEAS/CART,140,20,40,0,0,1\nPTMEAS/CART,80,90,40,0,0,1\nENDMES\n"
              "OUTPUT/FA(TOP)\nOUTPUT/FA(SIDE),TA(PAR)\n");
  const auto lenient = run(text);
  ASSERT_EQ(lenient.status, ExecStatus::Finished) << lenient.diagnostics;
  EXPECT_NE(lenient.diagnostics.find("T(PAR) is not evaluated: "), std::string::npos) << lenient.diagnostics;
  EXPECT_FALSE(tolerance(*lenient.session, "PAR"));
  EXPECT_TRUE(report(*lenient.session, "TOP"));
  EXPECT_TRUE(report(*lenient.session, "BORE1"));  // the OUTPUT after it

  const fs::path p = write("strict.dmi", text);
  auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
  ASSERT_TRUE(backend.has_value());
  auto strict = Session::create(std::move(*backend));
  strict->runtime().set_strict(true);
  ASSERT_TRUE(strict->load(p.string()));
  EXPECT_EQ(strict->interpreter().run(), ExecStatus::Error);
  EXPECT_FALSE(report(*strict, "BORE1"));
}

// A measured line is reported at the point of the fitted line nearest its nominal's (a BND
// line's start and end), as a cylinder's axis is: the points' centroid put a perfect line probed
// at x = 10, 50 and 90 at x = 50, 40 mm off its start, and CORTOL said OUT.
TEST(ShopPrograms, AMeasuredLineIsReportedFromItsNominalsPoint) {
  const std::string text =
      "DMISMN/'line', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
      "DECL/REAL,DX,DU\nF(LB)=FEAT/LINE,BND,CART,10,5,-3,90,5,-3,0,0,1\nMEAS/LINE,F(LB),3\n"
      "PTMEAS/CART,10,5,-3,0,-1,0\nPTMEAS/CART,50,5,-3,0,-1,0\nPTMEAS/CART,90,5,-3,0,-1,0\nENDMES\n"
      "F(LU)=FEAT/LINE,UNBND,CART,20,5,-6,1,0,0,0,0,1\nMEAS/LINE,F(LU),2\n"
      "PTMEAS/CART,60,5,-6,0,-1,0\nPTMEAS/CART,80,5,-6,0,-1,0\nENDMES\n"
      "T(LX)=TOL/CORTOL,XAXIS,-0.1,0.1\nOUTPUT/FA(LB),FA(LU),TA(LX)\nDX=VALUE/TA(LX),DEV,1\nDU=VALUE/"
      "TA(LX),DEV,2\nENDFIL\n";
  const Ran dry = dry_run(text);
  ASSERT_EQ(dry.status, ExecStatus::Finished) << dry.diagnostics;
  Session* session = dry.session.get();
  const auto* lb = report(*session, "LB");
  ASSERT_TRUE(lb && lb->actual);
  EXPECT_NEAR((lb->actual->position - Eigen::Vector3d(10, 5, -3)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(lb->actual->length_mm, 80.0, 1e-6);
  const auto* lu = report(*session, "LU");
  ASSERT_TRUE(lu && lu->actual);
  EXPECT_NEAR((lu->actual->position - Eigen::Vector3d(20, 5, -6)).norm(), 0.0, 1e-6);
  EXPECT_NEAR(session->interpreter().variable("DX")->number, 0.0, 1e-6);
  EXPECT_NEAR(session->interpreter().variable("DU")->number, 0.0, 1e-6);
}

// A DMIS module (DMISMD, as MODUS's helper tools write) starts a file as DMISMN does.
TEST(ShopPrograms, AModuleHeaderStartsAFile) {
  const Checked c = check("DMISMD/'PerpendicularPoints', 5.0\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n");
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  EXPECT_TRUE(check("F(P)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n").has("does not start with DMISMN"));
  // A DMISMN the parser cannot read has its error, at its place; the next line is not blamed.
  const Checked unread = check("DMISMN/'p' 5.0\nF(P)=FEAT/POINT,CART,0,0,0,0,0,1\nENDFIL\n");
  EXPECT_EQ(unread.errors, 1u) << unread.text;
  EXPECT_TRUE(unread.has("shop.dmi:1:")) << unread.text;
  EXPECT_FALSE(unread.has("does not start with DMISMN")) << unread.text;
}

// A stylus's tip shape after its diameter (`SNSDEF/PROBE,FIXED,POL,...,115,12,DISC,3`): the tip
// diameter is 12, not the disc's thickness 3 (the last number), and the shape is told once. A
// `VEC` word before the stylus vector (`POL,0,0,VEC,0,0,1,50,4`) was an error.
TEST(ShopPrograms, SensorTipShapesKeepTheirDiameter) {
  const std::string text =
      "DMISMN/'s', 5.0\nS(DISK1)=SNSDEF/PROBE,FIXED,POL,0,0,0,0,1,115,12,DISC,3\n"
      "S(B)=SNSDEF/PROBE,INDEX,POL,90,45,0,0,1,127,2,SPHERE\nCI(CL1)=CLMPID/'CLAMP-A'\n"
      "S(V)=SNSDEF/PROBE,INDEX,POL,0,0,VEC,0,0,1,50,4\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 1u) << c.text;
  EXPECT_TRUE(c.has("S(DISK1) has a DISC tip")) << c.text;
  SourceManager sources;
  DiagnosticSink sink;
  Compiler compiler(sources, sink);
  compiler.compile_text("shop.dmi", text);
  std::vector<double> tips;
  std::vector<std::size_t> counts;
  for (const auto& in : compiler.module().units.at(0).code)
    if (in.op == metron::interpreter::ir::Op::SensorDef) {
      tips.push_back(in.operands.back().expr.value.number);
      counts.push_back(in.operands.size());
    }
  EXPECT_EQ(tips, (std::vector<double>{12, 2, 4}));
  EXPECT_EQ(counts.back(), counts[1]);  // VEC's three numbers read as the POL form's i, j, k
  const Checked other = check("DMISMN/'s', 5.0\nS(C)=SNSDEF/PROBE,INDEX,POL,90,45,0,0,1,127,2,FOO,3\nENDFIL\n");
  EXPECT_TRUE(other.has("or the tip's shape (SPHERE, CYLNDR, DISC), got the word FOO")) << other.text;
}

// A material modifier after a datum (`DAT(B),MMC`) is the datum's: it must not make an RFS
// feature's position MMC (it did: every MMC word set the feature's condition, and a bonus
// appeared). POS takes it as the datum's (a datum shift, TolerancePosition.ADatumHoleAtMmcLetsTheFrameShift);
// other tolerances evaluate their datums RFS, which a warning says.
TEST(ShopPrograms, DatumModifiersDoNotChangeTheFeaturesCondition) {
  const std::string text =
      "DMISMN/'s', 5.0\nF(P)=FEAT/PLANE,CART,0,0,0,0,0,1\nDATDEF/FA(P),DAT(A)\nDATDEF/FA(P),DAT(B)\n"
      "T(TP)=TOL/POS,2D,0.010,RFS,DAT(A),DAT(B),MMC\nT(TQ)=TOL/POS,2D,0.010,MMC,DAT(A),DAT(B),RFS\n"
      "T(TR)=TOL/PERP,0.010,DAT(A),MMC\nENDFIL\n";
  const Checked c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_EQ(c.warnings, 2u) << c.text;  // the one below, and P is never measured
  EXPECT_TRUE(c.has("3:8: warning: FA(P) is read here, but nothing in this program measures")) << c.text;
  EXPECT_TRUE(
      c.has("7:29: warning: DAT(A) at MMC: the datums of TOL/PERP are evaluated RFS, metron applies no datum shift"))
      << c.text;
  SourceManager sources;
  DiagnosticSink sink;
  Compiler compiler(sources, sink);
  compiler.compile_text("shop.dmi", text);
  std::vector<std::string> conditions;
  for (const auto& in : compiler.module().units.at(0).code)
    if (in.op == metron::interpreter::ir::Op::ToleranceDef)
      for (const auto& o : in.operands)
        if (o.word == "MMC" || o.word == "LMC" || o.word == "RFS" || o.word.rfind("DATUM-", 0) == 0)
          conditions.push_back(in.name + ":" + o.word);
  EXPECT_EQ(conditions, (std::vector<std::string>{"TP:RFS", "TP:DATUM-MMC", "TQ:MMC"}));
}

// A tolerance of one feature output with several applies to each (it stopped the run: "DIAM
// applies to one feature, got 2"), and check and run agree about PERP of a CIRCLE: read
// leniently it is left out with its reason (shop software reports it from the circle's vector;
// one section gives no axis), --strict refuses it.
TEST(ShopPrograms, OneFeatureTolerancesApplyToEachOutputFeatureAndCheckAgreesWithRun) {
  const std::string text =
      "DMISMN/'each', 5.0\nDECL/REAL,D1,D2\n"
      "F(H1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nFA(H1)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10.02\n"
      "F(H2)=FEAT/CIRCLE,INNER,CART,20,0,0,0,0,1,10\nFA(H2)=FEAT/CIRCLE,INNER,CART,20,0,0,0,0,1,9.9\n"
      "T(DD)=TOL/DIAM,-0.05,0.05\nOUTPUT/FA(H1),FA(H2),TA(DD)\n"
      "D1=VALUE/TA(DD),DEV,1\nD2=VALUE/TA(DD),DEV,2\nENDFIL\n";
  EXPECT_EQ(check(text).errors, 0u);
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_NEAR(r.session->interpreter().variable("D1")->number, 0.02, 1e-9);
  EXPECT_NEAR(r.session->interpreter().variable("D2")->number, -0.1, 1e-9);
  const std::string perp_text =
      "DMISMN/'p', 5.0\nFA(P)=FEAT/PLANE,CART,0,0,0,0,0,1\nDATDEF/FA(P),DAT(A)\n"
      "FA(C)=FEAT/CIRCLE,INNER,CART,0,0,0,0,0,1,10\nT(PR)=TOL/PERP,0.02,DAT(A)\nT(DD)=TOL/DIAM,-0.1,0.1\n"
      "OUTPUT/FA(C),TA(PR),TA(DD)\nEVAL/FA(C),TA(PR)\nENDFIL\n";
  const Checked perp = check(perp_text);
  EXPECT_EQ(perp.errors, 0u) << perp.text;
  EXPECT_TRUE(
      perp.has("7:14: warning: TOL/PERP of T(PR) is not evaluated for a CIRCLE (metron evaluates it for "
               "PLANE, LINE, CYLNDR, CONE, PARPLN or CPARLN): left out of this OUTPUT"))
      << perp.text;
  EXPECT_TRUE(
      perp.has("8:12: warning: TOL/PERP of T(PR) is not evaluated for a CIRCLE (metron evaluates it for PLANE, LINE, "
               "CYLNDR, CONE, PARPLN or CPARLN): left out of this EVAL"))
      << perp.text;
  const auto left_out = run(perp_text);
  ASSERT_EQ(left_out.status, ExecStatus::Finished) << left_out.diagnostics;
  EXPECT_EQ(tolerance(*left_out.session, "PR"), nullptr);
  EXPECT_NE(tolerance(*left_out.session, "DD"), nullptr);  // the rest of the OUTPUT is reported
  const Checked strict = check(perp_text, true);
  EXPECT_TRUE(strict.has("7:14: error: TOL/PERP of T(PR) does not apply to a CIRCLE")) << strict.text;
  // A VALUE of it has nothing to read: check says where the run stops.
  std::string with_value = perp_text;
  with_value.replace(with_value.find("ENDFIL"), 6, "DECL/REAL,V1\nV1=VALUE/TA(PR),ACT\nENDFIL");
  const Checked value = check(with_value);
  EXPECT_TRUE(
      value.has("10:10: warning: T(PR) was left out of its last OUTPUT or EVAL (not evaluated for a CIRCLE): "
                "a run stops at this VALUE"))
      << value.text;
  const auto stopped = run(with_value);
  EXPECT_EQ(stopped.status, ExecStatus::Error);
  EXPECT_NE(stopped.diagnostics.find("10:1: error: VALUE/TA(PR) before T(PR) was evaluated"), std::string::npos)
      << stopped.diagnostics;
  const Checked cone = check(
      "DMISMN/'s', 5.0\nFA(K)=FEAT/CONE,INNER,CART,0,0,0,0,0,1,90\nT(ST)=TOL/STRGHT,0.01\n"
      "T(CY)=TOL/CYLCTY,0.01\nOUTPUT/FA(K),TA(ST)\nOUTPUT/FA(K),TA(CY)\nENDFIL\n");
  EXPECT_TRUE(cone.has("5:14: warning: TOL/STRGHT of T(ST) is not evaluated for a CONE")) << cone.text;
  EXPECT_TRUE(cone.has("6:14: error: TOL/CYLCTY of T(CY) does not apply to a CONE")) << cone.text;
}

// The plane-hole-hole alignment, the commonest of shop programs: a hole whose axis is the
// primary's orients X from the origin hole toward its centre. It stopped the run ("the secondary
// datum is parallel to the primary datum").
TEST(ShopPrograms, PlaneHoleHoleAlignsXFromTheOriginHoleToTheOther) {
  const std::string text =
      "DMISMN/'phh', 5.0\nFA(PA)=FEAT/PLANE,CART,0,0,5,0,0,1\n"
      "FA(B)=FEAT/CIRCLE,INNER,CART,10,20,5,0,0,1,8\nFA(C)=FEAT/CIRCLE,INNER,CART,70,100,5,0,0,1,8\n"
      "FA(E)=FEAT/POINT,CART,10,120,5,0,0,1\n"
      "DATDEF/FA(PA),DAT(A)\nDATDEF/FA(B),DAT(B)\nDATDEF/FA(C),DAT(C)\n"
      "D(A1)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),XORIG,YORIG,DAT(C),XDIR\nOUTPUT/FA(C),FA(E)\nENDFIL\n";
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  // B at the origin, C on +X at |BC| = 100; E (0, 100) from B is at 3-4-5 angles: (80, 60) in the part.
  const auto part = [&](const char* label) {
    const auto* f = report(*r.session, label);
    EXPECT_TRUE(f && f->actual) << label;
    return f && f->actual ? f->actual->position : Eigen::Vector3d(NAN, NAN, NAN);
  };
  EXPECT_NEAR((part("C") - Eigen::Vector3d(100, 0, 0)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((part("E") - Eigen::Vector3d(80, 60, 0)).norm(), 0.0, 1e-9);
  // Spheres have no direction of their own: a sphere orients from the origin sphere toward it,
  // whatever the primary (here a wall x = 0, so Y runs from S1 to S2 along (0, 0.6, 0.8)).
  const auto balls =
      run("DMISMN/'balls', 5.0\nFA(W)=FEAT/PLANE,CART,0,0,0,1,0,0\n"
          "FA(S1)=FEAT/SPHERE,OUTER,CART,0,10,10,25\nFA(S2)=FEAT/SPHERE,OUTER,CART,0,40,50,25\n"
          "DATDEF/FA(W),DAT(A)\nDATDEF/FA(S1),DAT(B)\nDATDEF/FA(S2),DAT(C)\n"
          "D(A2)=DATSET/DAT(A),XDIR,XORIG,DAT(B),YORIG,ZORIG,DAT(C),YDIR\nOUTPUT/FA(S2)\nENDFIL\n");
  ASSERT_EQ(balls.status, ExecStatus::Finished) << balls.diagnostics;
  const auto* s2 = report(*balls.session, "S2");
  ASSERT_TRUE(s2 && s2->actual);
  EXPECT_NEAR((s2->actual->position - Eigen::Vector3d(0, 50, 0)).norm(), 0.0, 1e-9);
}

TEST(ShopPrograms, JumptoALabelWithAMinus) {
  const auto c = check(
      "DMISMN/'p', 5.1\nDECL/INTGR,I\nI=ASSIGN/0\n(L-1)\nI=ASSIGN/I+1\nIF/(I.LT.3)\nJUMPTO/(L-1)\nENDIF\nENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  const auto r =
      run("DMISMN/'p', 5.1\nDECL/INTGR,I\nI=ASSIGN/0\n(L-1)\nI=ASSIGN/I+1\nIF/(I.LT.3)\nJUMPTO/(L-1)\nENDIF\n"
          "TEXT/OPER,STR(I)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.session->interpreter().variable("I")->number, 3);
}

TEST(ShopPrograms, CheckOfAPipeReadsIt) {
  // `metron check /dev/stdin` on a pipe: /proc/self/fd/N names `pipe:[...]`, which has no
  // canonical form; the path as given is read.
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const std::string text = "DMISMN/'p', 5.1\nSNSLCT/S(NOPE)\nENDFIL\n";
  ASSERT_EQ(::write(fds[1], text.data(), text.size()), static_cast<ssize_t>(text.size()));
  ::close(fds[1]);
  SourceManager sources;
  DiagnosticSink sink;
  Compiler compiler(sources, sink);
  std::optional<std::size_t> unit;
  EXPECT_NO_THROW(unit = compiler.compile_file("/proc/self/fd/" + std::to_string(fds[0])));
  ::close(fds[0]);
  EXPECT_TRUE(unit.has_value());
  EXPECT_EQ(sink.error_count(), 0u);
  ASSERT_FALSE(sink.items().empty());
  EXPECT_EQ(sink.items().front().code, "sema.library-sensor");
}

// ---- the reconstructed shop programs of programs/real -----------------------------------------

TEST(ShopPrograms, ReconstructedShopProgramsCheckCleanAndRunToTheEnd) {
  int seen = 0;
  for (const auto& entry : fs::directory_iterator(source_dir / "programs/real")) {
    if (entry.path().extension() != ".dmi") continue;
    ++seen;
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto c = check(text);
    EXPECT_EQ(c.errors, 0u) << entry.path() << "\n" << c.text;
    const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
    EXPECT_EQ(r.status, ExecStatus::Finished) << entry.path() << "\n" << r.diagnostics;
  }
  EXPECT_EQ(seen, 10);
}

// What WinWerth writes (programs/real/winwerth_style_plate.dmi, written for metron in its manner):
// the circle written by its radius (10) read as the 20 mm bore the world holds, the tolerance
// written upper first (0.03, -0.01) read as -0.01 .. +0.03, a point constructed without a
// direction between two top points (60, 35) and (60, 65): (60, 50, 40) in the part, machine
// (360, 250, 40). --strict refuses each reading.
TEST(ShopPrograms, WinWerthProgramsAreReadAsWinWerthMeansThem) {
  std::ifstream in(source_dir / "programs/real/winwerth_style_plate.dmi", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("1: note: a characterisation block (BEGIN/CHFILE ... END/CHFILE, WinWerth's) is skipped"))
      << c.text;
  EXPECT_TRUE(c.has("which writes a FEAT/CIRCLE's radius where DMIS has its diameter")) << c.text;
  EXPECT_FALSE(c.has("LOCTOL is not one metron knows")) << c.text;
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* bore = r.session->runtime().find_feature("R_CIR_1");
  ASSERT_TRUE(bore && bore->actual);
  EXPECT_NEAR(bore->nominal.diameter_mm, 20.0, 1e-12);
  EXPECT_NEAR(bore->actual->diameter_mm, 20.0, 1e-6);
  const auto* size = tolerance(*r.session, "D_20.00");
  ASSERT_NE(size, nullptr);
  EXPECT_TRUE(size->in_tolerance);
  EXPECT_DOUBLE_EQ(size->lower, -0.01);
  EXPECT_DOUBLE_EQ(size->upper, 0.03);
  // The distance held as a feature (CONST/DIST of the top face, z 40, and the bore's section
  // measured at z 30): 10, its tolerance written upper first.
  const auto* distance = tolerance(*r.session, "DIM_10.000");
  ASSERT_NE(distance, nullptr);
  EXPECT_NEAR(distance->actual, 10.0, 1e-6);
  EXPECT_DOUBLE_EQ(distance->lower, -0.005);
  EXPECT_TRUE(distance->in_tolerance);
  // The location tolerance held as a feature: the parallelism of the second region of the top
  // face to the first (the reference), 0 on the perfect block.
  const auto* parallel = tolerance(*r.session, "PARALLEL_1");
  ASSERT_NE(parallel, nullptr);
  EXPECT_EQ(parallel->kind, metron::runtime::ToleranceKind::Parlel);
  EXPECT_NEAR(parallel->value, 0.0, 1e-9);
  EXPECT_TRUE(parallel->in_tolerance);
  const auto* point = r.session->runtime().find_feature("R_1");
  ASSERT_TRUE(point && point->actual);
  EXPECT_NEAR((point->actual->position - Eigen::Vector3d(360, 250, 40)).norm(), 0.0, 1e-6);
  const auto unclosed = check("BEGIN / CHFILE\n\tTYPE = MACRO\nDMISMN/'p', 5.1\nENDFIL\n");
  EXPECT_TRUE(unclosed.has("1:1: error: BEGIN/CHFILE is never closed by END/CHFILE")) << unclosed.text;
  const auto strict = check(text, true);
  for (const char* refused :
       {"error: expected '/' after the major word 'L'", "expected AUTO, PROG,MAN or MAN after MODE/",
        "MACRO needs a label on the left", "CZSLCT is not allowed inside a MEAS block",
        "the direction vector i,j,k is zero", "the lower tolerance 0.03 is above the upper",
        "the lower tolerance 0.005 is above the upper", "expected a feature type after CONST/"})
    EXPECT_TRUE(strict.has(refused)) << refused << "\n" << strict.text;
}

TEST(ShopPrograms, ForeignCallPathWarnsAtCheckResolvesWithIncludeAndFailsOnlyAtRun) {
  const fs::path lib = temp_dir() / "library";
  fs::create_directories(lib);
  std::ofstream(lib / "SUB_PART.dmi") << "DMISMN/'sub', 5.0\nTEXT/OPER,'in the sub program'\nENDFIL\n";
  const std::string text =
      "DMISMN/'p', "
      "5.1\nTEXT/OPER,'before'\nCALL/EXTERN,DMIS,'Z:\\CMM\\Programs\\SUB_PART.dmi'\nTEXT/OPER,'after'\nENDFIL\n";
  const auto c = check(text);
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(c.has("'Z:\\CMM\\Programs\\SUB_PART.dmi' was written on another machine and SUB_PART.dmi is not in"))
      << c.text;
  {
    SourceManager sources;
    DiagnosticSink sink;
    Compiler compiler(sources, sink);
    compiler.set_include_dirs({lib.string()});
    compiler.compile_text("shop.dmi", text);
    EXPECT_TRUE(sink.items().empty()) << (sink.items().empty() ? "" : sink.items().front().message);
    EXPECT_EQ(compiler.module().units.size(), 2u);  // the called file was found and compiled
  }
  const auto r = run(text);
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find("was not found (give its folder with --include DIR)"), std::string::npos)
      << r.diagnostics;
  // CAMIO writes a label after the file (CALL/EXTERN,DMIS,'...',PLNA02): a warning on it, and
  // the file is still the string.
  const auto labelled = check("DMISMN/'p', 5.1\nCALL/EXTERN,DMIS,'Z:\\CMM\\SUB_PART.dmi',PLNA02\nENDFIL\n");
  EXPECT_EQ(labelled.errors, 0u) << labelled.text;
  EXPECT_TRUE(labelled.has("2:40: warning: CALL/EXTERN,DMIS passes nothing but the file")) << labelled.text;
  EXPECT_TRUE(labelled.has("SUB_PART.dmi is not in")) << labelled.text;
}

// OUTPUT/S(x) and OUTPUT/SA(x): a sensor's definition and its qualification on the reference
// sphere, as report lines and comment lines of the DMIS output file. In the perfect world (no
// pre-travel, no delays, a true ball) the qualified diameter is the ball's own, 2 mm; in the
// default world the tip qualifies smaller by its pre-travel and trigger delays.
// OUTPUT/D(x), DA(x): the coordinate system's origin and axes in the machine's (was ignored with
// a warning). By hand: the part origin at machine (300, 200, 0), turned 90 deg about z, so part x
// is machine y and part y machine -x; in inches 300 mm is 11.81102.
TEST(ShopPrograms, CoordinateSystemsAreOutputAsOriginAndAxes) {
  const auto r =
      run("DMISMN/'d', 5.1\nUNITS/MM,ANGDEC\nD(PART)=TRANS/XORIG,300,YORIG,200,ZORIG,0\nD(R)=ROTATE/ZAXIS,90\n"
          "OUTPUT/D(R)\nUNITS/INCH,ANGDEC\nOUTPUT/DA(PART),D(MCS)\nOUTPUT/D(LATER)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> said = texts_of(*r.session);
  const std::vector<std::string> expected = {
      "D(R): origin (300.0000, 200.0000, 0.0000) mm, X axis (0.000000, 1.000000, 0.000000), Y axis (-1.000000, "
      "0.000000, "
      "0.000000), Z axis (0.000000, 0.000000, 1.000000) in machine coordinates",
      "DA(PART): origin (11.81102, 7.87402, 0.00000) INCH, X axis (1.000000, 0.000000, 0.000000), Y axis (0.000000, "
      "1.000000, "
      "0.000000), Z axis (0.000000, 0.000000, 1.000000) in machine coordinates",
      "D(MCS): origin (0.00000, 0.00000, 0.00000) INCH, X axis (1.000000, 0.000000, 0.000000), Y axis (0.000000, "
      "1.000000, "
      "0.000000), Z axis (0.000000, 0.000000, 1.000000) in machine coordinates"};
  EXPECT_EQ(said, expected);
  EXPECT_NE(r.diagnostics.find("D(LATER) is not defined yet: nothing to output"), std::string::npos) << r.diagnostics;
  const auto c = check("DMISMN/'d', 5.1\nOUTPUT/D(NOPE)\nENDFIL\n");
  EXPECT_TRUE(c.has("2:8: warning: coordinate system D(NOPE) is not defined in this program")) << c.text;
}

TEST(ShopPrograms, SensorsAreOutputWithTheirQualification) {
  const std::string program =
      "DMISMN/'sensors', 5.0\nUNITS/MM, ANGDEC\n"
      "S(P1) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nOUTPUT/S(P1), SA(P1)\nSNSLCT/S(P1)\n"
      "OUTPUT/S(P1), SA(P1)\nENDFIL\n";
  auto texts = [](const auto& r) {
    const std::vector<std::string> out = texts_of(*r.session);
    return out;
  };
  const auto perfect = run(program, source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(perfect.status, ExecStatus::Finished) << perfect.diagnostics;
  const auto p = texts(perfect);
  ASSERT_EQ(p.size(), 4U) << perfect.diagnostics;
  EXPECT_EQ(p[0], "S(P1): probe tip 2.0000 mm diameter, stylus 50.0000 mm along (0.0000, 0.0000, -1.0000)");
  EXPECT_EQ(p[1], "SA(P1): tip 2.0000 mm nominal diameter, not qualified yet");
  EXPECT_EQ(p[3].rfind("SA(P1): tip 2.0000 mm nominal diameter, 2.0000 mm effective (qualified on the reference "
                       "sphere, form 0.0000 mm)",
                       0),
            0U)
      << p[3];
  const auto plain = run(program, source_dir / "programs/worlds/default.json");
  ASSERT_EQ(plain.status, ExecStatus::Finished) << plain.diagnostics;
  const auto d = texts(plain);
  ASSERT_EQ(d.size(), 4U);
  const auto at = d[3].find(" mm effective");
  ASSERT_NE(at, std::string::npos) << d[3];
  const double effective = std::stod(d[3].substr(d[3].rfind(", ", at) + 2));
  // 10 um of pre-travel and 4 ms of delays at the 3 mm/s measuring feed: 2 * (10 + 12) um smaller.
  EXPECT_NEAR(effective, 2.0 - 2 * (0.010 + 0.012), 0.006) << d[3];
}

TEST(ShopPrograms, ASensorSelectedInsideABlockTakesTheRestOfItsPoints) {
  // A bore probed with two sensors: the 4 mm tip takes the first two points, the 2 mm tip the
  // last two. Before, SNSLCT inside MEAS was an error; carried out when reached, it would have
  // switched the sensor before any point (the block is measured at ENDMES).
  std::string text = bore_program(
      "S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "S(P2) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nSNSLCT/S(P4)\n");
  text.replace(text.find("  PTMEAS/CART, 30, 50"), 0, "  SNSLCT/S(P2)\n");
  const auto c = check(text);
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  const auto r = run(text);
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* bore = r.session->runtime().find_feature("BORE1");
  ASSERT_TRUE(bore && bore->actual);
  ASSERT_EQ(bore->points.size(), 4u);
  // The effective radius is the qualified one (the pre-travel takes some 22 um off the nominal).
  EXPECT_NEAR(bore->points[0].ball_radius_mm, 2.0, 0.05);
  EXPECT_NEAR(bore->points[1].ball_radius_mm, 2.0, 0.05);
  EXPECT_NEAR(bore->points[2].ball_radius_mm, 1.0, 0.05);
  EXPECT_NEAR(bore->points[3].ball_radius_mm, 1.0, 0.05);
  // The perfect world's bore is the design bore: each point compensated by its own ball.
  EXPECT_NEAR(bore->actual->diameter_mm, 20.0, 2e-3);
  // The sensor stays selected after the block, as SNSLCT outside one would leave it.
  ASSERT_TRUE(r.session->runtime().machine().state().tool);
  EXPECT_EQ(r.session->runtime().machine().state().tool->name, "P2");
  // A sensor switched after the block's first move: the move alone plans no points of its own
  // (4 points, all with the 4 mm tip); without PTMEAS (MODE/AUTO) the last sensor takes the planned ones.
  std::string after_move = text;
  after_move.erase(after_move.find("  SNSLCT/S(P2)\n"), std::string("  SNSLCT/S(P2)\n").size());
  after_move.replace(after_move.find("  PTMEAS/CART, 50, 50"), 0, "  SNSLCT/S(P4)\n");
  after_move.replace(after_move.find("SNSLCT/S(P4)\nD(PART)"), std::string("SNSLCT/S(P4)").size(), "SNSLCT/S(P2)");
  const auto moved = run(after_move);
  ASSERT_EQ(moved.status, ExecStatus::Finished) << moved.diagnostics;
  const auto* again = moved.session->runtime().find_feature("BORE1");
  ASSERT_TRUE(again && again->actual);
  ASSERT_EQ(again->points.size(), 4u);
  for (const auto& p : again->points) EXPECT_NEAR(p.ball_radius_mm, 2.0, 0.05);
  std::string automatic = bore_program(
      "S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "S(P2) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nSNSLCT/S(P4)\nMODE/AUTO\n");
  const std::size_t from = automatic.find("  GOTO/40, 50, 30\n"), to = automatic.find("ENDMES");
  automatic.replace(from, to - from, "  SNSLCT/S(P2)\n");
  const auto planned = run(automatic);
  ASSERT_EQ(planned.status, ExecStatus::Finished) << planned.diagnostics;
  const auto* bore3 = planned.session->runtime().find_feature("BORE1");
  ASSERT_TRUE(bore3 && bore3->actual);
  EXPECT_EQ(bore3->points.size(), 4u);
  for (const auto& p : bore3->points) EXPECT_NEAR(p.ball_radius_mm, 1.0, 0.05);
  EXPECT_NEAR(bore3->actual->diameter_mm, 20.0, 2e-3);
  // Read strictly too: SNSLCT belongs in a block (DMIS measures a feature with several sensors).
  EXPECT_EQ(check(text, true).errors, 0u);
  // A setting DMIS does not place in a block is a warning when read leniently, an error strictly.
  std::string fly = text;
  fly.replace(fly.find("  SNSLCT/S(P2)\n"), 0, "  FLY/1.0\n");
  EXPECT_TRUE(check(fly).has("warning: FLY inside a MEAS block is not DMIS")) << check(fly).text;
  EXPECT_TRUE(check(fly, true).has("error: FLY is not allowed inside a MEAS block"));
}

TEST(ShopPrograms, ProgramsInAPackagesOwnLanguageAreToldOnce) {
  // A CMM package's own language looks like DMIS but is not: before, each of its lines was a
  // syntax error (12 for a short MCOSMOS GEOPAK contour program) or a warning (51 for NIST's
  // I++ DME stream), and nothing said what the file was.
  const auto geopak = check(
      "$$ generated contour program\nFILNAM/ \"SURF01\"\nSNSLCT/1\nDATSET/MCS\n"
      "CNCON / MESVEL = DEFALT, POSVEL = HIGH, APPRCH = 0.3\nCONTOUR/MEAS, \"Scan\", NUMBER=1\n"
      "ASSIGN/'ZMEAS'=\"10.000000\",FIXP=4\nPTMEAS/CART,10.000,20.000,'ZMEAS',VECCOMP,0,0,-1\nENDMES\nENDFIL\n");
  EXPECT_EQ(geopak.errors, 1u) << geopak.text;
  EXPECT_EQ(geopak.warnings, 0u) << geopak.text;
  EXPECT_TRUE(
      geopak.has("shop.dmi:5:1: error: this file is not DMIS: it reads as a part program in MCOSMOS GEOPAK's own "
                 "language (CNCON/ here, and no DMISMN)"))
      << geopak.text;
  const auto pcdmis = check(
      "PART NAME  : BLOCK\n            MODE/DCC\n            LOADPROBE/PROBE1\nPNT2       =FEAT/POINT,RECT\n"
      "            ENDMEAS/\n            COMMENT/OPER,\"done\"\n");
  EXPECT_EQ(pcdmis.errors, 1u) << pcdmis.text;
  EXPECT_TRUE(
      pcdmis.has("shop.dmi:2:13: error: this file is not DMIS: it reads as a part program in PC-DMIS's own language "
                 "(MODE/DCC here"))
      << pcdmis.text;
  // A real file no one here wrote: NIST's I++ DME command stream of the simple part.
  std::ifstream in(fs::path(METRON_SHARED_DATA) / "nist-simple-part/simple.prg");
  ASSERT_TRUE(in);
  std::stringstream text;
  text << in.rdbuf();
  const auto ipp = check(text.str());
  EXPECT_EQ(ipp.errors, 1u) << ipp.text;
  EXPECT_EQ(ipp.warnings, 0u);
  EXPECT_TRUE(
      ipp.has("shop.dmi:1:1: error: this file is not DMIS: it reads as an I++ DME command stream, a client's tagged "
              "commands (StartSession() here"))
      << ipp.text;
  // DMIS stays DMIS: a DMISMN makes any program DMIS, whatever vendor words it holds.
  const auto dmis = check("DMISMN/'p', 5.0\nCONTOUR/MEAS, 'Scan'\nDRIVE/ZAXIS, 10\nENDFIL\n");
  EXPECT_FALSE(dmis.has("not DMIS")) << dmis.text;
  EXPECT_EQ(dmis.errors, 0u) << dmis.text;
}

TEST(ShopPrograms, ACountersinksGaugeCircleIsCutFromItsCone) {
  // CONST/CIRCLE,F(x),CONE,FA(cone),DIAM,d | DIST,h: the section of the cone (its vertex at x,y,z)
  // where its diameter is d, or h from the vertex along the axis. Before: a warning, no actual.
  // Expected by hand: a full apex angle a has radius h tan(a/2) at h.
  const std::string stated =
      "DMISMN/'csk', 5.1\nUNITS/MM, ANGDEC\nFA(CS)=FEAT/CONE,INNER,CART,1,2,10,0,0.6,0.8,60\n"
      "F(G)=FEAT/CIRCLE,INNER,CART,1,2,16,0,0,1,8\nF(H)=FEAT/CIRCLE,INNER,CART,1,2,13,0,0,1,6\n"
      "CONST/CIRCLE,F(G),CONE,FA(CS),DIAM,8\nCONST/CIRCLE,F(H),CONE,FA(CS),DIST,3\nOUTPUT/FA(G),FA(H)\n";
  EXPECT_EQ(check(stated + "ENDFIL\n").errors, 0u) << check(stated + "ENDFIL\n").text;
  const auto r = run(stated + "ENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const Eigen::Vector3d vertex(1, 2, 10), axis(0, 0.6, 0.8);
  const double tan30 = std::tan(M_PI / 6);
  const auto* g = report(*r.session, "G");
  ASSERT_TRUE(g && g->actual);
  EXPECT_NEAR(g->actual->diameter_mm, 8.0, 1e-12);
  EXPECT_NEAR((g->actual->position - (vertex + 4 / tan30 * axis)).norm(), 0.0, 1e-9);  // 6.93 mm up the axis
  EXPECT_NEAR((g->actual->direction - axis).norm(), 0.0, 1e-12);
  const auto* h = report(*r.session, "H");
  ASSERT_TRUE(h && h->actual);
  EXPECT_NEAR(h->actual->diameter_mm, 2 * 3 * tan30, 1e-12);
  EXPECT_NEAR((h->actual->position - (vertex + 3 * axis)).norm(), 0.0, 1e-9);
  // Only a cone is cut, only a circle is made, and the value is positive.
  const auto cylinder =
      run("DMISMN/'c', 5.1\nFA(CY)=FEAT/CYLNDR,INNER,CART,0,0,0,0,0,1,10,5\n"
          "CONST/CIRCLE,F(G),CONE,FA(CY),DIAM,8\nENDFIL\n");
  EXPECT_NE(cylinder.diagnostics.find("CONE cuts a CONE, FA(CY) is a CYLNDR"), std::string::npos)
      << cylinder.diagnostics;
  EXPECT_TRUE(
      check(
          "DMISMN/'c', 5.1\nFA(CS)=FEAT/CONE,INNER,CART,1,2,10,0,0,1,60\nCONST/POINT,F(P),CONE,FA(CS),DIAM,8\nENDFIL\n")
          .has("CONE constructs a CIRCLE"));
  const auto negative = run(
      "DMISMN/'c', 5.1\nFA(CS)=FEAT/CONE,INNER,CART,1,2,10,0,0,1,60\nCONST/CIRCLE,F(G),CONE,FA(CS),DIST,-1\nENDFIL\n");
  EXPECT_NE(negative.diagnostics.find("the distance must be positive"), std::string::npos) << negative.diagnostics;
}

TEST(ShopPrograms, ASensorsMountIsNotedNotAnError) {
  // SNSDEF/PROBE,...,SW(x): the wrist (extension, sensor group) a probe hangs from. Before: an
  // error "expected a value, got the label SW(W1)".
  const auto c = check(
      "DMISMN/'m', 5.1\nS(P1)=SNSDEF/PROBE,INDEX,POL,0,0,0,0,-1,100,4,SW(W1)\n"
      "S(P2)=SNSDEF/PROBE,FIXED,CART,0,0,50,0,0,-1,2,SX(E1)\nSNSLCT/S(P1)\nENDFIL\n");
  EXPECT_EQ(c.errors + c.warnings, 0u) << c.text;
  EXPECT_EQ(c.notes, 1u) << c.text;
  EXPECT_TRUE(c.has("S(P1) names the SW(W1) it is mounted on")) << c.text;
  // Only last: a label among the numbers is still an error.
  EXPECT_EQ(check("DMISMN/'m', 5.1\nS(P1)=SNSDEF/PROBE,FIXED,CART,0,0,50,SW(W1),0,-1,2\nENDFIL\n").errors, 1u);
}

TEST(ShopPrograms, DefaltGivesTheMachinesOwnFeedsAndAccelerationBack) {
  // FEDRAT/DEFALT, FEDRAT/POSVEL,DEFALT and ACLRAT/...,DEFALT: before, errors at check.
  const auto feeds_after = [](const std::string& lines) {
    const auto r = run("DMISMN/'d', 5.0\nUNITS/MM, ANGDEC\n" + lines + "ENDFIL\n");
    EXPECT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
    const auto s = r.session->runtime().machine().state();
    return std::make_pair(s.positioning_feed_mm_s, s.measuring_feed_mm_s);
  };
  const auto own = feeds_after("");
  EXPECT_NE(feeds_after("FEDRAT/POSVEL, MMPS, 20\nFEDRAT/MESVEL, MMPS, 2\n"), own);
  EXPECT_EQ(feeds_after("FEDRAT/POSVEL, MMPS, 20\nFEDRAT/MESVEL, MMPS, 2\nFEDRAT/DEFALT\n"), own);
  const auto one = feeds_after("FEDRAT/POSVEL, MMPS, 20\nFEDRAT/MESVEL, MMPS, 2\nFEDRAT/POSVEL, DEFALT\n");
  EXPECT_EQ(one.first, own.first);
  EXPECT_EQ(one.second, 2.0);
  // A 200 mm move: slower under a programmed acceleration of 10 mm/s^2, as fast again after DEFALT;
  // on the default machine and on one whose axes have their own ramp laws (which the programmed
  // acceleration caps).
  for (const std::optional<fs::path>& world :
       {std::optional<fs::path>(), std::optional(source_dir / "programs/worlds/touch_braking.json")}) {
    const auto move_time = [&](const std::string& lines) {
      const auto r = run(
          "DMISMN/'a', 5.0\nUNITS/MM, ANGDEC\nGOTO/300, 200, 200\n" + lines + "GOTO/500, 200, 200\nENDFIL\n", world);
      EXPECT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
      return r.session->runtime().machine().state().time_s;
    };
    const double plain = move_time("");
    EXPECT_GT(move_time("ACLRAT/POSACL, MMPSS, 10\n"), plain + 1.0);
    EXPECT_NEAR(move_time("ACLRAT/POSACL, MMPSS, 10\nACLRAT/POSACL, DEFALT\n"), plain, 1e-9);
    EXPECT_NEAR(move_time("ACLRAT/POSACL, MMPSS, 10\nACLRAT/DEFALT\n"), plain, 1e-9);
  }
}

TEST(ShopPrograms, AJumpOutOfABlockStopsTheRunAtTheNextMeas) {
  // JUMPTO belongs in a block; one that leaves it skips its ENDMES: the next MEAS says so instead
  // of dropping the open block's points unseen.
  std::string text = bore_program("S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n");
  text.replace(text.find("  GOTO/40, 50, 80\nENDMES"), 0, "  JUMPTO/(OUT)\n");
  text.replace(text.find("OUTPUT/FA(BORE1)"), 0, "(OUT)\nMEAS/CIRCLE, F(BORE1), 4\nENDMES\n");
  EXPECT_EQ(check(text).errors, 0u) << check(text).text;
  const auto r = run(text);
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find(
                "MEAS of BORE1 while the block of BORE1 is still open (a JUMPTO out of it skipped its ENDMES)"),
            std::string::npos)
      << r.diagnostics;
}

TEST(ShopPrograms, CheckCountsScanModePtmeasAsScansLikeTheRun) {
  // RationalDMIS's form: after SCNMOD/ON two PTMEAS are the start and end of a scan, so a circle
  // with one pair is measured by a scan of many points and MEAS's count is not a PTMEAS count
  // (Scanning.ScnmodWithPtmeasPairsScansFromStartToEnd runs it). Check said "needs at least 3".
  const std::string head =
      "DMISMN/'scan pairs', 05.2\nUNITS/MM, ANGDEC\n"
      "F(C1) = FEAT/CIRCLE, INNER, CART, 0, 0, 0, 0, 0, 1, 20\n";
  const std::string pair = "PTMEAS/CART, 10, 0, -5, -1, 0, 0\nPTMEAS/CART, -10, 0, -5, 1, 0, 0\n";
  const auto scanned = check(head + "SCNMOD/ON\nMEAS/CIRCLE, F(C1), 50\n" + pair + "ENDMES\nSCNMOD/OFF\nENDFIL\n");
  EXPECT_EQ(scanned.errors + scanned.warnings, 0U) << scanned.text;
  // An odd PTMEAS has no end: the run stops there, and check now says so at that PTMEAS.
  const auto odd =
      check(head + "SCNMOD/ON\nMEAS/CIRCLE, F(C1), 3\n" + pair + "PTMEAS/CART, 0, 10, -5, 0, -1, 0\nENDMES\nENDFIL\n");
  EXPECT_EQ(odd.errors, 1U) << odd.text;
  EXPECT_TRUE(odd.has("shop.dmi:8:1: error: in scan mode (SCNMOD/ON) PTMEAS come in pairs")) << odd.text;
  // After SCNMOD/OFF the same block is three touches again: no error, and two are too few.
  const auto touched = check(head + "SCNMOD/ON\nSCNMOD/OFF\nMEAS/CIRCLE, F(C1), 2\n" + pair + "ENDMES\nENDFIL\n");
  EXPECT_TRUE(touched.has("a CIRCLE needs at least 3 points, the block has 2")) << touched.text;
}

// CORTOL's polar coordinates and the LIMIT form of DISTB, against the geometry by hand. The bore's
// nominal is written 0.5 mm off in X (40.5, 50); the world's bore is at (40, 50), which its four
// points find. Polar radius and angle in each working plane: XY (40, 50) against (40.5, 50); YZ
// (50, 30) against (50, 30); ZX (30, 40) against (30, 40.5).
TEST(ShopPrograms, PolarCoordinatesAndDistanceLimitsAreEvaluated) {
  const std::string text =
      "DMISMN/'shop', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 80\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40.5, 50, 30, 0, 0, 1, 20\n"
      "MEAS/CIRCLE, F(BORE1), 4\n  GOTO/40.5, 50, 30\n"
      "  PTMEAS/CART, 50.5, 50, 30, -1, 0, 0\n  PTMEAS/CART, 40.5, 60, 30, 0, -1, 0\n"
      "  PTMEAS/CART, 30.5, 50, 30, 1, 0, 0\n  PTMEAS/CART, 40.5, 40, 30, 0, 1, 0\n  GOTO/40.5, 50, 80\nENDMES\n"
      "F(PNT) = FEAT/POINT, CART, 45, 50, 30, 0, 0, 1\nCONST/POINT, F(PNT), MOVEPT, FA(BORE1), 5, 0, 0\n"
      "T(PR) = TOL/CORTOL, RADIUS, -0.1, 0.1\nT(PA) = TOL/CORTOL, ANGLE, -0.1, 0.1\n"
      "T(LIM) = TOL/DISTB, LIMIT, 4.99, 5.03, XAXIS\nT(OUT) = TOL/DISTB, LIMIT, 5.01, 5.05, XAXIS\n"
      "OUTPUT/FA(BORE1), TA(PR), TA(PA)\nOUTPUT/FA(BORE1), FA(PNT), TA(LIM), TA(OUT)\n"
      "WKPLAN/YZPLAN\nOUTPUT/FA(BORE1), TA(PR), TA(PA)\nWKPLAN/ZXPLAN\nOUTPUT/FA(BORE1), TA(PR), TA(PA)\nENDFIL\n";
  const auto checked = check(text);
  EXPECT_EQ(checked.errors + checked.warnings, 0U) << checked.text;
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  std::vector<const metron::runtime::ToleranceResult*> results;
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::ToleranceResult>(&e)) results.push_back(t);
  ASSERT_EQ(results.size(), 8U);
  constexpr double deg = 180.0 / std::numbers::pi;
  constexpr double tol_mm = 2e-3;
  const struct {
    double actual, nominal;
    bool angle;
  } want[] = {{std::hypot(40.0, 50.0), std::hypot(40.5, 50.0), false},
              {std::atan2(50.0, 40.0) * deg, std::atan2(50.0, 40.5) * deg, true},
              {std::hypot(50.0, 30.0), std::hypot(50.0, 30.0), false},
              {std::atan2(30.0, 50.0) * deg, std::atan2(30.0, 50.0) * deg, true},
              {std::hypot(30.0, 40.0), std::hypot(30.0, 40.5), false},
              {std::atan2(40.0, 30.0) * deg, std::atan2(40.5, 30.0) * deg, true}};
  const std::size_t polar[] = {0, 1, 4, 5, 6, 7};
  for (std::size_t i = 0; i < 6; ++i) {
    SCOPED_TRACE(i);
    const auto& t = *results[polar[i]];
    EXPECT_NEAR(t.actual, want[i].actual, want[i].angle ? 3e-3 : tol_mm);
    EXPECT_NEAR(t.nominal, want[i].nominal, 1e-9);
    EXPECT_NEAR(t.value, want[i].actual - want[i].nominal, want[i].angle ? 3e-3 : tol_mm);
    EXPECT_EQ(t.angle_value, want[i].angle);
    EXPECT_EQ(t.in_tolerance, std::abs(want[i].actual - want[i].nominal) < 0.1);
  }
  // LIMIT: the distance 5 (MOVEPT's offset along X exactly) against 4.99..5.03 (IN, 0.01 below the
  // middle) and 5.01..5.05 (OUT).
  EXPECT_NEAR(results[2]->actual, 5.0, 1e-9);
  EXPECT_NEAR(results[2]->value, -0.01, 1e-9);
  EXPECT_TRUE(results[2]->in_tolerance);
  EXPECT_NEAR(results[3]->value, -0.03, 1e-9);
  EXPECT_FALSE(results[3]->in_tolerance);
  // The report shows the angle in degrees and names the plane.
  const std::string report = metron::runtime::format_tolerance_result(*results[5]);
  EXPECT_NE(report.find("polar angle in YZPLAN"), std::string::npos) << report;
  // Limits the wrong way round, and a coordinate CORTOL does not know.
  const auto wrong = check(
      "DMISMN/'t', 5.0\nT(L) = TOL/DISTB, LIMIT, 5.05, 5.01, XAXIS\n"
      "T(Q) = TOL/CORTOL, PZ, -0.1, 0.1\nWKPLAN/FA(TOP)\nENDFIL\n");
  EXPECT_TRUE(wrong.has("shop.dmi:2:32: error: the lower limit 5.05 is above the upper limit 5.01")) << wrong.text;
  EXPECT_TRUE(wrong.has("TOL/CORTOL,PZ is not evaluated by metron")) << wrong.text;
  EXPECT_TRUE(wrong.has("WKPLAN takes XYPLAN, YZPLAN or ZXPLAN")) << wrong.text;
}

// Polar positions (FEAT/POL, PTMEAS/POL, GOTO/POL) are (radius, angle, height) in the working plane
// WKPLAN set, as CMM software reads them: YZPLAN (y, z) and x the height, ZXPLAN (z, x) and y.
// Before, they stayed in XY whatever WKPLAN said. The bore of the world at (40, 50, 30) written in
// YZPLAN and a point of the top face (60, 80, 40) in ZXPLAN, their numbers computed here.
TEST(ShopPrograms, PolarPositionsAreInTheWorkingPlane) {
  constexpr double deg = 180.0 / std::numbers::pi;
  // (u, v, n) -> "r, angle, h" of the POL form.
  const auto pol = [&](double u, double v, double n) {
    return fmt::format("{:.9f}, {:.9f}, {:.9f}", std::hypot(u, v), std::atan2(v, u) * deg, n);
  };
  // YZPLAN: u = y, v = z, n = x.   ZXPLAN: u = z, v = x, n = y.
  const auto yz = [&](double x, double y, double z) { return pol(y, z, x); };
  const auto zx = [&](double x, double y, double z) { return pol(z, x, y); };
  const std::string text =
      "DMISMN/'polar', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 80\nWKPLAN/YZPLAN\n"
      "F(BORE1) = FEAT/CIRCLE, INNER, POL, " +
      yz(40, 50, 30) +
      ", 0, 0, 1, 20\n"
      "MEAS/CIRCLE, F(BORE1), 4\n  GOTO/POL, " +
      yz(40, 50, 30) +
      "\n"
      "  PTMEAS/POL, " +
      yz(50, 50, 30) + ", -1, 0, 0\n  PTMEAS/POL, " + yz(40, 60, 30) +
      ", 0, -1, 0\n"
      "  PTMEAS/POL, " +
      yz(30, 50, 30) + ", 1, 0, 0\n  PTMEAS/POL, " + yz(40, 40, 30) +
      ", 0, 1, 0\n"
      "  GOTO/POL, " +
      yz(40, 50, 80) +
      "\nENDMES\nWKPLAN/ZXPLAN\n"
      "F(TOPPT) = FEAT/POINT, POL, " +
      zx(60, 80, 40) +
      ", 0, 0, 1\n"
      "MEAS/POINT, F(TOPPT), 1\n  GOTO/POL, " +
      zx(60, 80, 50) + "\n  PTMEAS/POL, " + zx(60, 80, 40) + ", 0, 0, 1\nENDMES\nOUTPUT/FA(BORE1), FA(TOPPT)\nENDFIL\n";
  const auto checked = check(text);
  EXPECT_EQ(checked.errors + checked.warnings, 0U) << checked.text;
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* bore = report(*r.session, "BORE1");
  ASSERT_TRUE(bore && bore->actual) << r.diagnostics;
  EXPECT_LT((bore->nominal.position - Eigen::Vector3d(40, 50, 30)).norm(), 1e-6);
  EXPECT_LT((bore->actual->position - Eigen::Vector3d(40, 50, 30)).norm(), 2e-3);
  EXPECT_NEAR(bore->actual->diameter_mm, 20.0, 2e-3);
  const auto* top = report(*r.session, "TOPPT");
  ASSERT_TRUE(top && top->actual) << r.diagnostics;
  EXPECT_LT((top->nominal.position - Eigen::Vector3d(60, 80, 40)).norm(), 1e-6);
  EXPECT_LT((top->actual->position - Eigen::Vector3d(60, 80, 40)).norm(), 2e-3);
}

// A setting between a block's points (FEDRAT, ACLRAT, SNSET) holds for the points after it, as
// SNSLCT there does: before, it held for the whole block, which metron measures at ENDMES. The
// first point's nominal is 4 mm above the top face (z = 40): SEARCH 6 finds it; the SEARCH 2 after
// it, applied to the whole block, made it "no contact within 2.000 mm".
TEST(ShopPrograms, ASettingInsideABlockHoldsFromWhereItStands) {
  const std::string text =
      "DMISMN/'block settings', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/90, 10, 80\nSNSET/SEARCH, 6\n"
      "F(TOP) = FEAT/PLANE, CART, 120, 25, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 4\n"
      "  PTMEAS/CART, 90, 10, 44, 0, 0, 1\n  SNSET/SEARCH, 2\n  FEDRAT/MESVEL, MMPS, 4\n"
      "  PTMEAS/CART, 150, 10, 40, 0, 0, 1\n  PTMEAS/CART, 150, 40, 40, 0, 0, 1\n  PTMEAS/CART, 90, 40, 40, 0, 0, 1\n"
      "ENDMES\nOUTPUT/FA(TOP)\nF(LOW) = FEAT/POINT, CART, 100, 20, 43, 0, 0, 1\nMEAS/POINT, F(LOW), 1\nENDMES\n"
      "ENDFIL\n";
  const auto checked = check(text);
  EXPECT_EQ(checked.errors + checked.warnings, 0U) << checked.text;
  const auto r = run(text, source_dir / "programs/worlds/probe_library.json");
  const auto* top = report(*r.session, "TOP");
  ASSERT_TRUE(top && top->actual) << r.diagnostics;
  EXPECT_EQ(top->point_count, 4U);
  EXPECT_NEAR(top->actual->position.z(), 40.0, 2e-3);
  // The FEDRAT between the first point and the second holds from the second on: the feed differs
  // from the qualification's at line 12, not at the first point (line 9).
  EXPECT_NE(r.diagnostics.find("run.dmi:12:3: warning: probing at 4.000 mm/s"), std::string::npos) << r.diagnostics;
  // SEARCH 2 holds after the block: the point 3 mm above the face (line 18) is not found.
  ASSERT_EQ(r.status, ExecStatus::Faulted) << r.diagnostics;
  const auto* fault = std::get_if<metron::runtime::FaultReport>(&r.session->record().events.back());
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->statement.line, 18U);
  EXPECT_NE(fault->message.find("no contact within 2.000 mm"), std::string::npos) << fault->message;
}

// A dry run follows a program to its end: CHARACTERISE there (example 06) stopped it with
// "characterisation failed: ... a positive feed and ramp time", the nominal machine having no
// ramps. It is a warning now, and the program's bore is measured after it.
TEST(ShopPrograms, ADryRunGoesPastCharacterise) {
  const auto r = dry_run(
      "DMISMN/'dry', 5.0\nUNITS/MM, ANGDEC\nCALL/EXTERN, SYS, 'CHARACTERISE touch.json'\n"
      "SNSLCT/SA(T1A0B0)\nF(B) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\n"
      "MEAS/CIRCLE, F(B), 4\nENDMES\nOUTPUT/FA(B)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("CHARACTERISE in a dry run: the nominal machine has no dynamics to characterise"),
            std::string::npos)
      << r.diagnostics;
  const auto* b = report(*r.session, "B");
  ASSERT_TRUE(b && b->actual);
  EXPECT_NEAR(b->actual->diameter_mm, 20.0, 1e-9);
}

// A file that is not DMIS and whose language metron has no signature for (here a report and a
// QUINDOS-like listing, written for this test) is told once: before, an error or a warning on each
// line. A DMIS module without DMISMN (a CALL/EXTERN file) with one bad line keeps its diagnostics.
TEST(ShopPrograms, AFileThatIsNotDmisIsToldOnce) {
  const auto report = check(
      "Inspection report  part 4711   operator: K. Meier\n"
      "------------------------------------------------\n"
      "Feature      Nominal    Actual     Dev      Tol\n"
      "Bore 1 D     20.000     20.004    0.004   +-0.010   OK\n"
      "Bore 2 D     20.000     19.987   -0.013   +-0.010   NOT OK\n"
      "Flatness A    0.000      0.006    0.006    0.020    OK\n"
      "MESPLN (NAM=EBENE1, NPT=4)\nMESCIR (NAM=KREIS1, NPT=8)\n");
  EXPECT_EQ(report.errors, 1U) << report.text;
  EXPECT_EQ(report.warnings, 0U) << report.text;
  EXPECT_TRUE(
      report.has("shop.dmi:1:1: error: this file does not read as DMIS: 8 of its lines are not DMIS statements"))
      << report.text;
  const auto module = check(
      "GOTO/10, 10, 60\nF(P1) = FEAT/POINT, CART, 10, 10, 50, 0, 0, 1\nMEAS/POINT, F(P1), 1\n"
      "PTMEAS/CART, 10, 10, 50, 0, 0, 1\nENDMES\nthis line is a note\nGOTO/10, 10, 60\n");
  EXPECT_FALSE(module.has("does not read as DMIS")) << module.text;
  EXPECT_TRUE(module.has("shop.dmi:6:1: warning: this line is not a DMIS statement")) << module.text;
  // Five notes in a module of twenty statements: still DMIS (the bad lines are not the most).
  std::string long_module;
  for (int k = 0; k < 20; ++k)
    long_module += (k % 4 == 0 ? "operator note " + std::to_string(k) + "\n" : "") + "GOTO/10, 10, 60\n";
  const auto noted = check(long_module);
  EXPECT_FALSE(noted.has("does not read as DMIS")) << noted.text;
  EXPECT_TRUE(noted.has("shop.dmi:21:1: warning: this line is not a DMIS statement")) << noted.text;
}

// EOLN(DID(x)): .TRUE. once READ has taken the last field of a line (and at the end of the file),
// so a program can read rows of different lengths field by field: rows of 3, 2 and 1 values.
TEST(ShopPrograms, EolnEndsEachRowOfAnInputFile) {
  write("rows.txt", "1, 2, 3\n4 5\n\n6\n");
  const auto r =
      run("DMISMN/'p', 5.0\nDECL/REAL,X,S\nDECL/INTGR,N\nDECL/BOOL,B\n"
          "DID(IN1)=DEVICE/STOR,'rows.txt'\nOPEN/DID(IN1),DIRECT,INPUT\nB=ASSIGN/EOLN(DID(IN1))\n"
          "TEXT/OPER,STR(B)\n(ROW)\nIF/(.NOT.EOF(DID(IN1)))\n  S=ASSIGN/0\n  N=ASSIGN/0\n"
          "  (FIELD)\n  READ/DID(IN1),X\n  S=ASSIGN/S+X\n  N=ASSIGN/N+1\n"
          "  IF/(.NOT.EOLN(DID(IN1)))\n    JUMPTO/(FIELD)\n  ENDIF\n"
          "  TEXT/OPER,CONCAT(STR(N),':',STR(S,1))\n  JUMPTO/(ROW)\nENDIF\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const std::vector<std::string> texts = texts_of(*r.session);
  EXPECT_EQ(texts, (std::vector<std::string>{".FALSE.", "3:6.0", "2:9.0", "1:6.0"}));
}

// LOCATE read leniently: a word it does not know is a warning (--strict: an error), a LOCATE
// without a feature an error; at run, features that cannot fix a freedom given are an error at
// its line naming the freedom (the top face alone says nothing of X), and fixing only what they
// can (ZDIR, XAXIS, YAXIS) the fit goes on. DAT(x) fits the datum's feature.
TEST(ShopPrograms, LocateIsReadLenientlyAndNamesWhatItCannotFix) {
  const std::string head =
      "DMISMN/'locate', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/20, 20, 80\n"
      "F(TOP) = FEAT/PLANE, CART, 80, 50, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 4\n"
      "  PTMEAS/CART, 10, 10, 40, 0, 0, 1\n  PTMEAS/CART, 150, 10, 40, 0, 0, 1\n"
      "  PTMEAS/CART, 150, 90, 40, 0, 0, 1\n  PTMEAS/CART, 10, 90, 40, 0, 0, 1\nENDMES\nDATDEF/FA(TOP), DAT(A)\n";
  const auto lenient = check(head + "D(BF) = LOCATE/ZDIR, XAXIS, YAXIS, FA(TOP), MINMAX\nENDFIL\n");
  EXPECT_EQ(lenient.errors, 0U) << lenient.text;
  EXPECT_EQ(lenient.warnings, 1U) << lenient.text;
  EXPECT_TRUE(lenient.has("shop.dmi:14:45: warning: not read: LOCATE is a least-squares fit")) << lenient.text;
  EXPECT_EQ(check(head + "D(BF) = LOCATE/ZDIR, XAXIS, YAXIS, FA(TOP), MINMAX\nENDFIL\n", true).errors, 1U);
  EXPECT_TRUE(check(head + "D(BF) = LOCATE/XDIR, YDIR\nENDFIL\n").has("LOCATE needs at least one feature"));
  EXPECT_EQ(check(head + "D(BF) = LOCATE/FA(NOWHERE)\nENDFIL\n", true).errors, 1U);

  const auto loose = run(head + "D(BF) = LOCATE/FA(TOP)\nENDFIL\n", source_dir / "programs/worlds/perfect.json");
  EXPECT_EQ(loose.status, ExecStatus::Error);
  EXPECT_NE(loose.diagnostics.find("run.dmi:14:1: error: LOCATE D(BF): the features do not fix the part's"),
            std::string::npos)
      << loose.diagnostics;

  const auto fixed = run(head + "D(BF) = LOCATE/ZDIR, XAXIS, YAXIS, DAT(A)\nOUTPUT/FA(TOP)\nENDFIL\n",
                         source_dir / "programs/worlds/perfect.json");
  ASSERT_EQ(fixed.status, ExecStatus::Finished) << fixed.diagnostics;
  EXPECT_NE(fixed.diagnostics.find("LOCATE D(BF): 1 features fitted"), std::string::npos) << fixed.diagnostics;
  const auto* top = report(*fixed.session, "TOP");
  ASSERT_TRUE(top && top->actual);
  EXPECT_EQ(top->frame, "BF");
  EXPECT_NEAR(top->actual->position.z(), 40.0, 1e-6);
}

// ITERAT read in the form metron documents, or skipped with the reason (as before metron read it):
// no jump label, a word it does not know before the label, no accuracy and count.
TEST(ShopPrograms, IteratIsReadOrSkippedWithAReason) {
  const std::string head =
      "DMISMN/'iterat', 5.0\nUNITS/MM, ANGDEC\nSNSLCT/SA(T1A0B0)\nD(PART) = TRANS/XORIG, 300, YORIG, 200\n(AGAIN)\n"
      "F(P1) = FEAT/POINT, CART, 10, 10, 40, 0, 0, 1\nMEAS/POINT, F(P1), 1\nENDMES\n";
  const auto read = check(head + "D(IT) = ITERAT/ZDIR, FA(P1), (AGAIN), 0.01, 5, ABSL\nENDFIL\n");
  EXPECT_EQ(read.errors + read.warnings, 0U) << read.text;
  EXPECT_EQ(check(head + "D(IT) = ITERAT/-ZDIR, FA(P1), (AGAIN), 0.01, 5\nENDFIL\n").warnings, 0U);
  for (const char* form :
       {"D(IT) = ITERAT/ZDIR, FA(P1), 0.01, 5\n", "D(IT) = ITERAT/ZDIR, FA(P1), WHAT, (AGAIN), 0.01, 5\n",
        "D(IT) = ITERAT/ZDIR, FA(P1), (AGAIN), 0.01\n", "D(IT) = ITERAT/ZDIR, (AGAIN), 0.01, 5\n"}) {
    const auto skipped = check(head + std::string(form) + "ENDFIL\n");
    EXPECT_EQ(skipped.errors, 0U) << form << skipped.text;
    EXPECT_TRUE(skipped.has("warning: ITERAT is skipped: ")) << form << skipped.text;
  }
  // A jump label no statement defines is an error, as JUMPTO's is.
  EXPECT_EQ(check(head + "D(IT) = ITERAT/ZDIR, FA(P1), (NOWHERE), 0.01, 5\nENDFIL\n").errors, 1U);
  // At run, one point cannot fix the part's six freedoms: an error at the ITERAT naming them.
  const auto r = run(head + "D(IT) = ITERAT/ZDIR, FA(P1), (AGAIN), 0.01, 5\nENDFIL\n",
                     source_dir / "programs/worlds/perfect.json");
  EXPECT_EQ(r.status, ExecStatus::Error) << r.diagnostics;
  EXPECT_NE(r.diagnostics.find("error: ITERAT D(IT): the features do not fix the part's position along X, position "
                               "along Y, position along Z, rotation about X, rotation about Y and rotation about Z"),
            std::string::npos)
      << r.diagnostics;
}

// RAND, read as Fortran's RAND(flag) (no public text of DMIS's was found): uniform in [0, 1) by
// its moments (mean 1/2, variance 1/12: 4000 draws put the mean within 0.018 at four sigma),
// the same sequence every run, RAND(1) restarting it and RAND(n) seeding it.
// SELAPSETIME(start, end, LONG|SHORT) as CAMIO programs write it: the time between two SDATETIME
// strings, 'HH:MM:SS' or seconds (expected values by hand); SELAPSETIME() stays the run's seconds.
TEST(ShopPrograms, ElapsedTimeBetweenTwoDateTimes) {
  const std::string head = "DMISMN/'t', 05.2\nDECL/LOCAL, CHAR, 512, START, LAPSE, SECS\n";
  const auto r = run(head +
                     "LAPSE = ASSIGN/SELAPSETIME('2026/12/01 23:00:00', '2026/12/02 00:02:03', LONG)\n"
                     "SECS = ASSIGN/SELAPSETIME('2026/12/01 23:00:00', '2026/12/02 00:02:03', SHORT)\n"
                     "TEXT/OPER, LAPSE\nTEXT/OPER, SECS\nSTART = ASSIGN/SDATETIME( )\n"
                     "TEXT/OPER, SELAPSETIME(START, SDATETIME( ), LONG)\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(operator_texts(r), (std::vector<std::string>{"01:02:03", "3723", "00:00:00"})) << r.diagnostics;
  const Checked wrong = check(head + "LAPSE = ASSIGN/SELAPSETIME('a', 'b', HOURS)\nENDFIL\n");
  EXPECT_TRUE(wrong.has("3:38: error: SELAPSETIME's format is LONG ('HH:MM:SS') or SHORT (seconds)")) << wrong.text;
  const auto bad = run(head + "LAPSE = ASSIGN/SELAPSETIME('yesterday', SDATETIME( ))\nENDFIL\n");
  EXPECT_EQ(bad.status, ExecStatus::Error);
  EXPECT_NE(bad.diagnostics.find("SELAPSETIME: 'yesterday' is not a date-time as SDATETIME writes it"),
            std::string::npos)
      << bad.diagnostics;
}

TEST(ShopPrograms, RandDrawsAUniformSequenceThatRepeats) {
  const std::string text =
      "DMISMN/'rand', 5.0\nDECL/REAL,F,S,Q,A,LO,HI,B,C,D,E\nDECL/INTGR,I\n"
      "F=ASSIGN/RAND()\nS=ASSIGN/0\nQ=ASSIGN/0\nLO=ASSIGN/1\nHI=ASSIGN/0\n"
      "DO/I,1,4000\nA=ASSIGN/RAND()\nS=ASSIGN/S+A\nQ=ASSIGN/Q+A*A\nLO=ASSIGN/MN(LO,A)\nHI=ASSIGN/MX(HI,A)\nENDDO\n"
      "B=ASSIGN/RAND(1)\nC=ASSIGN/RAND(7)\nD=ASSIGN/RAND(7)\nE=ASSIGN/RAND(0)\nENDFIL\n";
  EXPECT_EQ(check(text).warnings, 0u) << check(text).text;
  const auto first = run(text);
  ASSERT_EQ(first.status, ExecStatus::Finished) << first.diagnostics;
  const auto value = [](const Ran& r, const char* name) { return r.session->interpreter().variable(name)->number; };
  const double mean = value(first, "S") / 4000;
  EXPECT_NEAR(mean, 0.5, 4 * std::sqrt(1.0 / 12 / 4000));
  EXPECT_NEAR(value(first, "Q") / 4000 - mean * mean, 1.0 / 12, 0.006);
  EXPECT_GE(value(first, "LO"), 0.0);
  EXPECT_LT(value(first, "HI"), 1.0);
  EXPECT_EQ(value(first, "B"), value(first, "F"));  // RAND(1): the sequence from its start
  EXPECT_EQ(value(first, "C"), value(first, "D"));  // RAND(7) twice: the same seed, the same number
  EXPECT_NE(value(first, "E"), value(first, "D"));  // RAND(0): the next one
  const auto again = run(text);
  ASSERT_EQ(again.status, ExecStatus::Finished) << again.diagnostics;
  EXPECT_EQ(value(again, "S"), value(first, "S"));
}

// A feature type metron skips (SYMPLN, COMPOUND ...): read leniently its MEAS block is skipped
// with it (its points, here in the air, would stop the run with a missed contact if taken), its
// OUTPUT is left out, and another use is a warning at check where the run stops, as check says.
// --strict: errors.
TEST(ShopPrograms, TheMeasurementOfASkippedFeatureIsSkippedWithIt) {
  const std::string head =
      "DMISMN/'skip', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "SNSLCT/S(P4)\nMODE/PROG, MAN\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
      "F(SYM) = FEAT/SYMPLN, CART, 80, 50, 20, 1, 0, 0\nMEAS/SYMPLN, F(SYM), 2\n"
      "PTMEAS/CART, -50, 50, 20, -1, 0, 0\nGOTO/-60, 50, 20\nPTMEAS/CART, 250, 50, 20, 1, 0, 0\nENDMES\n"
      "F(TOP) = FEAT/PLANE, CART, 80, 50, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 3\nPTMEAS/CART, 10, 10, 40, 0, 0, 1\n"
      "PTMEAS/CART, 150, 10, 40, 0, 0, 1\nPTMEAS/CART, 80, 90, 40, 0, 0, 1\nENDMES\n"
      "T(FL) = TOL/FLAT, 0.05\nOUTPUT/FA(SYM), FA(TOP), TA(FL)\n";
  const Checked c = check(head + "ENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(
      c.has("8:6: warning: MEAS of F(SYM): metron skips FEAT/SYMPLN, so this block is skipped up to its "
            "ENDMES, its points not taken"))
      << c.text;
  EXPECT_TRUE(
      c.has("20:8: warning: feature FA(SYM) is defined only by a statement metron skipped: left out of this "
            "OUTPUT"))
      << c.text;
  const auto r = run(head + "ENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* flat = tolerance(*r.session, "FL");
  ASSERT_NE(flat, nullptr);  // the rest of the OUTPUT: the top face's flatness
  EXPECT_NEAR(flat->value, 0.0, 0.005);
  const std::string used = head + "DATDEF/FA(SYM), DAT(S)\nENDFIL\n";
  const Checked u = check(used);
  EXPECT_EQ(u.errors, 0u) << u.text;
  EXPECT_TRUE(
      u.has("21:8: warning: feature FA(SYM) is defined only by a statement metron skipped: it has no actual, "
            "and a run stops here"))
      << u.text;
  const auto stopped = run(used);
  EXPECT_EQ(stopped.status, ExecStatus::Error);
  EXPECT_NE(stopped.diagnostics.find("21:1: error: FA(SYM) is not defined yet"), std::string::npos)
      << stopped.diagnostics;
  const Checked strict = check(used, true);
  EXPECT_TRUE(strict.has("8:6: error: MEAS of F(SYM): metron skips FEAT/SYMPLN\n")) << strict.text;
  EXPECT_TRUE(strict.has("21:8: error: feature FA(SYM) is defined only by a statement metron skipped")) << strict.text;
}

// PUSH/POP: a macro's alignment, working plane and sensor given back. P1 is measured in D(SHIFT)
// (10 mm along X of the part), P2 after POP/ALGN in D(PART): both touch the top face at machine
// X 380 (the part at 300: 70 + 10, and 80); without the POP, P2 would land at 390.
// PUSH/FEDRAT saves the positioning, measuring and scanning feeds; POP/FEDRAT gives them back
// (read with VALUE/FEDRAT, mm/s), whatever FEDRAT changed between them.
TEST(ShopPrograms, PushAndPopGiveBackTheFeeds) {
  const auto r =
      run("DMISMN/'feeds', 5.0\nUNITS/MM, ANGDEC\nDECL/REAL, KM, KP, KS\n"
          "S(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(P4)\n"
          "FEDRAT/MESVEL, MMPS, 4\nFEDRAT/POSVEL, MMPS, 40\nFEDRAT/SCNVEL, MMPS, 8\nPUSH/FEDRAT\n"
          "FEDRAT/MESVEL, MMPS, 2\nFEDRAT/POSVEL, MMPS, 20\nFEDRAT/SCNVEL, MMPS, 5\nPOP/FEDRAT\n"
          "KM = VALUE/FEDRAT, MESVEL\nKP = VALUE/FEDRAT, POSVEL\nKS = VALUE/FEDRAT, SCNVEL\n"
          "TEXT/OPER, CONCAT(STR(KM), ' ', STR(KP), ' ', STR(KS))\nENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(operator_texts(r), (std::vector<std::string>{"4 40 8"})) << r.diagnostics;
}

TEST(ShopPrograms, PushAndPopGiveBackTheAlignmentWorkingPlaneAndSensor) {
  const std::string text =
      "DMISMN/'push', 5.0\nUNITS/MM, ANGDEC\nS(P4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\n"
      "S(P2) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 2.0\nSNSLCT/S(P4)\nMODE/PROG, MAN\n"
      "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nPUSH/ALGN, WKPLAN, SNSLCT, DMISMD\n"
      "D(SHIFT) = TRANS/XORIG, 10\nWKPLAN/YZPLAN\nSNSLCT/S(P2)\n"
      "F(P1) = FEAT/POINT, CART, 70, 50, 40, 0, 0, 1\nMEAS/POINT, F(P1), 1\nPTMEAS/CART, 70, 50, 40, 0, 0, 1\n"
      "ENDMES\nPOP/ALGN, WKPLAN, SNSLCT\n"
      "F(P2) = FEAT/POINT, CART, 80, 50, 40, 0, 0, 1\nMEAS/POINT, F(P2), 1\nPTMEAS/CART, 80, 50, 40, 0, 0, 1\n"
      "ENDMES\n";
  const Checked c = check(text + "ENDFIL\n");
  EXPECT_EQ(c.errors, 0u) << c.text;
  EXPECT_TRUE(
      c.has("8:28: warning: PUSH/DMISMD: metron saves and restores ALGN, SNSLCT, WKPLAN, SNSET, GEOALG and FEDRAT"))
      << c.text;
  EXPECT_TRUE(check(text + "ENDFIL\n", true).has("8:28: error: PUSH/DMISMD")) << check(text, true).text;
  const auto r = run(text + "ENDFIL\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  const auto* p1 = r.session->runtime().find_feature("P1");
  const auto* p2 = r.session->runtime().find_feature("P2");
  ASSERT_TRUE(p1 && p1->actual && p2 && p2->actual);
  EXPECT_NEAR(p1->actual->position.x(), 380.0, 1e-3);
  EXPECT_NEAR(p2->actual->position.x(), 380.0, 1e-3);
  EXPECT_EQ(r.session->runtime().working_plane(), metron::runtime::WorkingPlane::XY);
  EXPECT_EQ(r.session->runtime().active_sensor(), "P4");
  const auto unbalanced = run(text + "POP/ALGN\nENDFIL\n");
  EXPECT_EQ(unbalanced.status, ExecStatus::Error);
  EXPECT_NE(unbalanced.diagnostics.find("21:1: error: POP/ALGN without a PUSH/ALGN left to restore"), std::string::npos)
      << unbalanced.diagnostics;
  // check tells it beforehand; the balanced POP above is not told.
  const Checked unbalanced_check = check(text + "POP/ALGN\nENDFIL\n");
  EXPECT_TRUE(unbalanced_check.has("21:5: warning: POP/ALGN has no PUSH/ALGN before it in this program"))
      << unbalanced_check.text;
  EXPECT_FALSE(c.has("has no PUSH")) << c.text;
}
