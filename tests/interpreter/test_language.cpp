// SPDX-License-Identifier: GPL-3.0-or-later
// The IR interpreter: variables, expressions, control flow, macros, called files, units.
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "cli/virtual_cmm_backend.hpp"
#include "metron/interpreter/session.hpp"

namespace {

namespace fs = std::filesystem;
using metron::interpreter::ExecStatus;
using metron::interpreter::Session;

struct Ran {
  ExecStatus status;
  std::vector<std::string> texts;
  std::string diagnostics;
  std::unique_ptr<Session> session;
};

fs::path temp_dir() {
  const fs::path d = metron::test_support::scratch_root("metron_lang");
  fs::create_directories(d);
  return d;
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = temp_dir() / name;
  std::ofstream(p) << text;
  return p;
}

Ran run(const std::string& body, const std::string& name = "prog.dmi") {
  const fs::path p = write(name, "DMISMN/'test', 5.0\nUNITS/MM, ANGDEC\n" + body + "ENDFIL\n");
  auto backend = metron::cli::virtual_cmm_backend(std::nullopt, 1);
  EXPECT_TRUE(backend.has_value());
  Ran r;
  r.session = Session::create(std::move(*backend));
  if (!r.session->load(p.string())) {
    r.status = ExecStatus::Error;
  } else {
    r.status = r.session->interpreter().run();
  }
  for (const auto& e : r.session->record().events)
    if (const auto* t = std::get_if<metron::runtime::TextReport>(&e)) r.texts.push_back(t->text);
  r.diagnostics = r.session->take_diagnostics();
  return r;
}

TEST(Language, ArithmeticPrecedenceAndIntrinsics) {
  auto r =
      run("DECL/REAL, A, B\nDECL/INTGR, I\nDECL/CHAR, 20, S\n"
          "A = ASSIGN/2 + 3 * 4 ** 2 / 8 - -1\n"                         // 2 + 3*16/8 + 1 = 9
          "B = ASSIGN/SQRT(16) + ABS(-2) + MN(3, 1, 2) + ATAN2(1, 1)\n"  // 4 + 2 + 1 + 45 (ANGDEC)
          "I = ASSIGN/7 / 2\n"                                           // INTGR truncates 3.5 -> 3
          "S = ASSIGN/CONCAT('ab', STR(I), SUBSTR('xyz', 2, 3))\n"
          "TEXT/OPER, STR(A)\nTEXT/OPER, STR(B)\nTEXT/OPER, STR(I)\nTEXT/OPER, S\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  ASSERT_EQ(r.texts.size(), 4u);
  EXPECT_EQ(r.texts[0], "9");
  EXPECT_EQ(r.texts[1], "52");
  EXPECT_EQ(r.texts[2], "3");
  EXPECT_EQ(r.texts[3], "ab3yz");
}

// Issue 15: INTGR had no range check (3e9 was stored as it came, NaN too). INTGR is 32-bit signed,
// LONG exact up to 2^53 (docs/language.md); a value outside is an error naming the statement.
TEST(Language, IntegerVariablesHoldTheirRangeOnly) {
  auto ok =
      run("DECL/INTGR, I, J\nDECL/LONG, L\nI = ASSIGN/2147483647\nJ = ASSIGN/-2147483648.9\n"
          "L = ASSIGN/3000000000 * 1000\nTEXT/OPER, STR(I)\nTEXT/OPER, STR(J)\nTEXT/OPER, STR(L)\n");
  ASSERT_EQ(ok.status, ExecStatus::Finished) << ok.diagnostics;
  ASSERT_EQ(ok.texts.size(), 3u);
  EXPECT_EQ(ok.texts[0], "2147483647");
  EXPECT_EQ(ok.texts[1], "-2147483648");  // truncated toward zero, still inside
  EXPECT_EQ(ok.texts[2], "3000000000000");
  for (const char* value : {"2147483648", "-3E9", "-2147483649", "1E300"}) {
    auto r = run(std::string("DECL/INTGR, I\nI = ASSIGN/") + value + "\nTEXT/OPER, 'not reached'\n");
    EXPECT_EQ(r.status, ExecStatus::Error) << value;
    EXPECT_TRUE(r.texts.empty()) << value;
    EXPECT_NE(r.diagnostics.find("prog.dmi:4:"), std::string::npos) << r.diagnostics;
    EXPECT_NE(r.diagnostics.find("I is declared INTGR"), std::string::npos) << r.diagnostics;
  }
  auto l = run("DECL/LONG, L\nL = ASSIGN/1E17\n");
  EXPECT_EQ(l.status, ExecStatus::Error);
  EXPECT_NE(l.diagnostics.find("L is declared LONG"), std::string::npos) << l.diagnostics;
  // A DO loop over an INTGR cannot step past the range either.
  auto loop = run("DECL/INTGR, I\nDO/I, 2147483646, 2147483648\nENDDO\n");
  EXPECT_EQ(loop.status, ExecStatus::Error);
  EXPECT_NE(loop.diagnostics.find("DO: I is declared INTGR"), std::string::npos) << loop.diagnostics;
}

TEST(Language, IfElseWithAndWithoutParentheses) {
  auto r =
      run("DECL/INTGR, I\nI = ASSIGN/5\n"
          "IF/(I .GT. 3 .AND. .NOT. (I .EQ. 4))\nTEXT/OPER, 'big'\nELSE\nTEXT/OPER, 'small'\nENDIF\n"
          "IF/I .LT. 3\nTEXT/OPER, 'wrong'\nENDIF\n"
          "IF/(I .GE. 5 .OR. I .LT. 0)\nTEXT/OPER, 'yes'\nENDIF\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"big", "yes"}));
}

TEST(Language, DoLoopsWithStepsAndArrays) {
  auto r =
      run("DECL/INTGR, I, J\nDECL/REAL, SUM, V[5]\nSUM = ASSIGN/0\n"
          "DO/I, 1, 5\nV[I] = ASSIGN/I * I\nENDDO\n"
          "DO/J, 5, 1, -2\nSUM = ASSIGN/SUM + V[J]\nENDDO\n"  // 25 + 9 + 1
          "DO/I, 3, 1\nTEXT/OPER, 'never'\nENDDO\n"
          "TEXT/OPER, STR(SUM)\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"35"}));
}

TEST(Language, ArraysOfSeveralDimensions) {
  // RationalDMIS's DECL/COMMON,DOUBLE,XX,NUM[3,30]: before, a declaration of two sizes was an
  // error, and an element V[i,j] of a one-dimensional array read V[i] (its second index ignored).
  auto r =
      run("DECL/COMMON, DOUBLE, XX, NUM[3,30]\nDECL/INTGR, I, J\n"
          "DO/I, 1, 3\nDO/J, 1, 30\nNUM[I,J] = ASSIGN/I*100 + J\nENDDO\nENDDO\n"
          "TEXT/OPER, STR(NUM[2,7])\nTEXT/OPER, STR(NUM[3,30] + NUM[1,1])\n"
          "NUM[1,31] = ASSIGN/0\n");
  EXPECT_EQ(r.texts, (std::vector<std::string>{"207", "431"}));
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find("index 1,31 is outside NUM[1..3,1..30]"), std::string::npos) << r.diagnostics;
  const auto rank = run("DECL/REAL, V[4], W[2,2]\nV[1,2] = ASSIGN/1\nV[1] = ASSIGN/W[1]\n");
  EXPECT_NE(rank.diagnostics.find("array V has 1 dimension: write V[i]"), std::string::npos) << rank.diagnostics;
  EXPECT_NE(rank.diagnostics.find("array W has 2 dimensions: write W[i,j]"), std::string::npos) << rank.diagnostics;
}

TEST(Language, TextJoinsItsPartsAndStrFormatsAWidth) {
  // TEXT/OPER,'R=',STR(R) showed only 'R=' (its other parts were dropped unseen); STR(x,w,d)
  // and STR of a BOOL were errors.
  auto r =
      run("DECL/REAL, R\nDECL/BOOL, B\nR = ASSIGN/2.5\nB = ASSIGN/(R .GT. 2)\n"
          "TEXT/OPER, 'R = ', STR(R), ' mm, ', R, ' B=', B\n"
          "TEXT/OPER, CONCAT('[', STR(R, 8, 3), ']', STR(B))\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"R = 2.5 mm, 2.5 B=.TRUE.", "[   2.500].TRUE."}));
}

TEST(Language, JumpToLabels) {
  auto r =
      run("DECL/INTGR, N\nN = ASSIGN/0\n(AGAIN)\nN = ASSIGN/N + 1\n"
          "IF/(N .LT. 4)\nJUMPTO/(AGAIN)\nENDIF\nTEXT/OPER, STR(N)\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"4"}));
}

TEST(Language, MacrosTakeValuesAndLabels) {
  auto r =
      run("DECL/REAL, R\n"
          "M(SQUARE) = MACRO/'X'\nR = ASSIGN/X * X\nENDMAC\n"
          "M(DEFINE) = MACRO/'NAME', 'D'\nF(NAME) = FEAT/CIRCLE, INNER, CART, 0, 0, 0, 0, 0, 1, D\nENDMAC\n"
          "CALL/M(SQUARE), 1.5\nTEXT/OPER, STR(R)\n"
          "CALL/M(DEFINE), F(HOLE9), 12\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"2.25"}));
  const auto* f = r.session->runtime().find_feature("HOLE9");
  ASSERT_NE(f, nullptr) << "the macro defined F(HOLE9) through its label parameter";
  EXPECT_DOUBLE_EQ(f->nominal.diameter_mm, 12.0);
}

TEST(Language, CalledFilesShareTheContext) {
  write("sub.dmi", "TEXT/OPER, CONCAT('sub sees ', STR(K))\nK = ASSIGN/K + 1\n");
  auto r = run("DECL/INTGR, K\nK = ASSIGN/41\nCALL/EXTERN, DMIS, 'sub.dmi'\nTEXT/OPER, STR(K)\n", "main.dmi");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"sub sees 41", "42"}));
}

TEST(Language, InchAndRadianUnitsConvertAtTheEdge) {
  auto r =
      run("UNITS/INCH, ANGRAD\nF(P) = FEAT/POINT, CART, 1, 2, 3, 0, 0, 1\n"
          "DECL/REAL, A\nA = ASSIGN/SIN(PI() / 2)\nTEXT/OPER, STR(A)\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"1"}));
  const auto* f = r.session->runtime().find_feature("P");
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(f->nominal.position.x(), 25.4, 1e-12);
  EXPECT_NEAR(f->nominal.position.z(), 76.2, 1e-12);
}

TEST(Language, RunTimeErrorsArePositioned) {
  auto r = run("DECL/REAL, A, B\nB = ASSIGN/0\nA = ASSIGN/1 / B\n");
  EXPECT_EQ(r.status, ExecStatus::Error);
  EXPECT_NE(r.diagnostics.find("prog.dmi:5:1: error: division by zero"), std::string::npos) << r.diagnostics;
}

TEST(Language, VendorStatementsAreSkippedWithAWarning) {
  auto r = run("VNDRX/SOMETHING, 1, 2\nTEXT/OPER, 'after'\nVNDRX/AGAIN\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"after"}));
  EXPECT_NE(r.diagnostics.find("prog.dmi:3:1: warning: unknown statement VNDRX is skipped (told once per word)"),
            std::string::npos)
      << r.diagnostics;
  EXPECT_EQ(r.diagnostics.find("prog.dmi:5:1"), std::string::npos) << r.diagnostics;  // the second is not told
}

TEST(Language, ObtainReadsFeatureParameters) {
  auto r =
      run("F(C) = FEAT/CIRCLE, INNER, CART, 1, 2, 3, 0, 0, 1, 10\n"
          "DECL/REAL, D\nD = OBTAIN/F(C), 10\nTEXT/OPER, STR(D)\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"10"}));
}

TEST(Language, ObtainOnABoundedLineReadsTheEndPoint) {
  // FA(x)=FEAT/LINE,BND,CART,x1,y1,z1,x2,y2,z2,i2,j2,k2 (DMIS 5.x, as FEAT takes it and the DMIS
  // output writes it): OBTAIN counts the words LINE, BND, CART first, so 7 is x2. UNBND: 7-9 are i,j,k.
  auto r =
      run("F(L) = FEAT/LINE, BND, CART, 1, 2, 3, 11, 2, 3, 0, 0, 1\n"
          "F(U) = FEAT/LINE, UNBND, CART, 1, 2, 3, 0, 1, 0, 0, 0, 1\n"
          "DECL/REAL, X2, K2, J\nX2 = OBTAIN/F(L), 7\nK2 = OBTAIN/F(L), 12\nJ = OBTAIN/F(U), 8\n"
          "TEXT/OPER, STR(X2)\nTEXT/OPER, STR(K2)\nTEXT/OPER, STR(J)\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"11", "1", "1"}));
  EXPECT_EQ(r.diagnostics.find("is not one of its numbers"), std::string::npos) << r.diagnostics;
}

// An OBTAIN index on a word of the output statement (CIRCLE, INNER, CART are 1 to 3) or past its
// last number: check tells where the numbers are, and the run stops there as told.
TEST(Language, AnObtainIndexOffTheNumbersIsToldAtCheck) {
  for (const int k : {3, 11}) {
    auto r = run("F(C) = FEAT/CIRCLE, INNER, CART, 1, 2, 3, 0, 0, 1, 10\nDECL/REAL, D\nD = OBTAIN/F(C), " +
                 std::to_string(k) + "\n");
    EXPECT_EQ(r.status, ExecStatus::Error) << r.diagnostics;
    EXPECT_NE(r.diagnostics.find(fmt::format("prog.dmi:5:18: warning: OBTAIN index {} of F(C) is not one of its "
                                             "numbers: its output statement has them at 4 to 10",
                                             k)),
              std::string::npos)
        << r.diagnostics;
    EXPECT_NE(r.diagnostics.find(fmt::format("error: OBTAIN index {} is not a number of F(C)", k)), std::string::npos)
        << r.diagnostics;
  }
}

TEST(Language, EmitIrKeepsSourcePositions) {
  const fs::path p = write("ir.dmi", "DMISMN/'ir', 5.0\nDECL/INTGR, I\nI = ASSIGN/1\nENDFIL\n");
  metron::SourceManager sources;
  metron::DiagnosticSink sink;
  metron::interpreter::Compiler compiler(sources, sink);
  ASSERT_TRUE(compiler.compile_file(p.string()));
  const std::string ir = metron::interpreter::ir::to_string(compiler.module(), sources);
  EXPECT_NE(ir.find("ASSIGN         I [1]"), std::string::npos) << ir;
  EXPECT_NE(ir.find("ir.dmi:3:1"), std::string::npos) << ir;
}

}  // namespace

// SCSNS(), SMODE() and SCFEAT(): the current sensor, mode and feature as strings (read as their
// names say, beside SDATE and STIME; they were unknown functions that stopped a run).
TEST(Language, CurrentSensorModeAndFeatureAreStrings) {
  auto r =
      run("TEXT/OPER, CONCAT('[', SCSNS(), '] [', SCFEAT(), '] ', SMODE())\n"
          "S(PROBE4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4.0\nSNSLCT/S(PROBE4)\n"
          "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/40, 50, 80\nMODE/PROG, MAN\n"
          "F(BORE1) = FEAT/CIRCLE, INNER, CART, 40, 50, 30, 0, 0, 1, 20\nMEAS/CIRCLE, F(BORE1), 4\n"
          "  GOTO/40, 50, 30\n  PTMEAS/CART, 50, 50, 30, -1, 0, 0\n  PTMEAS/CART, 40, 60, 30, 0, -1, 0\n"
          "  PTMEAS/CART, 30, 50, 30, 1, 0, 0\n  PTMEAS/CART, 40, 40, 30, 0, 1, 0\n  GOTO/40, 50, 80\nENDMES\n"
          "TEXT/OPER, CONCAT(SCSNS(), ' ', SCFEAT(), ' ', SMODE())\n"
          "F(MID) = FEAT/POINT, CART, 40, 50, 30, 0, 0, 1\nCONST/POINT, F(MID), MOVEPT, FA(BORE1), 0, 0, 0\n"
          "MODE/MAN\nTEXT/OPER, CONCAT(SCFEAT(), ' ', SMODE())\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"[] [] AUTO", "PROBE4 BORE1 PROG,MAN", "MID MAN"}));
}

// SCDAT(): the current coordinate system's label, which RationalDMIS's macros keep to give the
// system back after their own (DECL/CHAR,40,SD; SD=ASSIGN/SCDAT(); ...; RECALL/D(@SD)).
TEST(Language, CurrentCoordinateSystemIsAStringToRecall) {
  auto r =
      run("DECL/CHAR, 40, SD\nTEXT/OPER, SCDAT()\nD(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
          "SD = ASSIGN/SCDAT()\nD(OTHER) = TRANS/XORIG, 10, YORIG, 0, ZORIG, 0\nTEXT/OPER, SCDAT()\n"
          "RECALL/D(@SD)\nTEXT/OPER, SCDAT()\n");
  ASSERT_EQ(r.status, ExecStatus::Finished) << r.diagnostics;
  EXPECT_EQ(r.texts, (std::vector<std::string>{"MCS", "OTHER", "PART"}));
}

// VALUE/SNSET,word and VALUE/FEDRAT,word answer the setting in force (a program saves it to set it
// back), VALUE/SNSLCT the selected sensor; before, each was "not answered" and the variable kept
// its value. SNSET distances in the program's length unit, feeds in mm/s.
TEST(Language, ValueAnswersTheSettingsInForce) {
  auto s =
      run("DECL/REAL, KA, KS, KF, KP, KB\nDECL/CHAR, 20, KN\nUNITS/INCH, ANGDEC\nSNSET/APPRCH, 0.1\n"
          "S(PROBE4) = SNSDEF/PROBE, FIXED, CART, 0, 0, 2, 0, 0, -1, 0.16\nSNSLCT/S(PROBE4)\n"
          "FEDRAT/MESVEL, MMPS, 4\nFEDRAT/POSVEL, MMPS, 40\nKA = VALUE/SNSET, APPRCH\nKS = VALUE/SNSET, SEARCH\n"
          "KF = VALUE/FEDRAT, MESVEL\nKP = VALUE/FEDRAT, POSVEL\nKN = VALUE/SNSLCT\n"
          "SNSET/APPRCH, 0.5\nSNSET/APPRCH, KA\nKB = VALUE/SNSET, APPRCH\n"
          "TEXT/OPER, CONCAT(STR(KA), ' ', STR(KS * 25.4), ' ', STR(KF), ' ', STR(KP), ' ', KN, ' ', STR(KB))\n");
  ASSERT_EQ(s.status, ExecStatus::Finished) << s.diagnostics;
  // SEARCH at its default, 5 mm.
  EXPECT_EQ(s.texts, (std::vector<std::string>{"0.1 5 4 40 PROBE4 0.1"})) << s.diagnostics;
}
