// SPDX-License-Identifier: GPL-3.0-or-later
// Hostile program text (issue 15): no stack overflow, no huge allocation, no silent ambiguity,
// diagnostics that cannot flood or inject into a terminal.
#include <gtest/gtest.h>

#include <string>

#include "metron/interpreter/compiler.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/source.hpp"

namespace {

struct Compiled {
  metron::SourceManager sources;
  metron::DiagnosticSink sink;
  std::string all;  // every formatted diagnostic
  bool has(const std::string& text) const { return all.find(text) != std::string::npos; }
};

std::unique_ptr<Compiled> compile(const std::string& text) {
  auto c = std::make_unique<Compiled>();
  metron::interpreter::Compiler compiler(c->sources, c->sink);
  compiler.compile_text("<hostile>", text);
  for (const auto& d : c->sink.items()) c->all += metron::format_diagnostic(d, c->sources);
  return c;
}

const std::string header = "DMISMN/'hostile', 5.0\n";

std::string chain(const std::string& op, std::size_t terms) {
  std::string s = "1";
  for (std::size_t i = 1; i < terms; ++i) s += op + "1";
  return s;
}

TEST(HostileCompile, LongOperatorChainsAreRefusedNotAStackOverflow) {
  // Before: a left-associative chain of about 6,600 terms overflowed the stack in the expression
  // compiler (the 64-level nesting guard did not count chains).
  for (const std::string op : {"+", "*", ".AND."}) {
    const auto c = compile(header + "DECL/REAL, V\nV = ASSIGN/" + chain(op, 100'000) + "\nENDFIL\n");
    EXPECT_TRUE(c->has("expression too long (more than 1000 operators")) << op << "\n" << c->all.substr(0, 500);
  }
  const auto in_if = compile(header + "IF/(" + chain("+", 20'000) + " .GT. 0)\nENDIF\nENDFIL\n");
  EXPECT_TRUE(in_if->has("expression too long"));
  // A long but sane expression still compiles.
  const auto ok = compile(header + "DECL/REAL, V\nV = ASSIGN/" + chain("+", 900) + "\nENDFIL\n");
  EXPECT_FALSE(ok->sink.has_errors()) << ok->all;
}

TEST(HostileCompile, ArraySizesAreCheckedAndCapped) {
  // Before: V[1000000000] aborted with bad_alloc, sizes >= 2^31 became 1, V[1e300] cast
  // undefined, V[2.5] was accepted.
  for (const std::string size : {"1000000000", "2147483648", "1e300", "1000001"}) {
    const auto c = compile(header + "DECL/REAL, V[" + size + "]\nENDFIL\n");
    EXPECT_TRUE(c->has("exceeds the limit of 1e+06 elements")) << size << ": " << c->all;
  }
  for (const std::string size : {"2.5", "0", "-3"}) {
    const auto c = compile(header + "DECL/REAL, V[" + size + "]\nENDFIL\n");
    EXPECT_TRUE(c->has("needs positive whole sizes")) << size << ": " << c->all;
  }
  EXPECT_FALSE(compile(header + "DECL/REAL, V[1000000]\nENDFIL\n")->sink.has_errors());
}

TEST(HostileCompile, DuplicateLabelsAreDiagnosed) {
  // Before: duplicate (L1) was silent and JUMPTO went to the last; T/S/DID and DECL twice silent.
  const auto labels = compile(header + "(L1)\nTEXT/OPER, 'a'\n(L1)\nJUMPTO/(L1)\nENDFIL\n");
  EXPECT_TRUE(labels->has("<hostile>:4:1: error: label (L1) is defined twice (first at line 2)")) << labels->all;
  const auto tols = compile(header + "T(A) = TOL/DIAM, -0.1, 0.1\nT(A) = TOL/DIAM, -0.2, 0.2\nENDFIL\n");
  EXPECT_TRUE(tols->has("warning: T(A) is defined again (first at line 2)")) << tols->all;
  const auto decls = compile(header + "DECL/REAL, V\nDECL/INTGR, V\nENDFIL\n");
  EXPECT_TRUE(decls->has("warning: variable V is declared again (first at line 2)")) << decls->all;
  const auto dids = compile(header + "DID(A) = DEVICE/STOR, 'a.txt'\nDID(A) = DEVICE/STOR, 'b.txt'\nENDFIL\n");
  EXPECT_TRUE(dids->has("warning: DID(A) is defined again")) << dids->all;
  // Before: a second DATDEF of DAT(A) replaced the first silently.
  const auto datums = compile(header +
                              "F(P1) = FEAT/PLANE, CART, 0, 0, 0, 0, 0, 1\nF(P2) = FEAT/PLANE, CART, 0, 0, 5, 0, 0, 1\n"
                              "DATDEF/FA(P1), DAT(A)\nDATDEF/FA(P2), DAT(A)\nDATDEF/FA(P2), DAT(B)\nENDFIL\n");
  EXPECT_TRUE(datums->has("<hostile>:5:1: warning: DAT(A) is defined again (first at line 4)")) << datums->all;
  EXPECT_FALSE(datums->has("DAT(B) is defined again")) << datums->all;
}

TEST(HostileCompile, DiagnosticsEscapeControlBytesAndAreCapped) {
  // Before: 1 MB of random bytes gave 3,860 errors and echoed raw control bytes (terminal escape
  // injection).
  std::string junk;
  std::uint32_t x = 12345;
  for (int i = 0; i < 1'000'000; ++i) {
    x = x * 1664525u + 1013904223u;
    junk += static_cast<char>(x >> 24);
  }
  // Without DMISMN the junk does not read as DMIS: one error for the file.
  const auto alone = compile(junk);
  EXPECT_EQ(alone->sink.error_count(), 1U);
  EXPECT_TRUE(alone->has("this file does not read as DMIS")) << alone->all.substr(0, 2000);
  // After a DMISMN it is a program's text: every bad line is told, up to the cap.
  const auto c = compile(header + junk);
  EXPECT_LE(c->sink.error_count(), metron::DiagnosticSink::max_errors + 1);
  EXPECT_TRUE(c->has("too many errors"));
  EXPECT_LT(c->all.size(), 200'000u);
  for (const char ch : c->all) {
    const auto u = static_cast<unsigned char>(ch);
    EXPECT_TRUE(u >= 0x20 || ch == '\n' || ch == '\t') << "raw control byte " << int(u);
    if (!(u >= 0x20 || ch == '\n' || ch == '\t')) break;
  }
  const auto esc = compile(header + "FOO\x1b[31m/1\nENDFIL\n");
  EXPECT_EQ(esc->all.find('\x1b'), std::string::npos);
}

}  // namespace
