// SPDX-License-Identifier: GPL-3.0-or-later
// Bad statements: exact diagnostic code, message and line:col; recovery at the next line.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "metron/grammar/parser.hpp"

using namespace metron;
using namespace metron::grammar;

namespace {

struct BadCase {
  std::string source;
  std::string code;
  std::string message;
  std::string where;  // line:col of the diagnostic
};

// "code|message|line:col" of the only diagnostic (or a description of what went wrong).
std::string diagnose(const std::string& source, std::size_t* statements = nullptr) {
  SourceManager sources;
  DiagnosticSink sink;
  const auto file = sources.add("bad.dmi", source);
  const Program p = parse_program(sources, file, sink);
  if (statements) *statements = p.statements.size();
  if (sink.items().size() != 1) return std::to_string(sink.items().size()) + " diagnostics";
  const Diagnostic& d = sink.items()[0];
  const Location l = sources.locate(d.span);
  return d.code + "|" + d.message + "|" + std::to_string(l.line) + ":" + std::to_string(l.column);
}

// A text read leniently (the program and its diagnostics) and strictly (the diagnostics).
struct BothWays {
  SourceManager sources;
  DiagnosticSink lenient, strict;
  Program program;
};
std::unique_ptr<BothWays> parse_both_ways(const std::string& name, const std::string& text) {
  auto r = std::make_unique<BothWays>();
  const auto file = r->sources.add(name, text);
  r->program = parse_program(r->sources, file, r->lenient);
  parse_program(r->sources, file, r->strict, ParseOptions{true});
  return r;
}

class BadStatement : public ::testing::TestWithParam<BadCase> {};

}  // namespace

TEST_P(BadStatement, ReportsTheExpectedDiagnostic) {
  const BadCase& c = GetParam();
  std::size_t statements = 99;
  EXPECT_EQ(diagnose(c.source, &statements), c.code + "|" + c.message + "|" + c.where) << c.source;
  EXPECT_EQ(statements, 0u) << "a bad statement is not kept";
}

// clang-format off
INSTANTIATE_TEST_SUITE_P(Grammar, BadStatement, ::testing::Values(
  BadCase{"FEAT PLANE", "parse.expected-slash", "expected '/' after the major word 'FEAT'", "1:6"},
  BadCase{"GOTO/1,2,", "parse.expected-parameter", "expected a parameter after ','", "1:10"},
  BadCase{"GOTO/1, $$ comment", "parse.expected-parameter", "expected a parameter after ','", "1:9"},
  BadCase{"A/", "parse.expected-parameter", "expected a parameter after '/'", "1:3"},
  BadCase{"OUTPUT/FA(PLN1", "parse.expected-close", "expected ')' after the label name", "1:15"},
  BadCase{"OUTPUT/FA(PLN 1", "parse.expected-close", "expected ')' after the label name", "1:16"},
  BadCase{"OUTPUT/FA(PLN 1 ,X)", "parse.expected-close", "expected ')' after the label name", "1:17"},
  BadCase{"OUTPUT/FA()", "parse.expected-label-name", "expected a label name after 'FA('", "1:11"},
  BadCase{"TEXT/OPER,'abc", "parse.unterminated-string", "unterminated string", "1:11"},
  BadCase{"TEXT/OPER,'it''", "parse.unterminated-string", "unterminated string", "1:11"},
  BadCase{"A/1+", "parse.expected-expression", "expected an expression after '+'", "1:5"},
  BadCase{"A/-", "parse.expected-expression", "expected an expression after '-'", "1:4"},
  BadCase{"A/2** )", "parse.expected-expression", "expected an expression after '**'", "1:7"},
  BadCase{"A/.NOT.", "parse.expected-expression", "expected an expression after '.NOT.'", "1:8"},
  BadCase{"A/X .eq.", "parse.expected-expression", "expected an expression after '.EQ.'", "1:9"},
  BadCase{"A/X.AND.", "parse.expected-expression", "expected an expression after '.AND.'", "1:9"},
  BadCase{"A/(", "parse.expected-expression", "expected an expression after '('", "1:4"},
  BadCase{"A/(1+2", "parse.expected-close", "expected ')' after the expression in parentheses", "1:7"},
  BadCase{"GOTO/1,2,3 %", "parse.unexpected-character", "unexpected character '%' after parameter 3 of 'GOTO'", "1:12"},
  BadCase{"GOTO/1 $ 2", "parse.unexpected-character", "unexpected character '$' after parameter 1 of 'GOTO'", "1:8"},
  BadCase{"GOTO/1,2,3 \x01", "parse.unexpected-character", "unexpected character '\\x01' after parameter 3 of 'GOTO'", "1:12"},
  BadCase{"A/1 .XOR. 2", "parse.unknown-operator", "unknown operator '.XOR.' after parameter 1 of 'A'", "1:5"},
  BadCase{"A/1.5D", "parse.unexpected-character", "unexpected character 'D' after a number", "1:6"},
  BadCase{"A/1e999", "parse.number-range", "number '1e999' is too large", "1:3"},
  BadCase{"=FEAT/PLANE", "parse.expected-major", "expected a major word at the start of the statement", "1:1"},
  BadCase{"  12=FEAT/PLANE", "parse.expected-major", "expected a major word at the start of the statement", "1:3"},
  BadCase{"F(X)FEAT/PLANE", "parse.expected-equals", "expected '=' after the label 'F(X)'", "1:5"},
  BadCase{"V1[2] X", "parse.expected-equals", "expected '=' after the array element 'V1[...]'", "1:7"},
  BadCase{"F(X)=", "parse.expected-major", "expected a major word after '='", "1:6"},
  BadCase{"V1 = 3", "parse.expected-major", "expected a major word after '='", "1:6"},
  BadCase{"XYZ(A)=FEAT/PLANE", "parse.unknown-label-prefix", "unknown label prefix 'XYZ' before '(': the statement is skipped (--strict makes it an error)", "1:1"},
  BadCase{"A/SIN(1", "parse.expected-close", "expected ')' after the arguments of 'SIN'", "1:8"},
  BadCase{"A/SIN(", "parse.expected-argument", "expected an argument or ')' after 'SIN('", "1:7"},
  BadCase{"A/MAX(1,)", "parse.expected-argument", "expected an argument after ','", "1:9"},
  BadCase{"A/V1[", "parse.expected-index", "expected an index after 'V1['", "1:6"},
  BadCase{"A/V1[1", "parse.expected-close", "expected ']' after the index of 'V1'", "1:7"},
  BadCase{"A/V1[1,]", "parse.expected-index", "expected an index after ','", "1:8"},
  BadCase{"(L1", "parse.expected-close", "expected ')' after the label name", "1:4"},
  BadCase{"( )", "parse.expected-label-name", "expected a label name after '('", "1:3"},
  BadCase{"(L1) X", "parse.unexpected-character", "unexpected character 'X' after the jump label '(L1)'", "1:6"},
  BadCase{std::string("A/1\x01", 4), "parse.unexpected-character", "unexpected character '\\x01' after parameter 1 of 'A'", "1:4"},
  BadCase{std::string("A/\0", 3), "parse.expected-parameter", "expected a parameter after '/'", "1:3"},
  BadCase{"A/\xc3\xa9", "parse.expected-parameter", "expected a parameter after '/'", "1:3"},
  // Positions are physical even when the error is on a continuation line.
  BadCase{"GOTO/1,$\n  2,$\n  %", "parse.expected-parameter", "expected a parameter after ','", "3:3"},
  BadCase{"$$ c\nF(CLIN1)=FEAT/LINE,UNBND,$\n  CART,(1,2\n", "parse.expected-close", "expected ')' after the expression in parentheses", "3:10"}
));
// clang-format on

// A label prefix metron does not know (a vendor's, a newer DMIS's) skips its statement with a
// warning, as an unknown statement is; --strict keeps it an error. CI is CLMPID's.
TEST(ParserErrors, AnUnknownLabelPrefixSkipsItsStatementLeniently) {
  const auto r = parse_both_ways("prefix.dmi", "DH(X)=DMEHW/'controller'\nCI(CL1)=CLMPID/'CLAMP-A'\nENDFIL\n");
  EXPECT_EQ(r->program.statements.size(), 2u);
  EXPECT_EQ(r->lenient.error_count(), 0u);
  ASSERT_EQ(r->lenient.items().size(), 1u);
  EXPECT_EQ(r->lenient.items()[0].severity, Severity::Warning);
  EXPECT_EQ(r->strict.error_count(), 1u);
}

// Feature names as CMM software shows them, with a blank (`F(HOLE 1)`): read leniently the
// blanks are dropped, with one warning per file; strictly each is an error. Before: a syntax
// error "expected ')' after the label name".
TEST(ParserErrors, BlanksInsideALabelNameAreDroppedLeniently) {
  const auto r =
      parse_both_ways("blank.dmi", "F(HOLE 1)=FEAT/POINT,CART,0,0,0,0,0,1\nOUTPUT/FA( HOLE 1 ),F(HOLE\t2)\nENDFIL\n");
  ASSERT_EQ(r->program.statements.size(), 3u);
  ASSERT_TRUE(r->program.statements[0].target);
  EXPECT_EQ(r->program.statements[0].target->name, "HOLE1");
  ASSERT_EQ(r->program.statements[1].params.size(), 2u);
  EXPECT_EQ(r->program.statements[1].params[0].label.name, "HOLE1");
  EXPECT_EQ(r->program.statements[1].params[1].label.name, "HOLE2");
  EXPECT_EQ(r->lenient.error_count(), 0u);
  ASSERT_EQ(r->lenient.items().size(), 1u);
  EXPECT_EQ(r->lenient.items()[0].code, "parse.blank-in-label");
  EXPECT_EQ(r->sources.locate(r->lenient.items()[0].span).column, 3u);
  EXPECT_EQ(r->strict.error_count(), 2u);
}

// A public lab generator of CAMIO programs writes `F(A02F1=FEAT/POINT,...` (the `)` left out):
// read leniently the `)` is put back with a warning; elsewhere, and strictly, it is the error.
TEST(ParserErrors, ATargetLabelWithoutItsCloseIsRestoredLeniently) {
  const auto r = parse_both_ways("open.dmi", "F(A02F1=FEAT/POINT,CART,0,0,0,0,-1.0,0\nOUTPUT/FA(A02F1\nENDFIL\n");
  ASSERT_EQ(r->program.statements.size(), 2u);  // the OUTPUT is still an error
  ASSERT_TRUE(r->program.statements[0].target);
  EXPECT_EQ(r->program.statements[0].target->name, "A02F1");
  EXPECT_EQ(r->program.statements[0].major, "FEAT");
  EXPECT_EQ(r->program.statements[0].params.size(), 8u);
  ASSERT_EQ(r->lenient.items().size(), 2u);
  EXPECT_EQ(r->lenient.items()[0].code, "parse.missing-close");
  EXPECT_EQ(r->lenient.items()[0].severity, Severity::Warning);
  EXPECT_EQ(r->sources.locate(r->lenient.items()[0].span).column, 8u);
  EXPECT_EQ(r->lenient.items()[1].code, "parse.expected-close");
  EXPECT_EQ(r->strict.error_count(), 2u);
}

// The same generator leaves out commas in long CONST lists (`FA(E02F4)FA(F02F1)`, 12 errors in
// its mmt_code.dmi): read leniently the comma is put back with a warning, outside strings only.
TEST(ParserErrors, ACommaMissingBetweenTwoLabelsIsRestoredLeniently) {
  const auto r =
      parse_both_ways("comma.dmi", "CONST/PLANE,F(P),BF,FA(A1),FA(A2)FA(A3), FA(A4) FA(A5)\nTEXT/OPER,'(x)FA(y)'\n");
  ASSERT_EQ(r->program.statements.size(), 2u);
  ASSERT_EQ(r->program.statements[0].params.size(), 8u);
  EXPECT_EQ(r->program.statements[0].params[5].label.name, "A3");
  EXPECT_EQ(r->program.statements[0].params[7].label.name, "A5");
  EXPECT_EQ(r->program.statements[1].params[1].text, "(x)FA(y)");
  ASSERT_EQ(r->lenient.items().size(), 2u);
  EXPECT_EQ(r->lenient.items()[0].code, "parse.missing-comma");
  EXPECT_EQ(r->sources.locate(r->lenient.items()[0].span).column, 34u);  // where the comma belongs
  EXPECT_EQ(r->lenient.error_count(), 0u);
  EXPECT_EQ(r->strict.error_count(), 1u);
}

TEST(ParserErrors, DeepNestingIsAnErrorNotACrash) {
  const std::string deep = "A/" + std::string(100000, '(') + "1";
  EXPECT_EQ(diagnose(deep), "parse.too-deep|expression nested too deeply (more than 64 levels)|1:67");
  EXPECT_EQ(diagnose("A/" + std::string(100000, '-') + "1").substr(0, 15), "parse.too-deep|");
  std::string nots = "A/";
  for (int i = 0; i < 10000; ++i) nots += ".NOT.";
  EXPECT_EQ(diagnose(nots + "X").substr(0, 15), "parse.too-deep|");
  std::string pows = "A/2";
  for (int i = 0; i < 10000; ++i) pows += "**2";
  EXPECT_EQ(diagnose(pows).substr(0, 15), "parse.too-deep|");
  // 63 levels of parentheses inside the parameter are fine, 64 are not.
  std::size_t n = 0;
  EXPECT_EQ(diagnose("A/" + std::string(63, '(') + "1" + std::string(63, ')'), &n), "0 diagnostics");
  EXPECT_EQ(n, 1u);
  EXPECT_EQ(diagnose("A/" + std::string(64, '(') + "1" + std::string(64, ')')).substr(0, 15), "parse.too-deep|");
}

TEST(ParserErrors, AllErrorsAreReportedAndGoodLinesKept) {
  const std::string src =
      "UNITS/MM,ANGDEC\n"
      "FEAT PLANE\n"
      "F(P1)=FEAT/PLANE,CART,0,0,0,0,0,1\n"
      "GOTO/1,2,\n"
      "TEXT/OPER,'oops\n"
      "ENDFIL\n";
  SourceManager sources;
  DiagnosticSink sink;
  const auto file = sources.add("multi.dmi", src);
  const Program p = parse_program(sources, file, sink);
  ASSERT_EQ(p.statements.size(), 3u);
  EXPECT_EQ(p.statements[0].major, "UNITS");
  EXPECT_EQ(p.statements[1].major, "FEAT");
  EXPECT_EQ(p.statements[2].major, "ENDFIL");
  ASSERT_EQ(sink.error_count(), 3u);
  EXPECT_EQ(format_diagnostic(sink.items()[0], sources),
            "multi.dmi:2:6: error: expected '/' after the major word 'FEAT'\n"
            "  FEAT PLANE\n"
            "       ^\n");
  EXPECT_EQ(sources.locate(sink.items()[1].span).line, 4u);
  EXPECT_EQ(sink.items()[2].message, "unterminated string");
  EXPECT_EQ(sources.locate(sink.items()[2].span).column, 11u);
}

TEST(ParserErrors, BadFileIdIsADiagnostic) {
  SourceManager sources;
  DiagnosticSink sink;
  const Program p = parse_program(sources, 7, sink);
  EXPECT_TRUE(p.statements.empty());
  ASSERT_EQ(sink.items().size(), 1u);
  EXPECT_EQ(sink.items()[0].code, "parse.no-file");
}
