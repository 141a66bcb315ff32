// SPDX-License-Identifier: GPL-3.0-or-later
// The I++ DME codec: command lines in, response lines out (docs/ipp-dme.md). Expected error
// numbers come from the NIST test suite's parser (numbersErrorCmd.txt, parserCmdErrors.txt).
#include <gtest/gtest.h>

#include <random>

#include "metron/machine/ipp/command_line.hpp"
#include "metron/machine/ipp/response_line.hpp"

using namespace metron::machine::ipp;

namespace {

int error_number(std::string_view line) {
  auto r = parse_command_line(line);
  return r ? -1 : static_cast<int>(r.error().code);
}

}  // namespace

TEST(IppCodec, ParsesTagNameAndNestedArguments) {
  auto c = parse_command_line("00012 PtMeas(X(10), Y(-2.6E01),Z(+1.9473294E-01), IJK(0,0,1))\r\n");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->tag.text(), "00012");
  EXPECT_FALSE(c->tag.event);
  EXPECT_EQ(c->name, "PtMeas");
  ASSERT_EQ(c->args.size(), 4u);
  EXPECT_TRUE(c->args[0].is_call("X"));
  EXPECT_EQ(c->args[0].call_number(), 10.0);
  EXPECT_DOUBLE_EQ(*c->args[1].call_number(), -26.0);
  EXPECT_DOUBLE_EQ(*c->args[2].call_number(), 0.19473294);
  ASSERT_EQ(c->args[3].args.size(), 3u);
  EXPECT_EQ(c->args[3].args[2].number, 1.0);
}

TEST(IppCodec, ParsesEventTagsStringsNamesAndProperties) {
  auto e = parse_command_line("E0005 OnMoveReportE(Time(5), Dis(0.34), X(), Y(), Z())");
  ASSERT_TRUE(e);
  EXPECT_TRUE(e->tag.event);
  EXPECT_EQ(e->tag.number, 5u);
  EXPECT_EQ(e->tag.text(), "E0005");
  EXPECT_TRUE(e->args[2].is_call("X"));
  EXPECT_TRUE(e->args[2].args.empty());

  auto s = parse_command_line("00020 ChangeTool(\"Probe 1\")");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->args[0].kind, Argument::Kind::String);
  EXPECT_EQ(s->args[0].text, "Probe 1");

  auto p = parse_command_line("00030 SetProp(Tool.PtMeasPar.Speed(5), Tool.GoToPar.Accel.Act(6.42))");
  ASSERT_TRUE(p);
  EXPECT_TRUE(p->args[0].is_call("Tool.PtMeasPar.Speed"));
  EXPECT_EQ(p->args[1].text, "Tool.GoToPar.Accel.Act");

  auto n = parse_command_line("00010 StopDaemon(E0006)");
  ASSERT_TRUE(n);
  EXPECT_EQ(n->args[0].kind, Argument::Kind::Name);
  EXPECT_EQ(n->args[0].text, "E0006");

  auto t = parse_command_line("00120 GoTo(Tool.A(45), Z(-4.003E-01) )  ");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->args.size(), 2u);
}

TEST(IppCodec, NumberErrorsHaveTheNistNumbers) {
  // numbersErrorCmd.txt: 0509 for malformed numbers, 0502 for an illegal space.
  EXPECT_EQ(error_number("00010 GoTo(X(12345678901234567))"), 509);
  EXPECT_EQ(error_number("00020 GoTo(X(-.))"), 509);
  EXPECT_EQ(error_number("00030 GoTo(X(+))"), 509);
  EXPECT_EQ(error_number("00040 GoTo(X(+1.2 E2))"), 502);
  EXPECT_EQ(error_number("00050 GoTo(X(+1.2E))"), 509);
  EXPECT_EQ(error_number("00060 GoTo(X(+1.2E0010))"), 509);
  EXPECT_EQ(error_number("00070 GoTo(X(0.34.33))"), 509);
  EXPECT_EQ(error_number("00080 GoTo(X(1234567890123456))"), -1);  // 16 digits are allowed
  EXPECT_EQ(error_number("00090 GoTo(X(9.9E999))"), 509);          // beyond the double range
}

TEST(IppCodec, TagAndLineErrorsHaveTheNistNumbers) {
  EXPECT_EQ(error_number("A2345 GoTo(X(3.1))"), 1);
  EXPECT_EQ(error_number("012345 GoTo(X(3.1))"), 2);
  EXPECT_EQ(error_number("E0000 AbortE()"), 1);
  EXPECT_EQ(error_number("00000 GoTo(X(2.1))"), 1);
  EXPECT_EQ(error_number("05401 GoTo(X(0.1))2"), 507);
  EXPECT_EQ(error_number("05501 GoTo(X(1,)"), 502);
  EXPECT_EQ(error_number("05502 GoTo(X(#))"), 502);
  EXPECT_EQ(error_number("05701 GoTo(X2)"), -1);  // a bare keyword parses; the checker rejects it
  EXPECT_EQ(error_number("05901 GoTo(\"hello)"), 509);
  EXPECT_EQ(error_number("05902 GoTo(\"\")"), 509);
  EXPECT_EQ(error_number("00202 AlignPart(0\"oops\"-1, 0, 0.6, 0.0, 0.8, 1.0)"), 502);
  EXPECT_EQ(error_number("00001 Start\x01Session()"), 7);
  EXPECT_EQ(error_number("00001"), 2);
  EXPECT_EQ(error_number(""), 1);
  EXPECT_EQ(error_number("00001 EndSession"), 502);
}

TEST(IppCodec, FormatsResponsesAsTheStandardWritesThem) {
  const Tag t{false, 12};
  EXPECT_EQ(format_ack(t), "00012 &");
  EXPECT_EQ(format_complete(t), "00012 %");
  EXPECT_EQ(format_data(t, "X(1.5), Y(2)"), "00012 # X(1.5), Y(2)");
  EXPECT_EQ(format_error(t, ErrorCode::IllegalCommand, "00012 GoTo(\"x\")"),
            "00012 ! Error(3, 0507, \"00012 GoTo(#x#)\", \"Illegal command\")");
  EXPECT_EQ(format_error(Tag{true, 0}, ErrorCode::ArgumentOutOfRange, "c"),
            "E0000 ! Error(1, 0504, \"c\", \"Argument out of range\")");
  EXPECT_EQ(format_number(1.5), "1.5");
  EXPECT_EQ(format_number(-0.0000001), "0");
  EXPECT_EQ(format_number(30.0), "30");
  EXPECT_EQ(format_number(-1.23456789), "-1.234568");
}

TEST(IppCodec, ReadsResponseLinesBack) {
  auto e = parse_response_line("00010 ! Error(3,1008, \"DoGoTo\", \"Target position out of machine volume\")");
  ASSERT_TRUE(e) << e.error();
  EXPECT_EQ(e->kind, ResponseLine::Kind::Error);
  EXPECT_EQ(e->severity, 3);
  EXPECT_EQ(e->error_number, 1008);
  EXPECT_EQ(e->error_cause, "DoGoTo");
  EXPECT_EQ(e->error_text, "Target position out of machine volume");
  auto d = parse_response_line("E0001 # X(-1.71667E002), Y(3.25371E001)");
  ASSERT_TRUE(d);
  EXPECT_TRUE(d->tag.event);
  EXPECT_EQ(d->body, "X(-1.71667E002), Y(3.25371E001)");
  auto args = parse_arguments(d->body);
  ASSERT_TRUE(args);
  EXPECT_DOUBLE_EQ(*(*args)[0].call_number(), -171.667);
  EXPECT_FALSE(parse_response_line("00010 ? what"));
}

// Fuzz: random bytes, random mutations of valid lines, and deep nesting never crash and always
// give either a command or an error with a number from the specification's table.
TEST(IppCodec, FuzzedLinesNeverCrash) {
  std::mt19937_64 rng(16);
  const std::vector<std::string> seeds{"00012 PtMeas(X(10), Y(-2.6E01), Z(30.998), IJK(0,0,1))",
                                       "E0005 OnMoveReportE(Time(5), Dis(0.34), X(), Y(), Z())",
                                       "00030 SetProp(Tool.PtMeasPar.Speed(5))", "00020 ChangeTool(\"Probe1\")"};
  const std::string alphabet = "0123456789E(),.\"+- XYZIJKabc\t\r\n\x7f\x80\xff";
  int parsed = 0;
  for (int i = 0; i < 200000; ++i) {
    std::string s;
    if (i % 3 == 0) {
      s.resize(rng() % 80);
      for (char& c : s) c = static_cast<char>(rng() & 0xff);
    } else {
      s = seeds[rng() % seeds.size()];
      const int edits = 1 + static_cast<int>(rng() % 4);
      for (int k = 0; k < edits && !s.empty(); ++k) {
        const std::size_t at = rng() % s.size();
        switch (rng() % 3) {
          case 0: s[at] = alphabet[rng() % alphabet.size()]; break;
          case 1: s.erase(at, 1); break;
          default: s.insert(at, 1, alphabet[rng() % alphabet.size()]); break;
        }
      }
    }
    auto r = parse_command_line(s);
    if (r)
      ++parsed;
    else
      ASSERT_TRUE(find_error(static_cast<int>(r.error().code))) << s;
    (void)parse_response_line(s);
  }
  EXPECT_GT(parsed, 1000);  // the mutations keep some lines valid
  std::string deep = "00001 GoTo(";
  for (int k = 0; k < 100000; ++k) deep += "X(";
  EXPECT_EQ(error_number(deep), 502);
}
