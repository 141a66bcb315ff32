// SPDX-License-Identifier: GPL-3.0-or-later
// join_continuations: `$` continuation lines, `$$` comments, and the physical offset map.
#include "metron/grammar/preprocess.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using metron::grammar::join_continuations;
using metron::grammar::LogicalLine;

namespace {

std::vector<std::string> texts(const std::vector<LogicalLine>& lines) {
  std::vector<std::string> out;
  for (const auto& l : lines) out.push_back(l.text);
  return out;
}

// Every logical byte must equal the physical byte its map entry points at, and the map ends
// one past the last byte.
void expect_map_exact(const std::string& src, const LogicalLine& l) {
  ASSERT_EQ(l.physical.size(), l.text.size() + 1);
  for (std::size_t i = 0; i < l.text.size(); ++i) {
    ASSERT_LT(l.physical[i], src.size());
    EXPECT_EQ(src[l.physical[i]], l.text[i]) << "logical index " << i;
    if (i > 0) {
      EXPECT_LT(l.physical[i - 1], l.physical[i]);
    }
  }
  if (!l.text.empty()) {
    EXPECT_EQ(l.physical.back(), l.physical[l.text.size() - 1] + 1);
  }
}

}  // namespace

TEST(Preprocess, PlainLinesKeepTheirOffsets) {
  const std::string src = "UNITS/MM,ANGDEC\nPRCOMP/ON\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].text, "UNITS/MM,ANGDEC");
  EXPECT_EQ(lines[1].text, "PRCOMP/ON");
  EXPECT_EQ(lines[1].physical[0], 16u);
  EXPECT_EQ(lines[1].physical.back(), 25u);
  for (const auto& l : lines) expect_map_exact(src, l);
}

TEST(Preprocess, ContinuationInsideANumber) {
  const std::string src = "GOTO/12.$\n5,3\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "GOTO/12.5,3");
  // "12." at 5..7, '5' is the first byte of the second physical line (offset 10).
  EXPECT_EQ(lines[0].physical[7], 7u);
  EXPECT_EQ(lines[0].physical[8], 10u);
  EXPECT_EQ(lines[0].physical[10], 12u);
  EXPECT_EQ(lines[0].physical[11], 13u);
  expect_map_exact(src, lines[0]);
}

TEST(Preprocess, ContinuationInsideAString) {
  const std::string src = "TEXT/OPER,'hello $\nworld'\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "TEXT/OPER,'hello world'");
  expect_map_exact(src, lines[0]);
}

TEST(Preprocess, ContinuationInsideALabelName) {
  const std::string src = "OUTPUT/FA(CL$\nIN1)\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "OUTPUT/FA(CLIN1)");
  expect_map_exact(src, lines[0]);
}

TEST(Preprocess, ContinuationInsideALabelWithAnIndentedRest) {
  const std::string src = "OUTPUT/FA(A02$\n    F5),TA(T1)\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "OUTPUT/FA(A02F5),TA(T1)");
  expect_map_exact(src, lines[0]);
}

TEST(Preprocess, ContinuationWithSpacesAndCrlf) {
  // Blanks after the `$` are dropped; the next line is appended without its indentation (shop
  // software splits labels and indents the rest: issue 14).
  const std::string src = "F(CLIN1)=FEAT/LINE,0.000, $  \r\n  0.000,1.0\r\nENDFIL\r\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].text, "F(CLIN1)=FEAT/LINE,0.000, 0.000,1.0");
  EXPECT_EQ(lines[1].text, "ENDFIL");
  EXPECT_EQ(lines[1].physical[0], src.find("ENDFIL"));
  for (const auto& l : lines) expect_map_exact(src, l);
}

TEST(Preprocess, SeveralContinuationsInARow) {
  const std::string src = "A/1,$\n2,$\n3\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "A/1,2,3");
  expect_map_exact(src, lines[0]);
}

TEST(Preprocess, BlankLinesAfterAContinuationAreSkipped) {
  // A program pasted into a web page or a mail comes back double-spaced.
  const std::string src = "F(P)=FEAT/POINT,CART,1,2,3,$\n\n   \r\n0,0,1\nENDFIL\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].text, "F(P)=FEAT/POINT,CART,1,2,3,0,0,1");
  EXPECT_EQ(lines[1].text, "ENDFIL");
  for (const auto& l : lines) expect_map_exact(src, l);
}

// CAMIO writes an operator's text as it was typed: an apostrophe inside, over several lines
// (flatness_meas, Test_Emery-1.dmi). A TEXT line that does not end in a quote goes on to the line
// that does, its line breaks inside the string; an apostrophe (a quote between letters) is doubled.
TEST(Preprocess, ATextsStringRunsToItsLastQuote) {
  const std::string src =
      "TEXT/OPER,'Mettre l'\xC3\xA9"
      "chelle en place;\r\nplans paires vers vous,\r\n"
      "et en but\xC3\xA9"
      "e vers la gauche'\r\nENDFIL\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].text,
            "TEXT/OPER,'Mettre l''\xC3\xA9"
            "chelle en place;\r\nplans paires vers vous,\r\net en but\xC3\xA9"
            "e vers la gauche'");
  EXPECT_EQ(lines[1].text, "ENDFIL");
  ASSERT_EQ(lines[0].physical.size(), lines[0].text.size() + 1);
  for (std::size_t i = 0; i < lines[0].text.size(); ++i) EXPECT_EQ(src[lines[0].physical[i]], lines[0].text[i]) << i;
  // One line with an apostrophe; quotes next to commas or doubled stay as they are.
  EXPECT_EQ(texts(join_continuations("TEXT/OPER,'l'outil'\n")), (std::vector<std::string>{"TEXT/OPER,'l''outil'"}));
  EXPECT_EQ(texts(join_continuations("TEXT/OPER,'it''s', '', 'C:\\x'\n")),
            (std::vector<std::string>{"TEXT/OPER,'it''s', '', 'C:\\x'"}));
  EXPECT_EQ(texts(join_continuations("TEXT/OUTFIL,'done'\n")), (std::vector<std::string>{"TEXT/OUTFIL,'done'"}));
  // A TEXT whose strings are closed is one line, whatever follows.
  EXPECT_EQ(texts(join_continuations("TEXT/OPER,CONCAT('two:',STR(I))\nENDCAS\nTEXT/OPER,'x'\n")),
            (std::vector<std::string>{"TEXT/OPER,CONCAT('two:',STR(I))", "ENDCAS", "TEXT/OPER,'x'"}));
  // No line ending in a quote follows: the statement is left as it is (the parser reports it).
  EXPECT_EQ(texts(join_continuations("TEXT/OPER,'open\nGOTO/1,2,3\n")),
            (std::vector<std::string>{"TEXT/OPER,'open", "GOTO/1,2,3"}));
}

TEST(Preprocess, CommentsAreRemovedAndCommentLinesDropped) {
  const std::string src = "$$ a comment\nGOTO/1,2,3 $$ trailing note\n   \n\nENDFIL";
  const auto lines = join_continuations(src);
  EXPECT_EQ(texts(lines), (std::vector<std::string>{"GOTO/1,2,3 ", "ENDFIL"}));
  for (const auto& l : lines) expect_map_exact(src, l);
}

TEST(Preprocess, ContinuedCommentSwallowsTheNextLine) {
  const std::string src = "$$ this comment goes on $\nstill comment\nENDFIL\n";
  EXPECT_EQ(texts(join_continuations(src)), (std::vector<std::string>{"ENDFIL"}));
  // A continued comment may go on over several lines.
  const std::string src2 = "$$ one $\ntwo $\nthree\nENDMES\n";
  EXPECT_EQ(texts(join_continuations(src2)), (std::vector<std::string>{"ENDMES"}));
  // A comment after code that ends in a single `$` continues the comment, not the code.
  const std::string src3 = "GOTO/1,2,3 $$ note $\nmore note\nENDMES\n";
  EXPECT_EQ(texts(join_continuations(src3)), (std::vector<std::string>{"GOTO/1,2,3 ", "ENDMES"}));
}

TEST(Preprocess, DollarBannersDoNotContinue) {
  const std::string src = "$$$$$$$$$$$$$$$$$$$$\n$$ header\n$$$$$$$$$$$$$$$$$$$$\nENDFIL\n$$\nENDMES\n";
  EXPECT_EQ(texts(join_continuations(src)), (std::vector<std::string>{"ENDFIL", "ENDMES"}));
}

TEST(Preprocess, DoubleDollarInsideAStringIsText) {
  const std::string src = "TEXT/OPER,'cost $$ 5' $$ real comment\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].text, "TEXT/OPER,'cost $$ 5' ");
  // Quotes escaped as '' keep the string open.
  const std::string src2 = "TEXT/OPER,'it''s $$ here'\n";
  EXPECT_EQ(join_continuations(src2)[0].text, "TEXT/OPER,'it''s $$ here'");
}

TEST(Preprocess, DollarInTheMiddleIsKept) {
  const std::string src = "TEXT/OPER,'$5 each'\n";
  EXPECT_EQ(join_continuations(src)[0].text, "TEXT/OPER,'$5 each'");
}

TEST(Preprocess, LastLineWithoutNewline) {
  const std::string src = "ENDMES\nENDFIL";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1].text, "ENDFIL");
  EXPECT_EQ(lines[1].physical.back(), src.size());
  // A continuation on the very last line just ends the logical line.
  EXPECT_EQ(texts(join_continuations("A/1,$")), (std::vector<std::string>{"A/1,"}));
  EXPECT_TRUE(join_continuations("").empty());
  EXPECT_TRUE(join_continuations("\n\n  \n").empty());
}

TEST(Preprocess, MapIsExactOnAMixedFile) {
  const std::string src =
      "$$$$$$\r\nF(X)=FEAT/CIRCLE,INNER,CART,$\r\n 1.$\n5, 2, 3 $$ c $\nnote\n"
      "TEXT/OPER,'a$\n$$b'\nDATDEF/FA(PL$\n.N-1_x),DAT(A)";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0].text, "F(X)=FEAT/CIRCLE,INNER,CART,1.5, 2, 3 ");
  EXPECT_EQ(lines[1].text, "TEXT/OPER,'a$$b'");
  EXPECT_EQ(lines[2].text, "DATDEF/FA(PL.N-1_x),DAT(A)");
  for (const auto& l : lines) expect_map_exact(src, l);
}

TEST(Preprocess, ByteOrderMarkIsSkipped) {
  const std::string src = "\xEF\xBB\xBFUNITS/MM\nENDFIL\n";
  const auto lines = join_continuations(src);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].text, "UNITS/MM");
  EXPECT_EQ(lines[0].physical[0], 3u);
  for (const auto& l : lines) expect_map_exact(src, l);
}
