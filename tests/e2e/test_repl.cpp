// SPDX-License-Identifier: GPL-3.0-or-later
// Scripted debugger and REPL sessions through the metron binary (commands from a file).
#include <gtest/gtest.h>

#include "scratch.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;

fs::path temp(const std::string& name) {
  const fs::path d = metron::test_support::scratch_root("metron_repl");
  fs::create_directories(d);
  return d / name;
}

std::pair<int, std::string> session(const std::string& args, const std::string& commands) {
  const fs::path script = temp("commands.txt");
  std::ofstream(script) << commands;
  std::string out;
  const std::string command = std::string(METRON_BINARY) + " " + args + " --out " + temp("out").parent_path().string() +
                              " --commands " + script.string() + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  char buf[4096];
  while (pipe && std::fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = pipe ? ::pclose(pipe) : -1;
  return {WEXITSTATUS(status), out};
}

const std::string example = std::string(METRON_SOURCE_DIR) + "/programs/examples/01_first_circle.dmi";

TEST(Debugger, BreaksAtALineAndAtAFeatureAndPrintsActuals) {
  const auto [code, out] =
      session("debug " + example, "break 13\nbreak F(BORE1)\nrun\ncontinue\nprint FA(BORE1)\ncontinue\n");
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("breakpoint 1: " + example + ":13: MEAS/CIRCLE, F(BORE1), 4"), std::string::npos) << out;
  EXPECT_NE(out.find("breakpoint 2: F(BORE1) measured\nnext: " + example + ":21: OUTPUT/FA(BORE1), TA(DIAM1)"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("FA(BORE1)  CIRCLE INNER  measured, 4 points  frame PART"), std::string::npos) << out;
  EXPECT_NE(out.find("  pt  4 "), std::string::npos) << out;
  EXPECT_NE(out.find("the program has ended"), std::string::npos) << out;
}

TEST(Debugger, StepsIntoAMacroAndNextStepsOverIt) {
  const fs::path prog = temp("macro.dmi");
  std::ofstream(prog) << "DMISMN/'macro', 5.0\n"   // 1
                         "DECL/REAL, R\n"          // 2
                         "M(TWICE) = MACRO/'X'\n"  // 3
                         "R = ASSIGN/X * 2\n"      // 4
                         "TEXT/OPER, STR(R)\n"     // 5
                         "ENDMAC\n"                // 6
                         "CALL/M(TWICE), 21\n"     // 7
                         "CALL/M(TWICE), 5\n"      // 8
                         "TEXT/OPER, 'done'\n"     // 9
                         "ENDFIL\n";
  const auto [code, out] =
      session("debug " + prog.string(), "break 7\nrun\nstep\nwhere\nprint X\nfinish\nnext\nnext\n");
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("breakpoint 1: " + prog.string() + ":7: CALL/M(TWICE), 21"), std::string::npos) << out;
  EXPECT_NE(out.find("(metron) step\n" + prog.string() + ":4: R = ASSIGN/X * 2"), std::string::npos) << out;
  EXPECT_NE(out.find("#0 M(TWICE) at " + prog.string() + ":4: R = ASSIGN/X * 2\n#1 " + prog.string()),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("X = 21"), std::string::npos) << out;
  // finish returns from the macro (printing 42), next runs the second call whole (printing 10).
  EXPECT_NE(out.find("(metron) finish\n42\n" + prog.string() + ":8: CALL/M(TWICE), 5"), std::string::npos) << out;
  EXPECT_NE(out.find("(metron) next\n10\n" + prog.string() + ":9: TEXT/OPER, 'done'"), std::string::npos) << out;
}

TEST(Repl, TypedMeasBlockMeasuresAndABadStatementDoesNotEndTheSession) {
  const auto [code, out] =
      session("repl",
              "S(P) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4\nSNSLCT/S(P)\n"
              "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\n"
              "F(B2) = FEAT/CIRCLE, INNER, CART, 120, 30, 35, 0, 0, 1, 12\nGOTO/120, 30, 60\n"
              "MEAS/CIRCLE, F(B2), 4\nPTMEAS/CART, 126, 30, 35, -1, 0, 0\nPTMEAS/CART, 120, 36, 35, 0, -1, 0\n"
              "PTMEAS/CART, 114, 30, 35, 1, 0, 0\nPTMEAS/CART, 120, 24, 35, 0, 1, 0\nENDMES\n"
              "F(BAD) = FEAT/CIRCLE, INNER, CART, 1, 2, 3\n"
              "DECL/REAL, D\nD = OBTAIN/FA(B2), 10\nprint D\nprint FA(B2)\nmachine\n");
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("...> ENDMES"), std::string::npos) << out;
  EXPECT_NE(out.find(":1:42: error: FEAT/CIRCLE expects 7 numbers (x,y,z,i,j,k,diam), got 3"), std::string::npos)
      << out;
  // After the error the session goes on: the diameter of the bore measured at the prompt.
  const auto at = out.find("D = 12.0");
  EXPECT_NE(at, std::string::npos) << out;
  EXPECT_NE(out.find("sensor     P (nominal radius 2.0000"), std::string::npos) << out;
  EXPECT_NE(out.find("last hit   420.0000"), std::string::npos) << out;
}

TEST(Debugger, StopsOnAFaultWithBreakFault) {
  const fs::path prog = temp("fault.dmi");
  std::ofstream(prog) << "DMISMN/'fault', 5.0\nS(P) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 4\nSNSLCT/S(P)\n"
                         "GOTO/350, 250, 60\nGOTO/350, 250, 20\nTEXT/OPER, 'after'\nENDFIL\n";
  const auto [code, out] = session("debug " + prog.string(), "break fault\nrun\nmachine\ncontinue\n");
  EXPECT_EQ(code, 0) << out;
  EXPECT_NE(out.find("machine fault (breakpoint 1): collision:"), std::string::npos) << out;
  EXPECT_NE(out.find("position   350.0000 250.0000 42.0000"), std::string::npos) << out;
}

}  // namespace

// `continue` from a breakpoint inside a DO loop stops at it again on the next iteration (issue
// 14: it ran to the end, while `next` stopped).
TEST(Debugger, ContinueStopsAtTheSameBreakpointOnEachIterationOfADoLoop) {
  const fs::path prog = temp("loop.dmi");
  std::ofstream(prog) << "DMISMN/'loop', 5.0\n"  // 1
                         "DECL/INTGR, I\n"       // 2
                         "DO/I, 1, 3\n"          // 3
                         "TEXT/OPER, STR(I)\n"   // 4
                         "ENDDO\n"               // 5
                         "TEXT/OPER, 'done'\n"   // 6
                         "ENDFIL\n";
  const auto [code, out] = session("debug " + prog.string(), "break 4\nrun\ncontinue\ncontinue\ncontinue\n");
  EXPECT_EQ(code, 0) << out;
  std::size_t hits = 0;
  for (std::size_t at = out.find("breakpoint 1: " + prog.string() + ":4:"); at != std::string::npos;
       at = out.find("breakpoint 1: " + prog.string() + ":4:", at + 1))
    ++hits;
  EXPECT_EQ(hits, 3u) << out;
  EXPECT_NE(out.find("1\n"), std::string::npos) << out;
  EXPECT_NE(out.find("done"), std::string::npos) << out;
}

// Inside a MEAS block, a FEDRAT or SNSET waits for ENDMES, between the points after which it
// stands: `machine` shows the feeds before the block and says how many steps wait so; after
// ENDMES the FEDRAT holds.
TEST(Debugger, MachineTellsOfSettingsWaitingInABlock) {
  const fs::path prog = temp("block_settings.dmi");
  std::ofstream(prog) << "DMISMN/'block settings', 5.0\nUNITS/MM, ANGDEC\n"
                         "S(P) = SNSDEF/PROBE, FIXED, CART, 0, 0, 50, 0, 0, -1, 3\nSNSLCT/S(P)\n"
                         "D(PART) = TRANS/XORIG, 300, YORIG, 200, ZORIG, 0\nGOTO/90, 10, 80\n"
                         "F(TOP) = FEAT/PLANE, CART, 120, 25, 40, 0, 0, 1\nMEAS/PLANE, F(TOP), 3\n"  // 7, 8
                         "  PTMEAS/CART, 90, 10, 40, 0, 0, 1\n  FEDRAT/MESVEL, MMPS, 4\n  SNSET/SEARCH, 3\n"
                         "  PTMEAS/CART, 150, 10, 40, 0, 0, 1\n  PTMEAS/CART, 150, 40, 40, 0, 0, 1\n"  // 12, 13
                         "ENDMES\nTEXT/OPER, 'after'\nENDFIL\n";                                       // 14, 15
  const auto [code, out] = session("debug " + prog.string(), "break 12\nbreak 15\nrun\nmachine\ncontinue\nmachine\n");
  EXPECT_EQ(code, 0) << out;
  const auto inside = out.find(
      "measuring  F(TOP): 3 steps collected (2 settings or sensor selections, applied "
      "between the points), sent at ENDMES");
  ASSERT_NE(inside, std::string::npos) << out;
  EXPECT_NE(out.rfind("measuring 3.000 mm/s", inside), std::string::npos) << out;
  EXPECT_NE(out.find("measuring 4.000 mm/s", inside), std::string::npos) << out;
}
