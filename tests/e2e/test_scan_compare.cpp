// SPDX-License-Identifier: GPL-3.0-or-later
// `metron scan-compare` as a user runs it (issue 11): the law table with the deviation across the
// scan direction, and the segmented modes against the independent time-optimal bound.
#include <gtest/gtest.h>

#include "shell.hpp"

#include <cstdio>
#include <regex>
#include <string>

namespace {

using metron::test_support::shell;

double field(const std::string& out, const std::string& row_regex) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex(row_regex))) return -1;
  return std::stod(m[1].str());
}

// A 40 mm line on the default block's top (z = 40, ball 2, E0 0.3), the head starting 0.5 mm
// sideways: without a correction the lateral error stays 500 um (geometry); every law removes it
// by the second half of the path. A 40 mm line at 10 mm/s, 500 mm/s2 takes at least
// 40/10 + 10/500 = 4.02 s (analytic), and no mode beats that.
TEST(ScanCompareCli, LateralErrorPerLawAndModesAgainstTheBound) {
  const auto [code, out] =
      shell(std::string(METRON_BINARY) + " scan-compare --line 310 210 41.7 350 210 41.7 --start-offset 0 0.5 0");
  ASSERT_EQ(code, 0) << out;
  EXPECT_NEAR(field(out, R"(\nnone\s+\S+\s+\S+\s+(\S+))"), 500, 2) << out;
  for (const char* law : {"Vc1", "Vc1'", "Vc2"})
    EXPECT_LT(field(out, std::string(R"(\n)") + law + R"(\s+\S+\s+\S+\s+(\S+))"), 1.0) << law << "\n" << out;
  EXPECT_NEAR(field(out, R"(no jerk\): (\S+) s)"), 4.02, 0.001) << out;
  for (const char* mode : {"conventional", "seed", "look-ahead"})
    EXPECT_GE(field(out, std::string(R"(\n)") + mode + R"(\s+\S+\s+\S+\s+\S+\s+(\S+))"), 1.0) << mode << "\n" << out;
  const auto [bad, msg] = shell(std::string(METRON_BINARY) + " scan-compare");
  EXPECT_EQ(bad, 2);
  EXPECT_NE(msg.find("give the ball-centre path"), std::string::npos) << msg;
}

}  // namespace
