// SPDX-License-Identifier: GPL-3.0-or-later
// Property tests with a fixed seed: no input makes the preprocessor or the parser throw or
// produce positions outside the file; the failing input is printed.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>

#include "metron/grammar/parser.hpp"
#include "metron/grammar/preprocess.hpp"

using namespace metron;
using namespace metron::grammar;

namespace {

std::string escaped(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out;
}

bool within(Span s, std::uint32_t file, std::size_t size) {
  return s.file == file && s.begin <= s.end && s.end <= size;
}

void check_expr(const Expr& e, std::uint32_t file, std::size_t size, int& bad) {
  if (!within(e.span, file, size)) ++bad;
  if (e.kind == ExprKind::Label && !within(e.label.span, file, size)) ++bad;
  for (const auto& a : e.args) check_expr(a, file, size, bad);
}

// Parses `src`; fails the test (printing the input) if anything throws or a span is off.
void check_input(const std::string& src) {
  SourceManager sources;
  DiagnosticSink sink;
  const auto file = sources.add("fuzz.dmi", src);
  // Spans point into the text as loaded: bytes that are not UTF-8 are decoded as Windows-1252.
  const std::string& text = sources.file(file).text;
  Program p;
  try {
    for (const auto& l : join_continuations(text)) {
      ASSERT_EQ(l.physical.size(), l.text.size() + 1) << "input: \"" << escaped(src) << "\"";
      for (std::size_t i = 0; i < l.text.size(); ++i)
        ASSERT_EQ(text[l.physical[i]], l.text[i]) << "input: \"" << escaped(src) << "\"";
    }
    p = parse_program(sources, file, sink);
  } catch (...) {
    FAIL() << "exception on input: \"" << escaped(src) << "\"";
  }
  int bad = 0;
  for (const auto& s : p.statements) {
    if (!within(s.span, file, text.size())) ++bad;
    if (!s.major.empty() && !within(s.major_span, file, text.size())) ++bad;
    if (s.target && !within(s.target->span, file, text.size())) ++bad;
    if (s.variable) check_expr(*s.variable, file, text.size(), bad);
    for (const auto& e : s.params) check_expr(e, file, text.size(), bad);
  }
  for (const auto& d : sink.items()) {
    if (!within(d.span, file, text.size())) ++bad;
    if (d.message.empty() || d.code.rfind("parse.", 0) != 0) ++bad;
    if (d.code == "parse.internal") ++bad;
    (void)format_diagnostic(d, sources);
  }
  EXPECT_EQ(bad, 0) << "input: \"" << escaped(src) << "\"";
}

}  // namespace

TEST(GrammarFuzz, RandomBytes) {
  std::mt19937 rng(20240607u);
  std::uniform_int_distribution<int> len(0, 80);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < 3000; ++i) {
    std::string s(static_cast<std::size_t>(len(rng)), '\0');
    for (char& c : s) c = static_cast<char>(byte(rng));
    check_input(s);
    if (HasFailure()) return;
  }
}

TEST(GrammarFuzz, RandomDmisLikeText) {
  // Mostly the characters of DMIS, so the parser gets deep into its rules.
  static const char raw[] = "FEATMSDPLNCXYZ0123456789019.+-*/,,,==(()))[]''$$\n\n  \t\r.EQ.AND.NOT.OR._#@!~%\0\xff";
  static const std::string alphabet(raw, sizeof raw - 1);
  std::mt19937 rng(7u);
  std::uniform_int_distribution<int> len(0, 120);
  std::uniform_int_distribution<std::size_t> pick(0, alphabet.size() - 1);
  for (int i = 0; i < 5000; ++i) {
    std::string s(static_cast<std::size_t>(len(rng)), ' ');
    for (char& c : s) c = alphabet[pick(rng)];
    check_input(s);
    if (HasFailure()) return;
  }
}

TEST(GrammarFuzz, MutatedRealStatements) {
  static const char* seeds[] = {
      "F(CLIN1)=FEAT/LINE,UNBND,CART,0.000,-52.000,30.000,1.000,0.000,0.000, $\n0.000,0.000,1.000\n",
      "D(CALN1_b)= ROTATE/ZAXIS,FA(CLIN1),XDIR\n",
      "IF/(V1.EQ.1 .AND. .NOT. SQRT(A[2]**2).GT.-3.5E-2)\n",
      "TEXT/OPER,'it''s $\n$$ ok'\n$$ comment $\nmore\n(L1)\nJUMPTO/(L1)\n",
      "T(TOL2)=TOL/POS,3D,0.100,RFS,DAT(A),DAT(B),DAT(C)\nV1[2,3]=ASSIGN/1,,2\n",
  };
  std::mt19937 rng(99u);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < 4000; ++i) {
    std::string s = seeds[static_cast<std::size_t>(i) % std::size(seeds)];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < edits && !s.empty(); ++k) {
      const std::size_t at = rng() % s.size();
      switch (rng() % 3) {
        case 0: s[at] = static_cast<char>(byte(rng)); break;
        case 1: s.erase(at, 1); break;
        default: s.insert(at, 1, s[rng() % s.size()]); break;
      }
    }
    check_input(s);
    if (HasFailure()) return;
  }
}
