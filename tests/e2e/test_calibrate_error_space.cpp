// SPDX-License-Identifier: GPL-3.0-or-later
// `metron calibrate error-space` as a user runs it: on a world with hidden machine errors the
// command writes an error-space file the controller format reads back, and with --truth its
// recovered space stands within a small multiple of the method's own noise floor (the method's
// accuracy against truth is tested in tests/machine/test_error_space_calibration.cpp).
#include <gtest/gtest.h>

#include "shell.hpp"

#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

#include "metron/stdlib/error_space/error_space_file.hpp"

namespace {

using metron::test_support::shell;

TEST(CalibrateErrorSpaceCli, WritesAFileAndComparesWithTheHiddenErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "metron_calibrate_es";
  std::filesystem::create_directories(dir);
  const auto file = (dir / "space.json").string();
  const auto [code, out] =
      shell(std::string(METRON_BINARY) + " calibrate error-space --world " + METRON_SOURCE_DIR +
            "/programs/worlds/cmm_errors.json --size 6,5,2 --components xyz --reversal --truth --out " + file +
            " --report " + (dir / "space.svg").string());
  ASSERT_EQ(code, 0) << out;
  auto read = metron::error_space::read_error_space_file(file);
  ASSERT_TRUE(read) << read.error().pointer << ": " << read.error().message;
  ASSERT_EQ(read->spaces.size(), 1u);
  EXPECT_EQ(read->spaces[0].grid.axes_mm[0].size(), 6u);
  EXPECT_EQ(read->spaces[0].grid.axes_mm[2].size(), 2u);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(read->spaces[0].values_mm[c].size(), 60u) << c;
  // Every component's distance from the hidden truth, in multiples of its noise floor: the world
  // has a pitching carriage, which the seed's method assumes away, so allow 3x.
  const std::regex ratio(R"(\(([0-9.]+) x the floor\))");
  int found = 0;
  for (auto it = std::sregex_iterator(out.begin(), out.end(), ratio); it != std::sregex_iterator(); ++it, ++found)
    EXPECT_LT(std::stod((*it)[1]), 3.0) << out;
  EXPECT_EQ(found, 3) << out;
  EXPECT_TRUE(std::filesystem::exists(dir / "space.svg"));
}

TEST(CalibrateErrorSpaceCli, AGridThatDoesNotStepByTheHeadSpacingIsRefused) {
  const auto [code, out] = shell(std::string(METRON_BINARY) + " calibrate error-space --size 4,4,1 --step-mm 0");
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("error:"), std::string::npos) << out;
}

}  // namespace
