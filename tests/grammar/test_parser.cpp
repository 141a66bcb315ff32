// SPDX-License-Identifier: GPL-3.0-or-later
// parse_program: statement forms, expressions and their tree shape, spans.
#include "metron/grammar/parser.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <sstream>
#include <string>

using namespace metron;
using namespace metron::grammar;

namespace {

struct Parsed {
  SourceManager sources;
  DiagnosticSink sink;
  std::uint32_t file = 0;
  Program program;
};

std::unique_ptr<Parsed> parse(const std::string& text) {
  auto p = std::make_unique<Parsed>();
  p->file = p->sources.add("test.dmi", text);
  p->program = parse_program(p->sources, p->file, p->sink);
  return p;
}

std::string errors(const Parsed& p) {
  std::string out;
  for (const auto& d : p.sink.items()) out += format_diagnostic(d, p.sources);
  return out;
}

// One statement, no diagnostics.
Statement one(const std::string& text) {
  auto p = parse(text);
  EXPECT_EQ(p->sink.items().size(), 0u) << errors(*p);
  EXPECT_EQ(p->program.statements.size(), 1u);
  return p->program.statements.empty() ? Statement{} : p->program.statements[0];
}

// A compact rendering of an expression tree: (op a b), F(PLN1), 'text', (call SIN x) ...
std::string sexpr(const Expr& e) {
  std::ostringstream os;
  switch (e.kind) {
    case ExprKind::Number: os << e.number; break;
    case ExprKind::String: os << "'" << e.text << "'"; break;
    case ExprKind::Word: os << (e.text.empty() ? "<empty>" : e.text); break;
    case ExprKind::Label: os << e.label.prefix << "(" << e.label.name << ")"; break;
    case ExprKind::Call:
    case ExprKind::Index:
      os << "(" << (e.kind == ExprKind::Call ? "call " : "index ") << e.text;
      for (const auto& a : e.args) os << " " << sexpr(a);
      os << ")";
      break;
    case ExprKind::Unary:
    case ExprKind::Binary:
      os << "(" << e.text;
      for (const auto& a : e.args) os << " " << sexpr(a);
      os << ")";
      break;
    case ExprKind::Paren: os << "(paren " << sexpr(e.args.at(0)) << ")"; break;
    case ExprKind::Format:
      os << "(layout";
      for (const auto& a : e.args) os << " " << sexpr(a);
      os << ")";
      break;
  }
  return os.str();
}

// The single parameter of `A/<expr>`, rendered.
std::string expr_of(const std::string& expr) {
  std::string src = "A/";  // (not "A/" + expr: GCC 12 -Wrestrict false positive)
  src += expr;
  const Statement s = one(src);
  if (s.params.size() != 1) {
    std::string bad = "<params: ";
    bad += std::to_string(s.params.size());
    return bad + ">";
  }
  return sexpr(s.params[0]);
}

std::string params_of(const Statement& s) {
  std::string out;
  for (const auto& p : s.params) out += (out.empty() ? "" : " | ") + sexpr(p);
  return out;
}

// line:col of a physical offset.
std::string lc(const Parsed& p, std::uint32_t offset) {
  const Location l = p.sources.locate(p.file, offset);
  return std::to_string(l.line) + ":" + std::to_string(l.column);
}

std::string text_of(const Parsed& p, Span s) { return p.sources.file(p.file).text.substr(s.begin, s.end - s.begin); }

}  // namespace

// ---- statement forms ------------------------------------------------------------------------

TEST(ParserForms, MajorWordAlone) {
  auto p = parse("ENDMES\nENDFIL\nELSE\nENDIF\nENDDO\nENDMAC\nENDSEL\n");
  ASSERT_EQ(p->sink.items().size(), 0u) << errors(*p);
  ASSERT_EQ(p->program.statements.size(), 7u);
  const char* majors[] = {"ENDMES", "ENDFIL", "ELSE", "ENDIF", "ENDDO", "ENDMAC", "ENDSEL"};
  for (std::size_t i = 0; i < 7; ++i) {
    const Statement& s = p->program.statements[i];
    EXPECT_EQ(s.major, majors[i]);
    EXPECT_FALSE(s.has_slash);
    EXPECT_TRUE(s.params.empty());
    EXPECT_FALSE(s.target || s.variable || s.jump_label);
  }
}

TEST(ParserForms, MajorWithParameters) {
  const Statement s = one("PTMEAS/CART,-43.000,+15.000,30.000,0.000,0.000,1.000");
  EXPECT_EQ(s.major, "PTMEAS");
  EXPECT_TRUE(s.has_slash);
  EXPECT_EQ(params_of(s), "CART | -43 | 15 | 30 | 0 | 0 | 1");
  EXPECT_EQ(s.params[1].kind, ExprKind::Number);  // signed literals are numbers
  EXPECT_EQ(s.params[2].kind, ExprKind::Number);
}

TEST(ParserForms, NegativeZeroKeepsItsSign) {
  const Statement s = one("PTMEAS/CART,-15.500,-0.000,23.000");
  ASSERT_EQ(s.params.size(), 4u);
  EXPECT_EQ(s.params[2].number, 0.0);
  EXPECT_TRUE(std::signbit(s.params[2].number));
}

TEST(ParserForms, LabelTarget) {
  const Statement s = one("F(PLN1)=FEAT/PLANE,CART,0.000,0.000,30.000,0.000,0.000,1.000");
  ASSERT_TRUE(s.target.has_value());
  EXPECT_EQ(s.target->prefix, "F");
  EXPECT_EQ(s.target->name, "PLN1");
  EXPECT_EQ(s.major, "FEAT");
  EXPECT_EQ(s.params.size(), 8u);
  EXPECT_EQ(sexpr(s.params[0]), "PLANE");
}

// DMIS 5.x indexed labels: the name keeps the index's text, the index its expression.
TEST(ParserForms, IndexedLabels) {
  const Statement s = one("F(HOLE[ i+1 ])=FEAT/POINT,CART,0,0,0,0,0,1");
  ASSERT_TRUE(s.target.has_value());
  EXPECT_EQ(s.target->name, "HOLE[I+1]");
  ASSERT_EQ(s.target->index.size(), 1u);
  EXPECT_EQ(sexpr(s.target->index[0]), "(+ I 1)");
  EXPECT_EQ(expr_of("FA(H[N[2]])"), "FA(H[N[2]])");
  EXPECT_EQ(expr_of("FA(P1)"), "FA(P1)");
}

// WRITE values with their layout `e:width[:decimals]`.
TEST(ParserForms, WriteLayouts) {
  const Statement s = one("WRITE/DID(F),'X=':6,X*2 : 10 : 3,N:4");
  EXPECT_EQ(params_of(s), "DID(F) | (layout 'X=' 6) | (layout (* X 2) 10 3) | (layout N 4)");
}

TEST(ParserForms, VariableTargets) {
  const Statement s = one("V1=ASSIGN/V2+1");
  ASSERT_TRUE(s.variable.has_value());
  EXPECT_EQ(sexpr(*s.variable), "V1");
  EXPECT_EQ(s.major, "ASSIGN");
  EXPECT_EQ(params_of(s), "(+ V2 1)");
  const Statement t = one("arr[ i , 2 ] = assign/ 3");
  ASSERT_TRUE(t.variable.has_value());
  EXPECT_EQ(t.variable->kind, ExprKind::Index);
  EXPECT_EQ(sexpr(*t.variable), "(index ARR I 2)");
  EXPECT_EQ(t.major, "ASSIGN");
}

TEST(ParserForms, JumpLabelLine) {
  const Statement s = one("  ( L_1.a )  ");
  ASSERT_TRUE(s.jump_label.has_value());
  EXPECT_EQ(*s.jump_label, "L_1.a");
  EXPECT_TRUE(s.major.empty());
  const Statement j = one("JUMPTO/(L_1a)");
  EXPECT_EQ(j.major, "JUMPTO");
  EXPECT_EQ(params_of(j), "(paren L_1A)");
}

TEST(ParserForms, FreeSpacing) {
  const Statement s = one("  D(CALN1_b) =   ROTATE  /  ZAXIS ,FA ( CLIN1 )  , XDIR   ");
  ASSERT_TRUE(s.target.has_value());
  EXPECT_EQ(s.target->prefix, "D");
  EXPECT_EQ(s.target->name, "CALN1_b");
  EXPECT_EQ(s.major, "ROTATE");
  EXPECT_EQ(params_of(s), "ZAXIS | FA(CLIN1) | XDIR");
}

TEST(ParserForms, CaseInsensitiveKeywordsKeepLabelNames) {
  const Statement s = one("f(Pln1)=feat/plane,cart,1,2,3,0,0,1");
  EXPECT_EQ(s.target->prefix, "F");
  EXPECT_EQ(s.target->name, "Pln1");
  EXPECT_EQ(s.major, "FEAT");
  EXPECT_EQ(sexpr(s.params[0]), "PLANE");
  EXPECT_EQ(sexpr(s.params[1]), "CART");
  EXPECT_EQ(expr_of("a .eq. b .Or. .not. c .aNd. d"), "(.OR. (.EQ. A B) (.AND. (.NOT. C) D))");
}

TEST(ParserForms, LabelNamesWithDotsDashesAndUnderscores) {
  const Statement s = one("OUTPUT/FA(PLN.1-a_b),TA(TOL-3),S(PROBE.6),DAT(A#1@x!~)");
  EXPECT_EQ(params_of(s), "FA(PLN.1-a_b) | TA(TOL-3) | S(PROBE.6) | DAT(A#1@x!~)");
  EXPECT_EQ(s.params[0].kind, ExprKind::Label);
  EXPECT_EQ(s.params[0].label.prefix, "FA");
}

TEST(ParserForms, EmptyParameterBetweenCommas) {
  const Statement s = one("A/1,,2, ,3");
  ASSERT_EQ(s.params.size(), 5u);
  EXPECT_EQ(params_of(s), "1 | <empty> | 2 | <empty> | 3");
  EXPECT_EQ(s.params[1].kind, ExprKind::Word);
  EXPECT_EQ(s.params[1].span.begin, s.params[1].span.end);
  EXPECT_EQ(s.params[1].span.begin, 4u);  // at the second comma
}

TEST(ParserForms, DigitLeadingMinorWords) {
  const Statement s = one("T(TOL2)=TOL/POS,3D,0.100,RFS,DAT(A),DAT(B),DAT(C)");
  EXPECT_EQ(params_of(s), "POS | 3D | 0.1 | RFS | DAT(A) | DAT(B) | DAT(C)");
  EXPECT_EQ(s.params[1].kind, ExprKind::Word);
}

TEST(ParserForms, StringsWithEscapedQuotes) {
  const Statement s = one("TEXT/OPER,'it''s ok', '', 'C:\\imts.dmo'");
  ASSERT_EQ(s.params.size(), 4u);
  EXPECT_EQ(s.params[1].kind, ExprKind::String);
  EXPECT_EQ(s.params[1].text, "it's ok");
  EXPECT_EQ(s.params[2].text, "");
  EXPECT_EQ(s.params[3].text, "C:\\imts.dmo");
}

// ---- expressions ----------------------------------------------------------------------------

TEST(ParserExpr, NumberForms) {
  const Statement s = one("A/+15.000,-0.5,.5,5.,1.E-3,2e5,7,1.5E+2");
  ASSERT_EQ(s.params.size(), 8u);
  const double want[] = {15.0, -0.5, 0.5, 5.0, 1e-3, 2e5, 7.0, 150.0};
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_EQ(s.params[i].kind, ExprKind::Number) << i;
    EXPECT_DOUBLE_EQ(s.params[i].number, want[i]) << i;
  }
}

TEST(ParserExpr, ArithmeticPrecedence) {
  EXPECT_EQ(expr_of("1+2*3"), "(+ 1 (* 2 3))");
  EXPECT_EQ(expr_of("1-2-3"), "(- (- 1 2) 3)");
  EXPECT_EQ(expr_of("8/4/2"), "(/ (/ 8 4) 2)");
  EXPECT_EQ(expr_of("2**3**2"), "(** 2 (** 3 2))");
  EXPECT_EQ(expr_of("-X**2"), "(- (** X 2))");
  EXPECT_EQ(expr_of("-2**2"), "(- (** 2 2))");  // ** binds tighter than the sign
  EXPECT_EQ(expr_of("2**-1"), "(** 2 -1)");
  EXPECT_EQ(expr_of("-X*Y"), "(* (- X) Y)");
  EXPECT_EQ(expr_of("A*B+C/D"), "(+ (* A B) (/ C D))");
  EXPECT_EQ(expr_of("1 - -2"), "(- 1 -2)");
  EXPECT_EQ(expr_of("--5"), "(- -5)");
  EXPECT_EQ(expr_of("-(5)"), "(- (paren 5))");
  EXPECT_EQ(expr_of("(1+2)*3"), "(* (paren (+ 1 2)) 3)");
}

TEST(ParserExpr, LogicAndComparisonPrecedence) {
  EXPECT_EQ(expr_of("A.OR.B.AND.C"), "(.OR. A (.AND. B C))");
  EXPECT_EQ(expr_of(".NOT.A.AND.B"), "(.AND. (.NOT. A) B)");
  EXPECT_EQ(expr_of(".NOT.A.EQ.B"), "(.NOT. (.EQ. A B))");
  EXPECT_EQ(expr_of("A+1.EQ.B*2"), "(.EQ. (+ A 1) (* B 2))");
  EXPECT_EQ(expr_of("5.EQ.X"), "(.EQ. 5 X)");  // the dot belongs to the operator
  EXPECT_EQ(expr_of("1.5.GE..5"), "(.GE. 1.5 0.5)");
  EXPECT_EQ(expr_of("A.NE.B.OR.C.LT.D.AND.E.LE.F.OR.G.GT.H"),
            "(.OR. (.OR. (.NE. A B) (.AND. (.LT. C D) (.LE. E F))) (.GT. G H))");
  EXPECT_EQ(expr_of(".NOT..NOT.X"), "(.NOT. (.NOT. X))");
}

TEST(ParserExpr, CallsLabelsAndIndices) {
  EXPECT_EQ(expr_of("SQRT(V1**2+V2**2)"), "(call SQRT (+ (** V1 2) (** V2 2)))");
  EXPECT_EQ(expr_of("MAX(1, 2 ,3)"), "(call MAX 1 2 3)");
  EXPECT_EQ(expr_of("RAND()"), "(call RAND)");
  EXPECT_EQ(expr_of("sin(cos(x))"), "(call SIN (call COS X))");
  EXPECT_EQ(expr_of("V1[3]"), "(index V1 3)");
  EXPECT_EQ(expr_of("M[I+1, J]*2"), "(* (index M (+ I 1) J) 2)");
  EXPECT_EQ(expr_of("FA(PLN1)"), "FA(PLN1)");
  EXPECT_EQ(expr_of("STR(D(x))"), "(call STR D(x))");
  EXPECT_EQ(expr_of("'a'"), "'a'");
  EXPECT_EQ(expr_of("(((X)))"), "(paren (paren (paren X)))");
}

TEST(ParserExpr, BooleanConstantsAreWords) {
  EXPECT_EQ(expr_of(".true."), ".TRUE.");
  EXPECT_EQ(expr_of("B.EQ..FALSE. .OR. .NOT. .TRUE."), "(.OR. (.EQ. B .FALSE.) (.NOT. .TRUE.))");
  const Statement s = one("V1=ASSIGN/.FALSE.");
  ASSERT_EQ(s.params.size(), 1u);
  EXPECT_EQ(s.params[0].kind, ExprKind::Word);
  EXPECT_EQ(s.params[0].text, ".FALSE.");
}

TEST(ParserExpr, IfWithAndWithoutParentheses) {
  EXPECT_EQ(params_of(one("IF/(V1.EQ.1)")), "(paren (.EQ. V1 1))");
  EXPECT_EQ(params_of(one("IF/V1 .GT. 2.5")), "(.GT. V1 2.5)");
}

// ---- spans ----------------------------------------------------------------------------------

TEST(ParserSpans, NodesPointAtTheirPhysicalText) {
  auto p = parse("$$ header\nUNITS/MM\n  F(PLN1) = FEAT/PLANE,CART, 1+2*3 ,'s'\n");
  ASSERT_EQ(p->sink.items().size(), 0u) << errors(*p);
  ASSERT_EQ(p->program.statements.size(), 2u);
  const Statement& s = p->program.statements[1];
  EXPECT_EQ(lc(*p, s.span.begin), "3:3");
  EXPECT_EQ(text_of(*p, s.span), "F(PLN1) = FEAT/PLANE,CART, 1+2*3 ,'s'");
  EXPECT_EQ(text_of(*p, s.target->span), "F(PLN1)");
  EXPECT_EQ(text_of(*p, s.major_span), "FEAT");
  EXPECT_EQ(lc(*p, s.major_span.begin), "3:13");
  EXPECT_EQ(text_of(*p, s.params[0].span), "PLANE");
  EXPECT_EQ(text_of(*p, s.params[2].span), "1+2*3");
  EXPECT_EQ(text_of(*p, s.params[2].args[1].span), "2*3");
  EXPECT_EQ(text_of(*p, s.params[2].args[1].args[1].span), "3");
  EXPECT_EQ(text_of(*p, s.params[3].span), "'s'");
  for (const auto& e : s.params) EXPECT_EQ(e.span.file, p->file);
}

TEST(ParserSpans, LabelSpanCoversPrefixToParenthesis) {
  auto p = parse("OUTPUT/FA ( PLN1 ),TA(T1)");
  ASSERT_EQ(p->program.statements.size(), 1u);
  const Statement& s = p->program.statements[0];
  EXPECT_EQ(text_of(*p, s.params[0].span), "FA ( PLN1 )");
  EXPECT_EQ(text_of(*p, s.params[0].label.span), "FA ( PLN1 )");
  EXPECT_EQ(text_of(*p, s.params[1].span), "TA(T1)");
}

TEST(ParserSpans, MultiLineStatement) {
  const std::string src =
      "F(CLIN1)=FEAT/LINE,UNBND,CART,0.000,-52.000,30.000,1.000,0.000,0.000, $\n"
      "0.000,0.000,1.000\n"
      "OUTPUT/FA(CLIN1)\n";
  auto p = parse(src);
  ASSERT_EQ(p->sink.items().size(), 0u) << errors(*p);
  ASSERT_EQ(p->program.statements.size(), 2u);
  const Statement& s = p->program.statements[0];
  EXPECT_EQ(s.params.size(), 12u);
  EXPECT_EQ(lc(*p, s.span.begin), "1:1");
  EXPECT_EQ(lc(*p, s.span.end - 1), "2:17");  // the last '0' of 1.000
  EXPECT_EQ(lc(*p, s.params[8].span.begin), "1:64");
  EXPECT_EQ(lc(*p, s.params[9].span.begin), "2:1");
  EXPECT_EQ(lc(*p, s.params[11].span.begin), "2:13");
  EXPECT_EQ(lc(*p, p->program.statements[1].span.begin), "3:1");
}

TEST(ParserSpans, TokenSplitByAContinuation) {
  auto p = parse("GOTO/12.$\n5,'ab$\ncd',FA(P$\nL1)\n");
  ASSERT_EQ(p->sink.items().size(), 0u) << errors(*p);
  ASSERT_EQ(p->program.statements.size(), 1u);
  const Statement& s = p->program.statements[0];
  ASSERT_EQ(s.params.size(), 3u);
  EXPECT_DOUBLE_EQ(s.params[0].number, 12.5);
  EXPECT_EQ(lc(*p, s.params[0].span.begin), "1:6");
  EXPECT_EQ(lc(*p, s.params[0].span.end - 1), "2:1");
  EXPECT_EQ(s.params[1].text, "abcd");
  EXPECT_EQ(lc(*p, s.params[1].span.begin), "2:3");
  EXPECT_EQ(lc(*p, s.params[1].span.end - 1), "3:3");
  EXPECT_EQ(s.params[2].label.name, "PL1");
  EXPECT_EQ(lc(*p, s.params[2].span.begin), "3:5");
  EXPECT_EQ(lc(*p, s.params[2].span.end - 1), "4:3");
}

TEST(ParserSpans, ByteOrderMarkDoesNotShiftColumnsOfLaterLines) {
  auto p = parse("\xEF\xBB\xBFUNITS/MM\nENDFIL");
  ASSERT_EQ(p->sink.items().size(), 0u) << errors(*p);
  ASSERT_EQ(p->program.statements.size(), 2u);
  EXPECT_EQ(text_of(*p, p->program.statements[0].span), "UNITS/MM");
  EXPECT_EQ(lc(*p, p->program.statements[1].span.begin), "2:1");
}

TEST(ParserLabelPrefix, Table) {
  for (const char* w : {"A", "F", "FA", "DAT", "DATT", "DID", "S", "SA", "T", "TA", "M", "QIS", "VW", "D", "DA"})
    EXPECT_TRUE(is_label_prefix(w)) << w;
  for (const char* w : {"", "FEAT", "SIN", "X", "f", "DATS", "B", "V1", "SQRT"}) EXPECT_FALSE(is_label_prefix(w)) << w;
}
