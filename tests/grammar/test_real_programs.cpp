// SPDX-License-Identifier: GPL-3.0-or-later
// The real NIST DMIS programs from ../shared/data parse without a diagnostic.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>

#include "metron/grammar/parser.hpp"

using namespace metron;
using namespace metron::grammar;

namespace {

struct Loaded {
  SourceManager sources;
  DiagnosticSink sink;
  std::uint32_t file = 0;
  Program program;
};

// Loads and parses a file under METRON_SHARED_DATA; nullptr when the data folder is absent.
std::unique_ptr<Loaded> load(const std::string& relative) {
  const std::string path = std::string(METRON_SHARED_DATA) + "/" + relative;
  if (!std::filesystem::exists(path)) return nullptr;
  auto l = std::make_unique<Loaded>();
  l->file = l->sources.load(path);
  if (l->file == 0) return nullptr;
  l->program = parse_program(l->sources, l->file, l->sink);
  return l;
}

std::string diagnostics(const Loaded& l) {
  std::string out;
  for (const auto& d : l.sink.items()) out += format_diagnostic(d, l.sources);
  return out;
}

std::map<std::string, int> histogram(const Program& p) {
  std::map<std::string, int> h;
  for (const auto& s : p.statements) ++h[s.major];
  return h;
}

std::string lc(const Loaded& l, std::uint32_t offset) {
  const Location loc = l.sources.locate(l.file, offset);
  return std::to_string(loc.line) + ":" + std::to_string(loc.column);
}

}  // namespace

TEST(RealPrograms, NistDcxPartInspection) {
  auto l = load("nist-dcx-part/IMTS_M_clean.dmi");
  if (!l) GTEST_SKIP() << "shared data not found at " << METRON_SHARED_DATA << " (nist-dcx-part/IMTS_M_clean.dmi)";
  EXPECT_EQ(l->sink.items().size(), 0u) << diagnostics(*l);
  const auto& st = l->program.statements;
  ASSERT_EQ(st.size(), 111u);
  const std::map<std::string, int> want = {
      {"CLOSE", 1},  {"CONST", 2},  {"DATDEF", 4}, {"DATSET", 2},  {"DEVICE", 1}, {"DISPLY", 1}, {"DMISMN", 1},
      {"ENDFIL", 1}, {"ENDMES", 5}, {"FEAT", 7},   {"FILNAM", 1},  {"GOTO", 15},  {"MEAS", 5},   {"MODE", 1},
      {"OPEN", 1},   {"OUTPUT", 7}, {"PRCOMP", 1}, {"PTMEAS", 28}, {"ROTATE", 2}, {"SAVE", 1},   {"SNSDEF", 1},
      {"SNSET", 4},  {"SNSLCT", 1}, {"SNSMNT", 1}, {"TEXT", 2},    {"TOL", 7},    {"TRANS", 7},  {"UNITS", 1}};
  EXPECT_EQ(histogram(l->program), want);

  EXPECT_EQ(st[0].major, "DMISMN");
  ASSERT_EQ(st[0].params.size(), 2u);
  EXPECT_EQ(st[0].params[0].text, "IMTS_M_clean.dmi");
  EXPECT_DOUBLE_EQ(st[0].params[1].number, 4.0);
  EXPECT_EQ(lc(*l, st[0].span.begin), "16:1");
  EXPECT_EQ(st.back().major, "ENDFIL");  // the last line has no newline

  // DID(OUTFILE)=DEVICE/STOR,'C:\imts.dmo'
  const auto dev = std::find_if(st.begin(), st.end(), [](const Statement& s) { return s.major == "DEVICE"; });
  ASSERT_NE(dev, st.end());
  EXPECT_EQ(dev->target->prefix, "DID");
  EXPECT_EQ(dev->params[1].text, "C:\\imts.dmo");

  // F(CLIN1)=FEAT/LINE,... split over two lines with `$`.
  const auto clin =
      std::find_if(st.begin(), st.end(), [](const Statement& s) { return s.target && s.target->name == "CLIN1"; });
  ASSERT_NE(clin, st.end());
  EXPECT_EQ(clin->major, "FEAT");
  ASSERT_EQ(clin->params.size(), 12u);  // LINE,UNBND,CART, point, direction, normal
  EXPECT_EQ(clin->params[0].text, "LINE");
  EXPECT_EQ(clin->params[1].text, "UNBND");
  EXPECT_DOUBLE_EQ(clin->params[4].number, -52.0);
  EXPECT_DOUBLE_EQ(clin->params[11].number, 1.0);
  EXPECT_EQ(lc(*l, clin->span.begin), "86:1");
  EXPECT_EQ(lc(*l, clin->params[9].span.begin), "87:1");
  EXPECT_EQ(lc(*l, clin->span.end - 1), "87:17");

  // D(CALN1_b)= ROTATE/ZAXIS,FA(CLIN1),XDIR and T(TOL2)=TOL/POS,3D,...
  const auto rot =
      std::find_if(st.begin(), st.end(), [](const Statement& s) { return s.target && s.target->name == "CALN1_b"; });
  ASSERT_NE(rot, st.end());
  EXPECT_EQ(rot->major, "ROTATE");
  EXPECT_EQ(rot->params[1].kind, ExprKind::Label);
  EXPECT_EQ(rot->params[1].label.prefix, "FA");
  EXPECT_EQ(rot->params[1].label.name, "CLIN1");
  const auto tol2 =
      std::find_if(st.begin(), st.end(), [](const Statement& s) { return s.target && s.target->name == "TOL2"; });
  ASSERT_NE(tol2, st.end());
  EXPECT_EQ(tol2->params[1].kind, ExprKind::Word);
  EXPECT_EQ(tol2->params[1].text, "3D");
}

TEST(RealPrograms, NistSimplePart) {
  auto l = load("nist-simple-part/simple_in.dms");
  if (!l) GTEST_SKIP() << "shared data not found at " << METRON_SHARED_DATA << " (nist-simple-part/simple_in.dms)";
  EXPECT_EQ(l->sink.items().size(), 0u) << diagnostics(*l);
  const auto& st = l->program.statements;
  ASSERT_EQ(st.size(), 24u);
  const std::map<std::string, int> want = {{"DATSET", 1}, {"DMISMN", 1}, {"ENDFIL", 1}, {"ENDMES", 1}, {"FEAT", 1},
                                           {"FEDRAT", 1}, {"FILNAM", 1}, {"GOTO", 5},   {"MEAS", 1},   {"OUTPUT", 1},
                                           {"PTMEAS", 4}, {"SNSDEF", 1}, {"SNSET", 3},  {"SNSLCT", 1}, {"UNITS", 1}};
  EXPECT_EQ(histogram(l->program), want);
  const char* first[] = {"DMISMN", "FILNAM", "UNITS", "DATSET", "GOTO", "SNSDEF", "SNSLCT", "GOTO"};
  for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(st[i].major, first[i]) << i;
  const auto circle = std::find_if(st.begin(), st.end(), [](const Statement& s) { return s.major == "FEAT"; });
  ASSERT_NE(circle, st.end());
  EXPECT_EQ(circle->target->name, "A_CIRCLE");
  EXPECT_EQ(circle->params.size(), 10u);
  EXPECT_DOUBLE_EQ(circle->params[9].number, 50.0);
  EXPECT_EQ(st.back().major, "ENDFIL");
}
